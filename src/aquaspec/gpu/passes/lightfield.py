"""Deferred shading with the light-field multiple-scattering model on the GPU.

The ``ms_model="lightfield"`` counterpart of
:class:`aquaspec.gpu.passes.deferred.DeferredPass`: it reads the same G-buffer
textures (``DeferredPass.gbuffer_textures``, the geometry pass's render
targets; layout in :mod:`aquaspec.gpu.passes.deferred`; the sigmoid texture only
when ``DeferredPass.per_pixel`` is true) and shades with the model compiled
for the camera's depth (:mod:`aquaspec.transport.lightfield.compiled`: a camera-RGB
water table over ``(v_y, S)``, built on the GPU by ``shaders/watertable.wgsl``
(twin: :func:`aquaspec.transport.lightfield.compiled.water_table`) when the camera's
depth changes, and the factored irradiance, fitted on the host per medium).
WGSL: ``shaders/lightfield.wgsl``; NumPy twin:
:func:`aquaspec.transport.lightfield.compiled.shade_compiled`; the test
``tests/test_gpu_lightfield.py`` holds them together, and
``tests/test_lightfield_compiled.py`` the twin and the model
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
6   storage ``array<vec4<f32>>``        linear camera RGB out (w = 1), pixel
                                        ``p = row * width + column``
8   storage ``array<atomic<u32>>``      status: [0] pixels with a material index
                                        out of range; with ``display=True`` [2]
                                        non-finite pixels, [3] the first of them
9   uniform ``DISPLAY_LAYOUT``          fused display transform
                                        (:mod:`aquaspec.gpu.passes.display`)
10  storage ``array<u32>``              display RGBA8 out (``display=True``)
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
==  ==================================  ==========================================

With the cone spread a frame is three steps, in one compute pass: the COARSE
pipeline (one invocation per two blocks of the spread's start level,
:func:`aquaspec.transport.lightfield.compiled.spread_plan`), the pyramid
(:class:`aquaspec.gpu.passes.conespread.ConeSpreadPass`), then the
full-resolution pass, which can apply the display transform itself.

The tables are read with the sampler's bilinear filtering when the device
has ``float32-filterable`` (lavapipe has it); without it the shader
interpolates from four fetches (``filtering=False``, tested too).
"""

from __future__ import annotations

import types

import numpy as np

from aquaspec.transport.lightfield import compiled as lfc
from aquaspec.errors import AquaspecError
from aquaspec.shading.shade import camera_depth
from aquaspec.gpu.buffers import (create_storage_buffer, create_texture, create_uniform_buffer,
                      read_buffer, record_dispatches, upload_buffer)
from aquaspec.gpu.passes.deferred import CAMERA_FIELDS, bind_group_entries, bind_group_layout, camera_fields
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.materials import MaterialTable
from aquaspec.gpu.shaders import load_wgsl

PARAMS_LAYOUT = UniformLayout("LightfieldParams", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("n_materials", "u32"), ("depth_o", "f32"),
    ("max_depth", "f32"), ("window_cos", "f32"), ("coarse_size", "vec2<u32>"),
    ("block", "u32"), ("alpha", "f32"), ("fb_mean", "f32"),
    # lightfield_compiled.kept_projection: [lam_K, lam_c, mu, 0], lam_G.
    ("kept_lam", "vec4<f32>"), ("kept_lam_g0", "vec4<f32>"), ("kept_lam_g1", "vec4<f32>"),
    # The multiple-scattering spread: the share kept at each lambda node (up to 8).
    ("alpha_lo", "vec4<f32>"), ("alpha_hi", "vec4<f32>"),
])

#: Compute workgroup size (x, y) of lightfield.wgsl, in invocations.
WORKGROUP = (8, 8)
#: Adjacent pixels of a row shaded by one invocation.
PIXELS_PER_INVOCATION = 4

