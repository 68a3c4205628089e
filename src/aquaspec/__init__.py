"""aquaspec: spectral, physically based, real-time rendering of underwater scenes.

Conventions: world units are metres, y is up, the water surface is the plane
y = 0 and depth is ``-y``; wavelengths in nm; coefficients in 1/m.

The public API, at the top for scripts::

    import aquaspec
    result = aquaspec.render(water="IB", depth_m=5.0, size=(640, 360))

:func:`aquaspec.render` (:func:`aquaspec.rendering.api.render`),
:class:`aquaspec.RenderResult`, :class:`aquaspec.Renderer` and
:class:`aquaspec.SpectralSetup`.
"""

__version__ = "0.1.0"

__all__ = ["render", "RenderResult", "Renderer", "SpectralSetup", "__version__"]


def __getattr__(name):
    # PEP 562: the API is imported when first asked for, so that importing a
    # light module (``import aquaspec.errors``, the CLI's parser) does not
    # load wgpu and the GPU passes.
    if name == "render":
        from aquaspec.rendering.api import render  # deferred: loads wgpu and every pass
        return render
    if name == "RenderResult":
        from aquaspec.rendering.result import RenderResult  # deferred: loads NumPy and the scene
        return RenderResult
    if name == "Renderer":
        from aquaspec.rendering.renderer import Renderer  # deferred: loads wgpu and every pass
        return Renderer
    if name == "SpectralSetup":
        from aquaspec.rendering.setup import SpectralSetup  # deferred: loads the physics and SciPy
        return SpectralSetup
    raise AttributeError(f"module 'aquaspec' has no attribute {name!r}")


def __dir__():
    return sorted(list(globals()) + __all__)
