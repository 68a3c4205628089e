"""One camera-RGB image added to another in place on the GPU.

``rgb[p] += change[p]`` over ``width x height`` pixels of ``vec4<f32>``
(RGB, w kept), ``p = row * width + column``: the layout of the shading
passes' :attr:`rgb_buffer` and of the passes that compute a change to it
(:class:`aquaspec.gpu.passes.below_waves.BelowWavesPass`). Its NumPy twin is
``rgb[..., :3] + change[..., :3]`` (``tests/gpu/passes/test_add_rgb_pass.py``).
WGSL: ``add_rgb.wgsl`` beside this module.
"""

from __future__ import annotations

from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_uniform_buffer, upload_buffer
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.shaders import load_wgsl

PARAMS_LAYOUT = UniformLayout("AddRgbParams", [("width", "u32"), ("height", "u32")])
#: Compute workgroup size (x, y) of add_rgb.wgsl: one pixel per invocation.
WORKGROUP = (8, 8)


class AddRgbPass:
    """Adds ``change`` to ``rgb`` (both ``width * height`` vec4 storage buffers)."""

    def __init__(self, device, width: int, height: int):
        self.device, self.width, self.height = device, int(width), int(height)
        self._params = create_uniform_buffer(device, PARAMS_LAYOUT, label="add rgb params")
        upload_buffer(device, self._params, PARAMS_LAYOUT.pack(width=self.width,
                                                               height=self.height))
        self._layout = bind_group_layout(device, {0: "uniform", 1: "read", 2: "write"})
        code = load_wgsl("add_rgb.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                         params_struct_name=PARAMS_LAYOUT.name)
        self._pipeline = compute_pipeline(device, self._layout, code, "add_rgb.wgsl")
        self._group = None

    def encode(self, encoder, change, rgb, timestamp_writes=None) -> None:
        """Record ``rgb += change`` (the bind group made again when the buffers change)."""
        if self._group is None or self._group[1] is not change or self._group[2] is not rgb:
            self._group = (self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries({0: self._params, 1: change,
                                                                 2: rgb})), change, rgb)
        groups = (-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]), 1)
        record_dispatch(encoder, self._pipeline, self._group[0], groups, timestamp_writes)