# (Bindings 3 and 5: the material table, aquaspec.gpu.materials.)
B_PARAMS, B_SURFACE, B_SIGMOID, B_BANDS, B_RGB = 0, 1, 2, 4, 6
B_STATUS, B_DISPLAY, B_RGBA, B_WATER, B_BASIS = 8, 9, 10, 11, 12
B_SAMPLER, B_CONE, B_SPREAD = 14, 15, 16


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
    (:func:`aquaspec.transport.lightfield.compiled.fb_projection`).
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


WATER_PARAMS_LAYOUT = UniformLayout("WaterTableParams", [
    ("depth_o", "f32"), ("window_cos", "f32"), ("max_depth", "f32"), ("alpha", "f32"),
    ("n_out", "u32"), ("n_in", "u32"), ("fb_mean", "f32"), ("alpha_lo", "vec4<f32>"),
    ("alpha_hi", "vec4<f32>"),
])

#: Most lambda nodes of the multiple-scattering spread the shaders take.
MAX_NODES = 8


def _alpha_vec4s(alpha) -> dict:
    """``alpha_lo``, ``alpha_hi`` of the uniforms: the nodes' kept shares (or zeros)."""
    v = np.zeros(MAX_NODES)
    if isinstance(alpha, tuple):
        v[:len(alpha)] = alpha
    return {"alpha_lo": v[:4], "alpha_hi": v[4:]}


