"""Deferred shading with the light-field multiple-scattering model on the GPU.

The ``ms_model="lightfield"`` counterpart of
:class:`aquaspec.gpu.passes.deferred.DeferredPass`: it reads a G-buffer
(:class:`aquaspec.gpu.gbuffer.GBufferTextures`, the geometry pass's render
targets, shared with the deferred pass; the sigmoid texture only when its
``per_pixel`` is true) and shades with the model compiled for the camera's
depth (:mod:`aquaspec.transport.lightfield.compiled`: a camera-RGB water table
over ``(v_y, S)``, built on the GPU by
:class:`aquaspec.gpu.passes.watertable.WaterTablePass` when the camera's depth
changes, and the factored irradiance, fitted on the host per medium). WGSL:
``lightfield.wgsl`` beside this module; NumPy twin:
:func:`aquaspec.transport.lightfield.compiled.shade_compiled`; the test
``tests/gpu/passes/test_lightfield_pass.py`` holds them together, and
``tests/transport/lightfield/test_compiled.py`` the twin and the model
(:func:`aquaspec.shading.shade.shade_gbuffer` with tables). Deep water only.

One invocation shades four horizontally adjacent pixels. Bindings:

==  ==================================  ==========================================
0   uniform :data:`PARAMS_LAYOUT`       camera, image size, camera depth, axes
1   texture ``rgba32uint``              G-buffer surface (S, n_y, normal, material)
2   texture ``rgba32float``             G-buffer sigmoid (read when per_pixel)
4   uniform ``array<vec4<f32>, B n>``   per band (:func:`band_table`, float64 on
                                        the host; B = 2 + ceil(rank / 4))
5   storage ``array<f32>``              material band reflectances, row-major
                                        ``(material, band)``
6-10                                    the outputs: linear RGB, status, the
                                        fused display transform and its RGBA8
                                        (:mod:`aquaspec.gpu.shading_output`)
11  2-D array texture ``rgba32float``  water table (distances, directions,
                                        layers): layer 0 camera RGB (with the
                                        spread W0 + alpha W1), layer 1 the cone's
                                        share W1 (with the spread)
12  2-D array texture ``rgba32float``  irradiance basis U: layer ``g``, texel
    (n_mu, n_depth, ceil(rank / 4))     ``(j, i)`` (direction, depth) holds
                                        ``U_4g .. U_4g+3`` (:func:`band_group_texture`)
14  sampler                             bilinear (``filtering``) or nearest
15  storage texture ``rgba32float``     COARSE: the cone term at the spread's
                                        start level (the pyramid's level 0)
16  texture ``rgba32float``             the pyramid's result (full-resolution
                                        pass with the spread)
17- the sun's (:meth:`set_sun`;             :data:`aquaspec.gpu.passes.sun.FUSED_BINDINGS`
25  full-resolution pass only)
26  2-D array texture                   the occlusion factors' grid
                                        (:meth:`set_occlusion`), both passes
27  texture ``rgba32uint``              marine snow's accumulated discs
                                        (:meth:`set_snow`; fused display only)
28  uniform                             their scale (the particle pass's params)
==  ==================================  ==========================================

With marine snow (:meth:`set_snow`: a
:class:`aquaspec.gpu.passes.particles.ParticlePass` whose splat is recorded
before this pass) a frame with the display fused composes the particles over
each pixel before its display transform (one texel load per pixel,
:func:`aquaspec.shading.particles.composite`), instead of a pass of its own
that reads the linear image back.

With a sun (:meth:`set_sun`) the full-resolution pass adds the sun's light
in its own band loop (the froxels are built before it,
:meth:`aquaspec.gpu.passes.sun.SunPass.encode_froxels`), and the display
transform stays fused.

With the cone spread a frame is three steps, in one compute pass: the COARSE
pipeline (one invocation per two blocks of the spread's start level,
:func:`aquaspec.transport.lightfield.spreadplan.spread_plan`), the pyramid
(:class:`aquaspec.gpu.passes.conespread.ConeSpreadPass`), then the
full-resolution pass, which can apply the display transform itself.

The tables are read with the sampler's bilinear filtering when the device
has ``float32-filterable`` (lavapipe has it); without it the shader
interpolates from four fetches (``filtering=False``, tested too).
"""

