"""The receivers' rays of the scene's shadow on the GPU, for :func:`aquaspec.transport.lightfield.shadow.ambient_shadow`.

``ambient_shadow(..., rays=ShadowRays(device, n))`` plans the term in NumPy
(which pixels take which receivers, the source blocks, the interpolation)
and hands the rays to this object, whose two methods are the WGSL twins of
the context's own (:meth:`aquaspec.transport.lightfield.shadow.ShadowContext.hit_rays`, over
directions around rays that end on a surface:
:class:`~aquaspec.gpu.passes.shadow_hit.HitRayPass`; and
:meth:`aquaspec.transport.lightfield.shadow.ShadowContext.open_integrand`, over the source blocks
along open-water rays: :class:`~aquaspec.gpu.passes.shadow_open.OpenRayPass`).
The GPU renderer (:meth:`aquaspec.rendering.renderer.Renderer.subtract_shadow`) makes
one per renderer. Float32; against the NumPy rays within about 1e-5 of
each band's largest value (``tests/gpu/passes/test_shadow_hit_pass.py``,
``test_shadow_open_pass.py``).

Not a pass of its own (it has no WGSL): the driver of the two ray passes,
which share :class:`aquaspec.gpu.band_rays.BandRayPass`.
"""

from __future__ import annotations

from aquaspec.gpu.passes.shadow_hit import HitRayPass
from aquaspec.gpu.passes.shadow_open import OpenRayPass


class ShadowRays:
    """Both ray integrals of the scene's shadow for ``n_bands`` bands on ``device``
    (each pipeline compiled when first used)."""

    def __init__(self, device, n_bands: int):
        self.device, self.n_bands = device, int(n_bands)
        self._hit = self._open = None

    def hit_rays(self, ctx, rows, cols):
        """``ctx.hit_rays(rows, cols)``: (P, n) float64."""
        if self._hit is None:
            self._hit = HitRayPass(self.device, self.n_bands)
        return self._hit.hit_rays(ctx, rows, cols)

    def open_integrand(self, ctx, rays):
        """``ctx.open_integrand(rays)``: (R, K, n) float64."""
        if self._open is None:
            self._open = OpenRayPass(self.device, self.n_bands)
        return self._open.integrand(ctx, rays)
