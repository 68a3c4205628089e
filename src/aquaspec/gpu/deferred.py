"""The deferred spectral shading pass: G-buffer -> linear camera RGB on the GPU.

One compute invocation per pixel evaluates the analytic model of
:mod:`aquaspec.model` band by band (WGSL: ``shaders/deferred.wgsl`` with the
model functions in ``shaders/common.wgsl``) and sums the bands into camera
RGB. Its NumPy reference is :func:`aquaspec.shading.shade_gbuffer`; the test
``tests/test_gpu_deferred.py`` holds the two together.

Conventions: metres, y up, water surface y = 0, depth ``-p.y``; a, b, Kd in
1/m; E0 in W m^-2 nm^-1; output radiance-weighted camera RGB, linear, f32.

G-buffer layout (GPU-resident)
------------------------------
The G-buffer lives in two textures, texel ``(column, row)`` per pixel (row 0
at the top, as in :meth:`aquaspec.camera.Camera.ray_directions`), the render
targets of the geometry pass (:class:`aquaspec.gpu.raster.RasterPass`
renders straight into :attr:`DeferredPass.gbuffer_textures`; usage
``RENDER_ATTACHMENT | TEXTURE_BINDING | COPY_DST | COPY_SRC``), or textures
made elsewhere in the same formats (:meth:`DeferredPass.use_gbuffer_textures`):

===========  =====================  ==============================================
binding      format                 contents
===========  =====================  ==============================================
1 geometry   ``rgba32float``        ``xyz``: unit world normal (0 for open water);
                                    ``w``: distance S in m from the camera centre
                                    along the pixel's ray, :data:`OPEN_WATER_DISTANCE`
                                    (any negative value) where it sees open water
2 material   ``rgba32uint``         ``xyz``: Jakob-Hanika coefficients (c0, c1, c2)
                                    in t = (lambda - 550) / 100 as f32 bits (0 for
                                    single-material pixels); ``w``: material
                                    index, or ``0xffffffff`` (gbuffer.PER_PIXEL)
                                    for the pixel's own sigmoid coefficients
===========  =====================  ==============================================

Reading the render targets directly saved the compute pass that used to
repack them into storage buffers (6-7 ms of a 1280x720 frame on lavapipe).
Storing the material as an integer (rather than a float bit pattern) keeps
``0xffffffff`` from ever passing through a float register, where a NaN
payload is not guaranteed to survive.

Storage-buffer copy (for :class:`~aquaspec.gpu.lightfield_pass.LightfieldPass`)
-------------------------------------------------------------------------------
:attr:`DeferredPass.gbuffer_buffers` holds the same G-buffer in three storage
buffers, one element per pixel ``p = row * width + column``: ``distance``
``array<f32>``; ``surface`` ``array<vec4<u32>>`` (normal f32 bits, material);
``sigmoid`` ``array<vec4<f32>>`` (c0, c1, c2, unused); see
:func:`pack_gbuffer_storage`. :meth:`DeferredPass.set_gbuffer` fills them
always; the geometry pass fills them (with a compute repack) only when
:attr:`DeferredPass.storage_gbuffer` is true.

Per-band inputs (:meth:`DeferredPass.set_medium`): binding 4 is a uniform
``array<vec4<f32>, 3 n>``, :func:`band_table` (the per-band factors that do
not depend on the pixel, precomputed in float64 for the camera's depth; 12
f32 per band, :data:`BAND_FIELDS`), binding 5 ``array<f32>`` of material
band reflectances, ``material * n_bands + band``. Outputs: binding 6
``array<vec4<f32>>`` RGB (w = 1), binding 7 ``array<f32>`` band radiance
``p * n_bands + band`` (debug mode only), binding 8 a status counter of
pixels with a material index out of range.
"""

from __future__ import annotations

import numpy as np

from .. import model
from ..bands import MAX_BANDS
from ..camera import check_size
from ..errors import AquaspecError
from ..gbuffer import PER_PIXEL, GBuffer
from ..shading import camera_depth, check_medium
from .buffers import (create_storage_buffer, create_texture, create_uniform_buffer,
                      read_buffer, record_dispatch, submit_pass, upload_buffer, upload_texture)
from .layout import UniformLayout
from .shaders import load_wgsl

#: Value written to the distance buffer where a pixel's ray sees open water.
OPEN_WATER_DISTANCE = -1.0

#: Ambient models of :data:`aquaspec.model.AMBIENT_MODELS` by WGSL id
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
])

#: Compute workgroup size (x, y) of deferred.wgsl, in invocations.
WORKGROUP = (8, 8)
#: Adjacent pixels of a row shaded by one invocation of deferred.wgsl.
PIXELS_PER_INVOCATION = 4

