"""The deferred spectral shading pass: G-buffer -> linear camera RGB on the GPU.

One compute invocation per four pixels of a row evaluates the analytic model
of :mod:`aquaspec.transport.monzon2022` band by band (WGSL: ``deferred.wgsl``
beside this module, with the model functions in ``gpu/wgsl/common.wgsl``) and
sums the bands into camera RGB. Its NumPy reference is :func:`aquaspec.shading.shade.shade_gbuffer`; the test
``tests/gpu/passes/test_deferred_pass.py`` holds the two together.

Conventions: metres, y up, water surface y = 0, depth ``-p.y``; a, b, Kd in
1/m; E0 in W m^-2 nm^-1; output radiance-weighted camera RGB, linear, f32.

Inputs: the G-buffer (:class:`aquaspec.gpu.gbuffer.GBufferTextures`, bindings 1
and 2, layout in :mod:`aquaspec.gpu.gbuffer`), shared with the geometry pass
that renders into it and with the light-field pass; binding 0 the camera and
frame uniform (:data:`PARAMS_LAYOUT`).

Per-band inputs (:meth:`DeferredPass.set_medium`): binding 4 is a uniform
``array<vec4<f32>, 3 n>``, :func:`band_table` (the per-band factors that do
not depend on the pixel, precomputed in float64 for the camera's depth; 12
f32 per band, :data:`BAND_FIELDS`), bindings 3 and 5 the material band
reflectances, four bands to a vec4 (:mod:`aquaspec.gpu.materials`). Outputs: binding 6
``array<vec4<f32>>`` RGB (w = 1), binding 7 ``array<f32>`` band radiance
``p * n_bands + band`` (debug mode only), binding 8 a status counter of
pixels with a material index out of range, 9 and 10 the fused display
transform (:mod:`aquaspec.gpu.shading_output`), 11 the open-water table
(:func:`open_water_table`).
"""

from __future__ import annotations

import numpy as np

from aquaspec.transport import monzon2022 as model
from aquaspec.colour.bands import MAX_BANDS
from aquaspec.scene.camera import check_size
from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import N_WATER, snell_window_cos
from aquaspec.shading.shade import camera_depth, check_medium
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_storage_buffer, create_uniform_buffer, read_buffer, upload_buffer
from aquaspec.gpu.camera import CAMERA_FIELDS, camera_fields
from aquaspec.gpu.device import get_device
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.display_transform import display_template
from aquaspec.gpu.gbuffer import B_SIGMOID, B_SURFACE, GBufferTextures
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.materials import MaterialTable
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.gpu.shading_output import ShadingOutput
from aquaspec.gpu.shading_pass import WORKGROUP, ShadingPass

#: Ambient models of :data:`aquaspec.transport.monzon2022.AMBIENT_MODELS` by WGSL id
#: (``ambient_factor`` in ``gpu/wgsl/common.wgsl``).
AMBIENT_MODEL_IDS = {"uniform": 0, "cosine": 1}

#: Per-band fields of the band table (binding 4), in order: three vec4 per band.
BAND_FIELDS = ("c", "kd", "t", "ms_scale", "w_r", "w_g", "w_b", "e0_over_pi",
               "be0", "base", "e0_window", "unused")

#: Camera and frame uniforms of deferred.wgsl (binding 0), also read by copy.wgsl.
PARAMS_LAYOUT = UniformLayout("DeferredCamera", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("n_bands", "u32"), ("ambient_model", "u32"),
    ("n_materials", "u32"), ("write_radiance", "u32"),
    ("snell_cos", "f32"), ("window_factor", "f32"),
    ("per_pixel", "u32"), ("open_table", "u32"),
])

# Binding numbers (also in deferred.wgsl). (1 and 2: the G-buffer,
# aquaspec.gpu.gbuffer; 3 and 5: the material table, aquaspec.gpu.materials;
# 6, 8, 9, 10: the outputs, aquaspec.gpu.shading_output.)
B_CAMERA, B_BANDS, B_RADIANCE, B_OPEN_TABLE = 0, 4, 7, 11

#: Entries of the open-water table (:func:`open_water_table`) over v_y in [-1, 1].
OPEN_TABLE_SIZE = 4096


