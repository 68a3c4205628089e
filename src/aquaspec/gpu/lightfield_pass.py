"""Deferred shading with the light-field multiple-scattering model on the GPU.

The ``ms_model="lightfield"`` counterpart of
:class:`aquaspec.gpu.deferred.DeferredPass`: it reads the same G-buffer
textures (``DeferredPass.gbuffer_textures``, the geometry pass's render
targets; layout in :mod:`aquaspec.gpu.deferred`; the sigmoid texture only
when ``DeferredPass.per_pixel`` is true) and per band the tables of
:func:`aquaspec.lightfield.lightfield_tables` (``ln F`` over depth x
direction for the in-scattering, ``E(d, n_y)/E0`` for the surfaces). WGSL:
``shaders/lightfield.wgsl`` (its header gives the formulas and how they are
split between host and GPU); NumPy reference:
:func:`aquaspec.shading.shade_gbuffer` with ``lightfield=`` tables; the test
``tests/test_gpu_lightfield.py`` holds them together. Deep water only.

One invocation shades four horizontally adjacent pixels. Bindings:

==  ==================================  ==========================================
0   uniform :data:`PARAMS_LAYOUT`       camera, image size, camera depth, table
                                        sizes
1   texture ``rgba32uint``              G-buffer surface (S, n_y, normal, material)
2   texture ``rgba32float``             G-buffer sigmoid (read when per_pixel)
4   uniform ``array<vec4<f32>, 3 n>``   per band :data:`BAND_FIELDS` (float64 on
                                        the host, :func:`band_table`)
5   storage ``array<f32>``              material band reflectances, row-major
                                        ``(material, band)``
6   storage ``array<vec4<f32>>``        linear camera RGB out (w = 1), pixel
                                        ``p = row * width + column``
8   storage ``array<atomic<u32>>``      status: [0] pixels with a material index
                                        out of range; with ``display=True`` [2]
                                        non-finite pixels, [3] the first of them
9   uniform ``DISPLAY_LAYOUT``          fused display transform
                                        (:mod:`aquaspec.gpu.display_pass`)
10  storage ``array<u32>``              display RGBA8 out (``display=True``)
11  texture ``rgba32float``             open-water table (:func:`open_water_table`):
                                        sample ``m``, part ``h`` at texel
                                        ``(2 (m % OPEN_ROW) + h, m / OPEN_ROW)``
12  2-D array texture ``rgba32float``  ``ln F``: layer ``g``, texel ``(j, i)``
    (n_mu, n_depth, ceil(n / 4))        (direction, depth) holds bands
                                        ``4g .. 4g + 3`` (:func:`band_group_texture`)
13  2-D array texture ``rgba32float``  ``E / E0``, same layout
14  sampler                             bilinear (``filtering``) or nearest
==  ==================================  ==========================================

The tables are read with the sampler's bilinear filtering when the device
has ``float32-filterable`` (lavapipe has it): one sample gives four bands,
where a fetch per band and pixel had been most of the pass's time; without
it the shader interpolates from four fetches (``filtering=False``, tested
too).
"""

from __future__ import annotations

import numpy as np

from ..errors import AquaspecError
from ..lightfield import _seeds_shape, bilinear
from ..shading import camera_depth
from .buffers import (create_storage_buffer, create_uniform_buffer, read_buffer,
                      create_texture, record_dispatch, upload_buffer, upload_texture)
from .deferred import CAMERA_FIELDS, bind_group_entries, bind_group_layout, camera_fields
from .layout import UniformLayout
from .shaders import load_wgsl

PARAMS_LAYOUT = UniformLayout("LightfieldParams", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("n_materials", "u32"), ("table_sub", "u32"),
    ("table_last", "u32"), ("depth_o", "f32"), ("max_depth", "f32"), ("window_cos", "f32"),
])

#: Per-band fields of the band table (binding 4), three vec4 per band.
BAND_FIELDS = ("c", "k_inf", "c_beam", "scale", "w_r", "w_g", "w_b", "e0_over_pi",
               "t", "l_top", "fb", "unused")

#: Compute workgroup size (x, y) of lightfield.wgsl, in invocations.
WORKGROUP = (8, 8)
#: Adjacent pixels of a row shaded by one invocation.
PIXELS_PER_INVOCATION = 4

