"""The deferred spectral shading pass: G-buffer -> linear camera RGB on the GPU.

One compute invocation per pixel evaluates the analytic model of
:mod:`aquaspec.transport.monzon2022` band by band (WGSL: ``shaders/deferred.wgsl`` with the
model functions in ``shaders/common.wgsl``) and sums the bands into camera
RGB. Its NumPy reference is :func:`aquaspec.shading.shade.shade_gbuffer`; the test
``tests/test_gpu_deferred.py`` holds the two together.

Conventions: metres, y up, water surface y = 0, depth ``-p.y``; a, b, Kd in
1/m; E0 in W m^-2 nm^-1; output radiance-weighted camera RGB, linear, f32.

G-buffer layout (GPU-resident)
------------------------------
The G-buffer lives in textures, texel ``(column, row)`` per pixel (row 0 at
the top, as in :meth:`aquaspec.scene.camera.Camera.ray_directions`), the render
targets of the geometry pass (:class:`aquaspec.gpu.passes.raster.RasterPass`
renders straight into :attr:`DeferredPass.gbuffer_textures`; usage
``RENDER_ATTACHMENT | TEXTURE_BINDING | COPY_DST | COPY_SRC``), or textures
made elsewhere in the same formats (:meth:`DeferredPass.use_gbuffer_textures`):

===========  =====================  ==============================================
binding      format                 contents
===========  =====================  ==============================================
1 surface    ``rgba32uint``         ``x``: distance S in m from the camera centre
                                    along the pixel's ray as f32 bits,
                                    :data:`OPEN_WATER_DISTANCE` (any negative
                                    value) where it sees open water; ``y``: the
                                    unit world normal's up component n_y as f32
                                    bits (all the shading needs); ``z``: the whole
                                    normal, octahedral (:func:`oct_decode`), two
                                    16-bit snorm; ``w``: material index, or
                                    ``0xffffffff`` (gbuffer.PER_PIXEL) for the
                                    pixel's own sigmoid coefficients
2 sigmoid    ``rgba32float``        ``xyz``: Jakob-Hanika coefficients (c0, c1, c2)
                                    in t = (lambda - 550) / 100 (0 for
                                    single-material pixels); read only when
                                    :attr:`DeferredPass.per_pixel` is true
===========  =====================  ==============================================

One 16-byte target for scenes without per-pixel materials (the built-in
scene, and any scene of plain-coloured meshes) made the geometry pass about
40 % faster on lavapipe than the 32 bytes of two targets. Reading the render
targets directly saved the compute pass that used to repack them into
storage buffers (6-7 ms of a 1280x720 frame on lavapipe). Storing the
material as an integer (rather than a float bit pattern) keeps
``0xffffffff`` from ever passing through a float register, where a NaN
payload is not guaranteed to survive.

Per-band inputs (:meth:`DeferredPass.set_medium`): binding 4 is a uniform
``array<vec4<f32>, 3 n>``, :func:`band_table` (the per-band factors that do
not depend on the pixel, precomputed in float64 for the camera's depth; 12
f32 per band, :data:`BAND_FIELDS`), bindings 3 and 5 the material band
reflectances, four bands to a vec4 (:mod:`aquaspec.gpu.materials`). Outputs: binding 6
``array<vec4<f32>>`` RGB (w = 1), binding 7 ``array<f32>`` band radiance
``p * n_bands + band`` (debug mode only), binding 8 a status counter of
pixels with a material index out of range.
"""

from __future__ import annotations

import numpy as np

from aquaspec.transport import monzon2022 as model
from aquaspec.colour.bands import MAX_BANDS
from aquaspec.scene.camera import check_size
from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer
from aquaspec.shading.shade import camera_depth, check_medium
from aquaspec.gpu.buffers import (create_storage_buffer, create_texture, create_uniform_buffer,
                      read_buffer, record_dispatch, upload_buffer, upload_texture)
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.materials import MaterialTable
from aquaspec.gpu.shaders import load_wgsl