def shader_source(n_bands: int, write_radiance: bool, per_pixel: bool, tonemap: str | None,
                  materials: dict) -> str:
    """WGSL of ``deferred.wgsl`` with its uniform struct and constants filled in.

    The band count, the debug-radiance switch and whether per-pixel
    (sigmoid) materials occur are compile-time constants (a constant trip
    count and uniform-array band table made the band loop about 4x faster on
    lavapipe; SIMD lanes would evaluate the sigmoid for every pixel
    otherwise). ``tonemap`` (a key of
    :data:`aquaspec.gpu.display_transform.TONEMAP_IDS`) compiles the fused
    display transform in; None writes linear RGB. ``materials``: the material
    table's template values (:meth:`aquaspec.gpu.materials.MaterialTable.template`).
    """
    return load_wgsl("deferred.wgsl", camera_struct=PARAMS_LAYOUT.wgsl(),
                     camera_struct_name=PARAMS_LAYOUT.name, **display_template(tonemap),
                     n_bands=int(n_bands), band_table_len=len(BAND_FIELDS) // 4 * int(n_bands),
                     write_radiance="true" if write_radiance else "false",
                     per_pixel="true" if per_pixel else "false",
                     open_table_size=OPEN_TABLE_SIZE, **materials,
                     workgroup_x=WORKGROUP[0], workgroup_y=WORKGROUP[1])


def open_water_table(a, b, kd, e0, response_weights, depth_o, size: int = OPEN_TABLE_SIZE):
    """Camera RGB of open water against the ray's up component, for the deferred pass.

    A ray that hits nothing sees, per band, the seeds' multiple scattering
    to infinity (down) or to the water surface (up), plus, inside Snell's
    window, the sky through the water: both depend on the pixel only
    through ``v_y`` (the camera depth is fixed). Sampled at ``size`` values
    of ``v_y`` evenly over [-1, 1] with :mod:`aquaspec.transport.monzon2022` in float64 and
    summed over bands into camera RGB. Returns (size, 2, 4) float64: per
    sample ``[0, :3]`` the scattering term, ``[1, :3]`` the window term
    (``T(S) E0 n^2 / pi``, to be added inside the window only; it is smooth
    across the window's rim, where the shader decides exactly per pixel).
    """
    a, b, kd, e0 = (np.asarray(x, dtype=np.float64) for x in (a, b, kd, e0))
    w = np.asarray(response_weights, dtype=np.float64)
    v = np.linspace(-1.0, 1.0, int(size))[:, None]
    c = a + b
    s = model.ray_length(np.inf, depth_o, v)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        scatter = model.l_ms_seeds(b, c, kd, e0, depth_o, v, s)
        window = np.where(v > 0, model.transmittance(c, s) * e0 * N_WATER ** 2 / np.pi,
                          0.0)
    out = np.zeros((int(size), 2, 4))
    out[:, 0, :3] = scatter @ w
    out[:, 1, :3] = window @ w
    return out


def band_table(a, b, kd, e0, response_weights, sigmoid_centers_t, depth_o) -> np.ndarray:
    """The deferred pass's band table (binding 4): (n, 12) float64, :data:`BAND_FIELDS`.

    The per-band factors of the model that do not depend on the pixel, for a
    camera at depth ``depth_o`` (m): ``c = a + b``; ``ms_scale = b E0 / (4 pi)
    exp(-Kd d_o)`` and ``be0 = b E0 / (4 pi)``, ``base = -Kd d_o`` (the
    seeds' multiple scattering, :func:`aquaspec.transport.monzon2022.l_ms_seeds`);
    ``e0_over_pi = E0 / pi`` (:func:`aquaspec.transport.monzon2022.lambertian_radiance` of
    :func:`aquaspec.transport.monzon2022.ambient_irradiance`); ``e0_window = E0 n^2 / pi``
    (:func:`aquaspec.medium.interface.surface_from_below`).
    """
    a, b, kd, e0, t = (np.asarray(x, dtype=np.float64) for x in (a, b, kd, e0, sigmoid_centers_t))
    w = np.asarray(response_weights, dtype=np.float64)
    be0 = b * e0 / (4.0 * np.pi)
    base = -kd * float(depth_o)
    return np.stack([a + b, kd, t, be0 * np.exp(base),
                     w[:, 0], w[:, 1], w[:, 2], e0 / np.pi,
                     be0, base, e0 * N_WATER ** 2 / np.pi, np.zeros_like(a)], axis=1)


