"""The surface seen from below on the GPU: Snell's window broken by the waves,
and the sun's disc (or, under waves, its glitter) through it.

Twin of :func:`aquaspec.shading.below_waves.window_correction` and
:func:`aquaspec.shading.below_waves.sun_disc_below` (WGSL:
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
from aquaspec.light.sky import clear_sky_norm
from aquaspec.medium.interface import N_WATER
from aquaspec.shading.above_water import (WAVE_T_TOP, sky_radiance_above, sun_in_air,
                                          water_below_table)
from aquaspec.shading.below_waves import glitter_variance_below, sun_radius_below

PARAMS_LAYOUT = UniformLayout("BelowWavesParams", CAMERA_FIELDS + [
    ("n_water", "f32"), ("t_top", "f32"), ("tile_m", "f32"), ("tile_grid", "u32"),
    ("width", "u32"), ("height", "u32"), ("nodes", "u32"), ("n_bands", "u32"),
    ("sun_air", "vec3<f32>"), ("sun_cos_radius", "f32"),
    ("omega", "f32"), ("sun_on", "u32"), ("waves_on", "u32"), ("s2", "f32"),
    ("sky_norm", "f32"),
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

    def set_medium(self, tables, facets, *, a, b, e0, response_weights, sun=None) -> None:
        """Upload the water's table, the sky and the bands' constants (camera
        RGB weights), the tile's slopes (``facets`` None: the flat surface)
        and the sun (``sun``: :class:`aquaspec.transport.sun_scattering.SunInputs`
        or None)."""
        n = np.asarray(a).size
        if facets is None:
            # The flat surface: only the sun's disc; the water's table is not read.
            nodes, table = np.zeros(2), np.zeros((2, n))
        else:
            nodes, table = water_below_table(tables, a=a, b=b, e0=e0, t_top=WAVE_T_TOP)
        sky = sky_radiance_above(tables, e0)
        bands = np.zeros((n, 2, 4), dtype=np.float32)
        bands[:, 0, 0] = np.asarray(a, dtype=float) + np.asarray(b, dtype=float)
        bands[:, 0, 1] = sky
        bands[:, 1, :3] = np.asarray(response_weights, dtype=float)
        to_air = np.zeros(3)
        if sun is not None:
            to_air, e_air = sun_in_air(sun)
            bands[:, 0, 2] = e_air
        slopes = (np.zeros((2, 2), np.float32) if facets is None
                  else np.ascontiguousarray(facets.slopes, dtype=np.float32).reshape(-1, 2))
        data = {"bands": bands.reshape(-1, 4), "water": table.astype(np.float32).ravel(),
                "slopes": slopes}
        for name, arr in data.items():
            buf = self._buffers.get(name)
            if buf is None or buf.size != arr.nbytes:
                self._buffers[name] = create_storage_buffer(self.device, arr, label=name)
            else:
                upload_buffer(self.device, buf, arr)
        self._medium = {"n_water": N_WATER, "t_top": WAVE_T_TOP,
                        "tile_m": 1.0 if facets is None else float(facets.tile_m),
                        "tile_grid": 2 if facets is None else int(facets.slopes.shape[0]),
                        "nodes": int(nodes.size), "n_bands": int(n), "sun_air": to_air,
                        "sun_on": int(sun is not None), "waves_on": int(facets is not None),
                        "s2": 0.0 if facets is None else float(facets.s2),
                        "sky_norm": 1.0 if sun is None else clear_sky_norm(to_air)}

    def set_slopes(self, facets) -> None:
        """Replace the wave tile's slopes by ``facets``' (the same sea at
        another instant: its tile, grid and unresolved variance unchanged)
        without making the water's table again (a moving sea in live frames)."""
        if self._medium is None or not self._medium["waves_on"]:
            raise RuntimeError("BelowWavesPass.set_medium with facets first")
        upload_buffer(self.device, self._buffers["slopes"],
                      facets.slopes_for(self._medium["tile_grid"], self._medium["tile_m"]))

    def encode(self, encoder, camera, surface_texture) -> None:
        """Record the pass for ``camera`` reading the G-buffer's ``surface_texture``."""
        if self._medium is None:
            raise RuntimeError("BelowWavesPass.set_medium first")
        radius = sun_radius_below(camera, self._medium["sun_air"])
        medium = dict(self._medium)
        if medium["s2"] > 0:
            medium["s2"] = glitter_variance_below(camera, medium["s2"])
        upload_buffer(self.device, self._params, PARAMS_LAYOUT.pack(
            **camera_fields(camera), **medium, width=self.width, height=self.height,
            sun_cos_radius=float(np.cos(radius)), omega=2.0 * np.pi * (1.0 - np.cos(radius))))
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
