"""The scene's shadow along open-water rays, on the GPU.

Twin of :meth:`aquaspec.transport.lightfield.shadow.ShadowContext.open_ray` (float64 NumPy; the
maths is in :mod:`aquaspec.transport.lightfield.shadow`'s docstring): the integrand at the nodes
``ctx.t`` along rays that end on no surface, summed over the context's
source blocks. WGSL: ``shadow_open.wgsl`` beside this module, one invocation per
(ray, node), each looping over the sources and summing per band in a
private array (bands four to a vec4). Conventions: metres, y up, water surface y = 0, depth -y.
The cumulative integral along the rays stays on the host
(:meth:`~aquaspec.transport.lightfield.shadow.ShadowContext.cumulative`).
``tests/gpu/passes/test_shadow_open_pass.py`` holds the pass against ``open_ray``.

Bands are four to a vec4 (the last padded with zeros) in every per-band
buffer, band-contiguous. Bindings of shadow_open.wgsl (float32):

==  ==========================  ===============================================
0   uniform ``OpenParams``      camera position, counts, ``t`` step, cone, axes
1   ``array<vec4<f32>>``        ray directions
2   ``array<vec4<f32>>``        per source ``(mean point, area)``, ``(normal, 0)``
3   ``array<vec4<f32>>``        ``src_rows - l_s`` [source, cos, band], then
                                ``in_cone_dl`` [source, band]
4   ``array<vec4<f32>>``        ``disc_all`` [theta, alpha] ``(p0, p1, shift, 0)``
5   ``array<f32>``              ``disc_theta``, then ``disc_alpha``
6   ``array<vec4<f32>>``        ``k`` [band], then ``mix`` [band], then ``b`` [band]
7   ``array<vec4<f32>>``        the integrand [ray, node, band]
==  ==========================  ===============================================
"""

from __future__ import annotations

import numpy as np

from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.band_rays import BandRayPass, group_grid

#: Invocations per workgroup (consecutive nodes of a ray share one).
WORKGROUP = 64

PARAMS_LAYOUT = UniformLayout("OpenParams", [
    ("origin", "vec4<f32>"), ("n_rays", "u32"), ("n_nodes", "u32"), ("n_sources", "u32"),
    ("n_mu", "u32"), ("n_theta", "u32"), ("n_alpha", "u32"), ("cone_offset", "u32"),
    ("row_invocations", "u32"), ("t_step", "f32"), ("cone_cos", "f32"),
    ("log_theta", "f32"), ("log_alpha", "f32"),
])


class OpenRayPass(BandRayPass):
    """:meth:`~aquaspec.transport.lightfield.shadow.ShadowContext.open_ray` on the GPU for ``n_bands`` bands (a compile-time
    constant) on ``device`` (:func:`aquaspec.gpu.device.get_device`)."""

    def __init__(self, device, n_bands: int):
        super().__init__(device, n_bands, "shadow_open.wgsl", "shadow open rays", PARAMS_LAYOUT,
                         workgroup=WORKGROUP)

    def prepare(self, ctx) -> None:
        """Upload what every ray of ``ctx`` (:class:`aquaspec.transport.lightfield.shadow.ShadowContext`) reads:
        the sources, the cap-averaged phase table and the band constants. Once
        per context (by identity: the pass keeps it; a context is not changed
        after it is made); :meth:`integrand` calls it."""
        if not self._is_new(ctx):
            return
        m, n_mu = ctx.src_rows.shape[:2]
        geom = np.zeros((m, 2, 4))
        geom[:, 0, :3], geom[:, 0, 3], geom[:, 1, :3] = ctx.pts, ctx.area, ctx.nrm
        # (The source's own radiance taken off its rows in float64.)
        b4 = self.bands4
        rows = b4(ctx.src_rows - ctx.l_s[:, None, :]).reshape(-1)
        src_bands = np.concatenate([rows, b4(ctx.in_cone_dl).reshape(-1)])
        disc = np.zeros(ctx.disc_all.shape[:2] + (4,))
        disc[..., :3] = ctx.disc_all
        th, al = ctx.disc_theta, ctx.disc_alpha
        self._set_context(ctx, {
            2: geom, 3: src_bands, 4: disc, 5: np.concatenate([th, al]),
            6: np.concatenate([b4(ctx.k), b4(ctx.mix), b4(ctx.b)])},
            dict(origin=np.append(ctx.cam.position, 0.0), n_nodes=ctx.t.size, n_sources=m,
                 n_mu=n_mu, n_theta=th.size, n_alpha=al.size, cone_offset=rows.size // 4,
                 t_step=ctx.t[1] - ctx.t[0], cone_cos=ctx.cone_cos,
                 log_theta=np.log(th[-1] / th[1]), log_alpha=np.log(al[-1] / al[0])))

    def integrand(self, ctx, rays) -> np.ndarray:
        """``np.stack([ctx.open_ray(v) for v in rays])`` (R, K, n) float64 for ray
        directions ``rays`` (R, 3), summed in float32 on the GPU."""
        rays = np.asarray(rays, dtype=float).reshape(-1, 3)
        self.prepare(ctx)
        n, k, r = self.n_bands, ctx.t.size, rays.shape[0]
        if r == 0 or ctx.area.size == 0:
            return np.zeros((r, k, n))
        dirs = np.zeros((r, 4))
        dirs[:, :3] = rays
        grid = group_grid(-(-r * k // WORKGROUP))
        out = self._run(dirs, r * k * self.n_vec4, grid, n_rays=r,
                        row_invocations=grid[0] * WORKGROUP).reshape(r, k, -1)
        return out[..., :n].astype(float)
