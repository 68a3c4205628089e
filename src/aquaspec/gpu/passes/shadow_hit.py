"""The scene's shadow along rays that end on a surface, on the GPU.

Twin of :meth:`aquaspec.transport.lightfield.shadow.ShadowContext.hit_rays` (float64 NumPy; the
maths is in :mod:`aquaspec.transport.lightfield.shadow`'s docstring); WGSL:
``shadow_hit.wgsl`` beside this module, one workgroup of :data:`WORKGROUP` invocations
per receiver, which share out the direction cells around its ray and walk
the nodes along it, each summing its blocked samples per band in a private
array; the workgroup then sums those. Conventions: metres, y up, water
surface y = 0, depth -y. The direction cells, their phase functions and
the nodes along the ray are ``hit_rays``'s own
(:meth:`~aquaspec.transport.lightfield.shadow.ShadowContext.hit_quadrature`, float64, then float32),
and so is each receiver's frame (:func:`~aquaspec.transport.lightfield.shadow.ray_frames`).
``tests/gpu/passes/test_shadow_hit_pass.py`` holds the pass against ``hit_rays``.

Bands are four to a vec4 (the last vec4 padded with zeros) in every
per-band buffer. Bindings of shadow_hit.wgsl:

==  ==========================  ===============================================
0   uniform ``HitParams``       the camera (:data:`~aquaspec.gpu.camera.CAMERA_FIELDS`),
                                image and table sizes, counts
1   ``array<Cell>``             per direction cell ``(cos theta, sin theta cos phi,
                                sin theta sin phi, dw)`` and whether it is in
                                the forward cone; then the nodes along the ray
                                ``(x^2, 2 x w_x, 0, 0)``
2   ``array<vec4<f32>>``        the band phase functions ``p[cell, band]``, then
                                ``k[band]``
3   ``array<vec4<f32>>``        ``L_bg`` [depth, cos, band] (``ctx.lrad_e0``)
4   ``array<f32>``              the G-buffer's hit distance per pixel
                                (:data:`NO_HIT` where none)
5   ``array<vec4<f32>>``        the surfaces' radiance [pixel, band]
6   ``array<Receiver>``         per receiver ``(v, s)``, ``(e1, clamp(-v . n, 0, 1))``,
                                ``(e2, 0)``, ``(n, 0)``
7   ``array<vec4<f32>>``        the result [receiver, band], before the factor ``b``
==  ==========================  ===============================================
"""

from __future__ import annotations

import numpy as np

from aquaspec.transport.lightfield.shadow import ray_frames
from aquaspec.gpu.band_rays import BandRayPass, group_grid
from aquaspec.gpu.camera import CAMERA_FIELDS, camera_fields
from aquaspec.gpu.layout import UniformLayout

#: Invocations per workgroup (one workgroup per receiver).
WORKGROUP = 64
#: The G-buffer distance of a pixel that sees no surface.
NO_HIT = -1.0
#: Workgroup memory for the reduction, in vec4 (16 KB, WebGPU's minimum).
SHARED_VEC4 = 1024

PARAMS_LAYOUT = UniformLayout("HitParams", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("n_depth", "u32"), ("n_mu", "u32"),
    ("max_depth", "f32"), ("n_receivers", "u32"), ("n_cells", "u32"), ("n_nodes", "u32"),
])


class HitRayPass(BandRayPass):
    """:meth:`~aquaspec.transport.lightfield.shadow.ShadowContext.hit_rays` on the GPU for ``n_bands`` bands (a compile-time
    constant) on ``device`` (:func:`aquaspec.gpu.device.get_device`)."""

    RECORDS = 6

    def __init__(self, device, n_bands: int):
        chunk = min(-(-int(n_bands) // 4), SHARED_VEC4 // WORKGROUP, WORKGROUP)
        super().__init__(device, n_bands, "shadow_hit.wgsl", "shadow hit rays", PARAMS_LAYOUT,
                         workgroup=WORKGROUP, chunk=chunk, shared_len=WORKGROUP * chunk)

    def prepare(self, ctx) -> None:
        """Upload what every ray of ``ctx`` (:class:`aquaspec.transport.lightfield.shadow.ShadowContext`) reads:
        the quadrature, the radiance table and the G-buffer. Once per context
        (by identity: the pass keeps it; a context is not changed after it is
        made); :meth:`hit_rays` calls it."""
        if not self._is_new(ctx):
            return
        (ct, c1, c2, dw, in_cone), p_dir, gx, gw = ctx.hit_quadrature()
        cells = np.zeros((ct.size + gx.size, 8), np.float32)
        cells[:ct.size, :4] = np.stack([ct, c1, c2, dw], -1)
        cells[:ct.size, 4] = in_cone.astype(np.uint32).view(np.float32)   # (the u32 field)
        cells[ct.size:, 0], cells[ct.size:, 1] = gx ** 2, 2 * gx * gw
        hgt, wid = ctx.distance.shape
        nd, nm = ctx.lrad_e0.shape[:2]
        b4 = self.bands4
        self._set_context(ctx, {
            1: cells, 2: np.concatenate([b4(p_dir).reshape(-1), b4(ctx.k)]),
            3: b4(ctx.lrad_e0),
            4: np.where(ctx.hit, ctx.distance, NO_HIT),
            5: b4(np.where(ctx.hit[..., None], ctx.l_s_img, 0.0))},
            dict(width=wid, height=hgt, n_depth=nd, n_mu=nm, max_depth=ctx.d_max,
                 n_cells=ct.size, n_nodes=gx.size))

    def _receivers(self, ctx, rows, cols) -> np.ndarray:
        """Receiver records (P, 16) float32: the rays' frames as ``hit_rays`` makes them."""
        v, nrm, s = ctx.dirs[rows, cols], ctx.normal[rows, cols], ctx.distance[rows, cols]
        e1, e2 = ray_frames(v)
        cos_n = np.clip(-np.sum(v * nrm, axis=-1), 0.0, 1.0)
        out = np.zeros((rows.size, 4, 4))
        out[:, 0, :3], out[:, 0, 3] = v, s
        out[:, 1, :3], out[:, 1, 3] = e1, cos_n
        out[:, 2, :3], out[:, 3, :3] = e2, nrm
        return out.reshape(-1, 16).astype(np.float32)

    def hit_rays(self, ctx, rows, cols) -> np.ndarray:
        """``ctx.hit_rays(rows, cols)`` (P, n) float64, integrated in float32 on the GPU."""
        rows = np.asarray(rows, dtype=int).reshape(-1)
        cols = np.asarray(cols, dtype=int).reshape(-1)
        n, p = self.n_bands, rows.size
        self.prepare(ctx)
        if p == 0:
            return np.zeros((0, n))
        out = self._run(self._receivers(ctx, rows, cols), p * self.n_vec4, group_grid(p),
                        **camera_fields(ctx.cam), n_receivers=p).reshape(p, -1)
        return out[:, :n].astype(float) * ctx.b
