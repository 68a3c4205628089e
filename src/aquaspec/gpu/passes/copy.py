"""The "memory floor" pass: read the G-buffer, write the output, no shading.

It binds the same camera uniform, G-buffer textures and output buffer as a
:class:`~aquaspec.gpu.passes.deferred.DeferredPass` and covers the same pixels, so
``aquaspec bench`` can report how much of the deferred pass's time is memory
traffic (the floor) and how much is the per-band arithmetic. WGSL:
``shaders/copy.wgsl``; each output pixel is
``(distance, normal.y, sigmoid.z, f32(material))`` of its input (the
sigmoid texture is read only when the deferred pass's ``per_pixel`` is
true, as the deferred pass does; sigmoid.z is 0 otherwise).
"""

from __future__ import annotations

import numpy as np

from aquaspec.gpu.buffers import read_buffer, record_dispatch, submit_pass
from aquaspec.gpu.passes.deferred import (B_CAMERA, B_RGB, B_SIGMOID, B_SURFACE, DeferredPass,
                       bind_group_entries, bind_group_layout, shader_source)


class CopyPass:
    """Copy pass sharing the inputs and output of ``deferred``.

    Parameters
    ----------
    deferred : DeferredPass
        Its G-buffer textures (including ones handed over with
        ``use_gbuffer_textures``), camera uniform and RGB output are used.
    """

    def __init__(self, deferred: DeferredPass):
        self.deferred = deferred
        device = deferred.device
        self._layout = bind_group_layout(device, {
            B_CAMERA: "uniform", B_SURFACE: "uint", B_SIGMOID: "float", B_RGB: "write"})
        module = device.create_shader_module(label="copy.wgsl", code=shader_source("copy.wgsl"))
        self._pipeline = device.create_compute_pipeline(
            label="copy",
            layout=device.create_pipeline_layout(bind_group_layouts=[self._layout]),
            compute={"module": module, "entry_point": "main"})
        self._bind_group = None
        self._version = None

    def _get_bind_group(self):
        d = self.deferred
        if self._bind_group is None or self._version != d.bindings_version:
            gb = d.gbuffer_textures
            resources = {B_CAMERA: d._uniform, B_SURFACE: gb["surface"],
                         B_SIGMOID: gb["sigmoid"], B_RGB: d.rgb_buffer}
            self._bind_group = d.device.create_bind_group(layout=self._layout,
                                                          entries=bind_group_entries(resources))
            self._version = d.bindings_version
        return self._bind_group

    def workgroups(self) -> tuple[int, int, int]:
        """Dispatch size covering the image: one pixel per invocation, 8x8 workgroups."""
        d = self.deferred
        return (-(-d.width // 8), -(-d.height // 8), 1)

    def encode(self, encoder, timestamp_writes=None) -> None:
        """Record the copy into ``encoder`` (needs the deferred pass's camera)."""
        self.deferred.upload_uniforms()
        record_dispatch(encoder, self._pipeline, self._get_bind_group(), self.workgroups(),
                        timestamp_writes)

    def run(self) -> None:
        """Dispatch the copy (submits; does not wait)."""
        submit_pass(self.deferred.device, self)

    def read(self) -> np.ndarray:
        """The output buffer as (H, W, 4) float32: distance, normal.y, sigmoid.z, material."""
        d = self.deferred
        return read_buffer(d.device, d.rgb_buffer, np.float32, (d.height, d.width, 4))