#: Value written to the distance buffer where a pixel's ray sees open water.
OPEN_WATER_DISTANCE = -1.0

#: Ambient models of :data:`aquaspec.transport.monzon2022.AMBIENT_MODELS` by WGSL id
#: (``ambient_factor`` in ``shaders/common.wgsl``).
AMBIENT_MODEL_IDS = {"uniform": 0, "cosine": 1}

#: Per-band fields of the band table (binding 4), in order: three vec4 per band.
BAND_FIELDS = ("c", "kd", "t", "ms_scale", "w_r", "w_g", "w_b", "e0_over_pi",
               "be0", "base", "e0_window", "unused")

#: The pinhole camera as uniform fields (world position and axes, intrinsics
#: in pixels), shared by every shading pass's uniform layout.
CAMERA_FIELDS = [
    ("position", "vec3<f32>"), ("fx", "f32"),
    ("right", "vec3<f32>"), ("fy", "f32"),
    ("up", "vec3<f32>"), ("cx", "f32"),
    ("forward", "vec3<f32>"), ("cy", "f32"),
]


def camera_fields(camera) -> dict:
    """Values of :data:`CAMERA_FIELDS` for ``camera``."""
    return dict(position=camera.position, fx=camera.fx, right=camera.right, fy=camera.fy,
                up=camera.true_up, cx=camera.cx, forward=camera.forward, cy=camera.cy)


#: Camera and frame uniforms shared by deferred.wgsl and copy.wgsl.
CAMERA_LAYOUT = UniformLayout("DeferredCamera", CAMERA_FIELDS + [
    ("width", "u32"), ("height", "u32"), ("n_bands", "u32"), ("ambient_model", "u32"),
    ("n_materials", "u32"), ("write_radiance", "u32"),
    ("snell_cos", "f32"), ("window_factor", "f32"),
    ("per_pixel", "u32"), ("open_table", "u32"),
])

#: Compute workgroup size (x, y) of deferred.wgsl, in invocations.
WORKGROUP = (8, 8)
#: Adjacent pixels of a row shaded by one invocation of deferred.wgsl.
PIXELS_PER_INVOCATION = 4

# Binding numbers (also in the WGSL files).
B_CAMERA, B_SURFACE, B_SIGMOID = 0, 1, 2
# (Bindings 3 and 5: the material table, aquaspec.gpu.materials.)
B_BANDS, B_RGB, B_RADIANCE, B_STATUS = 4, 6, 7, 8
B_DISPLAY, B_RGBA, B_OPEN_TABLE = 9, 10, 11

#: Entries of the open-water table (:func:`open_water_table`) over v_y in [-1, 1].
OPEN_TABLE_SIZE = 4096
#: G-buffer textures: name -> (binding, texture format).
GBUFFER_TEXTURES = {"surface": (B_SURFACE, "rgba32uint"),
                    "sigmoid": (B_SIGMOID, "rgba32float")}