from __future__ import annotations

import types

import numpy as np
import wgpu

from aquaspec.transport.lightfield import compiled as lfc
from aquaspec.transport.lightfield import spreadplan
from aquaspec.transport.lightfield.conespread import level_shapes, node_pyramid_weights, pyramid_weights
from aquaspec.errors import AquaspecError
from aquaspec.shading.shade import camera_depth
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_array_texture, create_texture, create_uniform_buffer, upload_buffer
from aquaspec.gpu.camera import CAMERA_FIELDS, camera_fields
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatches
from aquaspec.gpu.display_transform import display_template
from aquaspec.gpu.gbuffer import B_SIGMOID, B_SURFACE, GBufferTextures
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.materials import MaterialTable
from aquaspec.gpu.passes.conespread import ConeSpreadPass
from aquaspec.gpu.passes.particles import PARAMS as SNOW_PARAMS
from aquaspec.gpu.passes.sun import SunPass, sunlight_values
from aquaspec.gpu.passes.watertable import MAX_NODES, WaterTablePass, alpha_vec4s
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.gpu.shading_output import ShadingOutput
from aquaspec.gpu.shading_pass import WORKGROUP, ShadingPass

PARAMS_LAYOUT = UniformLayout("LightfieldParams", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("n_materials", "u32"), ("depth_o", "f32"),
    ("max_depth", "f32"), ("window_cos", "f32"), ("coarse_size", "vec2<u32>"),
    ("block", "u32"), ("alpha", "f32"), ("fb_mean", "f32"),
    # lightfield_compiled.kept_projection: [lam_K, lam_c, mu, 0], lam_G.
    ("kept_lam", "vec4<f32>"), ("kept_lam_g0", "vec4<f32>"), ("kept_lam_g1", "vec4<f32>"),
    # The multiple-scattering spread: the share kept at each lambda node (up to 8).
    ("alpha_lo", "vec4<f32>"), ("alpha_hi", "vec4<f32>"),
])

# (Bindings 1 and 2: the G-buffer, aquaspec.gpu.gbuffer; 3 and 5: the material
# table, aquaspec.gpu.materials; 6-10: the outputs, aquaspec.gpu.shading_output.)
B_PARAMS, B_BANDS, B_WATER, B_BASIS = 0, 4, 11, 12
B_SAMPLER, B_CONE, B_SPREAD = 14, 15, 16
#: The occlusion factors' grid (after the sun's 17-25).
B_OCCLUSION = 26
#: Marine snow's accumulation texture and its uniform (:meth:`LightfieldPass.set_snow`).
B_SNOW, B_SNOW_PARAMS = 27, 28


