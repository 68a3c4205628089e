"""The half-and-half frame's sky on the GPU, in place on a frame's linear image.

Twin of :func:`aquaspec.rendering.above.waterline_sky` in camera RGB (WGSL:
``waterline_sky.wgsl`` beside this module;
``tests/gpu/passes/test_waterline_sky_pass.py`` holds them together): for a
camera on the surface, every pixel whose ray goes up (``v.y > 0``) becomes
the sky's camera RGB (uniform, :func:`aquaspec.shading.above_water.sky_radiance_above`
weighted by the sensor's band weights); the others keep the water's half.
The buffer is ``width * height`` ``vec4<f32>``, ``p = row * width + column``
(a shading pass's :attr:`rgb_buffer`).
"""

from __future__ import annotations

import numpy as np

from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_uniform_buffer, upload_buffer
from aquaspec.gpu.camera import CAMERA_FIELDS, camera_fields
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.light.sky import clear_sky_norm

PARAMS_LAYOUT = UniformLayout("WaterlineSkyParams", CAMERA_FIELDS + [
    ("sky_rgb", "vec3<f32>"), ("width", "u32"), ("height", "u32"),
    ("sun_air", "vec3<f32>"), ("sky_norm", "f32"), ("sun_on", "u32"),
])
#: Compute workgroup size (x, y) of waterline_sky.wgsl: one pixel per invocation.
WORKGROUP = (8, 8)


class WaterlineSkyPass:
    """The sky over the upper rays of ``width`` x ``height`` frames on ``device``."""

    def __init__(self, device, width: int, height: int):
        self.device, self.width, self.height = device, int(width), int(height)
        self._params = create_uniform_buffer(device, PARAMS_LAYOUT, label="waterline sky")
        self._layout = bind_group_layout(device, {0: "uniform", 1: "write"})
        code = load_wgsl("waterline_sky.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                         params_struct_name=PARAMS_LAYOUT.name)
        self._pipeline = compute_pipeline(device, self._layout, code, "waterline_sky.wgsl")
        self._group = None

    def encode(self, encoder, camera, sky_rgb, rgb_buffer, timestamp_writes=None,
               sun_air=None) -> None:
        """Record the sky ``sky_rgb`` (camera RGB, 3; the uniform sky's) over
        ``camera``'s rays going up in ``rgb_buffer``; with ``sun_air`` (the
        unit vector towards the sun in air) shaped as the CIE clear sky
        about it (:func:`aquaspec.shading.above_water.sky_shape`)."""
        sun = sun_air is not None
        upload_buffer(self.device, self._params, PARAMS_LAYOUT.pack(
            **camera_fields(camera), sky_rgb=np.asarray(sky_rgb, dtype=np.float64),
            width=self.width, height=self.height,
            sun_air=np.asarray(sun_air if sun else np.zeros(3), dtype=np.float64),
            sky_norm=clear_sky_norm(sun_air) if sun else 1.0, sun_on=int(sun)))
        if self._group is None or self._group[1] is not rgb_buffer:
            self._group = (self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries({0: self._params,
                                                                 1: rgb_buffer})), rgb_buffer)
        groups = (-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]), 1)
        record_dispatch(encoder, self._pipeline, self._group[0], groups, timestamp_writes)