# Binding numbers (also in the WGSL files).
B_CAMERA, B_GEOMETRY, B_MATERIAL = 0, 1, 2
B_BANDS, B_MATERIALS, B_RGB, B_RADIANCE, B_STATUS = 4, 5, 6, 7, 8
#: G-buffer textures: name -> (binding, texture format).
GBUFFER_TEXTURES = {"geometry": (B_GEOMETRY, "rgba32float"),
                    "material": (B_MATERIAL, "rgba32uint")}
#: Bytes per element of the storage-buffer copy (:attr:`DeferredPass.gbuffer_buffers`).
GBUFFER_BUFFER_BYTES = {"distance": 4, "surface": 16, "sigmoid": 16}


def shader_source(name: str, n_bands: int = 1, write_radiance: bool = False) -> str:
    """WGSL of ``deferred.wgsl`` or ``copy.wgsl`` with the camera struct filled in.

    The band count and the debug-radiance switch are compile-time constants
    of ``deferred.wgsl`` (a constant trip count and uniform-array band table
    made the band loop about 4x faster on lavapipe).
    """
    return load_wgsl(name, camera_struct=CAMERA_LAYOUT.wgsl(),
                     camera_struct_name=CAMERA_LAYOUT.name, n_bands=int(n_bands),
                     band_table_len=len(BAND_FIELDS) // 4 * int(n_bands),
                     write_radiance="true" if write_radiance else "false",
                     workgroup_x=WORKGROUP[0], workgroup_y=WORKGROUP[1])


def band_table(a, b, kd, e0, response_weights, sigmoid_centers_t, depth_o) -> np.ndarray:
    """The deferred pass's band table (binding 4): (n, 12) float64, :data:`BAND_FIELDS`.

    The per-band factors of the model that do not depend on the pixel, for a
    camera at depth ``depth_o`` (m): ``c = a + b``; ``ms_scale = b E0 / (4 pi)
    exp(-Kd d_o)`` and ``be0 = b E0 / (4 pi)``, ``base = -Kd d_o`` (the
    seeds' multiple scattering, :func:`aquaspec.model.l_ms_seeds`);
    ``e0_over_pi = E0 / pi`` (:func:`aquaspec.model.lambertian_radiance` of
    :func:`aquaspec.model.ambient_irradiance`); ``e0_window = E0 n^2 / pi``
    (:func:`aquaspec.model.surface_from_below`).
    """
    a, b, kd, e0, t = (np.asarray(x, dtype=np.float64) for x in (a, b, kd, e0, sigmoid_centers_t))
    w = np.asarray(response_weights, dtype=np.float64)
    be0 = b * e0 / (4.0 * np.pi)
    base = -kd * float(depth_o)
    return np.stack([a + b, kd, t, be0 * np.exp(base),
                     w[:, 0], w[:, 1], w[:, 2], e0 / np.pi,
                     be0, base, e0 * model.N_WATER ** 2 / np.pi, np.zeros_like(a)], axis=1)


def pack_gbuffer(gbuffer: GBuffer) -> dict:
    """Host arrays in the GPU G-buffer texture layout (see the module docstring).

    Returns ``{"geometry": (H, W, 4) f32, "material": (H, W, 4) u32}``.
    """
    h, w = gbuffer.distance.shape
    geometry = np.empty((h, w, 4), dtype=np.float32)
    geometry[..., :3] = gbuffer.normal
    geometry[..., 3] = np.where(np.isfinite(gbuffer.distance), gbuffer.distance,
                                np.float32(OPEN_WATER_DISTANCE))
    material = np.empty((h, w, 4), dtype=np.uint32)
    material[..., :3] = np.ascontiguousarray(gbuffer.sigmoid, dtype=np.float32).view(np.uint32)
    material[..., 3] = gbuffer.material
    return {"geometry": geometry, "material": material}


def pack_gbuffer_storage(gbuffer: GBuffer) -> dict:
    """Host arrays in the storage-buffer layout of :attr:`DeferredPass.gbuffer_buffers`.

    Returns ``{"distance": (H*W,) f32, "surface": (H*W, 4) u32,
    "sigmoid": (H*W, 4) f32}``.
    """
    tex = pack_gbuffer(gbuffer)
    geometry, material = tex["geometry"].reshape(-1, 4), tex["material"].reshape(-1, 4)
    surface = np.empty_like(material)
    surface[:, :3] = geometry[:, :3].view(np.uint32)
    surface[:, 3] = material[:, 3]
    sigmoid = np.zeros(geometry.shape, dtype=np.float32)
    sigmoid[:, :3] = material[:, :3].view(np.float32)
    return {"distance": geometry[:, 3].copy(), "surface": surface, "sigmoid": sigmoid}


