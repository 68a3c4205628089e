"""The G-buffer on the GPU: its texture format, its NumPy packing, and the textures.

The shading passes (:mod:`aquaspec.gpu.passes.deferred`,
:mod:`aquaspec.gpu.passes.lightfield`, :mod:`aquaspec.gpu.passes.sun`,
:mod:`aquaspec.gpu.passes.copy`) read one :class:`GBufferTextures`, which the
geometry pass (:meth:`aquaspec.gpu.passes.raster.RasterPass.render_to`) renders
into, or which a host :class:`aquaspec.scene.gbuffer.GBuffer` is uploaded to
(:meth:`GBufferTextures.upload`), or which adopts textures made elsewhere in
the same formats (:meth:`GBufferTextures.use_textures`).

Layout
------
Texel ``(column, row)`` per pixel (row 0 at the top, as in
:meth:`aquaspec.scene.camera.Camera.ray_directions`); every pass binds the
two textures at the same bindings (:data:`B_SURFACE`, :data:`B_SIGMOID`):

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
                                    :attr:`GBufferTextures.per_pixel` is true
===========  =====================  ==============================================

One 16-byte target for scenes without per-pixel materials (the built-in
scene, and any scene of plain-coloured meshes) made the geometry pass about
40 % faster on lavapipe than the 32 bytes of two targets. Reading the render
targets directly saved the compute pass that used to repack them into
storage buffers (6-7 ms of a 1280x720 frame on lavapipe). Storing the
material as an integer (rather than a float bit pattern) keeps
``0xffffffff`` from ever passing through a float register, where a NaN
payload is not guaranteed to survive.
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.gpu.buffers import create_texture, upload_texture
from aquaspec.scene.camera import check_size
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer
from aquaspec.shading.shade import camera_depth

#: Value written to the distance where a pixel's ray sees open water.
OPEN_WATER_DISTANCE = -1.0

#: The G-buffer textures' formats by name.
GBUFFER_FORMATS = {"surface": "rgba32uint", "sigmoid": "rgba32float"}
#: Bindings of the surface and sigmoid textures in every pass that reads them.
B_SURFACE, B_SIGMOID = 1, 2
#: Usage of the G-buffer textures: render targets of the geometry pass, read by
#: the shading passes, uploaded and read back.
GBUFFER_USAGE = (wgpu.TextureUsage.RENDER_ATTACHMENT | wgpu.TextureUsage.TEXTURE_BINDING
                 | wgpu.TextureUsage.COPY_DST | wgpu.TextureUsage.COPY_SRC)


def oct_encode(normal) -> np.ndarray:
    """Octahedral map of unit vectors (..., 3) onto [-1, 1]^2 (..., 2), as raster.wgsl.

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
    """Host arrays in the G-buffer texture layout (see the module docstring).

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


class GBufferTextures:
    """The G-buffer of a ``width`` x ``height`` image on ``device``, with the camera
    it was made with; shared by the geometry pass and every shading pass.

    Parameters
    ----------
    device : wgpu.GPUDevice
    width, height : int
        Image size in pixels.
    """

    def __init__(self, device, width: int, height: int):
        self.device = device
        self.width, self.height = check_size(width, height)
        self._textures = {name: create_texture(device, self.width, self.height, fmt,
                                               label=f"gbuffer {name}", usage=GBUFFER_USAGE)
                          for name, fmt in GBUFFER_FORMATS.items()}
        #: The camera whose rays the G-buffer was made with (None before the first).
        self.camera = None
        self._per_pixel = True
        #: Incremented whenever a texture is replaced (readers rebuild their bind groups).
        self.bindings_version = 0
        #: Incremented on every change: camera, :attr:`per_pixel` or textures
        #: (readers re-upload what depends on them).
        self.version = 0

    @property
    def textures(self) -> dict:
        """The textures ``{"surface", "sigmoid"}`` (the geometry pass's render targets)."""
        return dict(self._textures)

    @property
    def per_pixel(self) -> bool:
        """Whether the G-buffer has per-pixel (sigmoid) materials, so the sigmoid texture is read.

        Set by :meth:`upload`, :meth:`use_textures` and the geometry pass
        (:meth:`aquaspec.gpu.passes.raster.RasterPass.render_to`).
        """
        return self._per_pixel

    @per_pixel.setter
    def per_pixel(self, value: bool) -> None:
        if bool(value) != self._per_pixel:
            self._per_pixel = bool(value)
            self.version += 1

    def set_camera(self, camera) -> None:
        """Set the camera whose rays the G-buffer was made with (size must match;
        under the water surface)."""
        if (camera.width, camera.height) != (self.width, self.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height} but this G-buffer "
                                f"was created for {self.width}x{self.height}")
        camera_depth(camera)
        self.camera = camera
        self.version += 1

    def upload(self, gbuffer: GBuffer) -> None:
        """Upload a host G-buffer (and take its camera) into :attr:`textures`."""
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

    def use_textures(self, camera, *, per_pixel: bool = True, **textures) -> None:
        """Read the G-buffer from textures made elsewhere (e.g. a raster pass's own targets).

        Parameters
        ----------
        camera : Camera
            The camera the G-buffer was rendered with.
        per_pixel : bool
            Whether the sigmoid texture holds per-pixel materials to read.
        surface, sigmoid : wgpu.GPUTexture, optional
            Textures in the formats of the module docstring, of this size,
            with ``TEXTURE_BINDING`` usage; those not given stay as they are.
        """
        for name, tex in textures.items():
            if name not in self._textures:
                raise AquaspecError(f"unknown G-buffer texture {name!r}; accepted: "
                                    f"{', '.join(self._textures)}")
            fmt = GBUFFER_FORMATS[name]
            size = tuple(tex.size[:2])
            if size != (self.width, self.height) or tex.format != fmt:
                raise AquaspecError(f"G-buffer {name} texture is {size[0]}x{size[1]} "
                                    f"{tex.format}; this G-buffer needs {self.width}x"
                                    f"{self.height} {fmt}")
            if not tex.usage & wgpu.TextureUsage.TEXTURE_BINDING:
                raise AquaspecError(f"G-buffer {name} texture lacks TEXTURE_BINDING usage")
        self.set_camera(camera)
        self.per_pixel = bool(per_pixel)
        if textures:
            self._textures.update(textures)
            self.bindings_version += 1
            self.version += 1
