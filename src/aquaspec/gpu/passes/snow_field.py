"""Marine snow lit and splatted on the GPU, the particles' host part included.

:class:`SnowFieldPass` keeps a :class:`aquaspec.scene.particles.SnowField`'s
particles (their positions in the periodic cube and diameters, uploaded
once) on the GPU, and per frame moves, culls, lights and splats them in one
compute pass (one invocation per particle of the cells that may be in view,
:meth:`aquaspec.scene.particles.SnowField.indices_in_view`; WGSL
``snow_field.wgsl`` beside this module, the disc ``gpu/wgsl/snow_splat.wgsl``)
into a :class:`aquaspec.gpu.passes.particles.ParticlePass`'s accumulation:
what :func:`aquaspec.rendering.marine_snow.frame_splats` and
:meth:`ParticlePass.set_splats` do on the host, for particles lit by the
light field alone (:class:`aquaspec.shading.particles.ParticleLight` without
the sun or lamps, no lens blur: live frames). The NumPy twin is
``frame_splats`` followed by :func:`aquaspec.shading.particles.splat_image`;
``tests/gpu/passes/test_snow_field_pass.py`` holds them together.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import (create_array_texture, create_storage_buffer,
                                  create_uniform_buffer, read_buffer, upload_buffer)
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.passes.lightfield import band_group_texture
from aquaspec.gpu.passes.particles import PARAMS, SPLAT_WORKGROUP
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.shading.particles import MAX_RADIUS_PX, NEAR_M

FIELD_LAYOUT = UniformLayout("FieldParams", [
    ("shift", "vec3<f32>"), ("side", "f32"), ("cam", "vec3<f32>"), ("fx", "f32"),
    ("right", "vec3<f32>"), ("fy", "f32"), ("up", "vec3<f32>"), ("cx", "f32"),
    ("forward", "vec3<f32>"), ("cy", "f32"), ("count", "u32"), ("n_depth", "u32"),
    ("n_mu", "u32"), ("max_depth", "f32"), ("blur_px", "f32"), ("near", "f32"),
    ("max_radius", "f32")])


class SnowFieldPass:
    """The particles of a field, moved, lit and splatted into ``particles``
    (a :class:`aquaspec.gpu.passes.particles.ParticlePass`) each frame."""

    def __init__(self, particles):
        self.particles = particles
        self.device = dev = particles.device
        self._uniform = create_uniform_buffer(dev, FIELD_LAYOUT, label="snow field params")
        self._drawn = create_storage_buffer(dev, 16, label="snow field drawn")
        self._layout = bind_group_layout(dev, {0: "uint", 1: "uniform", 3: "write", 4: "uniform",
                                               5: "read", 6: "float_array", 7: "uniform",
                                               8: "write", 9: "read"})
        self._index = None
        self._pipelines = {}
        self._field = None
        self._origins = None
        self._light = None
        self._light_buffers = None
        self._group = None
        self._group_key = None

    def set_field(self, field) -> None:
        """The particles of ``field`` (a :class:`aquaspec.scene.particles.SnowField`), uploaded once."""
        if field is self._field:
            return
        data = np.empty((len(field.origin), 4), np.float32)
        data[:, :3] = field.origin
        data[:, 3] = field.diameter_m
        self._origins = create_storage_buffer(self.device, data, label="snow field origins")
        self._field = field
        self._group = None

    def set_light(self, light) -> None:
        """What lights the particles: a :class:`aquaspec.shading.particles.ParticleLight`
        without sun or lamps (the light field alone)."""
        if light.sun is not None or light.lamps:
            raise AquaspecError("the GPU's snow field is lit by the light field alone; "
                                "accepted: a ParticleLight without sun or lamps")
        if light is self._light:
            return
        visible = np.asarray(light.visible, np.float32)
        n = visible.shape[0]
        k = light.rho / np.pi * np.asarray(light.e0, float)
        w = np.asarray(light.response_weights, float)
        bands = np.zeros((n, 8), np.float32)
        bands[:, 0], bands[:, 1] = k, light.c_view
        bands[:, 2:5] = w
        uniform = create_uniform_buffer(self.device, bands.nbytes, label="snow field bands")
        upload_buffer(self.device, uniform, bands)
        self._light_buffers = (create_array_texture(self.device, band_group_texture(visible),
                                                    label="snow field V"), uniform)
        self._n_bands = n
        self._shape = visible.shape[1:]
        self._light = light
        self._group = None

    def encode(self, encoder, surface_texture, camera, time_s: float, blur_px=None) -> None:
        """Record the frame's particles at ``time_s`` (s) for ``camera`` into the
        particle pass's accumulation (cleared first; :meth:`set_field` and
        :meth:`set_light` before)."""
        if self._field is None or self._light is None:
            raise AquaspecError("SnowFieldPass needs set_field() and set_light() first")
        part, field = self.particles, self._field
        snow = field.snow
        side = 2.0 * snow.range_m
        cam = np.asarray(camera.position, float)
        # (Wrapped on the host in float64: the shader adds it to the origins in float32.)
        shift = np.mod(np.asarray(snow.current_m_s) * float(time_s) - cam + 0.5 * side, side)
        index = field.indices_in_view(cam, time_s, camera, MAX_RADIUS_PX + 1.0).astype(np.uint32)
        count = len(index)
        if self._index is None or self._index.size < max(index.nbytes, 4):
            self._index = create_storage_buffer(self.device, max(index.nbytes, 4096) * 2,
                                                label="snow field index")
            self._group = None
        if count:
            upload_buffer(self.device, self._index, index)
        u = np.zeros((), PARAMS.dtype)
        u["width"], u["height"], u["count"] = part.width, part.height, count
        upload_buffer(self.device, part.params, u)
        nd, nm = self._shape
        upload_buffer(self.device, self._uniform, FIELD_LAYOUT.pack(
            shift=shift, side=side, cam=cam, fx=camera.fx, right=camera.right, fy=camera.fy,
            up=camera.true_up, cx=camera.cx, forward=camera.forward, cy=camera.cy, count=count,
            n_depth=nd, n_mu=nm, max_depth=self._light.tables.max_depth_m,
            blur_px=snow.blur_px if blur_px is None else blur_px, near=NEAR_M,
            max_radius=MAX_RADIUS_PX))
        if self._group is None or self._group_key is not surface_texture:
            vis, bands = self._light_buffers
            self._group = self.device.create_bind_group(layout=self._layout, entries=(
                bind_group_entries({0: surface_texture, 1: part.params, 3: part.sums,
                                    4: self._uniform, 5: self._origins, 6: vis, 7: bands,
                                    8: self._drawn, 9: self._index})))
            self._group_key = surface_texture
        encoder.clear_buffer(self._drawn, 0, 16)
        part.encode_clear(encoder)
        if count:
            record_dispatch(encoder, self._pipeline(), self._group,
                            (-(-count // SPLAT_WORKGROUP), 1, 1))
        part.encode_copy(encoder)

    def _pipeline(self):
        n = self._n_bands
        if n not in self._pipelines:
            code = load_wgsl("snow_field.wgsl", params_struct=PARAMS.wgsl(),
                             params_name=PARAMS.name, field_struct=FIELD_LAYOUT.wgsl(),
                             n_bands=n, groups=-(-n // 4), band_vec4=2 * n)
            self._pipelines[n] = compute_pipeline(self.device, self._layout, code,
                                                  "snow_field.wgsl", entry_point="cs_field")
        return self._pipelines[n]

    def read_drawn(self) -> int:
        """The particles the last frame drew (waits for the GPU)."""
        return int(read_buffer(self.device, self._drawn, np.uint32, (4,))[0])
