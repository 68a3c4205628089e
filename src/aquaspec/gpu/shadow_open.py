"""The scene's shadow along open-water rays, on the GPU.

Twin of :meth:`aquaspec.shadow._Context._open_ray` (float64 NumPy; the
maths is in :mod:`aquaspec.shadow`'s docstring): the integrand at the nodes
``ctx.t`` along rays that end on no surface, summed over the context's
source blocks. WGSL: ``shaders/shadow_open.wgsl``, one invocation per
(ray, node), each looping over the sources and summing per band in a
private array (bands four to a vec4). Conventions: metres, y up, water surface y = 0, depth -y.
The cumulative integral along the rays stays on the host
(:meth:`~aquaspec.shadow._Context.cumulative`).
``tests/test_gpu_shadow_open.py`` holds the pass against ``_open_ray``.

Bands are four to a vec4 (the last padded with zeros) in every per-band
buffer, band-contiguous. Bindings of shadow_open.wgsl (float32):

==  ==========================  ===============================================
0   uniform ``OpenParams``      camera position, counts, ``t`` step, cone, axes
1   ``array<vec4<f32>>``        ray directions
2   ``array<vec4<f32>>``        per source ``(mean point, area)``, ``(normal, 0)``
3   ``array<f32>``              ``src_rows - l_s`` [source, cos, band], then
                                ``in_cone_dl`` [source, band]
4   ``array<vec4<f32>>``        ``disc_all`` [theta, alpha] ``(p0, p1, shift, 0)``
5   ``array<f32>``              ``disc_theta``, then ``disc_alpha``
6   ``array<vec4<f32>>``        ``k`` [band], then ``mix`` [band], then ``b`` [band]
7   ``array<f32>``              the integrand [ray, node, band]
==  ==========================  ===============================================
"""

from __future__ import annotations

import numpy as np

from ..errors import AquaspecError
from .buffers import (create_storage_buffer, create_uniform_buffer, read_buffer,
                      record_dispatch, upload_buffer)
from .deferred import bind_group_entries, bind_group_layout
from .layout import UniformLayout
from .shaders import load_wgsl

#: Invocations per workgroup (consecutive nodes of a ray share one).
WORKGROUP = 64
#: Workgroups along x of a dispatch (more take rows of them).
MAX_GROUPS_X = 65535

PARAMS_LAYOUT = UniformLayout("OpenParams", [
    ("origin", "vec4<f32>"), ("n_rays", "u32"), ("n_nodes", "u32"), ("n_sources", "u32"),
    ("n_mu", "u32"), ("n_theta", "u32"), ("n_alpha", "u32"), ("cone_offset", "u32"),
    ("row_invocations", "u32"), ("t_step", "f32"), ("cone_cos", "f32"),
    ("log_theta", "f32"), ("log_alpha", "f32"),
])


