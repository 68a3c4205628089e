"""Marine snow composed over the shaded image and shown, in one pass.

:class:`SnowDisplayPass` reads the shading pass's linear camera RGB
(``vec4<f32>`` per pixel) and the particles' accumulation texture of
:class:`aquaspec.gpu.passes.particles.ParticlePass`, composes them
(:func:`aquaspec.shading.particles.composite`) and applies the display
transform of :mod:`aquaspec.gpu.passes.display` (the folded matrix, the tone
map, sRGB, 8 bits; WGSL ``particles_display.wgsl`` beside this module, the
curves in ``gpu/wgsl/tonemap.wgsl``). One full-image pass instead of two (a
composition, then a display): on lavapipe such a pass costs about as much as
the splat of ten thousand particles.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import (create_storage_buffer, create_uniform_buffer, read_buffer,
                                  upload_buffer)
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.display_transform import DISPLAY_LAYOUT, display_template, display_uniform
from aquaspec.gpu.shaders import load_wgsl

WORKGROUP = (8, 8)


class SnowDisplayPass:
    """Compose and show ``width`` x ``height`` pixels: the particles of
    ``accum`` (its accumulation texture) with ``params`` (the
    particle pass's uniform buffer, of :class:`aquaspec.gpu.layout.UniformLayout`
    ``params_layout``) over a linear image."""

    def __init__(self, device, width: int, height: int, accum, params, params_layout):
        self.device, self.width, self.height = device, int(width), int(height)
        self._accum, self._params, self._params_layout = accum, params, params_layout
        self._uniform = create_uniform_buffer(device, DISPLAY_LAYOUT, label="snow display")
        self._status = create_storage_buffer(device, 16, label="snow display status")
        self._first = create_storage_buffer(device, np.array([0xFFFFFFFF], np.uint32),
                                            label="snow display first pixel")
        self._layout = bind_group_layout(device, {0: "uniform", 1: "read", 2: "write",
                                                  3: "write", 4: "uint", 5: "uniform"})
        #: ``display_buffer``: the image as packed RGBA8 (the display pass's layout).
        self.output = SimpleNamespace(display_buffer=create_storage_buffer(
            device, self.width * self.height * 4, label="snow display rgba8"))
        self._pipelines = {}
        self._group = None
        self._input = None
        self.settings = None

    def set_settings(self, *, exposure_ev, white_balance_gains=(1.0, 1.0, 1.0), matrix=None,
                     tonemap="filmic") -> None:
        """As :meth:`aquaspec.gpu.passes.display.DisplayPass.set_settings`."""
        data, self.settings = display_uniform(
            self.width, self.height, exposure_ev=exposure_ev,
            white_balance_gains=white_balance_gains, matrix=matrix, tonemap=tonemap)
        upload_buffer(self.device, self._uniform, data)

    def _pipeline(self, tonemap: str):
        if tonemap not in self._pipelines:
            lay = self._params_layout
            code = load_wgsl("particles_display.wgsl", params_struct=lay.wgsl(),
                             params_name=lay.name, **display_template(tonemap))
            self._pipelines[tonemap] = compute_pipeline(self.device, self._layout, code,
                                                        "particles_display.wgsl")
        return self._pipelines[tonemap]

    def encode(self, encoder, rgb_buffer) -> None:
        """Record the composition over ``rgb_buffer`` (read only) and the display."""
        if self.settings is None:
            raise AquaspecError("no display settings: call set_settings() first")
        if self._group is None or self._input is not rgb_buffer:
            self._group = self.device.create_bind_group(layout=self._layout, entries=(
                bind_group_entries({0: self._uniform, 1: rgb_buffer,
                                    2: self.output.display_buffer, 3: self._status,
                                    4: self._accum, 5: self._params})))
            self._input = rgb_buffer
        encoder.clear_buffer(self._status)
        encoder.copy_buffer_to_buffer(self._first, 0, self._status, 4, 4)
        record_dispatch(encoder, self._pipeline(self.settings["tonemap"]), self._group,
                        (-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]), 1))

    def read(self) -> np.ndarray:
        """The last image (H, W, 3) uint8; non-finite input refused."""
        status = read_buffer(self.device, self._status, np.uint32, (4,))
        if status[0]:
            row, col = divmod(int(status[1]), self.width)
            raise AquaspecError(f"{int(status[0])} pixel(s) came out non-finite under the "
                                f"marine snow (the first at row {row}, column {col}); this "
                                "is a bug, please report it with the parameters")
        rgba = read_buffer(self.device, self.output.display_buffer, np.uint8,
                           (self.height, self.width, 4))
        return np.ascontiguousarray(rgba[..., :3])
