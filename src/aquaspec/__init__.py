"""aquaspec: spectral, physically based, real-time rendering of underwater scenes.

Conventions: world units are metres, y is up, the water surface is the plane
y = 0 and depth is ``-y``; wavelengths in nm; coefficients in 1/m.
"""

__version__ = "0.1.0"