class DeferredPass(ShadingPass):
    """Deferred spectral shading of a ``width`` x ``height`` G-buffer with ``n_bands`` bands.

    Create it once per image size and band count; then per frame fill
    :attr:`gbuffer` (:meth:`~aquaspec.gpu.gbuffer.GBufferTextures.upload`, or
    a raster pass rendering into it), :meth:`set_medium` when the water,
    light or sensor change, :meth:`run`, :meth:`read_rgb`.

    Parameters
    ----------
    width, height : int
        Image size in pixels.
    n_bands : int
        Number of wavelength bands (1 to 1024).
    device : wgpu.GPUDevice, optional
        Default: :func:`aquaspec.gpu.device.get_device` (or the G-buffer's).
    debug_radiance : bool
        Also write the band radiance per pixel (``read_radiance``); needs
        ``width * height * n_bands * 4`` bytes within the device's storage
        binding limit.
    gbuffer : GBufferTextures, optional
        The G-buffer to shade (of this size); default: a new one.
    """

    label = "deferred shading"

    def __init__(self, width: int, height: int, n_bands: int, *, device=None,
                 debug_radiance: bool = False, gbuffer: GBufferTextures | None = None):
        self.width, self.height = check_size(width, height)
        if isinstance(n_bands, bool) or not isinstance(n_bands, (int, np.integer)) \
                or not 1 <= n_bands <= MAX_BANDS:
            raise AquaspecError(f"n_bands={n_bands!r}; accepted: an integer from 1 to {MAX_BANDS}")
        self.n_bands = int(n_bands)
        if device is None:
            device = gbuffer.device if gbuffer is not None else get_device()[1]
        self.device = device
        if gbuffer is None:
            gbuffer = GBufferTextures(device, self.width, self.height)
        if (gbuffer.width, gbuffer.height) != (self.width, self.height):
            raise AquaspecError(f"G-buffer is {gbuffer.width}x{gbuffer.height} but this pass "
                                f"was created for {self.width}x{self.height}")
        #: The G-buffer read (:class:`aquaspec.gpu.gbuffer.GBufferTextures`).
        self.gbuffer = gbuffer
        self.debug_radiance = bool(debug_radiance)
        npix = self.width * self.height
        if self.debug_radiance:
            need = npix * self.n_bands * 4
            limit = device.limits.get("max-storage-buffer-binding-size", 2 ** 27)
            if need > limit:
                raise AquaspecError(
                    f"debug radiance for {self.width}x{self.height} x {self.n_bands} bands "
                    f"needs {need} bytes; this device binds at most {limit}; use a "
                    "smaller image or fewer bands")

        #: The camera and frame uniform (:data:`PARAMS_LAYOUT`; the copy pass binds it too).
        self.params_buffer = create_uniform_buffer(device, PARAMS_LAYOUT, label="deferred camera")
        self._open_table = create_storage_buffer(device, OPEN_TABLE_SIZE * 32,
                                                 label="deferred open-water table")
        self._open_table_ok = False
        self._bands = create_uniform_buffer(device, self.n_bands * len(BAND_FIELDS) * 4,
                                            label="deferred band table")
        limit = device.limits.get("max-uniform-buffer-binding-size", 65536)
        if self._bands.size > limit:
            raise AquaspecError(f"{self.n_bands} bands need a {self._bands.size}-byte band "
                                f"table; this device binds at most {limit}")
        #: The material band reflectances (:class:`~aquaspec.gpu.materials.MaterialTable`).
        self.materials = MaterialTable(device, "deferred material bands")
        #: Linear RGB, display RGBA8 and the status (:class:`~aquaspec.gpu.shading_output.ShadingOutput`).
        self.output = ShadingOutput(device, self.width, self.height, "deferred")
        self._radiance = create_storage_buffer(
            device, npix * self.n_bands * 4 if self.debug_radiance else 4,
            label="deferred radiance")
        self._layout = bind_group_layout(device, {
            B_CAMERA: "uniform", B_SURFACE: "uint", B_SIGMOID: "float",
            B_BANDS: "uniform", B_RADIANCE: "write", B_OPEN_TABLE: "read",
            **ShadingOutput.layout(), **MaterialTable.layout()})
        # Pipelines by (per_pixel, tone map, materials in uniform): compile-time
        # constants of the shader; each made when first used.
        self._pipelines = {}
        #: Shade four-pixel groups that all see open water from the
        #: open-water table (:func:`open_water_table`) instead of the band
        #: loop; False forces the band loop everywhere (for comparisons).
        self.use_open_table = True
        self._uploaded = None
        self._bind_group = None
        self._bind_key = None
        self._n_materials = None
        self._ambient_id = None
        self._medium_bands = None
        self._medium_version = 0

    @property
    def n_materials(self) -> int | None:
        """Rows of the material table of the last :meth:`set_medium` (None before)."""
        return self._n_materials

    # ---------------------------------------------------------------- inputs
    def set_medium(self, a, b, kd, e0, response_weights, material_bands, sigmoid_centers_t,
                   ambient: str = model.DEFAULT_AMBIENT) -> None:
        """Upload the per-band water, light, sensor and material data.

        Same arguments and checks as :func:`aquaspec.shading.shade.shade_gbuffer`:
        ``a, b, kd`` (n,) in 1/m, ``e0`` (n,) in W m^-2 nm^-1,
        ``response_weights`` (n, 3), ``material_bands`` (M, n) or None,
        ``sigmoid_centers_t`` (n,), ``ambient`` a key of
        :data:`AMBIENT_MODEL_IDS`.
        """
        n = self.n_bands
        a, b, kd, e0, w, mb, t = check_medium(a, b, kd, e0, response_weights, material_bands,
                                              sigmoid_centers_t, ambient)
        if a.size != n:
            raise AquaspecError(f"medium has {a.size} bands; this pass was created for {n}")
        if ambient not in AMBIENT_MODEL_IDS:
            raise AquaspecError(f"ambient model {ambient!r} has no GPU implementation; "
                                f"accepted: {', '.join(AMBIENT_MODEL_IDS)}")
        # The band table also depends on the camera depth: built in upload_uniforms.
        self._medium_bands = (a, b, kd, e0, w, t)
        self.materials.upload(mb, n)
        self._n_materials = mb.shape[0]
        self._ambient_id = AMBIENT_MODEL_IDS[ambient]
        self._medium_version += 1

    # ------------------------------------------------------------- dispatch
    def upload_uniforms(self) -> None:
        """Write the camera/frame uniforms if they changed (needs the G-buffer's camera)."""
        cam = self.gbuffer.camera
        if cam is None:
            raise AquaspecError("no camera: upload a G-buffer or set its camera before running")
        key = (self.gbuffer.version, id(self.gbuffer), self._medium_version, self.use_open_table)
        if self._uploaded == key:
            return
        self._uploaded = key
        if self._medium_bands is not None:
            a, b, kd, e0, w, t = self._medium_bands
            table = band_table(a, b, kd, e0, w, t, depth_o=camera_depth(cam))
            upload_buffer(self.device, self._bands, table.astype(np.float32))
            open_table = open_water_table(a, b, kd, e0, w, camera_depth(cam)).astype(np.float32)
            # Non-finite entries (k <= 0 looking down: not a physical water)
            # would spread through the interpolation: the exact band loop
            # then shades every pixel and reports them.
            self._open_table_ok = bool(np.all(np.isfinite(open_table)))
            if self._open_table_ok:
                upload_buffer(self.device, self._open_table, open_table)
        data = PARAMS_LAYOUT.pack(
            **camera_fields(cam), width=self.width, height=self.height,
            n_bands=self.n_bands, ambient_model=self._ambient_id or 0,
            n_materials=self._n_materials or 0, write_radiance=int(self.debug_radiance),
            snell_cos=snell_window_cos(N_WATER),
            window_factor=N_WATER ** 2 / np.pi, per_pixel=int(self.gbuffer.per_pixel),
            open_table=int(self._open_table_ok and self.use_open_table))
        upload_buffer(self.device, self.params_buffer, data)

    def bind_group(self):
        """The pass's bind group (rebuilt when the G-buffer's textures or the material
        table's storage buffer are replaced)."""
        key = (self.gbuffer.bindings_version, self.materials.version)
        if self._bind_group is None or self._bind_key != key:
            tex = self.gbuffer.textures
            resources = {B_CAMERA: self.params_buffer, B_SURFACE: tex["surface"],
                         B_SIGMOID: tex["sigmoid"], B_BANDS: self._bands,
                         **self.materials.resources(), B_RADIANCE: self._radiance,
                         **self.output.resources(), B_OPEN_TABLE: self._open_table}
            self._bind_group = self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries(resources))
            self._bind_key = key
        return self._bind_group

    def pipeline(self, tonemap=None):
        """The compute pipeline for the G-buffer's ``per_pixel``, ``tonemap`` (None:
        linear RGB) and where the material table is (made when first used)."""
        key = (self.gbuffer.per_pixel, tonemap, self.materials.in_uniform)
        if key not in self._pipelines:
            code = shader_source(self.n_bands, self.debug_radiance, self.gbuffer.per_pixel,
                                 tonemap, self.materials.template())
            self._pipelines[key] = compute_pipeline(self.device, self._layout, code,
                                                    "deferred.wgsl")
        return self._pipelines[key]

    def encode(self, encoder, timestamp_writes=None, *, display: bool = False) -> None:
        """Record the shading into ``encoder`` (uniforms are uploaded first).

        ``display=True`` also applies the display transform of
        :meth:`set_display` in the same pass and writes the display image
        (read with :meth:`read_display`) instead of linear RGB.
        """
        if self._n_materials is None:
            raise AquaspecError("no medium: call set_medium() before running")
        self.upload_uniforms()
        tonemap = self.output.begin_frame(encoder, display)
        record_dispatch(encoder, self.pipeline(tonemap), self.bind_group(),
                        self.workgroups(), timestamp_writes)

    # ------------------------------------------------------------- outputs
    def read_radiance(self) -> np.ndarray:
        """Band radiance of the last run, (H, W, n) float32 (debug mode only)."""
        if not self.debug_radiance:
            raise AquaspecError("read_radiance() needs DeferredPass(..., debug_radiance=True)")
        self.output.check_materials(self._n_materials)
        rad = read_buffer(self.device, self._radiance, np.float32,
                          (self.height, self.width, self.n_bands))
        if not np.all(np.isfinite(rad)):
            raise AquaspecError("deferred shading produced a non-finite band radiance")
        return rad