def band_group_texture(table) -> np.ndarray:
    """Texels of a table (n, n_depth, n_mu): (ceil(n / 4), n_depth, n_mu, 4) float32.

    Layer ``g``, texel ``(j, i)`` (direction, depth) holds entries
    ``4g .. 4g + 3`` at node ``(i, j)``, zero past the last: one
    (filtered) sample gives four.
    """
    t = np.asarray(table, dtype=np.float32)
    n, nd, nm = t.shape
    groups = -(-n // 4)
    out = np.zeros((groups * 4, nd, nm), np.float32)
    out[:n] = t
    return np.ascontiguousarray(np.moveaxis(out.reshape(groups, 4, nd, nm), 1, -1))


def band_table(factors, *, a, b, e0, response_weights, sigmoid_centers_t,
               forward_fraction, fb_offset_hat) -> np.ndarray:
    """The band table (binding 4): (n, 4 B) float64, ``B = 2 + ceil(rank / 4)`` vec4 per band.

    ``[K, c', f b - mean(f b), t]``, the rank's ``G`` (four per vec4) and ``[w'_r, w'_g,
    w'_b, delta_hat]`` with ``w' = w E0 / pi exp(C)`` (:mod:`aquaspec.transport.lightfield.compiled`)
    and ``delta_hat`` = ``fb_offset_hat``, the projection of ``f b - mean(f b)``
    (:func:`aquaspec.transport.lightfield.spreadplan.fb_projection`).
    """
    a, b, e0, t, f = (np.asarray(x, dtype=np.float64)
                      for x in (a, b, e0, sigmoid_centers_t, forward_fraction))
    w = np.asarray(response_weights, dtype=np.float64)
    coef = factors["coef"]
    n, rank = a.size, coef.shape[1] - 2
    out = np.zeros((n, 4 * (2 + -(-rank // 4))))
    out[:, :4] = np.stack([coef[:, 1], a + (1.0 - f) * b, f * b - np.mean(f * b), t],
                          axis=1)
    out[:, 4:4 + rank] = coef[:, 2:]
    out[:, -4:-1] = w * (e0 / np.pi * np.exp(coef[:, 0]))[:, None]
    out[:, -1] = fb_offset_hat
    return out


class LightfieldPass(ShadingPass):
    """Light-field shading of ``gbuffer`` (a :class:`~aquaspec.gpu.gbuffer.GBufferTextures`).

    Per frame, after the G-buffer and its camera are set: :meth:`run` then
    :meth:`read_rgb`, or (with :meth:`set_display`) ``run(display=True)``
    then :meth:`read_display`. :meth:`set_medium` when the water, light,
    sensor or tables change.
    """

    label = "light-field shading"

    def __init__(self, gbuffer: GBufferTextures, *, filtering: bool | None = None):
        #: The G-buffer read (shared with the deferred and geometry passes).
        self.gbuffer = gbuffer
        dev = self.device = gbuffer.device
        #: Whether the tables are read with the sampler's bilinear filtering
        #: (needs float32-filterable; default: when the device has it) or
        #: interpolated in the shader from four fetches.
        self.filtering = ("float32-filterable" in dev.features) if filtering is None \
            else bool(filtering)
        if self.filtering and "float32-filterable" not in dev.features:
            raise AquaspecError("filtering=True needs a device with float32-filterable; "
                                "accepted: filtering=False or None")
        self.width, self.height = gbuffer.width, gbuffer.height
        self._uniform = create_uniform_buffer(dev, PARAMS_LAYOUT, label="lightfield params")
        #: Linear RGB, display RGBA8 and the status (:class:`~aquaspec.gpu.shading_output.ShadingOutput`).
        self.output = ShadingOutput(dev, self.width, self.height, "lightfield")
        #: The water table per camera depth.
        self.water = WaterTablePass(dev)
        table_kind = "filterable_array" if self.filtering else "float_array"
        self._kinds = {
            B_PARAMS: "uniform", B_SURFACE: "uint", B_SIGMOID: "float", B_BANDS: "uniform",
            **MaterialTable.layout(), **ShadingOutput.layout(),
            B_WATER: table_kind, B_BASIS: table_kind,
            B_SAMPLER: "sampler" if self.filtering else "nonfiltering_sampler",
            B_CONE: "storage_rgba32float",
            B_SPREAD: "filterable" if self.filtering else "float"}
        self._layout = bind_group_layout(dev, self._kinds)
        #: The sun added in the full-resolution pass (:meth:`set_sun`), or None.
        self.sun = None
        #: The occlusion factors applied to surfaces (:meth:`set_occlusion`), or None.
        self.occlusion = None
        #: Marine snow composed in the fused display (:meth:`set_snow`), or None.
        self.snow = None
        self._layouts = {}
        mode = "linear" if self.filtering else "nearest"
        self._sampler = dev.create_sampler(label="lightfield tables", mag_filter=mode,
                                           min_filter=mode, address_mode_u="clamp-to-edge",
                                           address_mode_v="clamp-to-edge")
        # 1x1 textures for the spread's bindings when they are not used (a
        # texture may not be both written and sampled in one dispatch).
        usage = wgpu.TextureUsage.STORAGE_BINDING | wgpu.TextureUsage.TEXTURE_BINDING
        self._unused = {k: create_texture(dev, 1, 1, "rgba32float",
                                          label=f"lightfield unused {k}", usage=usage)
                        for k in ("storage", "sampled")}
        self._pipelines = {}
        self._buffers = None
        self.spread = False
        self._spread_pass = None
        self._spread_key = None
        self._shape = None
        self._medium = None
        self._groups = {}
        #: ``(L0, alpha, coarse weights)`` of the cone spread for the last camera.
        self.spread_plan = None
        #: The spread's start level; None: :func:`lightfield_compiled.spread_plan`'s
        #: choice for the camera.
        self.spread_start_level = None
        #: The irradiance factorisation of the current tables
        #: (:func:`aquaspec.transport.lightfield.compiled.choose_irradiance_factors`).
        self.factors = None

    @property
    def tables(self):
        """The light-field tables of the last :meth:`set_medium` (None before)."""
        return None if self._medium is None else self._medium[0]

    @property
    def band_coefficients(self):
        """``(a, b)`` (n,) 1/m of the last :meth:`set_medium` (None before)."""
        return None if self._medium is None else (self._medium[1], self._medium[2])

    @property
    def rank(self) -> int:
        """The rank of the irradiance factorisation (:attr:`factors`)."""
        return self._shape["rank"]

    @property
    def n_materials(self) -> int:
        """Rows of the material table of the last :meth:`set_medium`."""
        return self._shape["n_materials"]

    def set_medium(self, *, a, b, e0, response_weights, material_bands, sigmoid_centers_t,
                   tables, **_ignored):
        """Upload per-band data, the irradiance basis and (per depth) the water table.

        ``kd`` and ``ambient`` are not used. The irradiance is factorised here
        (:func:`aquaspec.transport.lightfield.compiled.choose_irradiance_factors`); the
        water table is built for the camera's depth when a frame is encoded.
        """
        a, b, e0 = (np.asarray(x, dtype=float) for x in (a, b, e0))
        n = a.size
        lp = np.asarray(tables.ms_log_prefactor)
        if lp.shape[0] != n:
            raise AquaspecError(f"tables have {lp.shape[0]} bands; the medium has {n}")
        # (The factors depend on the tables alone: the same tables object,
        # kept alive by self._medium, keeps them.)
        factors = (self.factors if self._medium is not None and self._medium[0] is tables
                   else lfc.choose_irradiance_factors(tables))
        f = np.asarray(tables.forward_fraction, dtype=float)
        # The band coefficients lightfield_compiled.kept_projection reads, and
        # their projection of f b (made once per medium).
        self._kept_coef = types.SimpleNamespace(split=True, k_depth=factors["coef"][:, 1],
                                                c_beam=a + (1.0 - f) * b,
                                                g=factors["coef"][:, 2:], fb=f * b)
        kc = self._kept_coef
        self._fb_projection = spreadplan.fb_projection(kc.k_depth, kc.c_beam, kc.g, kc.fb)
        self._kept_cache = {}
        band = band_table(factors, a=a, b=b, e0=e0, response_weights=response_weights,
                          sigmoid_centers_t=sigmoid_centers_t, forward_fraction=f,
                          fb_offset_hat=self._fb_projection[1])
        mb = np.asarray(material_bands, dtype=np.float32).reshape(-1, n)
        dev = self.device
        bands = create_uniform_buffer(dev, band.size * 4, label="lightfield bands")
        limit = dev.limits.get("max-uniform-buffer-binding-size", 65536)
        if bands.size > limit:
            raise AquaspecError(f"{n} bands need a {bands.size}-byte band table; this "
                                f"device binds at most {limit}")
        upload_buffer(dev, bands, band.astype(np.float32))
        max_2d = dev.limits.get("max-texture-dimension-2d", 8192)
        if max(lp.shape[1:]) > max_2d:
            raise AquaspecError(f"light-field tables of {lp.shape[1]}x{lp.shape[2]} samples "
                                f"exceed this device's {max_2d} texels per side; accepted: "
                                "smaller n_depth or n_mu")
        materials = MaterialTable(dev, "lightfield materials")
        materials.upload(mb, n)
        self.materials = materials
        self._buffers = {
            B_BANDS: bands,
            **materials.resources(),
            B_BASIS: create_array_texture(dev, band_group_texture(factors["basis"]),
                                          label="lightfield irradiance basis"),
            B_SAMPLER: self._sampler,
        }
        rank = factors["coef"].shape[1] - 2
        self._shape = dict(n_bands=n, n_materials=int(np.asarray(material_bands).shape[0]),
                           n_depth=lp.shape[1], n_mu=lp.shape[2], rank=rank,
                           max_depth=tables.max_depth_m,
                           window_cos=tables.window_cos,
                           fb_mean=float(np.mean(f * b)))
        self.factors = factors
        #: Tables with a seabed (watertable.wgsl's SEABED: the lines of sight
        #: going down end on it; twin
        #: :func:`aquaspec.transport.lightfield.compiled.water_table`).
        self.seabed = tables.has_seabed
        previous, self._medium = self._medium, (tables, a, b, e0,
                                                np.asarray(response_weights, dtype=float))
        # Only the materials changed (the same tables object, kept alive by
        # self._medium, and equal bands): the water table and the spread's
        # plan for this camera still hold.
        same_water = (previous is not None and previous[0] is tables
                      and all(np.array_equal(x, y) for x, y in zip(previous[1:],
                                                                   self._medium[1:])))
        #: Whether the forward cone is spread over the image (tables with
        #: lightfield_tables(cone_spread=True)): :class:`ConeSpreadPass` after this one.
        self.spread = tables.cone is not None
        #: Lambda nodes of the multiple-scattering spread (tables with
        #: spread_scattering="multiple"), else 0.
        self.nodes = (len(tables.cone.lambda_nodes) if self.spread and tables.cone.multiple
                      else 0)
        if self.nodes > MAX_NODES:
            raise AquaspecError(f"{self.nodes} lambda nodes; the GPU pass takes at most "
                                f"{MAX_NODES}")
        if not same_water:
            self._spread_pass = None
            self._spread_key = None
            self.water.set_medium(tables, a=a, b=b, e0=e0, response_weights=response_weights,
                                  log_prefactor=band_group_texture(lp), shape=self._shape,
                                  spread=self.spread, nodes=self.nodes, seabed=self.seabed)
        self._groups = {}

    def set_sun(self, sun: SunPass | None) -> None:
        """Add ``sun``'s light (its inputs set, its froxels encoded before each
        frame) in the full-resolution pass from the next frame on; None: no sun."""
        if sun is not None and (sun.width, sun.height) != (self.width, self.height):
            raise AquaspecError(f"the sun pass is {sun.width}x{sun.height}; the shading "
                                f"pass {self.width}x{self.height}")
        self.sun = sun

    def set_occlusion(self, occlusion) -> None:
        """Multiply every surface's light-field term per band by the factors
        of ``occlusion`` (an :class:`aquaspec.gpu.passes.occlusion.OcclusionPass`
        of this size and band count, encoded before each frame); None: no
        occlusion. The sun's direct light is not affected (it has its own
        shadow map)."""
        if occlusion is not None and ((occlusion.width, occlusion.height, occlusion.n_bands)
                                      != (self.width, self.height, self._shape["n_bands"]
                                          if self._shape else None)):
            raise AquaspecError(f"the occlusion pass is {occlusion.width}x{occlusion.height}"
                                f" with {occlusion.n_bands} bands; the shading pass "
                                f"{self.width}x{self.height}"
                                + (f" with {self._shape['n_bands']}" if self._shape else
                                   " (set_medium() first)"))
        self.occlusion = occlusion

    def set_snow(self, particles) -> None:
        """Compose the accumulated discs of ``particles`` (a
        :class:`aquaspec.gpu.passes.particles.ParticlePass` of this size, its
        splat recorded before each frame) over the image in frames encoded with
        ``display=True``, before the display transform; None: no snow. Frames
        of linear RGB ignore it."""
        if particles is not None and (particles.width, particles.height) != (self.width,
                                                                             self.height):
            raise AquaspecError(f"the particle pass is {particles.width}x{particles.height}; "
                                f"the shading pass {self.width}x{self.height}")
        self.snow = particles

    def _layout_for(self, sun: bool, snow: bool = False):
        """The bind-group layout with or without the sun's, the occlusion's and the snow's
        bindings."""
        occ = self.occlusion is not None
        if not sun and not occ and not snow:
            return self._layout
        key = (sun, occ, snow)
        if key not in self._layouts:
            kinds = dict(self._kinds)
            if sun:
                kinds.update(SunPass.fused_layout())
            if occ:
                kinds[B_OCCLUSION] = "filterable_array" if self.filtering else "float_array"
            if snow:
                kinds.update({B_SNOW: "uint", B_SNOW_PARAMS: "uniform"})
            self._layouts[key] = bind_group_layout(self.device, kinds)
        return self._layouts[key]

    # ------------------------------------------------------------- dispatch
    def _snow_on(self, tonemap, coarse=False) -> bool:
        """Whether this pipeline composes marine snow (the fused display's full-resolution pass)."""
        return self.snow is not None and tonemap is not None and not coarse

    def pipeline(self, per_pixel, tonemap, coarse=False, projected=False):
        """The compute pipeline for these compile-time constants (made when first used)."""
        sh = self._shape
        split = lfc.direction_split(sh["window_cos"])
        group = bool(self.spread and 2 ** self.spread_plan[0] >= 4)
        sun = self.sun is not None and not coarse
        snow = self._snow_on(tonemap, coarse)
        key = (sh["n_bands"], sh["n_depth"], sh["n_mu"], sh["rank"], split, per_pixel, tonemap,
               self.filtering, self.spread, coarse, group, projected,
               self.materials.in_uniform, self.nodes, sun,
               None if self.occlusion is None else (self.occlusion.scale,
                                                    self.occlusion.layers_out), snow)
        if key not in self._pipelines:
            band_vec4 = 2 + -(-sh["rank"] // 4)
            src = load_wgsl("lightfield.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                            params_struct_name=PARAMS_LAYOUT.name, **display_template(tonemap),
                            n_bands=sh["n_bands"], n_depth=sh["n_depth"], n_mu=sh["n_mu"],
                            rank=sh["rank"], band_vec4=band_vec4,
                            band_table_len=band_vec4 * sh["n_bands"],
                            directions_outside=split[0], directions_inside=split[1],
                            distances=lfc.DISTANCES,
                            length_scale=f"{float(lfc.LENGTH_SCALE_M)!r}",
                            per_pixel="true" if per_pixel else "false",
                            filter="true" if self.filtering else "false",
                            spread="true" if self.spread else "false",
                            coarse="true" if coarse else "false",
                            group_spread="true" if group else "false",
                            projected="true" if projected else "false",
                            nodes=self.nodes, slots=max(1, -(-3 * self.nodes // 4)),
                            **self.materials.template(),
                            **sunlight_values(self.width, sh["n_bands"]),
                            sun_pixels="sun_pixels" if sun else "no_sun_pixels",
                            sun_surface="sun_surface" if sun else "no_sun_surface",
                            **self._occlusion_values(),
                            snow_block=load_wgsl("snow_compose.wgsl",
                                                 snow_struct=SNOW_PARAMS.wgsl(),
                                                 snow_params=SNOW_PARAMS.name) if snow else "",
                            snow_compose="snow_compose" if snow else "no_snow_compose",
                            workgroup_x=WORKGROUP[0], workgroup_y=WORKGROUP[1])
            self._pipelines[key] = compute_pipeline(self.device, self._layout_for(sun, snow),
                                                    src, "lightfield.wgsl")
        return self._pipelines[key]

    def reference_compiled(self) -> "lfc.Compiled":
        """The NumPy compiled model for the last frame's camera depth (the twin's input)."""
        if self.water.key is None:
            raise AquaspecError("no frame yet: run the pass first")
        tables, a, b, e0, w = self._medium
        depth_o, alpha = self.water.key
        return lfc.compile_lightfield(tables, a=a, b=b, e0=e0, response_weights=w,
                                      depth_o=depth_o, factors=self.factors,
                                      alpha_nodes=np.array(alpha) if self.nodes else None)

    def _occlusion_values(self) -> dict:
        """lightfield.wgsl's template values of the occlusion (off: none of its bindings)."""
        occ = self.occlusion
        if occ is None:
            return dict(occlusion="false", occlusion_scale=1, occlusion_layers=1,
                        occlusion_block="", occlusion_fill="no_occlusion",
                        occlusion_coords="no_occlusion_coords")
        return dict(occlusion="true", occlusion_scale=occ.scale,
                    occlusion_layers=occ.layers_out,
                    occlusion_block=load_wgsl("occlusion_sample.wgsl"),
                    occlusion_fill="fill_occlusion", occlusion_coords="occlusion_coords")

    def bind_group(self, coarse=False, snow=False):
        """The bind group of the full-resolution pass (``snow``: with the
        snow's bindings), or of the COARSE one."""
        sp = self._spread_pass
        cone = sp.cone_texture if (coarse and sp) else self._unused["storage"]
        spread_in = sp.result if (sp and not coarse) else self._unused["sampled"]
        sun = None if coarse or self.sun is None else self.sun.fused_resources()
        occ = None if self.occlusion is None else self.occlusion.view
        snow_res = ({B_SNOW: self.snow.accum, B_SNOW_PARAMS: self.snow.params}
                  if snow and not coarse else {})
        key = (self.gbuffer.bindings_version, self.water.texture_version, id(cone),
               id(spread_in), None if sun is None else tuple(id(x) for x in sun.values()),
               id(occ), tuple(id(x) for x in snow_res.values()))
        cache = self._groups
        if key not in cache:
            tex = self.gbuffer.textures
            resources = {B_PARAMS: self._uniform, B_SURFACE: tex["surface"],
                         B_SIGMOID: tex["sigmoid"], **self._buffers, **self.output.resources(),
                         B_WATER: self.water.texture, B_CONE: cone, B_SPREAD: spread_in,
                         **(sun or {}), **({} if occ is None else {B_OCCLUSION: occ}),
                         **snow_res}
            cache[key] = self.device.create_bind_group(
                layout=self._layout_for(sun is not None, bool(snow_res)),
                entries=bind_group_entries(resources))
        return cache[key]

    def _update_spread(self, cam):
        """The spread's plan, pyramid pass and weights for this camera (fy) and size."""
        key = (id(self._medium[0]), float(cam.fy), self.spread_start_level)
        if self._spread_key != key:
            tables, fy = self._medium[0], float(cam.fy)
            if self.nodes:
                # (start, alpha per node as a tuple, node weights (K, levels + 1)).
                weights = np.array(node_pyramid_weights(tables.cone, fy, self.height, self.width))
                start, lv = spreadplan.multiple_plan(weights, fy, self.spread_start_level)
                self.spread_plan = (start, tuple(float(x) for x in lv["alpha"]), lv["a"])
            else:
                weights = pyramid_weights(tables.cone, fy, self.height, self.width)
                self.spread_plan = spreadplan.spread_plan(weights, fy, self.spread_start_level)
            self._spread_key = key
        start, alpha, coarse_w = self.spread_plan
        ch, cw = level_shapes(self.height, self.width, start)[-1]
        levels = coarse_w.shape[-1] - 1
        sp = self._spread_pass
        if (sp is None or sp.levels != levels or (sp.height, sp.width) != (ch, cw)
                or sp.nodes != max(1, self.nodes)):
            self._spread_pass = ConeSpreadPass(self.device, cw, ch, levels,
                                               nodes=max(1, self.nodes))
            self._groups = {}
        self._spread_pass.set_weights(coarse_w)
        return start, alpha, (cw, ch)

    def kept_projection(self, alpha: float):
        """:func:`aquaspec.transport.lightfield.spreadplan.kept_projection` for this medium
        and ``alpha`` (None: the shader keeps the multiply-add per band)."""
        if alpha not in self._kept_cache:
            self._kept_cache[alpha] = spreadplan.kept_projection(self._kept_coef, alpha,
                                                          self._fb_projection)
        return self._kept_cache[alpha]

    def encode(self, encoder, timestamp_writes=None, *, display: bool = False) -> None:
        """Record the shading into ``encoder`` (uniforms and tables are uploaded first).

        ``display=True`` also applies the display transform of
        :meth:`set_display` in the same pass and writes the display image
        (read with :meth:`read_display`) instead of linear RGB.
        """
        cam = self.gbuffer.camera
        if cam is None or self._buffers is None:
            raise AquaspecError("LightfieldPass needs a G-buffer (with its camera) and "
                                "set_medium() before running")
        if display and self.output.display_settings is None:
            raise AquaspecError("no display settings: call set_display() before "
                                "encoding with display=True")
        depth_o = camera_depth(cam)
        start, alpha, coarse_size = (self._update_spread(cam) if self.spread
                                     else (0, 0.0, (1, 1)))
        self.water.encode(encoder, depth_o, alpha)
        proj = self.kept_projection(alpha) if (self.spread and not self.nodes) else None
        lam = np.zeros(12)
        if proj is not None:
            # [lam_K, lam_c, mu, 0], then lam_G (up to eight).
            lam[[0, 1, 2]] = proj["lam"][[0, 1, -1]]
            lam[4:4 + proj["lam"].size - 3] = proj["lam"][2:-1]
        upload_buffer(self.device, self._uniform, PARAMS_LAYOUT.pack(
            **camera_fields(cam), width=self.width, height=self.height,
            n_materials=self._shape["n_materials"], depth_o=depth_o,
            max_depth=self._shape["max_depth"], window_cos=self._shape["window_cos"],
            coarse_size=coarse_size, block=2 ** start, alpha=0.0 if self.nodes else alpha,
            fb_mean=self._shape["fb_mean"], kept_lam=lam[0:4], kept_lam_g0=lam[4:8],
            kept_lam_g1=lam[8:12], **alpha_vec4s(alpha)))
        tonemap = self.output.begin_frame(encoder, display)
        per_pixel = bool(self.gbuffer.per_pixel)
        steps = []
        if self.spread:
            # The cone term at the spread's start level, then its pyramid.
            # (Two coarse pixels per invocation.)
            groups = (-(-coarse_size[0] // (2 * WORKGROUP[0])),
                      -(-coarse_size[1] // WORKGROUP[1]), 1)
            steps.append((self.pipeline(per_pixel, None, coarse=True,
                                        projected=proj is not None),
                          self.bind_group(coarse=True), groups))
            steps.extend(self._spread_pass.dispatches())
        steps.append((self.pipeline(per_pixel, tonemap, projected=proj is not None),
                      self.bind_group(snow=self._snow_on(tonemap)), self.workgroups()))
        # One compute pass (the timestamps, if any, bracket all of it).
        record_dispatches(encoder, steps, timestamp_writes)
