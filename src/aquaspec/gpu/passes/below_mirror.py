"""The scene mirrored in the sea surface seen from below, on the GPU.

Twin of :func:`aquaspec.shading.below_mirror.scene_in_mirror` (WGSL:
``below_mirror.wgsl`` beside this module;
``tests/gpu/passes/test_below_mirror_pass.py`` holds it against the NumPy
reference): per pixel looking up through open water (the frame's G-buffer
surface texture), the camera-RGB change of the flat surface's mirror where
the mirrored ray meets the scene, read from a G-buffer rasterised from the
mirrored camera (:func:`aquaspec.shading.below_mirror.mirrored_camera`;
:meth:`BelowMirrorPass.mirror_gbuffer` records it with the frame's raster
pass into that pass's own targets). The light field's irradiance table, the
open water's background table
(:func:`~aquaspec.shading.below_mirror.mirror_background_table`), the
materials and the bands' constants are uploaded once per medium
(:meth:`BelowMirrorPass.set_medium`).
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
from aquaspec.shading.below_mirror import mirror_background_table, mirrored_camera
from aquaspec.transport.lightfield.tables import band_last_table

PARAMS_LAYOUT = UniformLayout("BelowMirrorParams", CAMERA_FIELDS + [
    ("to_sun", "vec3<f32>"), ("mu0", "f32"),
    ("n_water", "f32"), ("max_depth", "f32"), ("width", "u32"), ("height", "u32"),
    ("groups", "u32"), ("bg_depth", "u32"), ("bg_mu", "u32"), ("e_depth", "u32"),
    ("e_mu", "u32"), ("sun_on", "u32"), ("waves_on", "u32"), ("tile_grid", "u32"),
    ("tile_m", "f32"), ("pad0", "u32"), ("pad1", "u32"), ("pad2", "u32"),
])
WORKGROUP = (8, 8)


class BelowMirrorPass:
    """The scene mirrored in the surface seen from below at ``width`` x
    ``height``: camera RGB into :attr:`rgb_buffer` ((H, W) vec4)."""

    def __init__(self, device, width: int, height: int):
        self.device, self.width, self.height = device, int(width), int(height)
        self._params = create_uniform_buffer(device, PARAMS_LAYOUT, label="below mirror params")
        self.rgb_buffer = create_storage_buffer(device, self.width * self.height * 16,
                                                label="below mirror rgb")
        self._layout = bind_group_layout(device, {0: "uniform", 1: "uint", 2: "uint",
                                                  3: "float", 4: "uniform", 5: "read", 6: "read",
                                                  7: "read", 8: "write", 9: "read"})
        self._pipelines = {}
        self._buffers = {}
        self._medium = None

    def set_medium(self, tables, *, a, b, e0, response_weights, material_bands,
                   sigmoid_centers_t, sun=None, facets=None) -> None:
        """Upload the light field's irradiance table, the open water's
        background, the materials' band reflectances (M, n), the bands'
        constants, the sun (``sun``:
        :class:`aquaspec.transport.sun_scattering.SunInputs` or None) and the
        wave tile's slopes (``facets``:
        :class:`aquaspec.light.wave_facets.SurfaceFacets`, None: the flat
        surface)."""
        a = np.asarray(a, dtype=float)
        n = a.size
        groups = -(-n // 4)
        rows = np.zeros((8, 4 * groups))
        rows[0, :n] = tables.ray_extinction(a, b)
        rows[1, :n] = np.asarray(sigmoid_centers_t, dtype=float)
        rows[2, :n] = np.asarray(e0, dtype=float)
        rows[3:6, :n] = np.asarray(response_weights, dtype=float).T
        to_sun, mu0 = np.array([0.0, 1.0, 0.0]), 1.0
        if sun is not None:
            rows[6, :n] = sun.beam0
            rows[7, :n] = sun.c_sun
            to_sun, mu0 = np.asarray(sun.to_sun, dtype=float), float(sun.mu0)
        background = mirror_background_table(tables, a=a, b=b, e0=e0)
        irradiance = band_last_table(tables.irradiance_per_e0)
        mats = np.asarray(material_bands, dtype=float).reshape(-1, n)
        data = {"bands": _grouped(rows, groups).reshape(8, groups, 4).transpose(1, 0, 2),
                "materials": _grouped(mats if mats.size else np.zeros((1, n)), groups),
                "background": _grouped(background, groups),
                "irradiance": _grouped(irradiance, groups)}
        data = {k: np.ascontiguousarray(v, dtype=np.float32).reshape(-1, 4)
                for k, v in data.items()}
        data["slopes"] = (np.zeros((2, 2), np.float32) if facets is None
                          else np.ascontiguousarray(facets.slopes, dtype=np.float32).reshape(-1, 2))
        for name, arr in data.items():
            buf = self._buffers.get(name)
            if buf is None or buf.size != arr.nbytes:
                # (The bands' constants in a uniform array: on lavapipe a uniform
                # read costs a quarter of a storage read, aquaspec.gpu.materials.)
                buf = (create_uniform_buffer(self.device, arr.nbytes, label=name)
                       if name == "bands" else create_storage_buffer(self.device, arr,
                                                                     label=name))
                self._buffers[name] = buf
            if name == "bands" or buf.size == arr.nbytes:
                upload_buffer(self.device, buf, arr)
        self._medium = {"n_water": N_WATER, "max_depth": float(tables.max_depth_m),
                        "groups": int(groups), "bg_depth": background.shape[0],
                        "bg_mu": background.shape[1], "e_depth": irradiance.shape[0],
                        "e_mu": irradiance.shape[1], "sun_on": int(sun is not None),
                        "to_sun": to_sun, "mu0": mu0,
                        "waves_on": int(facets is not None),
                        "tile_grid": 2 if facets is None else int(facets.slopes.shape[0]),
                        "tile_m": 1.0 if facets is None else float(facets.tile_m),
                        "pad0": 0, "pad1": 0, "pad2": 0}

    def _pipeline(self, groups: int):
        """The pipeline for ``groups`` vec4s of bands (a constant: the loop
        over them unrolled), compiled on first use."""
        if groups not in self._pipelines:
            code = load_wgsl("below_mirror.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                             params_struct_name=PARAMS_LAYOUT.name, groups=groups,
                             groups_x8=8 * groups)
            self._pipelines[groups] = compute_pipeline(self.device, self._layout, code,
                                                       "below_mirror.wgsl")
        return self._pipelines[groups]

    @staticmethod
    def mirror_gbuffer(encoder, raster, scene, camera) -> dict:
        """Record ``raster`` (:class:`aquaspec.gpu.passes.raster.RasterPass`)
        drawing ``scene`` from the camera mirrored in the surface into its own
        targets; returns them (``{"surface", "sigmoid"}``) for :meth:`encode`."""
        raster.encode(encoder, scene, mirrored_camera(camera))
        return raster.targets

    def encode(self, encoder, camera, surface_texture, mirror_textures) -> None:
        """Record the pass for ``camera`` reading the frame's G-buffer
        ``surface_texture`` and the mirrored camera's ``mirror_textures``."""
        if self._medium is None:
            raise RuntimeError("BelowMirrorPass.set_medium first")
        upload_buffer(self.device, self._params, PARAMS_LAYOUT.pack(
            **camera_fields(camera), **self._medium, width=self.width, height=self.height))
        group = self.device.create_bind_group(layout=self._layout, entries=bind_group_entries(
            {0: self._params, 1: surface_texture, 2: mirror_textures["surface"],
             3: mirror_textures["sigmoid"], 4: self._buffers["bands"],
             5: self._buffers["materials"], 6: self._buffers["background"],
             7: self._buffers["irradiance"], 8: self.rgb_buffer, 9: self._buffers["slopes"]}))
        groups = (-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]), 1)
        record_dispatch(encoder, self._pipeline(self._medium["groups"]), group, groups)

    def render(self, camera, surface_texture, mirror_textures) -> np.ndarray:
        """Run the pass and read back the camera-RGB change, (H, W, 3) float32."""
        encoder = self.device.create_command_encoder()
        self.encode(encoder, camera, surface_texture, mirror_textures)
        self.device.queue.submit([encoder.finish()])
        out = read_buffer(self.device, self.rgb_buffer, np.float32, (self.height, self.width, 4))
        return out[..., :3]


def _grouped(values, groups: int) -> np.ndarray:
    """``values`` (..., n) padded with zeros to ``4 groups`` bands, as
    (..., groups, 4): four bands to a vec4, as the WGSL reads them."""
    v = np.asarray(values, dtype=float)
    out = np.zeros(v.shape[:-1] + (4 * groups,))
    out[..., :v.shape[-1]] = v
    return out.reshape(v.shape[:-1] + (groups, 4))
