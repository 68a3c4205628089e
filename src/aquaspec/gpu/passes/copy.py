"""The "memory floor" pass: read the G-buffer, write the output, no shading.

It binds the same camera uniform, G-buffer textures and output buffer as a
:class:`~aquaspec.gpu.passes.deferred.DeferredPass` and covers the same pixels, so
``aquaspec bench`` can report how much of the deferred pass's time is memory
traffic (the floor) and how much is the per-band arithmetic. WGSL:
``copy.wgsl`` beside this module; each output pixel is
``(distance, normal.y, sigmoid.z, f32(material))`` of its input (the
sigmoid texture is read only when the G-buffer's ``per_pixel`` is true, as
the deferred pass does; sigmoid.z is 0 otherwise).
"""

from __future__ import annotations

import numpy as np

from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import read_buffer
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch, submit_pass
from aquaspec.gpu.gbuffer import B_SIGMOID, B_SURFACE
from aquaspec.gpu.passes.deferred import B_CAMERA, PARAMS_LAYOUT, DeferredPass
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.gpu.shading_output import B_RGB

#: Compute workgroup size (x, y) of copy.wgsl: one pixel per invocation.
WORKGROUP = (8, 8)


class CopyPass:
    """Copy pass sharing the inputs and output of ``deferred``.

    Parameters
    ----------
    deferred : DeferredPass
        Its G-buffer, camera uniform and RGB output are used.
    """

    def __init__(self, deferred: DeferredPass):
        self.deferred = deferred
        self.device = deferred.device
        self._layout = bind_group_layout(self.device, {
            B_CAMERA: "uniform", B_SURFACE: "uint", B_SIGMOID: "float", B_RGB: "write"})
        code = load_wgsl("copy.wgsl", camera_struct=PARAMS_LAYOUT.wgsl(),
                         camera_struct_name=PARAMS_LAYOUT.name)
        self._pipeline = compute_pipeline(self.device, self._layout, code, "copy.wgsl")
        self._bind_group = None
        self._version = None

    def bind_group(self):
        """The bind group (rebuilt when the G-buffer's textures are replaced)."""
        d = self.deferred
        if self._bind_group is None or self._version != d.gbuffer.bindings_version:
            gb = d.gbuffer.textures
            resources = {B_CAMERA: d.params_buffer, B_SURFACE: gb["surface"],
                         B_SIGMOID: gb["sigmoid"], B_RGB: d.rgb_buffer}
            self._bind_group = self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries(resources))
            self._version = d.gbuffer.bindings_version
        return self._bind_group

    def workgroups(self) -> tuple[int, int, int]:
        """Dispatch size covering the image."""
        d = self.deferred
        return (-(-d.width // WORKGROUP[0]), -(-d.height // WORKGROUP[1]), 1)

    def encode(self, encoder, timestamp_writes=None) -> None:
        """Record the copy into ``encoder`` (needs the G-buffer's camera)."""
        self.deferred.upload_uniforms()
        record_dispatch(encoder, self._pipeline, self.bind_group(), self.workgroups(),
                        timestamp_writes)

    def run(self) -> None:
        """Dispatch the copy (submits; does not wait)."""
        submit_pass(self.device, self)

    def read(self) -> np.ndarray:
        """The output buffer as (H, W, 4) float32: distance, normal.y, sigmoid.z, material."""
        d = self.deferred
        return read_buffer(self.device, d.rgb_buffer, np.float32, (d.height, d.width, 4))
