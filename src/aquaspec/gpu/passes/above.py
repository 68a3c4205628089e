"""The sea seen from above a flat surface, on the GPU (camera RGB per pixel).

Twin of :func:`aquaspec.shading.above_water.sea_from_above` (WGSL:
``above.wgsl`` beside this module; ``tests/gpu/passes/test_above_pass.py``
holds it against the NumPy reference). The per-frame work is one small
dispatch: per pixel the Fresnel reflection of the sky and, through the
surface, a lookup in the table of the water's light just below it over the
refracted ray's ``t_y`` (:func:`aquaspec.shading.above_water.water_below_table`),
which depends on the water, the light and the seabed but not on the camera:
it is uploaded once per medium (:meth:`AbovePass.set_medium`), so a moving
camera costs the dispatch alone. With a sun, a second table (the beam
scattered once, over ``t_y`` and the scattering cosine,
:func:`aquaspec.shading.above_water.sun_scattering_table`) is read
bilinearly, and the sun's disc mirrored in the surface is added.
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
from aquaspec.shading.above_water import (MIN_FACET_COS, WAVE_T_TOP, glint_radius,
                                          sky_radiance_above, sun_in_air, sun_scattering_table,
                                          water_below_table)

PARAMS_LAYOUT = UniformLayout("AboveParams", CAMERA_FIELDS + [
    ("sky_rgb", "vec3<f32>"), ("n_water", "f32"),
    ("to_sun", "vec3<f32>"), ("sun_cos_lo", "f32"),
    ("sun_air", "vec3<f32>"), ("sun_cos_hi", "f32"),
    ("glint_rgb", "vec3<f32>"), ("sun_cos_radius", "f32"),
    ("width", "u32"), ("height", "u32"), ("nodes", "u32"), ("edge_cos", "f32"),
    ("sun_rgb", "vec3<f32>"), ("s2", "f32"),
    ("sun_on", "u32"), ("sun_nodes_y", "u32"), ("sun_nodes_cos", "u32"),
    ("waves_on", "u32"), ("tile_grid", "u32"), ("tile_m", "f32"), ("min_facet_cos", "f32"),
    ("sky_norm", "f32"),
])
#: Compute workgroup size (x, y) of above.wgsl: one pixel per invocation.
WORKGROUP = (8, 8)


class AbovePass:
    """The view from above at ``width`` x ``height`` on ``device``: camera RGB
    into :attr:`rgb_buffer` ((H, W) vec4)."""

    def __init__(self, device, width: int, height: int):
        self.device, self.width, self.height = device, int(width), int(height)
        self._params = create_uniform_buffer(device, PARAMS_LAYOUT, label="above params")
        self.rgb_buffer = create_storage_buffer(device, self.width * self.height * 16,
                                                label="above rgb")
        self._layout = bind_group_layout(device, {0: "uniform", 1: "read", 2: "write",
                                                  3: "read", 4: "read"})
        self._pipelines = {}
        self._water = self._sun = self._slopes = self._bind_group = None
        self._medium = None

    def _pipeline(self, sun: bool, waves: bool):
        """The pipeline drawing the sun's terms and the waves or not, compiled
        once each (above.wgsl's SUN_ON and WAVES_ON constants): on lavapipe
        the sun's and waves' code cost the overcast frame 40 -> 65 ms as
        branches on a uniform, though never taken."""
        key = (bool(sun), bool(waves))
        if key not in self._pipelines:
            code = load_wgsl("above.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                             params_struct_name=PARAMS_LAYOUT.name,
                             sun_on=str(key[0]).lower(), waves_on=str(key[1]).lower())
            self._pipelines[key] = compute_pipeline(self.device, self._layout, code,
                                                    "above.wgsl")
        return self._pipelines[key]

    def _upload(self, name: str, table: np.ndarray):
        buf = getattr(self, name)
        if buf is None or buf.size != table.nbytes:
            setattr(self, name, create_storage_buffer(self.device, table, label=f"above{name}"))
            self._bind_group = None
        else:
            upload_buffer(self.device, buf, table)

    def set_medium(self, tables, *, a, b, e0, response_weights, sun=None, facets=None) -> None:
        """Upload the water's table below the surface and the sky, in camera
        RGB; with ``sun`` (:class:`aquaspec.transport.sun_scattering.SunInputs`)
        its scattering table and glint too; with ``facets``
        (:class:`aquaspec.light.wave_facets.SurfaceFacets`) the wave tile."""
        top = None if facets is None else WAVE_T_TOP
        t_y, water = water_below_table(tables, a=a, b=b, e0=e0, t_top=top)
        w = np.asarray(response_weights, dtype=np.float64)
        table = np.zeros((t_y.size, 4), dtype=np.float32)
        table[:, :3] = water @ w
        self._upload("_water", table)
        self._medium = {"sky_rgb": sky_radiance_above(tables, e0) @ w, "nodes": t_y.size,
                        "edge_cos": float(-t_y[-1]), "sun_on": 0, "sun_nodes_y": 2, "sun_nodes_cos": 2,
                        "to_sun": np.zeros(3), "sun_cos_lo": 0.0, "sun_cos_hi": 1.0,
                        "sun_air": np.zeros(3), "glint_rgb": np.zeros(3), "sun_cos_radius": 2.0,
                        "sun_rgb": np.zeros(3), "s2": 0.0, "waves_on": 0, "tile_grid": 2,
                        "tile_m": 1.0, "min_facet_cos": MIN_FACET_COS, "sky_norm": 1.0}
        sun_table = np.zeros((4, 4), dtype=np.float32)
        if sun is not None:
            _, cos, ss = sun_scattering_table(tables, sun, t_top=top)
            sun_table = np.zeros(ss.shape[:2] + (4,), dtype=np.float32)
            sun_table[..., :3] = ss @ w
            to_air, beam_air = sun_in_air(sun)
            self._sun_radiance = beam_air @ w
            self._medium.update(
                sky_norm=clear_sky_norm(to_air), sun_on=1, sun_nodes_y=ss.shape[0], sun_nodes_cos=ss.shape[1], to_sun=np.asarray(sun.to_sun, dtype=float),
                sun_cos_lo=float(cos[0]), sun_cos_hi=float(cos[-1]), sun_air=to_air,
                glint_rgb=np.zeros(3), sun_cos_radius=2.0, sun_rgb=beam_air @ w)
        self._upload("_sun", sun_table.reshape(-1, 4))
        slopes = np.zeros((2, 2), dtype=np.float32)
        if facets is not None:
            slopes = np.ascontiguousarray(facets.slopes, dtype=np.float32).reshape(-1, 2)
            self._medium.update(waves_on=1, tile_grid=facets.slopes.shape[0],
                                tile_m=float(facets.tile_m), s2=float(facets.s2))
        self._upload("_slopes", slopes)

    def set_slopes(self, facets) -> None:
        """Replace the wave tile's slopes by ``facets``' (the same sea at
        another instant: its tile, grid and unresolved variance unchanged),
        without making the water's and the sun's tables again (a moving sea
        in the live view)."""
        if not getattr(self, "_medium", {}).get("waves_on"):
            raise RuntimeError("AbovePass.set_medium with facets first")
        self._upload("_slopes", facets.slopes_for(self._medium["tile_grid"],
                                                  self._medium["tile_m"]))

    def encode(self, encoder, camera, timestamp_writes=None) -> None:
        """Record the pass for ``camera`` (after :meth:`set_medium`)."""
        if self._medium is None:
            raise RuntimeError("AbovePass.set_medium first")
        medium = dict(self._medium)
        if medium["sun_on"]:
            # The glint's disc for this camera (shading.above_water.glint_radius).
            cos_r = float(np.cos(glint_radius(camera)))
            medium.update(sun_cos_radius=cos_r,
                          glint_rgb=self._sun_radiance / (2.0 * np.pi * (1.0 - cos_r)))
        upload_buffer(self.device, self._params, PARAMS_LAYOUT.pack(
            **camera_fields(camera), **medium, n_water=N_WATER, width=self.width,
            height=self.height))
        if self._bind_group is None:
            self._bind_group = self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries(
                    {0: self._params, 1: self._water, 2: self.rgb_buffer, 3: self._sun,
                     4: self._slopes}))
        groups = (-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]), 1)
        pipeline = self._pipeline(medium["sun_on"], medium["waves_on"])
        record_dispatch(encoder, pipeline, self._bind_group, groups, timestamp_writes)

    def render(self, camera) -> np.ndarray:
        """Run the pass for ``camera`` and read back camera RGB, (H, W, 3) float32."""
        encoder = self.device.create_command_encoder()
        self.encode(encoder, camera)
        self.device.queue.submit([encoder.finish()])
        out = read_buffer(self.device, self.rgb_buffer, np.float32, (self.height, self.width, 4))
        return out[..., :3]
