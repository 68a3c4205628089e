"""The direct sun on the GPU: its shadow map and its light, added to a shading pass's image.

Three steps (maths in :mod:`aquaspec.transport.sun_scattering` and
:mod:`aquaspec.transport.froxels`, NumPy twin :func:`aquaspec.shading.sun.sun_radiance`):

- the shadow map (:class:`aquaspec.gpu.passes.sun_shadow.SunShadowPass`): the
  scene rasterised depth-only along the refracted beam;
- the froxels (``sun.wgsl`` beside this module, ``build_froxels``): the beam's single
  scattering integrated front to back along each column of
  :func:`aquaspec.transport.froxels.froxel_tile` pixels square, over
  :data:`aquaspec.transport.froxels.FROXEL_SLICES` slices, in camera RGB;
- the sun's radiance per pixel: the sun-lit surface's light and the single
  scattering read from the froxels at the pixel's distance. The light-field
  shading pass adds it in its own band loop (:meth:`fused_layout`,
  :meth:`fused_resources` and :meth:`wgsl_values` give it the bindings and
  ``sunlight.wgsl``'s templates; :meth:`encode_froxels` comes first); for the
  seeds' model ``main`` adds it in camera RGB to the shading pass's linear
  image (its ``rgb_buffer``), so :meth:`read_rgb` of that pass returns the
  whole image.

Bindings of sun.wgsl: 0 uniform :data:`PARAMS_LAYOUT`; 1, 2 the G-buffer's
surface and sigmoid textures (:mod:`aquaspec.gpu.gbuffer`); 3 material band
reflectances (M * n f32); 4 four vec4 per band (two constants, then the
polynomial of the caustics' contrast scale: :func:`caustic_scale_rows`); 5 ``ln p`` per band
(:func:`aquaspec.transport.sun_scattering.log_phase_table`); 6 the shadow map; 7 the image (vec4 per
pixel, read and written); 8 the froxels (a 3-D texture, RGB per column and
slice boundary, :func:`froxel_format`; written at 13 by build_froxels, read
through the linear clamped sampler 14); 9 ``ln`` of the bands' mean phase function
(:func:`aquaspec.transport.sun_scattering.band_mean_log_phase`); 10 the caustic factor's slices
(:class:`aquaspec.light.caustics.CausticMap`, an ``r16float`` 2-D array with its mip
levels; a 1 x 1 x 2 stand-in without caustics), 11 its repeating
trilinear sampler and 12 the shadow map's comparison sampler. The fused
bindings (:data:`FUSED_BINDINGS`) are the same resources at other numbers.

The shadow map is drawn again only when its geometry (the sun, the map's
place around the camera) or the scene's uploaded buffers change
(:meth:`aquaspec.gpu.passes.sun_shadow.SunShadowPass.encode`).
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.light.caustic_sample import scale_polynomial
from aquaspec.scene.shadowmap import (BIAS_TEXELS, DEFAULT_MAP_RADIUS_M, DEFAULT_MAP_SIZE,
                                      NORMAL_OFFSET_TEXELS, ShadowMapSpec)
from aquaspec.transport.froxels import CAUSTIC_SUBSAMPLES, FROXEL_SLICES, froxel_tile
from aquaspec.transport.sun_scattering import (PHASE_TABLE_SIZE, TAIL, SunInputs,
                                               band_mean_log_phase)
from aquaspec.gpu.buffers import create_storage_buffer, create_uniform_buffer, upload_buffer
from aquaspec.gpu.camera import CAMERA_FIELDS, camera_fields
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.materials import UNIFORM_VEC4
from aquaspec.gpu.passes.sun_shadow import SunShadowPass
from aquaspec.gpu.shaders import load_wgsl

PARAMS_LAYOUT = UniformLayout("SunParams", CAMERA_FIELDS + [
    ("to_sun", "vec3<f32>"),
    ("e1", "vec3<f32>"), ("u0", "f32"),
    ("e2", "vec3<f32>"), ("v0", "f32"),
    ("width", "u32"), ("height", "u32"), ("shadowed", "u32"), ("map_size", "u32"),
    ("texel", "f32"), ("h_min", "f32"), ("h_max", "f32"), ("bias", "f32"),
    ("normal_offset", "f32"), ("neg_log_tail", "f32"), ("cols_x", "u32"), ("cols_y", "u32"),
    ("caustic", "u32"), ("c_slices", "u32"), ("c_tile", "f32"), ("c_max_depth", "f32"),
    ("c_texel", "f32"), ("c_levels", "f32"), ("c_scaled", "u32"),
])
CAUSTIC_FORMAT = "r16float"
#: Bound in place of the caustics when there are none (two 1 x 1 slices of 1).
NO_CAUSTICS = (np.ones((2, 1, 1), np.float32),)
WORKGROUP = (8, 8)
#: sunlight.wgsl's bindings in sun.wgsl: params, shadow map, froxels (sampled), mean
#: phase, caustics, samplers (build_froxels writes the froxels at binding 13).
SUN_BINDINGS = {"params": 0, "shadow": 6, "froxels": 8, "ref_phase": 9, "caustic": 10,
                "caustic_sampler": 11, "shadow_sampler": 12, "froxel_sampler": 14}
#: The same resources in a shading pass that adds the sun itself (lightfield.wgsl with
#: SUN), with the per-band constants (``bands``, the layout of sun.wgsl's binding 4).
FUSED_BINDINGS = {"params": 17, "bands": 18, "shadow": 19, "froxels": 20, "ref_phase": 21,
                  "caustic": 22, "caustic_sampler": 23, "shadow_sampler": 24,
                  "froxel_sampler": 25}


def froxel_format(device) -> str:
    """The froxels' texture format: rgba32float where the device filters it
    (float32-filterable), else rgba16float."""
    return "rgba32float" if "float32-filterable" in device.features else "rgba16float"


def sunlight_values(width: int, n_bands: int, bindings: dict = FUSED_BINDINGS,
                    bands_var: str = "sun_bands") -> dict:
    """Template values of ``sunlight.wgsl`` for a shader binding the sun's resources
    at ``bindings`` (:data:`FUSED_BINDINGS` or :data:`SUN_BINDINGS`; with
    FUSED_BINDINGS also ``sun_b_bands`` and ``sun_band_vec4`` of the per-band
    constants) for images ``width`` pixels wide; ``bands_var``: the name of
    the per-band constants in the shader."""
    tile = froxel_tile(width)
    return {"sun_params_struct": PARAMS_LAYOUT.wgsl(),
            "sun_params_struct_name": PARAMS_LAYOUT.name, "tile": tile,
            "slices": FROXEL_SLICES, "phase_size": PHASE_TABLE_SIZE,
            "sun_band_vec4": 4 * int(n_bands), "sun_n_bands": int(n_bands),
            "sun_bands_var": bands_var,
            **{f"sun_b_{k}": v for k, v in bindings.items()}}


def caustic_scale_rows(scale) -> np.ndarray:
    """The bands' contrast scales (K, n) as the GPU reads them: two vec4 per
    band (n, 2, 4), the coefficients ``c_1 ... c_8`` of
    :func:`aquaspec.light.caustic_sample.scale_polynomial`."""
    return scale_polynomial(scale).astype(np.float32).reshape(-1, 2, 4)


class SunPass:
    """The sun's shadow map and radiance for one image size and band count.

    Parameters
    ----------
    device : wgpu.GPUDevice
    width, height, n_bands : int
    map_size : int
        Shadow-map side in texels.
    """

    def __init__(self, device, width: int, height: int, n_bands: int, *,
                 map_size: int = DEFAULT_MAP_SIZE):
        self.device = device
        self.width, self.height, self.n_bands = int(width), int(height), int(n_bands)
        self.map_size = int(map_size)
        self.phase_size = PHASE_TABLE_SIZE
        #: Froxel columns are ``tile`` pixels square (:func:`froxel_tile`).
        self.tile = froxel_tile(self.width)
        self.cols = (-(-self.width // self.tile), -(-self.height // self.tile))
        self._pipelines = {}
        self.froxel_format = froxel_format(device)
        texel = 8 if self.froxel_format == "rgba16float" else 16
        #: Texels per row of the froxels' buffer (rows of a multiple of 256 bytes).
        self._froxel_row = -(-self.cols[0] * texel // 256) * 256 // texel
        self._froxel_buffer = create_storage_buffer(
            device, texel * self._froxel_row * self.cols[1] * (FROXEL_SLICES + 1),
            label="sun froxels (written)")
        self._use_pipelines(True)
        self._froxels = device.create_texture(
            label="sun froxels", size=(self.cols[0], self.cols[1], FROXEL_SLICES + 1),
            format=self.froxel_format, dimension="3d",
            usage=wgpu.TextureUsage.COPY_DST | wgpu.TextureUsage.TEXTURE_BINDING)
        self._froxel_view = self._froxels.create_view()
        self._froxel_sampler = device.create_sampler(
            address_mode_u=wgpu.AddressMode.clamp_to_edge,
            address_mode_v=wgpu.AddressMode.clamp_to_edge,
            address_mode_w=wgpu.AddressMode.clamp_to_edge,
            mag_filter=wgpu.FilterMode.linear, min_filter=wgpu.FilterMode.linear)
        self._ref_phase = create_storage_buffer(device, 4 * self.phase_size,
                                                label="sun mean phase")
        self._caustic_scale = None
        self._params = create_uniform_buffer(device, PARAMS_LAYOUT, label="sun params")
        self._bands = device.create_buffer(
            label="sun bands", size=64 * self.n_bands,
            usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
        self._phase = create_storage_buffer(device, 4 * self.n_bands * self.phase_size,
                                            label="sun phase")
        self._materials = device.create_buffer(
            label="sun materials (uniform)", size=UNIFORM_VEC4 * 16,
            usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
        #: The shadow map (:class:`~aquaspec.gpu.passes.sun_shadow.SunShadowPass`).
        self.shadow_map = SunShadowPass(device, self.map_size)
        self._caustic_sampler = device.create_sampler(
            address_mode_u=wgpu.AddressMode.repeat, address_mode_v=wgpu.AddressMode.repeat,
            mag_filter=wgpu.FilterMode.linear, min_filter=wgpu.FilterMode.linear,
            mipmap_filter=wgpu.MipmapFilterMode.linear)
        self._shadow_sampler = device.create_sampler(
            address_mode_u=wgpu.AddressMode.clamp_to_edge,
            address_mode_v=wgpu.AddressMode.clamp_to_edge,
            mag_filter=wgpu.FilterMode.nearest, min_filter=wgpu.FilterMode.nearest,
            compare=wgpu.CompareFunction.less_equal)
        self._caustic_map = None
        self._caustic_geometry = None
        self._caustic_tex = self._caustic_texture(NO_CAUSTICS)
        self._bind_key = None
        self._froxel_key = None
        self._group = None
        self._inputs = None

    def _use_pipelines(self, materials_in_uniform: bool) -> None:
        """Compile (once) and select the pipelines for where the materials are."""
        key = bool(materials_in_uniform)
        half = self.froxel_format == "rgba16float"
        if key not in self._pipelines:
            binding = ("@group(0) @binding(3) var<uniform> material_bands: "
                       f"array<vec4<f32>, {UNIFORM_VEC4}>;") if key else \
                "@group(0) @binding(3) var<storage, read> material_bands: array<f32>;"
            src = load_wgsl("sun.wgsl", **self.wgsl_values(SUN_BINDINGS, "bands"),
                            froxel_row=self._froxel_row, froxel_half=str(half).lower(),
                            froxel_word="vec2<u32>" if half else "vec4<f32>",
                            froxel_pack=("vec2<u32>(pack2x16float(value.xy), "
                                         "pack2x16float(vec2<f32>(value.z, 0.0)))") if half
                            else "vec4<f32>(value, 0.0)",
                            n_bands=self.n_bands, caustic_sub=CAUSTIC_SUBSAMPLES,
                            band_vec4=4 * self.n_bands, material_binding=binding,
                            material_read="material_bands[k / 4u][k % 4u]" if key
                            else "material_bands[k]")
            module = self.device.create_shader_module(label="sun.wgsl", code=src)
            self._pipelines[key] = (
                self.device.create_compute_pipeline(
                    label="sun", layout="auto", compute={"module": module, "entry_point": "main"}),
                self.device.create_compute_pipeline(
                    label="sun froxels", layout="auto",
                    compute={"module": module, "entry_point": "build_froxels"}))
        self._pipeline, self._build = self._pipelines[key]
        self._bind_key = self._froxel_key = None

    def wgsl_values(self, bindings: dict = FUSED_BINDINGS, bands_var: str = "sun_bands") -> dict:
        """:func:`sunlight_values` for this pass's image width and bands."""
        return sunlight_values(self.width, self.n_bands, bindings, bands_var)

    @staticmethod
    def fused_layout() -> dict:
        """Binding kinds (:func:`aquaspec.gpu.bindings.bind_group_layout`) of the
        sun's resources in a shading pass that adds the sun itself."""
        b = FUSED_BINDINGS
        return {b["params"]: "uniform", b["bands"]: "uniform", b["shadow"]: "depth",
                b["froxels"]: "filterable_3d", b["ref_phase"]: "read",
                b["caustic"]: "filterable_array", b["caustic_sampler"]: "sampler",
                b["shadow_sampler"]: "comparison_sampler", b["froxel_sampler"]: "sampler"}

    def fused_resources(self) -> dict:
        """``{binding: resource}`` of :meth:`fused_layout` (after :meth:`set_inputs`)."""
        b = FUSED_BINDINGS
        return {b["params"]: self._params, b["bands"]: self._bands,
                b["shadow"]: self.shadow_map.view, b["froxels"]: self._froxel_view,
                b["ref_phase"]: self._ref_phase, b["caustic"]: self.caustic_view,
                b["caustic_sampler"]: self._caustic_sampler,
                b["shadow_sampler"]: self._shadow_sampler,
                b["froxel_sampler"]: self._froxel_sampler}

    @property
    def caustic_view(self):
        """The caustic factor's slices as bound (a 2-D array view with its mips; the
        1 x 1 x 2 stand-in without caustics): the one place that owns them."""
        return self._caustic_tex[1]

    def caustic_params(self) -> dict:
        """The caustics' fields of :data:`PARAMS_LAYOUT` (meta of :attr:`caustic_view`)."""
        geo = self._caustic_geometry
        if geo is None:
            return dict(caustic=0, c_slices=2, c_tile=1.0, c_max_depth=1.0, c_texel=1.0,
                        c_levels=1.0, c_scaled=0)
        return dict(caustic=1, c_slices=geo.slices, c_tile=geo.tile_m,
                    c_max_depth=geo.max_depth_m, c_texel=geo.texel_m, c_levels=float(geo.levels),
                    c_scaled=int(self._caustic_scale is not None))

    def _use_caustic_scale(self, scale=None, geometry=None) -> None:
        """Upload the caustics' band scales (``scale`` (K, n) of ``geometry``;
        None: every band reads the factor) as their polynomials
        (:func:`caustic_scale_rows`, after the bands' two vec4 each)."""
        if scale is not None:
            scale = np.asarray(scale, np.float32)
            if geometry is None or scale.shape != (geometry.slices, self.n_bands):
                raise AquaspecError(
                    f"caustic band scales of shape {scale.shape}; accepted: (slices, bands) = "
                    f"({None if geometry is None else geometry.slices}, {self.n_bands})")
        self._caustic_scale = scale
        rows = np.zeros((self.n_bands, 2, 4), np.float32) if scale is None \
            else caustic_scale_rows(scale)
        upload_buffer(self.device, self._bands, rows, offset=32 * self.n_bands)

    def _caustic_texture(self, levels):
        """An r16float 2-D array texture holding ``levels`` (K, n_m, n_m) as its mips."""
        k, n = levels[0].shape[0], levels[0].shape[-1]
        tex = self.device.create_texture(
            label="sun caustics", size=(n, n, k), format=CAUSTIC_FORMAT,
            mip_level_count=len(levels), dimension="2d",
            usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST)
        for m, lv in enumerate(levels):
            nm = lv.shape[-1]
            self.device.queue.write_texture(
                {"texture": tex, "mip_level": m, "origin": (0, 0, 0)},
                np.ascontiguousarray(lv, np.float16),
                {"offset": 0, "bytes_per_row": 2 * nm, "rows_per_image": nm}, (nm, nm, k))
        return tex, tex.create_view(dimension="2d-array")

    def _use_caustics(self, cmap) -> None:
        """Upload the caustic map (once per map; None: the 1 x 1 stand-in)."""
        if cmap is self._caustic_map:
            return
        self._caustic_tex = self._caustic_texture(NO_CAUSTICS if cmap is None else cmap.levels)
        self._caustic_map = cmap
        self._caustic_geometry = None if cmap is None else cmap.geometry
        self._use_caustic_scale(None if cmap is None else cmap.band_scale,
                                self._caustic_geometry)
        self._bind_key = self._froxel_key = None

    def use_caustic_texture(self, view, geometry, band_scale=None) -> None:
        """Sample caustic slices made on the GPU (e.g. by
        :class:`aquaspec.gpu.passes.caustics.CausticLoopPass`): ``view``, an
        r16float 2-D array view with mips laid out as a
        :class:`aquaspec.light.caustics.CausticMap`'s levels, its
        :class:`aquaspec.light.caustics.CausticGeometry` and the bands'
        contrast scales (K, n) (:attr:`aquaspec.light.caustics.CausticMap.band_scale`;
        None: every band reads the factor); until the next
        :meth:`set_inputs` with other caustics."""
        if (view is self.caustic_view and geometry == self._caustic_geometry
                and band_scale is self._caustic_scale):
            return
        self._caustic_tex = (None, view)
        self._caustic_map = None       # set_inputs() uploads its own map again
        self._caustic_geometry = geometry
        self._use_caustic_scale(band_scale, geometry)
        self._bind_key = self._froxel_key = None

    # ---- per-band inputs --------------------------------------------------------
    def set_inputs(self, sun: SunInputs, *, response_weights, material_bands,
                   sigmoid_centers_t) -> None:
        """Upload the per-band constants, the phase table and the materials."""
        n = self.n_bands
        w = np.asarray(response_weights, dtype=float)
        if sun.b.size != n or w.shape != (n, 3):
            raise AquaspecError(f"the sun pass was made for {n} bands; got {sun.b.size}")
        mu0 = sun.mu0
        bands = np.zeros((n, 2, 4), np.float32)
        bands[:, 0, 0] = sun.c_view
        bands[:, 0, 1] = np.asarray(sun.c_sun, dtype=float) / mu0
        bands[:, 0, 2] = sun.b * sun.beam0
        bands[:, 0, 3] = sun.beam0 / np.pi
        bands[:, 1, :3] = w
        bands[:, 1, 3] = sigmoid_centers_t
        upload_buffer(self.device, self._bands, bands)
        self._use_caustic_scale(self._caustic_scale, self._caustic_geometry)
        upload_buffer(self.device, self._phase, np.asarray(sun.log_phase, np.float32))
        upload_buffer(self.device, self._ref_phase,
                      band_mean_log_phase(sun.log_phase).astype(np.float32))
        mb = np.asarray(material_bands if material_bands is not None else np.zeros((0, n)),
                        np.float32).reshape(-1)
        mb = np.concatenate([mb, np.zeros(-mb.size % 4 or (4 if mb.size == 0 else 0),
                                          np.float32)])
        in_uniform = mb.size <= 4 * UNIFORM_VEC4
        if in_uniform:
            if self._materials.usage & wgpu.BufferUsage.STORAGE:
                self._materials = self.device.create_buffer(
                    label="sun materials (uniform)", size=UNIFORM_VEC4 * 16,
                    usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
            upload_buffer(self.device, self._materials, mb)
        else:
            self._materials = create_storage_buffer(self.device, mb, label="sun materials")
        self._use_pipelines(in_uniform)
        self._use_caustics(sun.caustics)
        self._inputs = sun

    # ---- the shadow map ---------------------------------------------------------
    @property
    def spec(self) -> ShadowMapSpec | None:
        """The shadow map's geometry (None: nothing shadowed)."""
        return self.shadow_map.spec

    @property
    def shadowed(self) -> bool:
        """Whether the shadow map is read (a scene was drawn into it)."""
        return self.shadow_map.shadowed

    def encode_shadow_map(self, encoder, raster, scene, camera, *,
                          radius_m: float = DEFAULT_MAP_RADIUS_M) -> ShadowMapSpec | None:
        """Record the shadow map of ``scene`` (None for no scene: nothing is shadowed):
        :meth:`aquaspec.gpu.passes.sun_shadow.SunShadowPass.encode` for this sun."""
        if self._inputs is None:
            raise AquaspecError("SunPass.set_inputs() first")
        return self.shadow_map.encode(encoder, raster, scene, camera, self._inputs.to_sun,
                                      radius_m=radius_m)

    def no_shadows(self) -> None:
        """Nothing shadows the sun in the next :meth:`encode` (e.g. RGB-D images)."""
        self.shadow_map.no_shadows()

    # ---- the sun's radiance -----------------------------------------------------
    def encode(self, encoder, camera, gbuffer_textures: dict, rgb_buffer) -> None:
        """Record the sun's light added into ``rgb_buffer`` (vec4 per pixel): the
        froxels (:meth:`encode_froxels`), then the per-pixel pass."""
        self.encode_froxels(encoder, camera)
        key = (id(gbuffer_textures["surface"]), id(gbuffer_textures["sigmoid"]),
               id(rgb_buffer), id(self._materials), id(self.caustic_view))
        if key != self._bind_key:
            def buf(binding, buffer):
                return {"binding": binding, "resource": {"buffer": buffer, "offset": 0,
                                                         "size": buffer.size}}
            self._group = self.device.create_bind_group(
                layout=self._pipeline.get_bind_group_layout(0), entries=[
                    *self._sun_entries(self._pipeline, with_phase=False),
                    {"binding": 1, "resource": gbuffer_textures["surface"].create_view()},
                    {"binding": 2, "resource": gbuffer_textures["sigmoid"].create_view()},
                    buf(3, self._materials), buf(4, self._bands), buf(7, rgb_buffer)])
            self._bind_key = key
        cp = encoder.begin_compute_pass()
        cp.set_pipeline(self._pipeline)
        cp.set_bind_group(0, self._group)
        cp.dispatch_workgroups(-(-self.width // WORKGROUP[0]), -(-self.height // WORKGROUP[1]))
        cp.end()

    def _sun_entries(self, pipeline, with_phase: bool) -> list:
        """Bind-group entries of sunlight.wgsl's resources at :data:`SUN_BINDINGS`
        (``with_phase``: build_froxels's, which writes the froxels, else main's,
        which samples them)."""
        def buf(binding, buffer):
            return {"binding": binding, "resource": {"buffer": buffer, "offset": 0,
                                                     "size": buffer.size}}
        b = SUN_BINDINGS
        out = [{"binding": b["params"], "resource": {"buffer": self._params, "offset": 0,
                                                     "size": PARAMS_LAYOUT.size}},
               {"binding": b["shadow"], "resource": self.shadow_map.view},
               buf(b["ref_phase"], self._ref_phase),
               {"binding": b["caustic"], "resource": self.caustic_view},
               {"binding": b["caustic_sampler"], "resource": self._caustic_sampler},
               {"binding": b["shadow_sampler"], "resource": self._shadow_sampler}]
        if with_phase:
            out += [buf(4, self._bands), buf(5, self._phase),
                    buf(13, self._froxel_buffer)]
        else:
            out += [{"binding": b["froxels"], "resource": self._froxel_view},
                    {"binding": b["froxel_sampler"], "resource": self._froxel_sampler}]
        return out

    def encode_froxels(self, encoder, camera) -> None:
        """Upload this frame's parameters and record the froxel pass (the single
        scattering along each column), which the per-pixel terms read."""
        if self._inputs is None:
            raise AquaspecError("SunPass.set_inputs() first")
        if (camera.width, camera.height) != (self.width, self.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height}; the sun pass was "
                                f"made for {self.width}x{self.height}")
        spec = self.spec
        geo = dict(e1=spec.e1, u0=spec.u0, e2=spec.e2, v0=spec.v0, map_size=spec.size,
                   texel=spec.texel, h_min=spec.h_min, h_max=spec.h_max,
                   bias=BIAS_TEXELS * spec.texel,
                   normal_offset=NORMAL_OFFSET_TEXELS * spec.texel) if self.shadowed else dict(
            e1=(1.0, 0.0, 0.0), u0=0.0, e2=(0.0, 0.0, 1.0), v0=0.0, map_size=self.map_size,
            texel=1.0, h_min=0.0, h_max=1.0, bias=0.0, normal_offset=0.0)
        upload_buffer(self.device, self._params, PARAMS_LAYOUT.pack(
            **camera_fields(camera), to_sun=self._inputs.to_sun, **self.caustic_params(),
            width=self.width, height=self.height, shadowed=int(self.shadowed),
            neg_log_tail=-np.log(TAIL), cols_x=self.cols[0], cols_y=self.cols[1], **geo))
        if self._froxel_key != id(self.caustic_view):
            self._build_group = self.device.create_bind_group(
                layout=self._build.get_bind_group_layout(0),
                entries=self._sun_entries(self._build, with_phase=True))
            self._froxel_key = id(self.caustic_view)
        cp = encoder.begin_compute_pass()
        cp.set_pipeline(self._build)
        cp.set_bind_group(0, self._build_group)
        cp.dispatch_workgroups(-(-self.cols[0] * self.cols[1] // 64))
        cp.end()
        texel = 8 if self.froxel_format == "rgba16float" else 16
        encoder.copy_buffer_to_texture(
            {"buffer": self._froxel_buffer, "offset": 0, "bytes_per_row": texel * self._froxel_row,
             "rows_per_image": self.cols[1]},
            {"texture": self._froxels, "mip_level": 0, "origin": (0, 0, 0)},
            (self.cols[0], self.cols[1], FROXEL_SLICES + 1))

    def read_shadow_map(self) -> np.ndarray | None:
        """:meth:`aquaspec.gpu.passes.sun_shadow.SunShadowPass.read` (tests)."""
        return self.shadow_map.read()
