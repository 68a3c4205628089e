"""sRGB (IEC 61966-2-1): its primaries from CIE XYZ, and its transfer curve both ways.

The one home of the sRGB formulas: the display chain encodes with
:func:`srgb_encode` (:mod:`aquaspec.colour.display`; its WGSL twin is in
``gpu/wgsl/tonemap.wgsl``), textures, vertex colours and RGB-D photographs
are decoded with :func:`srgb_decode` (:mod:`aquaspec.scene.mesh`,
:mod:`aquaspec.scene.load`), and the human sensor and the spectral upsampling
see colour through :data:`XYZ_TO_SRGB` (:mod:`aquaspec.colour.sensors`,
:mod:`aquaspec.colour.reflectance`).

References
----------
.. [IEC61966] IEC 61966-2-1:1999, "Multimedia systems and equipment - Colour
   measurement and management - Part 2-1: Default RGB colour space - sRGB".
"""

from __future__ import annotations

import numpy as np

#: XYZ (D65) to linear sRGB, [IEC61966].
XYZ_TO_SRGB = np.array([[3.2406, -1.5372, -0.4986],
                        [-0.9689, 1.8758, 0.0415],
                        [0.0557, -0.2040, 1.0570]])


def srgb_encode(linear) -> np.ndarray:
    """sRGB transfer function of [IEC61966] on [0, 1] (input clipped to it).

    ``12.92 x`` for ``x <= 0.0031308``, else ``1.055 x**(1/2.4) - 0.055``.
    """
    x = np.clip(np.asarray(linear, dtype=np.float64), 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055)


def srgb_decode(encoded) -> np.ndarray:
    """Inverse of :func:`srgb_encode`: sRGB-encoded values to linear (input
    clipped to [0, 1]).

    ``v / 12.92`` for ``v <= 0.04045``, else ``((v + 0.055) / 1.055)**2.4``.
    """
    v = np.clip(np.asarray(encoded, dtype=np.float64), 0.0, 1.0)
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))