def water_band_fields(tables, *, a, b, e0, response_weights) -> np.ndarray:
    """Per band group the fields of watertable.wgsl: (8, ceil(n / 4), 4) float64.

    ``c, kappa_1, c' = c - f b, b E0 / (4 pi), L_top, w_r, w_g, w_b``, four
    bands per vec4 (zero past the last band).
    """
    a, b, e0 = (np.asarray(x, dtype=np.float64) for x in (a, b, e0))
    w = np.asarray(response_weights, dtype=np.float64)
    n = a.size
    f = np.asarray(tables.get("forward_fraction", np.zeros(n)), dtype=np.float64)
    c = a + b
    rows = np.stack([c, np.asarray(tables["k_inf"], np.float64), c - f * b,
                     b * e0 / (4.0 * np.pi),
                     np.asarray(tables["sky_radiance_per_e0"], np.float64) * e0,
                     w[:, 0], w[:, 1], w[:, 2]])
    groups = -(-n // 4)
    out = np.zeros((8, groups * 4))
    out[:, :n] = rows
    # Padding bands: c = 1 keeps their (unused) path integrals finite.
    out[0, n:] = 1.0
    out[2, n:] = 1.0
    return out.reshape(8, groups, 4)


class LightfieldPass:
    """Light-field shading of the G-buffer held by ``deferred`` (a DeferredPass).

    Per frame, after the G-buffer and camera are set on ``deferred``:
    :meth:`run` then :meth:`read_rgb`, or (with :meth:`set_display`)
    ``run(display=True)`` then :meth:`read_display`. :meth:`set_medium` when
    the water, light, sensor or tables change.
    """

    def __init__(self, deferred, *, filtering: bool | None = None):
        from aquaspec.gpu.passes.display import DISPLAY_LAYOUT
        self.deferred = deferred
        dev = self.device = deferred.device
        #: Whether the tables are read with the sampler's bilinear filtering
        #: (needs float32-filterable; default: when the device has it) or
        #: interpolated in the shader from four fetches.
        self.filtering = ("float32-filterable" in dev.features) if filtering is None \
            else bool(filtering)
        if self.filtering and "float32-filterable" not in dev.features:
            raise AquaspecError("filtering=True needs a device with float32-filterable; "
                                "accepted: filtering=False or None")
        self.width, self.height = deferred.width, deferred.height
        npix = self.width * self.height
        self._uniform = create_uniform_buffer(dev, PARAMS_LAYOUT, label="lightfield params")
        self._water_params = create_uniform_buffer(dev, WATER_PARAMS_LAYOUT,
                                                   label="water table params")
        self.rgb_buffer = create_storage_buffer(dev, npix * 16, label="lightfield rgb")
        self._status = create_storage_buffer(dev, 16, label="lightfield status")
        self._display_uniform = create_uniform_buffer(dev, DISPLAY_LAYOUT,
                                                      label="lightfield display")
        #: Packed RGBA8 output of ``encode(display=True)``, ``width * height`` u32.
        self.display_buffer = create_storage_buffer(dev, npix * 4, label="lightfield rgba8")
        self.display_settings = None
        self._last_display = False
        table_kind = "filterable_array" if self.filtering else "float_array"
        self._layout = bind_group_layout(dev, {
            B_PARAMS: "uniform", B_SURFACE: "uint", B_SIGMOID: "float", B_BANDS: "uniform",
            **MaterialTable.layout(), B_RGB: "write", B_STATUS: "write", B_DISPLAY: "uniform",
            B_RGBA: "write", B_WATER: table_kind, B_BASIS: table_kind,
            B_SAMPLER: "sampler" if self.filtering else "nonfiltering_sampler",
            B_CONE: "storage_rgba32float",
            B_SPREAD: "filterable" if self.filtering else "float"})
        mode = "linear" if self.filtering else "nearest"
        self._sampler = dev.create_sampler(label="lightfield tables", mag_filter=mode,
                                           min_filter=mode, address_mode_u="clamp-to-edge",
                                           address_mode_v="clamp-to-edge")
        self._pipelines = {}
        self._buffers = None
        self.spread = False
        self._spread_pass = None
        self._spread_key = None
        self._shape = None
        self._medium = None
        self._water_texture = None
        self._water_key = None
        self._water_shape = None
        self._groups = {}
        #: ``(L0, alpha, coarse weights)`` of the cone spread for the last camera.
        self.spread_plan = None
        #: The spread's start level; None: :func:`lightfield_compiled.spread_plan`'s
        #: choice for the camera.
        self.spread_start_level = None
        #: The irradiance factorisation of the current tables
        #: (:func:`aquaspec.transport.lightfield.compiled.choose_irradiance_factors`).
        self.factors = None

    def set_medium(self, *, a, b, e0, response_weights, material_bands, sigmoid_centers_t,
                   tables, **_ignored):
        """Upload per-band data, the irradiance basis and (per depth) the water table.

        ``kd`` and ``ambient`` are not used. The irradiance is factorised here
        (:func:`aquaspec.transport.lightfield.compiled.choose_irradiance_factors`); the
        water table is built for the camera's depth when a frame is encoded.
        """
        a, b, e0 = (np.asarray(x, dtype=float) for x in (a, b, e0))
        n = a.size
        lp = np.asarray(tables["ms_log_prefactor"])
        if lp.shape[0] != n:
            raise AquaspecError(f"tables have {lp.shape[0]} bands; the medium has {n}")
        # (The factors depend on the tables alone: the same tables object,
        # kept alive by self._medium, keeps them.)
        factors = (self.factors if self._medium is not None and self._medium[0] is tables
                   else lfc.choose_irradiance_factors(tables))
        f = np.asarray(tables.get("forward_fraction", np.zeros(n)), dtype=float)
        # The band coefficients lightfield_compiled.kept_projection reads, and
        # their projection of f b (made once per medium).
        self._kept_coef = types.SimpleNamespace(split=True, k_depth=factors["coef"][:, 1],
                                                c_beam=a + (1.0 - f) * b,
                                                g=factors["coef"][:, 2:], fb=f * b)
        kc = self._kept_coef
        self._fb_projection = lfc.fb_projection(kc.k_depth, kc.c_beam, kc.g, kc.fb)
        self._kept_cache = {}
        band = band_table(factors, a=a, b=b, e0=e0, response_weights=response_weights,
                          sigmoid_centers_t=sigmoid_centers_t, forward_fraction=f,
                          fb_offset_hat=self._fb_projection[1])
        mb = np.asarray(material_bands, dtype=np.float32).reshape(-1, n)
        import wgpu
        dev = self.device
        bands = dev.create_buffer(label="lightfield bands", size=band.size * 4,
                                  usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
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
        self._materials = materials
        self._buffers = {
            B_BANDS: bands,
            **materials.resources(),
            B_BASIS: self._array_texture(band_group_texture(factors["basis"]),
                                         "lightfield irradiance basis"),
            B_SAMPLER: self._sampler,
        }
        self._water_bands = water_band_fields(tables, a=a, b=b, e0=e0,
                                              response_weights=response_weights)
        water_data = self._water_bands.reshape(-1, 4).astype(np.float32)
        self._water_band_buffer = dev.create_buffer(
            label="water table bands", size=water_data.nbytes,
            usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
        upload_buffer(dev, self._water_band_buffer, water_data)
        self._log_prefactor = self._array_texture(band_group_texture(lp),
                                                  "lightfield ln F")
        rank = factors["coef"].shape[1] - 2
        self._shape = dict(n_bands=n, n_materials=int(np.asarray(material_bands).shape[0]),
                           n_depth=lp.shape[1], n_mu=lp.shape[2], rank=rank,
                           max_depth=float(tables["max_depth_m"][0]),
                           window_cos=float(tables["window_cos"][0]),
                           fb_mean=float(np.mean(f * b)))
        self.factors = factors
        #: Tables with a seabed: the water table is built on the CPU
        #: (:func:`aquaspec.transport.lightfield.compiled.water_table`; watertable.wgsl
        #: has the deep-water closed form only) and uploaded.
        self.seabed = bool(np.isfinite(float(tables["seabed_depth_m"][0])))
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
        self.spread = "cone_offset_cdf" in tables
        #: Lambda nodes of the multiple-scattering spread (tables with
        #: spread_scattering="multiple"), else 0.
        self.nodes = (len(tables["cone_lambda_nodes"]) if "cone_offset_cdf_nodes" in tables
                      else 0)
        if self.nodes > MAX_NODES:
            raise AquaspecError(f"{self.nodes} lambda nodes; the GPU pass takes at most "
                                f"{MAX_NODES}")
        if not same_water:
            self._spread_pass = None
            self._spread_key = None
            self._water_key = None
        self._groups = {}

    def _array_texture(self, data, label):
        """A 2-D array texture from texels ``(layers, rows, cols, 4)`` float32."""
        import wgpu
        data = np.ascontiguousarray(data, dtype=np.float32)
        layers, rows, cols = data.shape[:3]
        tex = self.device.create_texture(
            label=label, size=(cols, rows, layers), format="rgba32float",
            usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST,
            dimension="2d", mip_level_count=1, sample_count=1)
        self.device.queue.write_texture({"texture": tex, "mip_level": 0, "origin": (0, 0, 0)},
                                        data, {"offset": 0, "bytes_per_row": cols * 16,
                                               "rows_per_image": rows}, (cols, rows, layers))
        return tex.create_view(dimension="2d-array")

    # ------------------------------------------------------------- dispatch
    def _pipeline(self, per_pixel, tonemap, coarse=False, projected=False):
        from aquaspec.gpu.passes.display import DISPLAY_LAYOUT, TONEMAP_IDS
        sh = self._shape
        split = lfc.direction_split(sh["window_cos"])
        group = bool(self.spread and 2 ** self.spread_plan[0] >= 4)
        key = (sh["n_bands"], sh["n_depth"], sh["n_mu"], sh["rank"], split, per_pixel, tonemap,
               self.filtering, self.spread, coarse, group, projected,
               self._materials.in_uniform, self.nodes)
        if key not in self._pipelines:
            band_vec4 = 2 + -(-sh["rank"] // 4)
            src = load_wgsl("lightfield.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                            params_struct_name=PARAMS_LAYOUT.name,
                            display_struct=DISPLAY_LAYOUT.wgsl(),
                            display_struct_name=DISPLAY_LAYOUT.name,
                            display="false" if tonemap is None else "true",
                            tonemap_id=TONEMAP_IDS[tonemap or "none"],
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
                            **self._materials.template(),
                            workgroup_x=WORKGROUP[0], workgroup_y=WORKGROUP[1])
            module = self.device.create_shader_module(label="lightfield.wgsl", code=src)
            self._pipelines[key] = self.device.create_compute_pipeline(
                label="lightfield",
                layout=self.device.create_pipeline_layout(bind_group_layouts=[self._layout]),
                compute={"module": module, "entry_point": "main"})
        return self._pipelines[key]

    def _water_pipeline(self):
        sh = self._shape
        key = ("water", self._water_bands.shape[1], sh["n_depth"], sh["n_mu"], self.spread,
               self.nodes)
        if key not in self._pipelines:
            src = load_wgsl("watertable.wgsl", params_struct=WATER_PARAMS_LAYOUT.wgsl(),
                            params_struct_name=WATER_PARAMS_LAYOUT.name,
                            n_groups=self._water_bands.shape[1], n_depth=sh["n_depth"],
                            n_mu=sh["n_mu"], distances=lfc.DISTANCES,
                            length_scale=f"{float(lfc.LENGTH_SCALE_M)!r}",
                            split="true" if self.spread else "false",
                            nodes=self.nodes, node_array=max(1, self.nodes),
                            band_len=self._water_bands.shape[0] * self._water_bands.shape[1])
            module = self.device.create_shader_module(label="watertable.wgsl", code=src)
            layout = bind_group_layout(self.device, {0: "uniform", 1: "uniform",
                                                     2: "float_array", 3: "write"})
            pipelines = [self.device.create_compute_pipeline(
                label=f"lightfield water table {entry}",
                layout=self.device.create_pipeline_layout(bind_group_layouts=[layout]),
                compute={"module": module, "entry_point": entry})
                for entry in ("open_column", "main")]
            self._pipelines[key] = (pipelines, layout)
        return self._pipelines[key]

    def _update_water_table(self, encoder, depth_o, alpha):
        """Build the water table for the camera's depth on the GPU (watertable.wgsl)
        when the depth, the medium or (with the spread) alpha changed: layer 0
        holds ``W0 + alpha W1`` with the spread (:func:`lightfield_compiled.spread_plan`);
        with the multiple-scattering spread ``alpha`` is the tuple of the nodes'
        shares and the table has a layer per node (:func:`lightfield_compiled.water_table`).
        With a seabed the table is built on the CPU and uploaded (0.3-1.5 s)."""
        key = (depth_o, alpha)
        if self._water_key == key:
            return
        import wgpu
        dev = self.device
        n_out, n_in = lfc.direction_split(self._shape["window_cos"])
        rows = n_out + n_in
        layers = (1 + self.nodes) if self.nodes else (2 if self.spread else 1)
        if self._water_texture is None or self._water_shape != (layers, rows):
            tex = dev.create_texture(
                label="lightfield water table", size=(lfc.DISTANCES, rows, layers),
                format="rgba32float", dimension="2d", mip_level_count=1, sample_count=1,
                usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST)
            self._water_tex = tex
            self._water_texture = tex.create_view(dimension="2d-array")
            self._water_out = create_storage_buffer(dev, layers * rows * lfc.DISTANCES * 16,
                                                    label="lightfield water table out")
            self._water_shape = (layers, rows)
            self._groups = {}
        if self.seabed:
            tables, a, b, e0, w = self._medium
            table = lfc.water_table(tables, a=a, b=b, e0=e0, response_weights=w,
                                    depth_o=depth_o, split=self.spread,
                                    alpha_nodes=np.array(alpha) if self.nodes else None)
            if self.spread and not self.nodes:
                table[0] += alpha * table[1]       # as watertable.wgsl's layer 0
            texels = np.zeros(table.shape[:3] + (4,), np.float32)
            texels[..., :3] = table
            if self.nodes:
                # (As watertable.wgsl: the pixel's kept share over the distances.)
                texels[0, :, :lfc.DISTANCES - 1, 3] = lfc.node_alpha(
                    types.SimpleNamespace(alpha_nodes=np.array(alpha),
                                          fb=np.array([self._shape["fb_mean"]])),
                    self._water_distances(depth_o))
            upload_buffer(dev, self._water_out, texels.reshape(-1))
        else:
            self._encode_water_table(encoder, depth_o, alpha, n_out, n_in, rows)
        encoder.copy_buffer_to_texture(
            {"buffer": self._water_out, "offset": 0, "bytes_per_row": lfc.DISTANCES * 16,
             "rows_per_image": rows},
            {"texture": self._water_tex, "mip_level": 0, "origin": (0, 0, 0)},
            (lfc.DISTANCES, rows, layers))
        self._water_key = key

    def _encode_water_table(self, encoder, depth_o, alpha, n_out, n_in, rows):
        """watertable.wgsl's two dispatches into the water table buffer."""
        dev = self.device
        (open_column, hits), layout = self._water_pipeline()
        upload_buffer(dev, self._water_params, WATER_PARAMS_LAYOUT.pack(
            depth_o=depth_o, window_cos=self._shape["window_cos"],
            max_depth=self._shape["max_depth"], alpha=0.0 if self.nodes else alpha,
            n_out=n_out, n_in=n_in, fb_mean=self._shape["fb_mean"], **_alpha_vec4s(alpha)))
        group = dev.create_bind_group(layout=layout, entries=bind_group_entries(
            {0: self._water_params, 1: self._water_band_buffer, 2: self._log_prefactor,
             3: self._water_out}))
        # The open-water column first: the hit columns read it.
        record_dispatches(encoder, [
            (open_column, group, (-(-rows // 64), 1, 1)),
            (hits, group, (-(-(lfc.DISTANCES - 1) // 8), -(-rows // 8), 1))])

    def _water_distances(self, depth_o: float) -> np.ndarray:
        """The hit columns' distances of the water table ``(directions, DISTANCES - 1)``,
        up rays' clipped at the surface (watertable.wgsl's ``s``)."""
        v, _ = lfc.direction_nodes(self._shape["window_cos"])
        s = np.broadcast_to(lfc.distance_nodes(), (v.size, lfc.DISTANCES - 1))
        up = v[:, None] > 0
        with np.errstate(over="ignore"):       # up rays within 1e-30 of level
            to_surface = depth_o / np.where(up, v[:, None], 1.0)
        return np.where(up, np.minimum(s, to_surface), s)

    def read_water_table(self, channels: int = 3) -> np.ndarray:
        """The last water table built, ``(layers, directions, DISTANCES, channels)``
        float32 (tests; the fourth channel of layer 0 is the multiple-scattering
        spread's kept share)."""
        if self._water_key is None:
            raise AquaspecError("no water table yet: run the pass first")
        layers, rows = self._water_shape
        return read_buffer(self.device, self._water_out, np.float32,
                           (layers, rows, lfc.DISTANCES, 4))[..., :channels]

    def reference_compiled(self) -> "lfc.Compiled":
        """The NumPy compiled model for the last frame's camera depth (the twin's input)."""
        if self._water_key is None:
            raise AquaspecError("no frame yet: run the pass first")
        tables, a, b, e0, w = self._medium
        alpha = self._water_key[1]
        return lfc.compile_lightfield(tables, a=a, b=b, e0=e0, response_weights=w,
                                      depth_o=self._water_key[0], factors=self.factors,
                                      alpha_nodes=np.array(alpha) if self.nodes else None)

    def _bind_group(self, coarse=False):
        """The bind group of the full-resolution pass, or of the COARSE one."""
        # The deferred pass counts replacements of its textures.
        sp = self._spread_pass
        cone = sp.cone_texture if (coarse and sp) else self._dummy("storage")
        spread_in = sp.result if (sp and not coarse) else self._dummy("sampled")
        key = (self.deferred.bindings_version, id(cone), id(spread_in), id(self._water_texture))
        cache = self._groups
        if key not in cache:
            tex = self.deferred.gbuffer_textures
            resources = {B_PARAMS: self._uniform, B_SURFACE: tex["surface"],
                         B_SIGMOID: tex["sigmoid"], **self._buffers, B_RGB: self.rgb_buffer,
                         B_STATUS: self._status, B_DISPLAY: self._display_uniform,
                         B_RGBA: self.display_buffer, B_WATER: self._water_texture,
                         B_CONE: cone, B_SPREAD: spread_in}
            cache[key] = self.device.create_bind_group(layout=self._layout,
                                                       entries=bind_group_entries(resources))
        return cache[key]

    def _dummy(self, kind):
        """1x1 textures for the spread's bindings when they are not used (a
        texture may not be both written and sampled in one dispatch)."""
        if not hasattr(self, "_dummies"):
            import wgpu
            usage = wgpu.TextureUsage.STORAGE_BINDING | wgpu.TextureUsage.TEXTURE_BINDING
            self._dummies = {k: create_texture(self.device, 1, 1, "rgba32float",
                                               label=f"lightfield unused {k}", usage=usage)
                             for k in ("storage", "sampled")}
        return self._dummies[kind]

    def _update_spread(self, cam):
        """The spread's plan, pyramid pass and weights for this camera (fy) and size."""
        from aquaspec.transport.lightfield.conespread import level_shapes, node_pyramid_weights, pyramid_weights
        from aquaspec.gpu.passes.conespread import ConeSpreadPass
        key = (id(self._medium[0]), float(cam.fy), self.spread_start_level)
        if self._spread_key != key:
            tables, fy = self._medium[0], float(cam.fy)
            if self.nodes:
                # (start, alpha per node as a tuple, node weights (K, levels + 1)).
                weights = np.array(node_pyramid_weights(tables, fy, self.height, self.width))
                start, lv = lfc.multiple_plan(weights, fy, self.spread_start_level)
                self.spread_plan = (start, tuple(float(x) for x in lv["alpha"]), lv["a"])
            else:
                weights = pyramid_weights(tables, fy, self.height, self.width)
                self.spread_plan = lfc.spread_plan(weights, fy, self.spread_start_level)
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
        """:func:`aquaspec.transport.lightfield.compiled.kept_projection` for this medium
        and ``alpha`` (None: the shader keeps the multiply-add per band)."""
        if alpha not in self._kept_cache:
            self._kept_cache[alpha] = lfc.kept_projection(self._kept_coef, alpha,
                                                          self._fb_projection)
        return self._kept_cache[alpha]

    def workgroups(self) -> tuple[int, int, int]:
        """Dispatch size covering the image."""
        per_x = WORKGROUP[0] * PIXELS_PER_INVOCATION
        return (-(-self.width // per_x), -(-self.height // WORKGROUP[1]), 1)

    def set_display(self, *, exposure_ev, white_balance_gains=(1.0, 1.0, 1.0), matrix=None,
                    tonemap="filmic") -> None:
        """Settings of the fused display transform (``encode(display=True)``).

        The same settings and checks as
        :meth:`aquaspec.gpu.passes.deferred.DeferredPass.set_display`.
        """
        from aquaspec.gpu.passes.display import DISPLAY_LAYOUT, TONEMAP_IDS, folded_matrix
        if not isinstance(tonemap, str) or tonemap not in TONEMAP_IDS:
            raise AquaspecError(f"unknown tone map {tonemap!r}; accepted: "
                                + ", ".join(repr(k) for k in TONEMAP_IDS))
        m = folded_matrix(exposure_ev, white_balance_gains, matrix).astype(np.float32)
        if not np.all(np.isfinite(m)):
            raise AquaspecError(f"exposure EV {exposure_ev!r} with these gains overflows "
                                "float32 on the GPU; accepted: a smaller exposure")
        upload_buffer(self.device, self._display_uniform, DISPLAY_LAYOUT.pack(
            m0=m[0], m1=m[1], m2=m[2], width=self.width, height=self.height,
            tonemap=TONEMAP_IDS[tonemap]))
        self.display_settings = {"exposure_ev": float(exposure_ev),
                                 "white_balance_gains": [float(g) for g in white_balance_gains],
                                 "matrix": None if matrix is None
                                 else np.asarray(matrix, float).tolist(),
                                 "tonemap": tonemap}

    def encode(self, encoder, timestamp_writes=None, *, display: bool = False) -> None:
        """Record the shading into ``encoder`` (uniforms and tables are uploaded first).

        ``display=True`` also applies the display transform of
        :meth:`set_display` in the same pass and writes
        :attr:`display_buffer` (read with :meth:`read_display`) instead of
        linear RGB.
        """
        d = self.deferred
        cam = d.camera
        if cam is None or self._buffers is None:
            raise AquaspecError("LightfieldPass needs a G-buffer (on its DeferredPass) and "
                                "set_medium() before running")
        tonemap = None
        if display:
            if self.display_settings is None:
                raise AquaspecError("no display settings: call set_display() before "
                                    "encoding with display=True")
            tonemap = self.display_settings["tonemap"]
        depth_o = camera_depth(cam)
        start, alpha, coarse_size = (self._update_spread(cam) if self.spread
                                     else (0, 0.0, (1, 1)))
        self._update_water_table(encoder, depth_o, alpha)
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
            kept_lam_g1=lam[8:12], **_alpha_vec4s(alpha)))
        if display:
            # status[3] is an atomicMin, so it starts at the maximum (a queue
            # write runs before the next submission).
            self.device.queue.write_buffer(self._status, 0,
                                           np.array([0, 0, 0, 0xFFFFFFFF], np.uint32))
        else:
            encoder.clear_buffer(self._status, 0, self._status.size)
        self._last_display = bool(display)
        per_pixel = bool(d.per_pixel)
        steps = []
        if self.spread:
            # The cone term at the spread's start level, then its pyramid.
            # (Two coarse pixels per invocation.)
            groups = (-(-coarse_size[0] // (2 * WORKGROUP[0])),
                      -(-coarse_size[1] // WORKGROUP[1]), 1)
            steps.append((self._pipeline(per_pixel, None, coarse=True,
                                         projected=proj is not None),
                          self._bind_group(coarse=True), groups))
            steps.extend(self._spread_pass.dispatches())
        steps.append((self._pipeline(per_pixel, tonemap, projected=proj is not None),
                      self._bind_group(), self.workgroups()))
        # One compute pass (the timestamps, if any, bracket all of it).
        record_dispatches(encoder, steps, timestamp_writes)

    def run(self, display: bool = False) -> None:
        """Shade the current G-buffer (submits; does not wait); ``display`` as in :meth:`encode`."""
        encoder = self.device.create_command_encoder()
        self.encode(encoder, display=display)
        self.device.queue.submit([encoder.finish()])

    # ------------------------------------------------------------- outputs
    def _bad_materials(self, status):
        if status[0]:
            raise AquaspecError(f"{int(status[0])} G-buffer pixels use a material index >= "
                                f"{self._shape['n_materials']}, the number of material_bands "
                                "rows")

    def read_display(self) -> np.ndarray:
        """The display image of the last ``run(display=True)``, (H, W, 3) uint8.

        Raises :class:`AquaspecError` if a pixel referenced an undefined
        material, or (with the count and the first pixel) if a value was not
        finite or overflowed after exposure.
        """
        if not self._last_display:
            raise AquaspecError("read_display() needs a run with display=True")
        status = read_buffer(self.device, self._status, np.uint32, (4,))
        self._bad_materials(status)
        if status[2]:
            row, col = divmod(int(status[3]), self.width)
            raise AquaspecError(f"shading produced {int(status[2])} pixel(s) with non-finite "
                                f"values (or overflow after exposure); the first is at "
                                f"(row {row}, column {col}); check the water coefficients "
                                "and G-buffer")
        rgba = read_buffer(self.device, self.display_buffer, np.uint8,
                           (self.height, self.width, 4))
        return np.ascontiguousarray(rgba[..., :3])

    def read_rgb(self) -> np.ndarray:
        """Linear camera RGB of the last run, (H, W, 3) float32.

        Raises :class:`AquaspecError` if a pixel referenced an undefined
        material or a value is not finite, or if the last run wrote the
        display image instead.
        """
        if self._last_display:
            raise AquaspecError("the last run wrote the display image (display=True); "
                                "read it with read_display(), or run without display")
        self._bad_materials(read_buffer(self.device, self._status, np.uint32, (4,)))
        rgb = read_buffer(self.device, self.rgb_buffer, np.float32,
                          (self.height, self.width, 4))[..., :3]
        if not np.all(np.isfinite(rgb)):
            raise AquaspecError("the light-field pass produced NaN or infinity")
        return np.ascontiguousarray(rgb)
