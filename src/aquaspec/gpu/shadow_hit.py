"""The scene's shadow along rays that end on a surface, on the GPU.

Twin of :meth:`aquaspec.shadow._Context.hit_rays` (float64 NumPy; the
maths is in :mod:`aquaspec.shadow`'s docstring); WGSL:
``shaders/shadow_hit.wgsl``, one workgroup of :data:`WORKGROUP` invocations
per receiver, which share out the direction cells around its ray and walk
the nodes along it, each summing its blocked samples per band in a private
array; the workgroup then sums those. Conventions: metres, y up, water
surface y = 0, depth -y. The direction cells, their phase functions and
the nodes along the ray are ``hit_rays``'s own
(:meth:`~aquaspec.shadow._Context.hit_quadrature`, float64, then float32),
and so is each receiver's frame (:func:`~aquaspec.shadow.ray_frames`).
``tests/test_gpu_shadow_hit.py`` holds the pass against ``hit_rays``.

Bands are four to a vec4 (the last vec4 padded with zeros) in every
per-band buffer. Bindings of shadow_hit.wgsl:

==  ==========================  ===============================================
0   uniform ``HitParams``       the camera (:data:`~aquaspec.gpu.deferred.CAMERA_FIELDS`),
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

from ..errors import AquaspecError
from .buffers import (create_storage_buffer, create_uniform_buffer, read_buffer,
                      record_dispatch, upload_buffer)
from .deferred import CAMERA_FIELDS, bind_group_entries, bind_group_layout, camera_fields
from .layout import UniformLayout
from .shaders import load_wgsl

#: Invocations per workgroup (one workgroup per receiver).
WORKGROUP = 64
#: Workgroups along x of a dispatch (more receivers take rows of them).
MAX_GROUPS_X = 65535
#: The G-buffer distance of a pixel that sees no surface.
NO_HIT = -1.0
#: Workgroup memory for the reduction, in vec4 (16 KB, WebGPU's minimum).
SHARED_VEC4 = 1024

PARAMS_LAYOUT = UniformLayout("HitParams", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("n_depth", "u32"), ("n_mu", "u32"),
    ("max_depth", "f32"), ("n_receivers", "u32"), ("n_cells", "u32"), ("n_nodes", "u32"),
])


class HitRayPass:
    """:meth:`~aquaspec.shadow._Context.hit_rays` on the GPU for ``n_bands`` bands.

    Parameters
    ----------
    device : wgpu.GPUDevice
        From :func:`aquaspec.gpu.device.get_device`.
    n_bands : int
        Bands of the contexts it integrates (a compile-time constant).
    """

    def __init__(self, device, n_bands: int):
        self.device, self.n_bands = device, int(n_bands)
        if self.n_bands < 1:
            raise AquaspecError(f"n_bands={n_bands!r}; accepted: an integer >= 1")
        self.n_vec4 = -(-self.n_bands // 4)
        chunk = min(self.n_vec4, SHARED_VEC4 // WORKGROUP, WORKGROUP)
        src = load_wgsl("shadow_hit.wgsl", n_vec4=self.n_vec4, workgroup=WORKGROUP,
                        chunk=chunk, shared_len=WORKGROUP * chunk,
                        params_struct=PARAMS_LAYOUT.wgsl(), params_name=PARAMS_LAYOUT.name)
        module = device.create_shader_module(label="shadow_hit.wgsl", code=src)
        self._layout = bind_group_layout(device, {0: "uniform", **{i: "read" for i in range(1, 7)},
                                                  7: "write"})
        self._pipeline = device.create_compute_pipeline(
            label="shadow hit rays",
            layout=device.create_pipeline_layout(bind_group_layouts=[self._layout]),
            compute={"module": module, "entry_point": "main"})
        self._uniform = create_uniform_buffer(device, PARAMS_LAYOUT, label="shadow hit params")
        self._ctx = None            # (the prepared context, kept: its id stays its own)
        self._ctx_buffers = {}
        self._rec_buffers = None    # (receivers, result), grown as needed
        self._group = None

    def _bands4(self, a) -> np.ndarray:
        """``a`` (..., n) as float32 with the band axis padded to whole vec4."""
        a = np.asarray(a, dtype=float)
        pad = [(0, 0)] * (a.ndim - 1) + [(0, 4 * self.n_vec4 - a.shape[-1])]
        return np.pad(a, pad).astype(np.float32)

    def prepare(self, ctx) -> None:
        """Upload what every ray of ``ctx`` (:class:`aquaspec.shadow._Context`) reads:
        the quadrature, the radiance table and the G-buffer. Once per context
        (by identity: the pass keeps it; a context is not changed after it is
        made); :meth:`hit_rays` calls it."""
        if ctx is self._ctx:
            return
        n = ctx.b.size
        if n != self.n_bands:
            raise AquaspecError(f"the context has {n} bands; this pass was made for "
                                f"{self.n_bands}")
        (ct, c1, c2, dw, in_cone), p_dir, gx, gw = ctx.hit_quadrature()
        cells = np.zeros((ct.size + gx.size, 8), np.float32)
        cells[:ct.size, :4] = np.stack([ct, c1, c2, dw], -1)
        cells[:ct.size, 4] = in_cone.astype(np.uint32).view(np.float32)   # (the u32 field)
        cells[ct.size:, 0], cells[ct.size:, 1] = gx ** 2, 2 * gx * gw
        hgt, wid = ctx.distance.shape
        nd, nm = ctx.lrad_e0.shape[:2]
        dev, b4 = self.device, self._bands4
        self._ctx_buffers = {
            1: create_storage_buffer(dev, cells, label="shadow hit cells"),
            2: create_storage_buffer(dev, np.concatenate([b4(p_dir).reshape(-1), b4(ctx.k)]),
                                     label="shadow hit band data"),
            3: create_storage_buffer(dev, b4(ctx.lrad_e0), label="shadow L_bg"),
            4: create_storage_buffer(dev, np.where(ctx.hit, ctx.distance, NO_HIT)
                                     .astype(np.float32), label="shadow G-buffer distance"),
            5: create_storage_buffer(dev, b4(np.where(ctx.hit[..., None], ctx.l_s_img, 0.0)),
                                     label="shadow G-buffer radiance")}
        self._sizes = dict(width=wid, height=hgt, n_depth=nd, n_mu=nm, max_depth=ctx.d_max,
                           n_cells=ct.size, n_nodes=gx.size)
        self._ctx, self._group = ctx, None

    def _receivers(self, ctx, rows, cols) -> np.ndarray:
        """Receiver records (P, 16) float32: the rays' frames as ``hit_rays`` makes them."""
        from ..shadow import ray_frames
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
        dev = self.device
        recs = self._receivers(ctx, rows, cols)
        if self._rec_buffers is None or self._rec_buffers[0].size < recs.nbytes:
            self._rec_buffers = (create_storage_buffer(dev, recs.nbytes, label="shadow receivers"),
                                 create_storage_buffer(dev, 16 * p * self.n_vec4,
                                                       label="shadow hit result"))
            self._group = None
        upload_buffer(dev, self._rec_buffers[0], recs)
        upload_buffer(dev, self._uniform, PARAMS_LAYOUT.pack(
            **camera_fields(ctx.cam), **self._sizes, n_receivers=p))
        if self._group is None:
            self._group = dev.create_bind_group(layout=self._layout, entries=bind_group_entries(
                {0: self._uniform, **self._ctx_buffers, 6: self._rec_buffers[0],
                 7: self._rec_buffers[1]}))
        gx = min(p, MAX_GROUPS_X)
        enc = dev.create_command_encoder()
        record_dispatch(enc, self._pipeline, self._group, (gx, -(-p // gx), 1))
        dev.queue.submit([enc.finish()])
        out = read_buffer(dev, self._rec_buffers[1], np.float32, (p, 4 * self.n_vec4))
        return out[:, :n].astype(float) * ctx.b
