"""The wind sea seen from below on the GPU: Snell's window broken by the waves.

Twin of :func:`aquaspec.shading.below_waves.window_correction` (WGSL:
``below_waves.wgsl`` beside this module; ``tests/gpu/passes/test_below_waves_pass.py``
holds it against the NumPy reference): per pixel looking up through open
water (read from the G-buffer's surface texture), the camera-RGB change the
wave tile's facet makes to the surface's light, to be added to the flat
surface's image. The water's table below the surface, the sky and the
tile's slopes are uploaded once per medium and sea (:meth:`BelowWavesPass.set_medium`);
a frame is one small dispatch and a readback.
"""

from __future__ import annotations

import numpy as np

from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import (create_storage_buffer, create_uniform_buffer, read_buffer,
                                  upload_buffer)
from aquaspec.gpu.camera import CAMERA_FIELDS, camera_fields
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.medium.interface import N_WATER
from aquaspec.shading.above_water import WAVE_T_TOP, sky_radiance_above, water_below_table

PARAMS_LAYOUT = UniformLayout("BelowWavesParams", CAMERA_FIELDS + [
    ("n_water", "f32"), ("t_top", "f32"), ("tile_m", "f32"), ("tile_grid", "u32"),
    ("width", "u32"), ("height", "u32"), ("nodes", "u32"), ("n_bands", "u32"),
])
WORKGROUP = (8, 8)


class BelowWavesPass:
    """The waves' change to the view from below at ``width`` x ``height``:
    camera RGB into :attr:`rgb_buffer` ((H, W) vec4)."""

    def __init__(self, device, width: int, height: int):
        self.device, self.width, self.height = device, int(width), int(height)
        self._params = create_uniform_buffer(device, PARAMS_LAYOUT, label="below waves params")
        self.rgb_buffer = create_storage_buffer(device, self.width * self.height * 16,
                                                label="below waves rgb")
        self._layout = bind_group_layout(device, {0: "uniform", 1: "uint", 2: "read",
                                                  3: "read", 4: "read", 5: "write"})
        code = load_wgsl("below_waves.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                         params_struct_name=PARAMS_LAYOUT.name)
        self._pipeline = compute_pipeline(device, self._layout, code, "below_waves.wgsl")
        self._buffers = {}
        self._medium = None

    def set_medium(self, tables, facets, *, a, b, e0, response_weights) -> None:
        """Upload the water's table, the sky and the bands' constants (camera
        RGB weights) and the tile's slopes."""
        nodes, table = water_below_table(tables, a=a, b=b, e0=e0, t_top=WAVE_T_TOP)
        n = table.shape[1]
        sky = sky_radiance_above(tables, e0)
        bands = np.zeros((n, 2, 4), dtype=np.float32)
        bands[:, 0, 0] = np.asarray(a, dtype=float) + np.asarray(b, dtype=float)
        bands[:, 0, 1] = sky
        bands[:, 1, :3] = np.asarray(response_weights, dtype=float)
        data = {"bands": bands.reshape(-1, 4), "water": table.astype(np.float32).ravel(),
                "slopes": np.ascontiguousarray(facets.slopes, dtype=np.float32).reshape(-1, 2)}
        for name, arr in data.items():
            buf = self._buffers.get(name)
            if buf is None or buf.size != arr.nbytes:
                self._buffers[name] = create_storage_buffer(self.device, arr, label=name)
            else:
                upload_buffer(self.device, buf, arr)
        self._medium = {"n_water": N_WATER, "t_top": WAVE_T_TOP, "tile_m": float(facets.tile_m),
                        "tile_grid": int(facets.slopes.shape[0]), "nodes": int(nodes.size),
                        "n_bands": int(n)}

    def encode(self, encoder, camera, surface_texture) -> None:
        """Record the pass for ``camera`` reading the G-buffer's ``surface_texture``."""
        if self._medium is None:
            raise RuntimeError("BelowWavesPass.set_medium first")
        upload_buffer(self.device, self._params, PARAMS_LAYOUT.pack(
            **camera_fields(camera), **self._medium, width=self.width, height=self.height))
        group = self.device.create_bind_group(layout=self._layout, entries=bind_group_entries(
            {0: self._params, 1: surface_texture, 2: self._buffers["bands"],
             3: self._buffers["water"], 4: self._buffers["slopes"], 5: self.rgb_buffer}))
        groups = (-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]), 1)
        record_dispatch(encoder, self._pipeline, group, groups)

    def render(self, camera, surface_texture) -> np.ndarray:
        """Run the pass and read back the camera-RGB change, (H, W, 3) float32."""
        encoder = self.device.create_command_encoder()
        self.encode(encoder, camera, surface_texture)
        self.device.queue.submit([encoder.finish()])
        out = read_buffer(self.device, self.rgb_buffer, np.float32, (self.height, self.width, 4))
        return out[..., :3]
