"""What the two ray passes of the scene's shadow share: a band-vectorised compute pass
over per-call records.

:class:`BandRayPass` is the base of :class:`aquaspec.gpu.passes.shadow_hit.HitRayPass`
and :class:`aquaspec.gpu.passes.shadow_open.OpenRayPass`; their driver is
:class:`aquaspec.gpu.passes.shadow_rays.ShadowRays`.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_storage_buffer, create_uniform_buffer, read_buffer, upload_buffer
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.shaders import load_wgsl

#: Workgroups along x of a dispatch (WebGPU's minimum limit; more take rows of them).
MAX_GROUPS_X = 65535


def group_grid(groups: int) -> tuple:
    """``(x, y, 1)`` workgroups covering ``groups`` (rows of at most :data:`MAX_GROUPS_X`)."""
    gx = max(1, min(int(groups), MAX_GROUPS_X))
    return gx, -(-int(groups) // gx), 1


class BandRayPass:
    """What both ray passes share: a compute pipeline for ``n_bands`` bands (four
    to a vec4: :meth:`bands4`), the bindings (0 the uniform of layout
    ``params``, 1-6 read-only storage, 7 the result), the per-context
    buffers (uploaded once per context: :meth:`_is_new` / :meth:`_set_context`)
    and a dispatch over per-call records at binding :attr:`RECORDS`
    (:meth:`_run`)."""

    #: The binding of the per-call records (the other read bindings: the context's).
    RECORDS = 1

    def __init__(self, device, n_bands: int, shader: str, label: str, params, **values):
        self.device, self.n_bands, self.label, self.params = device, int(n_bands), label, params
        if self.n_bands < 1:
            raise AquaspecError(f"n_bands={n_bands!r}; accepted: an integer >= 1")
        self.n_vec4 = -(-self.n_bands // 4)
        src = load_wgsl(shader, n_vec4=self.n_vec4, params_struct=params.wgsl(),
                        params_name=params.name, **values)
        self._layout = bind_group_layout(device, {0: "uniform", **{i: "read" for i in range(1, 7)},
                                                  7: "write"})
        self._pipeline = compute_pipeline(device, self._layout, src, label)
        self._uniform = create_uniform_buffer(device, params, label=f"{label} params")
        self._ctx = None            # (the prepared context, kept: its id stays its own)
        self._ctx_buffers, self._sizes = {}, {}
        self._io = None             # (records, result), grown as needed
        self._group = None

    def bands4(self, a) -> np.ndarray:
        """``a`` (..., n) as float64 with the band axis padded with zeros to whole vec4."""
        a = np.asarray(a, dtype=float)
        return np.pad(a, [(0, 0)] * (a.ndim - 1) + [(0, 4 * self.n_vec4 - a.shape[-1])])

    def _is_new(self, ctx) -> bool:
        """Whether ``ctx`` (the shadow's context, :func:`aquaspec.transport.lightfield.shadow.ambient_shadow`'s) is not the one uploaded
        (by identity: a context is not changed after it is made); refuses
        another band count."""
        if ctx is self._ctx:
            return False
        if ctx.b.size != self.n_bands:
            raise AquaspecError(f"the context has {ctx.b.size} bands; this pass was made for "
                                f"{self.n_bands}")
        return True

    def _set_context(self, ctx, arrays: dict, sizes: dict) -> None:
        """Upload ``arrays`` ({binding: array}, as float32) for ``ctx``; ``sizes``
        are its fields of the uniform."""
        self._ctx_buffers = {b: create_storage_buffer(self.device, np.asarray(a, np.float32),
                                                      label=f"{self.label} {b}")
                             for b, a in arrays.items()}
        self._sizes, self._ctx, self._group = sizes, ctx, None

    def _run(self, records, result_vec4: int, grid, **params) -> np.ndarray:
        """Dispatch ``grid`` workgroups over ``records`` (float32 rows); the
        result's first ``result_vec4`` vec4, (result_vec4, 4) float32."""
        dev = self.device
        records = np.ascontiguousarray(records, dtype=np.float32)
        if (self._io is None or self._io[0].size < records.nbytes
                or self._io[1].size < 16 * result_vec4):
            self._io = (create_storage_buffer(dev, records.nbytes, label=f"{self.label} records"),
                        create_storage_buffer(dev, 16 * result_vec4, label=f"{self.label} result"))
            self._group = None
        upload_buffer(dev, self._io[0], records)
        upload_buffer(dev, self._uniform, self.params.pack(**self._sizes, **params))
        if self._group is None:
            self._group = dev.create_bind_group(layout=self._layout, entries=bind_group_entries(
                {0: self._uniform, **self._ctx_buffers, self.RECORDS: self._io[0],
                 7: self._io[1]}))
        enc = dev.create_command_encoder()
        record_dispatch(enc, self._pipeline, self._group, grid)
        dev.queue.submit([enc.finish()])
        return read_buffer(dev, self._io[1], np.float32, (result_vec4, 4))