def bind_group_layout(device, bindings):
    """Compute-stage layout for ``bindings``: {binding: kind}.

    Kinds: ``"uniform"``, ``"read"`` / ``"write"`` (storage buffers),
    ``"float"`` / ``"uint"`` (unfilterable 2-D textures of that sample type).
    """
    import wgpu
    kinds = {"uniform": wgpu.BufferBindingType.uniform,
             "read": wgpu.BufferBindingType.read_only_storage,
             "write": wgpu.BufferBindingType.storage}
    samples = {"float": wgpu.TextureSampleType.unfilterable_float,
               "uint": wgpu.TextureSampleType.uint}

    def entry(b, k):
        if k in samples:
            return {"binding": b, "visibility": wgpu.ShaderStage.COMPUTE,
                    "texture": {"sample_type": samples[k],
                                "view_dimension": wgpu.TextureViewDimension.d2}}
        return {"binding": b, "visibility": wgpu.ShaderStage.COMPUTE,
                "buffer": {"type": kinds[k]}}

    return device.create_bind_group_layout(entries=[entry(b, k)
                                                    for b, k in sorted(bindings.items())])


def bind_group_entries(resources) -> list:
    """Bind-group entries for {binding: buffer or texture} (whole buffers, default views)."""
    out = []
    for b, r in sorted(resources.items()):
        if hasattr(r, "create_view"):
            out.append({"binding": b, "resource": r.create_view()})
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
            from .device import get_device
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
        self._buffers = None        # storage-buffer copy, made when first needed
        #: When true, the geometry pass also fills :attr:`gbuffer_buffers`
        #: (needed by the light-field pass; costs a compute repack per frame).
        self.storage_gbuffer = False
        self._bands = device.create_buffer(
            label="deferred band table", size=self.n_bands * len(BAND_FIELDS) * 4,
            usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
        limit = device.limits.get("max-uniform-buffer-binding-size", 65536)
        if self._bands.size > limit:
            raise AquaspecError(f"{self.n_bands} bands need a {self._bands.size}-byte band "
                                f"table; this device binds at most {limit}")
        self._materials = create_storage_buffer(device, self.n_bands * 4,
                                                label="deferred material bands")
        self.rgb_buffer = create_storage_buffer(device, npix * 16, label="deferred rgb")
        self._radiance = create_storage_buffer(
            device, npix * self.n_bands * 4 if self.debug_radiance else 4,
            label="deferred radiance")
        self._status = create_storage_buffer(device, 16, label="deferred status")

        self._layout = bind_group_layout(device, {
            B_CAMERA: "uniform", B_GEOMETRY: "float", B_MATERIAL: "uint",
            B_BANDS: "uniform", B_MATERIALS: "read", B_RGB: "write", B_RADIANCE: "write",
            B_STATUS: "write"})
        module = device.create_shader_module(label="deferred.wgsl",
                                             code=shader_source("deferred.wgsl", self.n_bands,
                                                                self.debug_radiance))
        self._pipeline = device.create_compute_pipeline(
            label="deferred",
            layout=device.create_pipeline_layout(bind_group_layouts=[self._layout]),
            compute={"module": module, "entry_point": "main"})
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
    def gbuffer_textures(self) -> dict:
        """The G-buffer textures ``{"geometry", "material"}`` read by the pass."""
        return dict(self._textures)

    @property
    def gbuffer_buffers(self) -> dict:
        """The storage-buffer copy ``{"distance", "surface", "sigmoid"}`` (module docstring).

        Kept up to date by :meth:`set_gbuffer`, and by the geometry pass when
        :attr:`storage_gbuffer` is true.
        """
        if self._buffers is None:
            npix = self.width * self.height
            self._buffers = {name: create_storage_buffer(self.device, npix * nbytes,
                                                         label=f"gbuffer {name}")
                             for name, nbytes in GBUFFER_BUFFER_BYTES.items()}
        return dict(self._buffers)

    def set_camera(self, camera) -> None:
        """Set the camera whose rays the G-buffer was made with (size must match)."""
        if (camera.width, camera.height) != (self.width, self.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height} but this pass was "
                                f"created for {self.width}x{self.height}")
        camera_depth(camera)
        self.camera = camera
        self._uniform_dirty = True

    def set_gbuffer(self, gbuffer: GBuffer) -> None:
        """Upload a host G-buffer (and its camera) into :attr:`gbuffer_textures`.

        The storage-buffer copy :attr:`gbuffer_buffers` is filled too.
        """
        if not isinstance(gbuffer, GBuffer):
            raise AquaspecError(f"gbuffer must be an aquaspec.gbuffer.GBuffer, got "
                                f"{type(gbuffer).__name__}")
        self.set_camera(gbuffer.camera)
        per_pixel = gbuffer.hit & (gbuffer.material == PER_PIXEL)
        if not np.all(np.isfinite(gbuffer.sigmoid[per_pixel])):
            raise AquaspecError("G-buffer sigmoid coefficients of per-pixel materials "
                                "must be finite")
        for name, arr in pack_gbuffer(gbuffer).items():
            upload_texture(self.device, self._textures[name], arr)
        bufs = self.gbuffer_buffers
        for name, arr in pack_gbuffer_storage(gbuffer).items():
            upload_buffer(self.device, bufs[name], arr)

    def use_gbuffer_textures(self, camera, **textures) -> None:
        """Read the G-buffer from textures made elsewhere (e.g. a raster pass's targets).

        Parameters
        ----------
        camera : Camera
            The camera the G-buffer was rendered with.
        geometry, material : wgpu.GPUTexture, optional
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
        if textures:
            self._textures.update(textures)
            self._bind_group = None
            self.bindings_version += 1

    def set_medium(self, a, b, kd, e0, response_weights, material_bands, sigmoid_centers_t,
                   ambient: str = model.DEFAULT_AMBIENT) -> None:
        """Upload the per-band water, light, sensor and material data.

        Same arguments and checks as :func:`aquaspec.shading.shade_gbuffer`:
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
        flat = mb.astype(np.float32).reshape(-1)
        if flat.nbytes > self._materials.size:
            self._materials = create_storage_buffer(self.device, flat.nbytes,
                                                    label="deferred material bands")
            self._bind_group = None
            self.bindings_version += 1
        if flat.size:
            upload_buffer(self.device, self._materials, flat)
        self._n_materials = mb.shape[0]
        self._ambient_id = AMBIENT_MODEL_IDS[ambient]
        self._uniform_dirty = True

    # ------------------------------------------------------------- dispatch
    def upload_uniforms(self) -> None:
        """Write the camera/frame uniforms if they changed (needs a camera)."""
        if self.camera is None:
            raise AquaspecError("no camera: call set_gbuffer() or set_camera() before running")
        if not self._uniform_dirty:
            return
        cam = self.camera
        data = CAMERA_LAYOUT.pack(
            **camera_fields(cam), width=self.width, height=self.height,
            n_bands=self.n_bands, ambient_model=self._ambient_id or 0,
            n_materials=self._n_materials or 0, write_radiance=int(self.debug_radiance),
            snell_cos=model.snell_window_cos(model.N_WATER),
            window_factor=model.N_WATER ** 2 / np.pi)
        upload_buffer(self.device, self._uniform, data)
        if self._medium_bands is not None:
            table = band_table(*self._medium_bands, depth_o=camera_depth(cam))
            upload_buffer(self.device, self._bands, table.astype(np.float32))
        self._uniform_dirty = False

    def _get_bind_group(self):
        if self._bind_group is None:
            resources = {B_CAMERA: self._uniform, B_GEOMETRY: self._textures["geometry"],
                         B_MATERIAL: self._textures["material"], B_BANDS: self._bands,
                         B_MATERIALS: self._materials, B_RGB: self.rgb_buffer,
                         B_RADIANCE: self._radiance, B_STATUS: self._status}
            self._bind_group = self.device.create_bind_group(
                layout=self._layout, entries=bind_group_entries(resources))
        return self._bind_group

    def workgroups(self) -> tuple[int, int, int]:
        """Dispatch size covering the image."""
        per_x = WORKGROUP[0] * PIXELS_PER_INVOCATION
        return (-(-self.width // per_x), -(-self.height // WORKGROUP[1]), 1)

    def encode(self, encoder, timestamp_writes=None) -> None:
        """Record the shading into ``encoder`` (uniforms are uploaded first)."""
        if self._n_materials is None:
            raise AquaspecError("no medium: call set_medium() before running")
        self.upload_uniforms()
        encoder.clear_buffer(self._status, 0, self._status.size)
        record_dispatch(encoder, self._pipeline, self._get_bind_group(), self.workgroups(),
                        timestamp_writes)

    def run(self) -> None:
        """Shade the current G-buffer (submits; does not wait)."""
        submit_pass(self.device, self)

    # ------------------------------------------------------------- outputs
    def _check_status(self):
        bad = int(read_buffer(self.device, self._status, np.uint32, (4,))[0])
        if bad:
            raise AquaspecError(f"{bad} G-buffer pixels use a material index >= "
                                f"{self._n_materials}, the number of material_bands rows")

    def read_rgb(self) -> np.ndarray:
        """Linear camera RGB of the last run, (H, W, 3) float32.

        Raises :class:`AquaspecError` if a pixel referenced an undefined
        material or a value is not finite.
        """
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