def shader_source(name: str, n_bands: int = 1, write_radiance: bool = False,
                  per_pixel: bool = True, tonemap: str | None = None,
                  materials_in_uniform: bool = True) -> str:
    """WGSL of ``deferred.wgsl`` or ``copy.wgsl`` with the camera struct filled in.

    The band count, the debug-radiance switch and whether per-pixel
    (sigmoid) materials occur are compile-time constants of
    ``deferred.wgsl`` (a constant trip count and uniform-array band table
    made the band loop about 4x faster on lavapipe; SIMD lanes would
    evaluate the sigmoid for every pixel otherwise). ``tonemap`` (a key of
    :data:`aquaspec.gpu.passes.display.TONEMAP_IDS`) compiles the fused
    display transform in; None writes linear RGB. ``materials_in_uniform``:
    where the material table is (:class:`aquaspec.gpu.materials.MaterialTable`).
    """
    from aquaspec.gpu.passes.display import DISPLAY_LAYOUT, TONEMAP_IDS
    from aquaspec.gpu.materials import GROUPED_MIN_BANDS, UNIFORM_VEC4
    return load_wgsl(name, camera_struct=CAMERA_LAYOUT.wgsl(),
                     display_struct=DISPLAY_LAYOUT.wgsl(), display_struct_name=DISPLAY_LAYOUT.name,
                     display="false" if tonemap is None else "true",
                     tonemap_id=TONEMAP_IDS[tonemap or "none"],
                     camera_struct_name=CAMERA_LAYOUT.name, n_bands=int(n_bands),
                     band_table_len=len(BAND_FIELDS) // 4 * int(n_bands),
                     write_radiance="true" if write_radiance else "false",
                     per_pixel="true" if per_pixel else "false",
                     open_table_size=OPEN_TABLE_SIZE,
                     materials_in_uniform="true" if materials_in_uniform else "false",
                     material_uniform_vec4=UNIFORM_VEC4, grouped_min_bands=GROUPED_MIN_BANDS,
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
        window = np.where(v > 0, model.transmittance(c, s) * e0 * model.N_WATER ** 2 / np.pi,
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
    (:func:`aquaspec.transport.monzon2022.surface_from_below`).
    """
    a, b, kd, e0, t = (np.asarray(x, dtype=np.float64) for x in (a, b, kd, e0, sigmoid_centers_t))
    w = np.asarray(response_weights, dtype=np.float64)
    be0 = b * e0 / (4.0 * np.pi)
    base = -kd * float(depth_o)
    return np.stack([a + b, kd, t, be0 * np.exp(base),
                     w[:, 0], w[:, 1], w[:, 2], e0 / np.pi,
                     be0, base, e0 * model.N_WATER ** 2 / np.pi, np.zeros_like(a)], axis=1)


def oct_encode(normal) -> np.ndarray:
    """Octahedral map of unit vectors (..., 3) onto [-1, 1]^2 (..., 2), as gbuffer.wgsl.

    The (x, z) plane, the lower hemisphere (y < 0) folded over the
    diagonals; zero vectors map to (0, 0).
    """
    n = np.asarray(normal, dtype=np.float64)
    l1 = np.abs(n).sum(axis=-1, keepdims=True)
    p = n[..., [0, 2]] / np.where(l1 > 0, l1, 1.0)
    sign = np.where(p >= 0, 1.0, -1.0)
    folded = (1.0 - np.abs(p[..., ::-1])) * sign
    return np.where(n[..., 1:2] < 0, folded, p)


def oct_decode(p) -> np.ndarray:
    """Unit vectors (..., 3) from octahedral coordinates (..., 2): inverse of :func:`oct_encode`."""
    p = np.asarray(p, dtype=np.float64)
    y = 1.0 - np.abs(p).sum(axis=-1)
    sign = np.where(p >= 0, 1.0, -1.0)
    xz = np.where((y < 0)[..., None], (1.0 - np.abs(p[..., ::-1])) * sign, p)
    n = np.stack([xz[..., 0], y, xz[..., 1]], axis=-1)
    norm = np.linalg.norm(n, axis=-1, keepdims=True)
    return n / np.where(norm > 0, norm, 1.0)


def pack_snorm16x2(p) -> np.ndarray:
    """WGSL ``pack2x16snorm`` of (..., 2) values in [-1, 1]: u32 words."""
    q = np.rint(np.clip(np.asarray(p, np.float64), -1.0, 1.0) * 32767.0).astype(np.int32)
    return ((q[..., 0] & 0xFFFF) | ((q[..., 1] & 0xFFFF) << 16)).astype(np.uint32)


def unpack_snorm16x2(words) -> np.ndarray:
    """WGSL ``unpack2x16snorm``: u32 words -> (..., 2) float64 in [-1, 1]."""
    w = np.asarray(words, dtype=np.uint32)
    q = np.stack([w & 0xFFFF, w >> 16], axis=-1).astype(np.int32)
    q = np.where(q >= 0x8000, q - 0x10000, q)
    return np.maximum(q / 32767.0, -1.0)


def unpack_surface(surface) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distance (f32, negative for open water), unit normal (f64) and material of surface texels.

    The normal keeps the exact n_y of word y; its horizontal part comes from
    the octahedral word z, rescaled so that the normal has unit length.
    """
    surface = np.asarray(surface, dtype=np.uint32)
    distance = surface[..., 0].view(np.float32)
    n_y = np.clip(surface[..., 1].view(np.float32).astype(np.float64), -1.0, 1.0)
    normal = oct_decode(unpack_snorm16x2(surface[..., 2]))
    h = np.hypot(normal[..., 0], normal[..., 2])
    scale = np.sqrt(np.maximum(1.0 - n_y ** 2, 0.0)) / np.where(h > 0, h, 1.0)
    normal[..., 0] *= scale
    normal[..., 2] *= scale
    normal[..., 1] = n_y
    return distance, normal, surface[..., 3].copy()


def pack_gbuffer(gbuffer: GBuffer) -> dict:
    """Host arrays in the GPU G-buffer texture layout (see the module docstring).

    Returns ``{"surface": (H, W, 4) u32, "sigmoid": (H, W, 4) f32}``.
    """
    h, w = gbuffer.distance.shape
    surface = np.empty((h, w, 4), dtype=np.uint32)
    distance = np.where(np.isfinite(gbuffer.distance), gbuffer.distance,
                        OPEN_WATER_DISTANCE).astype(np.float32)
    surface[..., 0] = distance.view(np.uint32)
    surface[..., 1] = np.ascontiguousarray(gbuffer.normal[..., 1], np.float32).view(np.uint32)
    surface[..., 2] = pack_snorm16x2(oct_encode(gbuffer.normal))
    surface[..., 3] = gbuffer.material
    sigmoid = np.zeros((h, w, 4), dtype=np.float32)
    sigmoid[..., :3] = gbuffer.sigmoid
    return {"surface": surface, "sigmoid": sigmoid}


def bind_group_layout(device, bindings):
    """Compute-stage layout for ``bindings``: {binding: kind}.

    Kinds: ``"uniform"``, ``"read"`` / ``"write"`` (storage buffers),
    ``"float"`` / ``"uint"`` (unfilterable 2-D textures of that sample type),
    ``"filterable"`` (2-D filterable float), ``"float_array"`` /
    ``"filterable_array"`` (2-D array textures, unfilterable / filterable
    float), ``"storage_rgba32float"`` (write-only storage texture),
    ``"sampler"`` / ``"nonfiltering_sampler"``.
    """
    import wgpu
    kinds = {"uniform": wgpu.BufferBindingType.uniform,
             "read": wgpu.BufferBindingType.read_only_storage,
             "write": wgpu.BufferBindingType.storage}
    samples = {"float": (wgpu.TextureSampleType.unfilterable_float, wgpu.TextureViewDimension.d2),
               "uint": (wgpu.TextureSampleType.uint, wgpu.TextureViewDimension.d2),
               "float_array": (wgpu.TextureSampleType.unfilterable_float,
                               wgpu.TextureViewDimension.d2_array),
               "filterable_array": (wgpu.TextureSampleType.float,
                                    wgpu.TextureViewDimension.d2_array),
               "filterable": (wgpu.TextureSampleType.float, wgpu.TextureViewDimension.d2)}
    samplers = {"sampler": wgpu.SamplerBindingType.filtering,
                "nonfiltering_sampler": wgpu.SamplerBindingType.non_filtering}

    def entry(b, k):
        if k in samples:
            return {"binding": b, "visibility": wgpu.ShaderStage.COMPUTE,
                    "texture": {"sample_type": samples[k][0], "view_dimension": samples[k][1]}}
        if k == "storage_rgba32float":
            return {"binding": b, "visibility": wgpu.ShaderStage.COMPUTE,
                    "storage_texture": {"access": wgpu.StorageTextureAccess.write_only,
                                        "format": wgpu.TextureFormat.rgba32float,
                                        "view_dimension": wgpu.TextureViewDimension.d2}}
        if k in samplers:
            return {"binding": b, "visibility": wgpu.ShaderStage.COMPUTE,
                    "sampler": {"type": samplers[k]}}
        return {"binding": b, "visibility": wgpu.ShaderStage.COMPUTE,
                "buffer": {"type": kinds[k]}}

    return device.create_bind_group_layout(entries=[entry(b, k)
                                                    for b, k in sorted(bindings.items())])


def bind_group_entries(resources) -> list:
    """Bind-group entries for {binding: buffer, texture, texture view or sampler}
    (whole buffers, default texture views)."""
    out = []
    for b, r in sorted(resources.items()):
        if hasattr(r, "create_view"):
            out.append({"binding": b, "resource": r.create_view()})
        elif type(r).__name__.endswith(("Sampler", "TextureView")):
            out.append({"binding": b, "resource": r})
        else:
            out.append({"binding": b, "resource": {"buffer": r, "offset": 0, "size": r.size}})
    return out


class DeferredPass:
    """Deferred spectral shading of a ``width`` x ``height`` G-buffer with ``n_bands`` bands.

    Create it once per image size and band count; then per frame
    :meth:`set_gbuffer` (or let a raster pass render into
    :attr:`gbuffer_textures` and call :meth:`set_camera`), :meth:`set_medium`
    when the water, light or sensor change, :meth:`run`, :meth:`read_rgb`.

    Parameters
    ----------
    width, height : int
        Image size in pixels.
    n_bands : int
        Number of wavelength bands (1 to 1024).
    device : wgpu.GPUDevice, optional
        Default: :func:`aquaspec.gpu.device.get_device`.
    debug_radiance : bool
        Also write the band radiance per pixel (``read_radiance``); needs
        ``width * height * n_bands * 4`` bytes within the device's storage
        binding limit.
    """

    def __init__(self, width: int, height: int, n_bands: int, *, device=None,
                 debug_radiance: bool = False):
        import wgpu
        self.width, self.height = check_size(width, height)
        if isinstance(n_bands, bool) or not isinstance(n_bands, (int, np.integer)) \
                or not 1 <= n_bands <= MAX_BANDS:
            raise AquaspecError(f"n_bands={n_bands!r}; accepted: an integer from 1 to {MAX_BANDS}")
        self.n_bands = int(n_bands)
        if device is None:
            from aquaspec.gpu.device import get_device
            _, device = get_device()
        self.device = device
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

        self._uniform = create_uniform_buffer(device, CAMERA_LAYOUT, label="deferred camera")
        usage = (wgpu.TextureUsage.RENDER_ATTACHMENT | wgpu.TextureUsage.TEXTURE_BINDING
                 | wgpu.TextureUsage.COPY_DST | wgpu.TextureUsage.COPY_SRC)
        self._textures = {name: create_texture(device, self.width, self.height, fmt,
                                               label=f"gbuffer {name}", usage=usage)
                          for name, (_, fmt) in GBUFFER_TEXTURES.items()}
        self._open_table = create_storage_buffer(device, OPEN_TABLE_SIZE * 32,
                                                 label="deferred open-water table")
        self._open_table_ok = False
        self._bands = device.create_buffer(
            label="deferred band table", size=self.n_bands * len(BAND_FIELDS) * 4,
            usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
        limit = device.limits.get("max-uniform-buffer-binding-size", 65536)
        if self._bands.size > limit:
            raise AquaspecError(f"{self.n_bands} bands need a {self._bands.size}-byte band "
                                f"table; this device binds at most {limit}")
        self._materials = MaterialTable(device, "deferred material bands")
        self.rgb_buffer = create_storage_buffer(device, npix * 16, label="deferred rgb")
        self._radiance = create_storage_buffer(
            device, npix * self.n_bands * 4 if self.debug_radiance else 4,
            label="deferred radiance")
        self._status = create_storage_buffer(device, 16, label="deferred status")
        # The fused display transform (set_display, encode(display=True)).
        from aquaspec.gpu.passes.display import DISPLAY_LAYOUT
        self._display_uniform = create_uniform_buffer(device, DISPLAY_LAYOUT,
                                                      label="deferred display")
        #: Packed RGBA8 output of ``encode(display=True)``, ``width * height`` u32.
        self.display_buffer = create_storage_buffer(device, npix * 4, label="deferred rgba8")
        self.display_settings = None
        self._last_display = False

        self._layout = bind_group_layout(device, {
            B_CAMERA: "uniform", B_SURFACE: "uint", B_SIGMOID: "float",
            B_BANDS: "uniform", B_RGB: "write", B_RADIANCE: "write",
            B_STATUS: "write", B_DISPLAY: "uniform", B_RGBA: "write",
            B_OPEN_TABLE: "read", **MaterialTable.layout()})
        # One pipeline per value of per_pixel (a compile-time constant of the
        # shader), made when first used.
        self._pipelines = {}
        self._per_pixel = True
        #: Shade four-pixel groups that all see open water from the
        #: open-water table (:func:`open_water_table`) instead of the band
        #: loop; False forces the band loop everywhere (for comparisons).
        self.use_open_table = True
        self._uploaded_use_open_table = None
        self._bind_group = None
        #: Incremented whenever a bound buffer is replaced (CopyPass rebinds then).
        self.bindings_version = 0
        self.camera = None
        self._n_materials = None
        self._ambient_id = None
        self._medium_bands = None
        self._uniform_dirty = True

    # ---------------------------------------------------------------- inputs
    @property
    def per_pixel(self) -> bool:
        """Whether the G-buffer has per-pixel (sigmoid) materials, so the sigmoid texture is read.

        Set by :meth:`set_gbuffer`, :meth:`use_gbuffer_textures` and the
        geometry pass (:meth:`aquaspec.gpu.passes.raster.RasterPass.render_to`).
        """
        return self._per_pixel

    @per_pixel.setter
    def per_pixel(self, value: bool) -> None:
        if bool(value) != self._per_pixel:
            self._per_pixel = bool(value)
            self._uniform_dirty = True

    @property
    def gbuffer_textures(self) -> dict:
        """The G-buffer textures ``{"surface", "sigmoid"}`` read by the pass."""
        return dict(self._textures)

    def set_camera(self, camera) -> None:
        """Set the camera whose rays the G-buffer was made with (size must match)."""
        if (camera.width, camera.height) != (self.width, self.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height} but this pass was "
                                f"created for {self.width}x{self.height}")
        camera_depth(camera)
        self.camera = camera
        self._uniform_dirty = True

    def set_gbuffer(self, gbuffer: GBuffer) -> None:
        """Upload a host G-buffer (and its camera) into :attr:`gbuffer_textures`."""
        if not isinstance(gbuffer, GBuffer):
            raise AquaspecError(f"gbuffer must be an aquaspec.scene.gbuffer.GBuffer, got "
                                f"{type(gbuffer).__name__}")
        self.set_camera(gbuffer.camera)
        per_pixel = gbuffer.hit & (gbuffer.material == PER_PIXEL)
        if not np.all(np.isfinite(gbuffer.sigmoid[per_pixel])):
            raise AquaspecError("G-buffer sigmoid coefficients of per-pixel materials "
                                "must be finite")
        self.per_pixel = bool(per_pixel.any())
        for name, arr in pack_gbuffer(gbuffer).items():
            upload_texture(self.device, self._textures[name], arr)

    def use_gbuffer_textures(self, camera, *, per_pixel: bool = True, **textures) -> None:
        """Read the G-buffer from textures made elsewhere (e.g. a raster pass's targets).

        Parameters
        ----------
        camera : Camera
            The camera the G-buffer was rendered with.
        per_pixel : bool
            Whether the sigmoid texture holds per-pixel materials to read.
        surface, sigmoid : wgpu.GPUTexture, optional
            Textures in the formats of the module docstring, of this pass's
            size, with ``TEXTURE_BINDING`` usage; those not given stay as they
            are.
        """
        import wgpu
        for name, tex in textures.items():
            if name not in self._textures:
                raise AquaspecError(f"unknown G-buffer texture {name!r}; accepted: "
                                    f"{', '.join(self._textures)}")
            fmt = GBUFFER_TEXTURES[name][1]
            size = tuple(tex.size[:2])
            if size != (self.width, self.height) or tex.format != fmt:
                raise AquaspecError(f"G-buffer {name} texture is {size[0]}x{size[1]} "
                                    f"{tex.format}; this pass needs {self.width}x"
                                    f"{self.height} {fmt}")
            if not tex.usage & wgpu.TextureUsage.TEXTURE_BINDING:
                raise AquaspecError(f"G-buffer {name} texture lacks TEXTURE_BINDING usage")
        self.set_camera(camera)
        self.per_pixel = bool(per_pixel)
        if textures:
            self._textures.update(textures)
            self._bind_group = None
            self.bindings_version += 1

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
        version = self._materials.version
        self._materials.upload(mb, n)
        if self._materials.version != version:
            self._bind_group = None
            self.bindings_version += 1
        self._n_materials = mb.shape[0]
        self._ambient_id = AMBIENT_MODEL_IDS[ambient]
        self._uniform_dirty = True

    # ------------------------------------------------------------- dispatch
    def upload_uniforms(self) -> None:
        """Write the camera/frame uniforms if they changed (needs a camera)."""
        if self.camera is None:
            raise AquaspecError("no camera: call set_gbuffer() or set_camera() before running")
        if not self._uniform_dirty and self._uploaded_use_open_table == self.use_open_table:
            return
        self._uploaded_use_open_table = self.use_open_table
        cam = self.camera
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
        data = CAMERA_LAYOUT.pack(
            **camera_fields(cam), width=self.width, height=self.height,
            n_bands=self.n_bands, ambient_model=self._ambient_id or 0,
            n_materials=self._n_materials or 0, write_radiance=int(self.debug_radiance),
            snell_cos=model.snell_window_cos(model.N_WATER),
            window_factor=model.N_WATER ** 2 / np.pi, per_pixel=int(self.per_pixel),
            open_table=int(self._open_table_ok and self.use_open_table))
        upload_buffer(self.device, self._uniform, data)
        self._uniform_dirty = False

    def _get_bind_group(self):
        if self._bind_group is None:
            resources = {B_CAMERA: self._uniform, B_SURFACE: self._textures["surface"],
                         B_SIGMOID: self._textures["sigmoid"], B_BANDS: self._bands,
                         **self._materials.resources(), B_RGB: self.rgb_buffer,
                         B_RADIANCE: self._radiance, B_STATUS: self._status,
                         B_DISPLAY: self._display_uniform, B_RGBA: self.display_buffer,
                         B_OPEN_TABLE: self._open_table}
            self._bind_group = self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries(resources))
        return self._bind_group

    def _pipeline(self, tonemap=None):
        key = (self.per_pixel, tonemap, self._materials.in_uniform)
        if key not in self._pipelines:
            module = self.device.create_shader_module(
                label="deferred.wgsl", code=shader_source("deferred.wgsl", self.n_bands,
                                                          self.debug_radiance,
                                                          per_pixel=self.per_pixel,
                                                          tonemap=tonemap,
                                                          materials_in_uniform=(
                                                              self._materials.in_uniform)))
            self._pipelines[key] = self.device.create_compute_pipeline(
                label="deferred",
                layout=self.device.create_pipeline_layout(bind_group_layouts=[self._layout]),
                compute={"module": module, "entry_point": "main"})
        return self._pipelines[key]

    def workgroups(self) -> tuple[int, int, int]:
        """Dispatch size covering the image."""
        per_x = WORKGROUP[0] * PIXELS_PER_INVOCATION
        return (-(-self.width // per_x), -(-self.height // WORKGROUP[1]), 1)

    def set_display(self, *, exposure_ev, white_balance_gains=(1.0, 1.0, 1.0), matrix=None,
                    tonemap="filmic") -> None:
        """Settings of the fused display transform (``encode(display=True)``).

        The same settings and checks as
        :meth:`aquaspec.gpu.passes.display.DisplayPass.set_settings` (the
        image-dependent ones, automatic exposure and grey-world gains, are
        resolved beforehand, e.g. from an earlier frame, with
        :func:`aquaspec.colour.display.display_settings`).
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
        """Record the shading into ``encoder`` (uniforms are uploaded first).

        ``display=True`` also applies the display transform of
        :meth:`set_display` in the same pass and writes
        :attr:`display_buffer` (read with :meth:`read_display`) instead of
        linear RGB: one pass instead of two, and the linear image never goes
        through memory.
        """
        if self._n_materials is None:
            raise AquaspecError("no medium: call set_medium() before running")
        self.upload_uniforms()
        tonemap = None
        if display:
            if self.display_settings is None:
                raise AquaspecError("no display settings: call set_display() before "
                                    "encoding with display=True")
            tonemap = self.display_settings["tonemap"]
            # status[3] is an atomicMin, so it starts at the maximum (a queue
            # write runs before the next submission).
            self.device.queue.write_buffer(self._status, 0,
                                           np.array([0, 0, 0, 0xFFFFFFFF], np.uint32))
        else:
            encoder.clear_buffer(self._status, 0, self._status.size)
        self._last_display = bool(display)
        record_dispatch(encoder, self._pipeline(tonemap), self._get_bind_group(),
                        self.workgroups(), timestamp_writes)

    def run(self, *, display: bool = False) -> None:
        """Shade the current G-buffer (submits; does not wait); ``display`` as in :meth:`encode`."""
        encoder = self.device.create_command_encoder()
        self.encode(encoder, display=display)
        self.device.queue.submit([encoder.finish()])

    # ------------------------------------------------------------- outputs
    def _check_status(self):
        bad = int(read_buffer(self.device, self._status, np.uint32, (4,))[0])
        if bad:
            raise AquaspecError(f"{bad} G-buffer pixels use a material index >= "
                                f"{self._n_materials}, the number of material_bands rows")

    def read_display(self) -> np.ndarray:
        """The display image of the last ``run(display=True)``, (H, W, 3) uint8.

        Raises :class:`AquaspecError` if a pixel referenced an undefined
        material, or (with the count and the first pixel) if a value was not
        finite or overflowed after exposure.
        """
        if not self._last_display:
            raise AquaspecError("read_display() needs a run with display=True")
        status = read_buffer(self.device, self._status, np.uint32, (4,))
        if status[0]:
            raise AquaspecError(f"{int(status[0])} G-buffer pixels use a material index >= "
                                f"{self._n_materials}, the number of material_bands rows")
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
        self._check_status()
        rgba = read_buffer(self.device, self.rgb_buffer, np.float32,
                           (self.height, self.width, 4))
        rgb = rgba[..., :3]
        if not np.all(np.isfinite(rgb)):
            i, j = np.argwhere(~np.all(np.isfinite(rgb), axis=-1))[0]
            raise AquaspecError(f"deferred shading produced a non-finite value at pixel "
                                f"({i}, {j}); check the water coefficients and G-buffer")
        return np.ascontiguousarray(rgb)

    def read_radiance(self) -> np.ndarray:
        """Band radiance of the last run, (H, W, n) float32 (debug mode only)."""
        if not self.debug_radiance:
            raise AquaspecError("read_radiance() needs DeferredPass(..., debug_radiance=True)")
        self._check_status()
        rad = read_buffer(self.device, self._radiance, np.float32,
                          (self.height, self.width, self.n_bands))
        if not np.all(np.isfinite(rad)):
            raise AquaspecError("deferred shading produced a non-finite band radiance")
        return rad