class OpenRayPass:
    """:meth:`~aquaspec.shadow._Context._open_ray` on the GPU for ``n_bands`` bands.

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
        src = load_wgsl("shadow_open.wgsl", n_vec4=self.n_vec4, workgroup=WORKGROUP,
                        params_struct=PARAMS_LAYOUT.wgsl(), params_name=PARAMS_LAYOUT.name)
        module = device.create_shader_module(label="shadow_open.wgsl", code=src)
        self._layout = bind_group_layout(device, {0: "uniform", **{i: "read" for i in range(1, 7)},
                                                  7: "write"})
        self._pipeline = device.create_compute_pipeline(
            label="shadow open rays",
            layout=device.create_pipeline_layout(bind_group_layouts=[self._layout]),
            compute={"module": module, "entry_point": "main"})
        self._uniform = create_uniform_buffer(device, PARAMS_LAYOUT, label="shadow open params")
        self._ctx = None            # (the prepared context, kept: its id stays its own)
        self._ctx_buffers = {}
        self._ray_buffers = None    # (rays, result), grown as needed
        self._group = None

    def _bands4(self, a) -> np.ndarray:
        """``a`` (..., n) with the band axis padded to whole vec4."""
        a = np.asarray(a, dtype=float)
        return np.pad(a, [(0, 0)] * (a.ndim - 1) + [(0, 4 * self.n_vec4 - a.shape[-1])])

    def prepare(self, ctx) -> None:
        """Upload what every ray of ``ctx`` (:class:`aquaspec.shadow._Context`) reads:
        the sources, the cap-averaged phase table and the band constants. Once
        per context (by identity: the pass keeps it; a context is not changed
        after it is made); :meth:`integrand` calls it."""
        if ctx is self._ctx:
            return
        n = ctx.b.size
        if n != self.n_bands:
            raise AquaspecError(f"the context has {n} bands; this pass was made for "
                                f"{self.n_bands}")
        m, n_mu = ctx.src_rows.shape[:2]
        geom = np.zeros((m, 2, 4))
        geom[:, 0, :3], geom[:, 0, 3], geom[:, 1, :3] = ctx.pts, ctx.area, ctx.nrm
        # (The source's own radiance taken off its rows in float64.)
        b4 = self._bands4
        rows = b4(ctx.src_rows - ctx.l_s[:, None, :]).reshape(-1)
        src_bands = np.concatenate([rows, b4(ctx.in_cone_dl).reshape(-1)])
        disc = np.zeros(ctx.disc_all.shape[:2] + (4,))
        disc[..., :3] = ctx.disc_all
        dev, f32 = self.device, np.float32
        self._ctx_buffers = {
            2: create_storage_buffer(dev, geom.astype(f32), label="shadow sources"),
            3: create_storage_buffer(dev, src_bands.astype(f32), label="shadow source bands"),
            4: create_storage_buffer(dev, disc.astype(f32), label="shadow disc phase"),
            5: create_storage_buffer(dev, np.concatenate([ctx.disc_theta, ctx.disc_alpha])
                                     .astype(f32), label="shadow disc nodes"),
            6: create_storage_buffer(dev, np.concatenate([b4(ctx.k), b4(ctx.mix), b4(ctx.b)])
                                     .astype(f32), label="shadow band constants")}
        th, al = ctx.disc_theta, ctx.disc_alpha
        self._sizes = dict(
            origin=np.append(ctx.cam.position, 0.0), n_nodes=ctx.t.size, n_sources=m,
            n_mu=n_mu, n_theta=th.size, n_alpha=al.size, cone_offset=rows.size // 4,
            t_step=ctx.t[1] - ctx.t[0], cone_cos=ctx.cone_cos,
            log_theta=np.log(th[-1] / th[1]), log_alpha=np.log(al[-1] / al[0]))
        self._ctx, self._group = ctx, None

    def integrand(self, ctx, rays) -> np.ndarray:
        """``np.stack([ctx._open_ray(v) for v in rays])`` (R, K, n) float64 for ray
        directions ``rays`` (R, 3), summed in float32 on the GPU."""
        rays = np.asarray(rays, dtype=float).reshape(-1, 3)
        self.prepare(ctx)
        n, k, r = self.n_bands, ctx.t.size, rays.shape[0]
        if r == 0 or ctx.area.size == 0:
            return np.zeros((r, k, n))
        dev = self.device
        dirs = np.zeros((r, 4), np.float32)
        dirs[:, :3] = rays
        if self._ray_buffers is None or self._ray_buffers[0].size < dirs.nbytes:
            self._ray_buffers = (create_storage_buffer(dev, dirs.nbytes, label="shadow open rays"),
                                 create_storage_buffer(dev, 16 * r * k * self.n_vec4,
                                                       label="shadow open result"))
            self._group = None
        upload_buffer(dev, self._ray_buffers[0], dirs)
        groups = -(-r * k // WORKGROUP)
        gx = min(groups, MAX_GROUPS_X)
        upload_buffer(dev, self._uniform, PARAMS_LAYOUT.pack(
            **self._sizes, n_rays=r, row_invocations=gx * WORKGROUP))
        if self._group is None:
            self._group = dev.create_bind_group(layout=self._layout, entries=bind_group_entries(
                {0: self._uniform, 1: self._ray_buffers[0], **self._ctx_buffers,
                 7: self._ray_buffers[1]}))
        enc = dev.create_command_encoder()
        record_dispatch(enc, self._pipeline, self._group, (gx, -(-groups // gx), 1))
        dev.queue.submit([enc.finish()])
        out = read_buffer(dev, self._ray_buffers[1], np.float32, (r, k, 4 * self.n_vec4))
        return out[..., :n].astype(float)
