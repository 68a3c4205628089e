"""GPU buffers and textures: creating, uploading, reading back.

Every helper takes the wgpu ``device`` explicitly (from
:func:`aquaspec.gpu.device.get_device`) so that passes never pick a device
behind the caller's back.
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError

#: Storage buffers are sized in multiples of this many bytes (vec4 alignment).
BUFFER_ALIGN = 16


def _aligned(nbytes: int) -> int:
    return max(BUFFER_ALIGN, -(-int(nbytes) // BUFFER_ALIGN) * BUFFER_ALIGN)


def create_storage_buffer(device, data_or_nbytes, *, label: str = "", extra_usage: int = 0):
    """A storage buffer (also copy source and destination), optionally filled.

    Parameters
    ----------
    device : wgpu.GPUDevice
    data_or_nbytes : ndarray or int
        Initial contents (uploaded as raw bytes), or a size in bytes (zeros).
        Sizes are rounded up to a multiple of :data:`BUFFER_ALIGN`.
    label : str
    extra_usage : int
        More ``wgpu.BufferUsage`` flags (e.g. ``VERTEX`` for a raster pass).
    """
    usage = (wgpu.BufferUsage.STORAGE | wgpu.BufferUsage.COPY_DST
             | wgpu.BufferUsage.COPY_SRC | extra_usage)
    if isinstance(data_or_nbytes, (int, np.integer)):
        if data_or_nbytes < 0:
            raise AquaspecError(f"buffer size {data_or_nbytes} bytes must be >= 0")
        return device.create_buffer(label=label, size=_aligned(data_or_nbytes), usage=usage)
    data = np.ascontiguousarray(data_or_nbytes)
    buf = device.create_buffer(label=label, size=_aligned(data.nbytes), usage=usage)
    if data.nbytes:
        upload_buffer(device, buf, data)
    return buf


def create_uniform_buffer(device, layout_or_nbytes, *, label: str = ""):
    """A uniform buffer sized for a :class:`~aquaspec.gpu.layout.UniformLayout`, or of
    a size in bytes (e.g. a uniform array of per-band vec4)."""
    size = layout_or_nbytes if isinstance(layout_or_nbytes, (int, np.integer)) \
        else layout_or_nbytes.size
    return device.create_buffer(label=label, size=int(size),
                                usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)


def upload_buffer(device, buffer, data, offset: int = 0) -> None:
    """Write ``data`` (any contiguous array or bytes) into ``buffer`` at ``offset``."""
    raw = data if isinstance(data, (bytes, bytearray)) else np.ascontiguousarray(data)
    nbytes = len(raw) if isinstance(raw, (bytes, bytearray)) else raw.nbytes
    if offset + nbytes > buffer.size:
        raise AquaspecError(f"{nbytes} bytes at offset {offset} do not fit in buffer "
                            f"{buffer.label!r} of {buffer.size} bytes")
    if nbytes % 4:
        raise AquaspecError(f"uploads must be a multiple of 4 bytes, got {nbytes}")
    device.queue.write_buffer(buffer, offset, raw)


def read_buffer(device, buffer, dtype, shape) -> np.ndarray:
    """Copy ``buffer``'s leading bytes back to the host as an array of ``shape``."""
    dtype = np.dtype(dtype)
    count = int(np.prod(shape))
    nbytes = count * dtype.itemsize
    if nbytes > buffer.size:
        raise AquaspecError(f"reading {shape} {dtype} needs {nbytes} bytes but buffer "
                            f"{buffer.label!r} has {buffer.size}")
    if nbytes % 4:
        raise AquaspecError(f"readbacks must be a multiple of 4 bytes, got {nbytes}")
    raw = device.queue.read_buffer(buffer, 0, nbytes)
    return np.frombuffer(raw, dtype=dtype, count=count).reshape(shape).copy()


def create_texture(device, width: int, height: int, format: str, *, label: str = "",
                   usage: int | None = None):
    """A 2-D texture (default usage: storage binding, texture binding, copies)."""
    if usage is None:
        usage = (wgpu.TextureUsage.STORAGE_BINDING | wgpu.TextureUsage.TEXTURE_BINDING
                 | wgpu.TextureUsage.COPY_DST | wgpu.TextureUsage.COPY_SRC)
    return device.create_texture(label=label, size=(int(width), int(height), 1),
                                 format=format, usage=usage, dimension="2d", mip_level_count=1,
                                 sample_count=1)


def upload_texture(device, texture, data) -> None:
    """Write an (H, W, ...) array whose row bytes match the texture's format."""
    data = np.ascontiguousarray(data)
    w, h = texture.size[0], texture.size[1]
    if data.shape[:2] != (h, w):
        raise AquaspecError(f"texture {texture.label!r} is {w}x{h}; data has shape {data.shape}")
    device.queue.write_texture({"texture": texture, "mip_level": 0, "origin": (0, 0, 0)},
                               data, {"offset": 0, "bytes_per_row": data.nbytes // h},
                               (w, h, 1))


def read_texture(device, texture, dtype, channels: int) -> np.ndarray:
    """Read a texture back as an (H, W, channels) array of ``dtype``."""
    dtype = np.dtype(dtype)
    w, h = texture.size[0], texture.size[1]
    row = w * channels * dtype.itemsize
    raw = device.queue.read_texture({"texture": texture, "mip_level": 0, "origin": (0, 0, 0)},
                                    {"offset": 0, "bytes_per_row": row}, (w, h, 1))
    return np.frombuffer(raw, dtype=dtype, count=w * h * channels).reshape(h, w, channels).copy()


def create_array_texture(device, data, *, label: str = ""):
    """A sampled ``rgba32float`` 2-D array texture holding texels ``(layers, rows, cols, 4)``;
    returns its ``2d-array`` view."""
    data = np.ascontiguousarray(data, dtype=np.float32)
    layers, rows, cols = data.shape[:3]
    tex = device.create_texture(
        label=label, size=(cols, rows, layers), format="rgba32float",
        usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST,
        dimension="2d", mip_level_count=1, sample_count=1)
    device.queue.write_texture({"texture": tex, "mip_level": 0, "origin": (0, 0, 0)},
                               data, {"offset": 0, "bytes_per_row": cols * 16,
                                      "rows_per_image": rows}, (cols, rows, layers))
    return tex.create_view(dimension="2d-array")