B_PARAMS, B_SURFACE, B_SIGMOID, B_BANDS, B_MATERIALS, B_RGB = 0, 1, 2, 4, 5, 6
B_STATUS, B_DISPLAY, B_RGBA, B_OPEN_TABLE, B_LOG_PREFACTOR, B_IRRADIANCE = 8, 9, 10, 11, 12, 13
B_SAMPLER, B_CONE = 14, 15

#: Samples of the open-water table per cell of the tables' direction axis,
#: the first whose estimated interpolation error is below
#: :data:`OPEN_TABLE_TOLERANCE` (:func:`open_water_table`), else the last (a
#: camera just below the surface: up rays near the horizon need more).
OPEN_TABLE_SUBS = (64, 128, 256, 512, 1024)
OPEN_TABLE_TOLERANCE = 1e-5
#: Samples of the open-water table per texture row.
OPEN_ROW = 2048


def band_group_texture(table) -> np.ndarray:
    """Texels of a table (n, n_depth, n_mu): (ceil(n / 4), n_depth, n_mu, 4) float32.

    Layer ``g``, texel ``(j, i)`` (direction, depth) holds bands
    ``4g .. 4g + 3`` at node ``(i, j)``, zero past the last band: one
    (filtered) sample gives four bands.
    """
    t = np.asarray(table, dtype=np.float32)
    n, nd, nm = t.shape
    groups = -(-n // 4)
    out = np.zeros((groups * 4, nd, nm), np.float32)
    out[:n] = t
    return np.ascontiguousarray(np.moveaxis(out.reshape(groups, 4, nd, nm), 1, -1))


#: One band's step of the band loop in lightfield.wgsl, for band ``i = 4 g + {k}``
#: whose table values are component ``{c}`` of the four pixels' samples.
#: Bands past the last of the last group are skipped (a branch every lane
#: takes the same way).
BAND_STEP = """        if (4u * g + {k}u < N_BANDS) {{
            let i = 4u * g + {k}u;
            let ln_f = vec4<f32>(f0.{c}, f1.{c}, f2.{c}, f3.{c});
            let irr = vec4<f32>(h0.{c}, h1.{c}, h2.{c}, h3.{c});
            let q0 = band_table[3u * i];
            let q1 = band_table[3u * i + 1u];
            let q2 = band_table[3u * i + 2u];
            let c = q0.x;
            let k1 = q0.y;
            let c_beam = q0.z;
            let tr = exp(-c_beam * s);
            // T' R(d_S, v) / scale (see the header).
            let a = ln_f - c_beam * s;
            let k = c - k1 * v_y;
            let e1 = exp(a - k1 * d_s);
            let e2 = select(vec4<f32>(0.0), exp(a - c * len_up), up);
            let x = k * len_up;
            let inv_k = 1.0 / select(vec4<f32>(1.0), k, k != vec4<f32>(0.0));
            let series = e1 * len_up * (1.0 - x * (0.5 - x * (1.0 / 6.0 - x * (1.0 / 24.0
                         - x * (1.0 / 120.0)))));
            let r_s = select((e1 - e2) * inv_k, series, up & (abs(x) < vec4<f32>(0.1)));
            var rho = select(vec4<f32>(0.0), vec4<f32>(material_bands[mrow.x + i],
                             material_bands[mrow.y + i], material_bands[mrow.z + i],
                             material_bands[mrow.w + i]), use_material);
            if (PER_PIXEL_MATERIALS) {{
                rho = select(rho, sigmoid_reflectance(c0, c1, c2, q2.x), use_sigmoid);
            }}
            var l = tr * rho * irr * q1.w - q0.w * r_s;
            if (CONE) {{
                // - T' u_S L_top inside the window.
                l = l - select(vec4<f32>(0.0), exp(-c_beam * s - c * len_up) * q2.y,
                               cone_window);
            }}
            l = select(vec4<f32>(0.0), l, hit);
            if (SPREAD) {{
                // The cone's term (T' - T) (...) = l (1 - exp(-f b S)), kept apart.
                let base_l = l * exp(-q2.z * s);
                let cone_l = l - base_l;
                cr = cr + cone_l * q1.x;
                cg = cg + cone_l * q1.y;
                cb = cb + cone_l * q1.z;
                l = base_l;
            }}
            r = r + l * q1.x;
            gr = gr + l * q1.y;
            b = b + l * q1.z;
        }}"""


def band_steps() -> str:
    """The four band steps of one band-loop iteration (:data:`BAND_STEP`)."""
    return "\n".join(BAND_STEP.format(k=k, c=c) for k, c in enumerate("xyzw"))


def band_table(a, b, e0, response_weights, sigmoid_centers_t, tables) -> np.ndarray:
    """The band table (binding 4): (n, 12) float64, :data:`BAND_FIELDS`.

    ``c = a + b``, ``k_inf`` (kappa_1), ``c_beam = c - f b`` (beam
    extinction with the forward cone), ``scale = b E0 / (4 pi)``, the RGB
    weights, ``E0 / pi``, the sigmoid band centre ``t`` and ``l_top`` the
    sky radiance below the surface (``sky_radiance_per_e0 E0``), ``fb`` the
    forward cone's share of ``b``.
    """
    a, b, e0, t = (np.asarray(x, dtype=np.float64) for x in (a, b, e0, sigmoid_centers_t))
    w = np.asarray(response_weights, dtype=np.float64)
    n = a.size
    f = np.asarray(tables.get("forward_fraction", np.zeros(n)), dtype=np.float64)
    c = a + b
    zero = np.zeros(n)
    return np.stack([c, np.asarray(tables["k_inf"], np.float64), c - f * b,
                     b * e0 / (4.0 * np.pi), w[:, 0], w[:, 1], w[:, 2], e0 / np.pi, t,
                     np.asarray(tables["sky_radiance_per_e0"], np.float64) * e0, f * b, zero],
                    axis=1)


def _open_water_rgb(tables, a, b, e0, w, depth_o, y):
    """Camera RGB of ``R(d_o, v)`` and of ``u(d_o) L_top`` (v > 0) at direction coordinates ``y``.

    Also the scale of their f32 error: the same sums with ``|w|``.
    """
    n_mu = tables["ms_log_prefactor"].shape[2]
    v = np.cos(np.pi * (1.0 - y / (n_mu - 1.0)))
    c = a + b
    d_max = float(tables["max_depth_m"][0])
    f = np.exp(bilinear(tables["ms_log_prefactor"], np.full(v.shape, depth_o), v, d_max))
    k1 = np.asarray(tables["k_inf"], dtype=np.float64)
    sky = np.asarray(tables["sky_radiance_per_e0"], dtype=np.float64) * e0
    vv = v[:, None]
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        r = f * e0 * _seeds_shape(b, c, k1, depth_o, vv, np.inf)
        u = np.where(vv > 0, np.exp(-c * depth_o / np.where(vv > 0, vv, 1.0)), 0.0) * sky
    return r @ w, u @ w, (np.abs(r) + np.abs(u)) @ np.abs(w)


def open_water_table(tables, a, b, e0, response_weights, depth_o):
    """The open-water field at the camera in camera RGB, for the shader (float64).

    Open water seen from depth ``depth_o`` depends on the pixel only through
    the ray's ``v_y`` (:mod:`aquaspec.lightfield`, ``lightfield_pixel_radiance``):
    per band ``R(d_o, v) = F(d_o, v) b E0 / (4 pi)
    ms_path_integral(c, kappa_1, d_o, v, inf)`` plus, inside Snell's window,
    ``exp(-c d_o / v) L_top``. Sampled along the tables' own direction axis,
    ``y = (1 - acos(v) / pi) (n_mu - 1)`` at ``m / sub`` (so the kinks of the
    bilinear ``F`` fall on samples) for the smallest ``sub`` of
    :data:`OPEN_TABLE_SUBS` whose linear interpolation error, measured at the
    midpoints of the first and scaled by ``sub^-2``, is below
    :data:`OPEN_TABLE_TOLERANCE` relative to the sum of the bands' absolute
    contributions (the scale of f32 rounding; camera RGB itself can cross 0).
    Returns ``(table, sub, error)``: table ``((n_mu - 1) sub + 1, 2, 4)`` with
    per sample ``[0, :3]`` the scattering term and ``[1, :3]`` the window
    term (the shader adds it where ``v > window_cos``); ``error`` the
    estimated largest relative interpolation error.
    """
    a, b, e0 = (np.asarray(x, dtype=np.float64) for x in (a, b, e0))
    w = np.asarray(response_weights, dtype=np.float64)
    n_mu = tables["ms_log_prefactor"].shape[2]
    sub0 = OPEN_TABLE_SUBS[0]
    y0 = np.arange((n_mu - 1) * sub0 + 1) / sub0
    scatter, window, _ = _open_water_rgb(tables, a, b, e0, w, depth_o, y0)
    mid_s, mid_w, mid_scale = _open_water_rgb(tables, a, b, e0, w, depth_o, y0[:-1] + 0.5 / sub0)
    with np.errstate(divide="ignore", invalid="ignore"):
        err0 = max(float(np.nanmax(np.abs(0.5 * (x[:-1] + x[1:]) - m) / mid_scale))
                   for x, m in ((scatter, mid_s), (scatter + window, mid_s + mid_w)))
    for sub in OPEN_TABLE_SUBS:
        err = err0 * (sub0 / sub) ** 2
        if err <= OPEN_TABLE_TOLERANCE:
            break
    if sub != sub0:
        y = np.arange((n_mu - 1) * sub + 1) / sub
        scatter, window, _ = _open_water_rgb(tables, a, b, e0, w, depth_o, y)
    out = np.zeros((scatter.shape[0], 2, 4))
    out[:, 0, :3] = scatter
    out[:, 1, :3] = window
    return out, sub, err


class LightfieldPass:
    """Light-field shading of the G-buffer held by ``deferred`` (a DeferredPass).

    Per frame, after the G-buffer and camera are set on ``deferred``:
    :meth:`run` then :meth:`read_rgb`, or (with :meth:`set_display`)
    ``run(display=True)`` then :meth:`read_display`. :meth:`set_medium` when
    the water, light, sensor or tables change.
    """

    def __init__(self, deferred, *, filtering: bool | None = None):
        from .display_pass import DISPLAY_LAYOUT
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
            B_MATERIALS: "read", B_RGB: "write", B_STATUS: "write", B_DISPLAY: "uniform",
            B_RGBA: "write", B_OPEN_TABLE: "float", B_LOG_PREFACTOR: table_kind,
            B_IRRADIANCE: table_kind,
            B_SAMPLER: "sampler" if self.filtering else "nonfiltering_sampler",
            B_CONE: "storage_rgba32float"})
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
        self._open_table = None
        self._open_key = None
        self._group = None
        self._group_key = None
        #: Samples per direction cell and estimated relative interpolation
        #: error of the current open-water table (:func:`open_water_table`).
        self.open_table_sub = None
        self.open_table_error = None

    def set_medium(self, *, a, b, e0, response_weights, material_bands, sigmoid_centers_t,
                   tables, **_ignored):
        """Upload per-band data and the tables (``kd`` and ``ambient`` are not used)."""
        if np.isfinite(float(tables["seabed_depth_m"][0])):
            raise AquaspecError("the GPU light-field pass supports deep water only (tables "
                                "without a seabed); use backend='numpy' for a seabed")
        a, b, e0 = (np.asarray(x, dtype=float) for x in (a, b, e0))
        n = a.size
        lp = np.asarray(tables["ms_log_prefactor"], dtype=np.float32)
        irr = np.asarray(tables["irradiance_per_e0"], dtype=np.float32)
        if lp.shape[0] != n:
            raise AquaspecError(f"tables have {lp.shape[0]} bands; the medium has {n}")
        band = band_table(a, b, e0, response_weights, sigmoid_centers_t, tables)
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
        usage = wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST
        max_2d = dev.limits.get("max-texture-dimension-2d", 8192)
        if max(lp.shape[1:]) > max_2d:
            raise AquaspecError(f"light-field tables of {lp.shape[1]}x{lp.shape[2]} samples "
                                f"exceed this device's {max_2d} texels per side; accepted: "
                                "smaller n_depth or n_mu")

        def array_texture(table, label):
            data = band_group_texture(table)          # (layers, n_depth, n_mu, 4)
            layers, nd, nm = data.shape[:3]
            tex = dev.create_texture(label=label, size=(nm, nd, layers), format="rgba32float",
                                     usage=usage, dimension="2d", mip_level_count=1,
                                     sample_count=1)
            dev.queue.write_texture({"texture": tex, "mip_level": 0, "origin": (0, 0, 0)},
                                    data, {"offset": 0, "bytes_per_row": nm * 16,
                                           "rows_per_image": nd}, (nm, nd, layers))
            return tex.create_view(dimension="2d-array")

        materials = create_storage_buffer(dev, max(mb.nbytes, 4), label="lightfield materials")
        if mb.size:
            upload_buffer(dev, materials, mb.reshape(-1))
        self._buffers = {
            B_BANDS: bands,
            B_MATERIALS: materials,
            B_LOG_PREFACTOR: array_texture(lp, "lightfield ln F"),
            B_IRRADIANCE: array_texture(irr, "lightfield irradiance"),
            B_SAMPLER: self._sampler,
        }
        f = np.asarray(tables.get("forward_fraction", np.zeros(n)), dtype=float)
        self._shape = dict(n_bands=n, n_materials=int(np.asarray(material_bands).shape[0]),
                           n_depth=lp.shape[1], n_mu=lp.shape[2],
                           max_depth=float(tables["max_depth_m"][0]),
                           window_cos=float(tables["window_cos"][0]),
                           cone=bool(np.any(f * b > 0)))
        self._medium = (tables, a, b, e0, np.asarray(response_weights, dtype=float))
        #: Whether the forward cone is spread over the image (tables with
        #: lightfield_tables(cone_spread=True)): :class:`ConeSpreadPass` after this one.
        self.spread = "cone_offset_cdf" in tables
        self._spread_pass = None
        self._spread_key = None
        self._open_key = None
        self._group = None

    # ------------------------------------------------------------- dispatch
    def _pipeline(self, per_pixel, tonemap):
        from .display_pass import DISPLAY_LAYOUT, TONEMAP_IDS
        sh = self._shape
        key = (sh["n_bands"], sh["n_depth"], sh["n_mu"], sh["cone"], per_pixel, tonemap,
               self.filtering, self.spread)
        if key not in self._pipelines:
            src = load_wgsl("lightfield.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                            params_struct_name=PARAMS_LAYOUT.name,
                            display_struct=DISPLAY_LAYOUT.wgsl(),
                            display_struct_name=DISPLAY_LAYOUT.name,
                            display="false" if tonemap is None else "true",
                            tonemap_id=TONEMAP_IDS[tonemap or "none"],
                            n_bands=sh["n_bands"], n_depth=sh["n_depth"], n_mu=sh["n_mu"],
                            cone="true" if sh["cone"] else "false",
                            per_pixel="true" if per_pixel else "false",
                            filter="true" if self.filtering else "false",
                            spread="true" if self.spread else "false",
                            band_steps=band_steps(),
                            band_table_len=len(BAND_FIELDS) // 4 * sh["n_bands"],
                            open_row=OPEN_ROW,
                            workgroup_x=WORKGROUP[0], workgroup_y=WORKGROUP[1])
            module = self.device.create_shader_module(label="lightfield.wgsl", code=src)
            self._pipelines[key] = self.device.create_compute_pipeline(
                label="lightfield",
                layout=self.device.create_pipeline_layout(bind_group_layouts=[self._layout]),
                compute={"module": module, "entry_point": "main"})
        return self._pipelines[key]

    def _update_open_table(self, depth_o):
        """Rebuild the open-water table when the camera depth or the medium changed."""
        if self._open_key == depth_o:
            return
        tables, a, b, e0, w = self._medium
        table, sub, err = open_water_table(tables, a, b, e0, w, depth_o)
        if not np.all(np.isfinite(table)):
            raise AquaspecError("the light-field open-water table came out non-finite; "
                                "check the water coefficients and tables")
        rows = -(-table.shape[0] // OPEN_ROW)
        data = np.zeros((rows * OPEN_ROW, 2, 4), np.float32)
        data[:table.shape[0]] = table
        data = data.reshape(rows, 2 * OPEN_ROW, 4)
        if self._open_table is None or self._open_table.size[1] != rows:
            import wgpu
            self._open_table = create_texture(
                self.device, 2 * OPEN_ROW, rows, "rgba32float", label="lightfield open water",
                usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST)
            self._group = None
        upload_texture(self.device, self._open_table, data)
        self.open_table_sub, self.open_table_error = sub, err
        self._open_last = table.shape[0] - 1
        self._open_key = depth_o

    def _bind_group(self):
        # The deferred pass counts replacements of its textures.
        cone = self._spread_pass.cone_texture if self._spread_pass else self._no_cone()
        key = (self.deferred.bindings_version, id(cone))
        if self._group is None or self._group_key != key:
            tex = self.deferred.gbuffer_textures
            resources = {B_PARAMS: self._uniform, B_SURFACE: tex["surface"],
                         B_SIGMOID: tex["sigmoid"], **self._buffers, B_RGB: self.rgb_buffer,
                         B_STATUS: self._status, B_DISPLAY: self._display_uniform,
                         B_RGBA: self.display_buffer, B_OPEN_TABLE: self._open_table,
                         B_CONE: cone}
            self._group = self.device.create_bind_group(layout=self._layout,
                                                        entries=bind_group_entries(resources))
            self._group_key = key
        return self._group

    def _no_cone(self):
        """A 1x1 texture for the cone binding when the cone is not spread."""
        if getattr(self, "_cone_dummy", None) is None:
            import wgpu
            self._cone_dummy = create_texture(
                self.device, 1, 1, "rgba32float", label="lightfield no cone",
                usage=wgpu.TextureUsage.STORAGE_BINDING | wgpu.TextureUsage.TEXTURE_BINDING)
        return self._cone_dummy

    def _update_spread(self, cam):
        """The pyramid pass and its weights for this camera (fy) and image size."""
        from ..conespread import pyramid_weights
        from .conespread_pass import ConeSpreadPass
        key = (id(self._medium[0]), float(cam.fy))
        if self._spread_key != key:
            self._spread_weights = pyramid_weights(self._medium[0], float(cam.fy),
                                                   self.height, self.width)
            self._spread_key = key
        w = self._spread_weights
        levels = w.size - 1
        if self._spread_pass is None or self._spread_pass.levels != levels:
            self._spread_pass = ConeSpreadPass(
                self.device, self.width, self.height, levels, filtering=self.filtering,
                rgb_buffer=self.rgb_buffer, status_buffer=self._status,
                display_uniform=self._display_uniform, display_buffer=self.display_buffer)
            self._group = None
        self._spread_pass.set_weights(w)

    def workgroups(self) -> tuple[int, int, int]:
        """Dispatch size covering the image."""
        per_x = WORKGROUP[0] * PIXELS_PER_INVOCATION
        return (-(-self.width // per_x), -(-self.height // WORKGROUP[1]), 1)

    def set_display(self, *, exposure_ev, white_balance_gains=(1.0, 1.0, 1.0), matrix=None,
                    tonemap="filmic") -> None:
        """Settings of the fused display transform (``encode(display=True)``).

        The same settings and checks as
        :meth:`aquaspec.gpu.deferred.DeferredPass.set_display`.
        """
        from .display_pass import DISPLAY_LAYOUT, TONEMAP_IDS, folded_matrix
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
        self._update_open_table(depth_o)
        upload_buffer(self.device, self._uniform, PARAMS_LAYOUT.pack(
            **camera_fields(cam), width=self.width, height=self.height,
            n_materials=self._shape["n_materials"], table_sub=self.open_table_sub,
            table_last=self._open_last, depth_o=depth_o, max_depth=self._shape["max_depth"],
            window_cos=self._shape["window_cos"]))
        if display:
            # status[3] is an atomicMin, so it starts at the maximum (a queue
            # write runs before the next submission).
            self.device.queue.write_buffer(self._status, 0,
                                           np.array([0, 0, 0, 0xFFFFFFFF], np.uint32))
        else:
            encoder.clear_buffer(self._status, 0, self._status.size)
        self._last_display = bool(display)
        if self.spread:
            # Linear RGB and the cone term first; the pyramid adds the spread
            # cone and applies the display transform.
            self._update_spread(cam)
            record_dispatch(encoder, self._pipeline(bool(d.per_pixel), None),
                            self._bind_group(), self.workgroups(), timestamp_writes)
            self._spread_pass.encode(encoder, tonemap=tonemap)
            return
        record_dispatch(encoder, self._pipeline(bool(d.per_pixel), tonemap), self._bind_group(),
                        self.workgroups(), timestamp_writes)

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
