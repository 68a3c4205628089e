"""Small GPU utilities: storage buffers, textures, readback and pass timing.

Every helper takes the wgpu ``device`` explicitly (from
:func:`aquaspec.gpu.device.get_device`) so that passes never pick a device
behind the caller's back.

Timing
------
:func:`time_passes` measures GPU time per pass with timestamp queries when
the device has the ``"timestamp-query"`` feature (wgpu-native resolves them
in device ticks; they are scaled by the queue's timestamp period), otherwise
with a wall clock around ``submit`` + wait, which also counts submission and
synchronisation overhead; the result says which method was used.
"""

from __future__ import annotations

import statistics
import time
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from aquaspec.errors import AquaspecError

#: Storage buffers are sized in multiples of this many bytes (vec4 alignment).
BUFFER_ALIGN = 16


def _wgpu():
    import wgpu
    return wgpu


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
    wgpu = _wgpu()
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


def create_uniform_buffer(device, layout, *, label: str = ""):
    """A uniform buffer sized for a :class:`~aquaspec.gpu.layout.UniformLayout`."""
    wgpu = _wgpu()
    return device.create_buffer(label=label, size=layout.size,
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
    wgpu = _wgpu()
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


def timestamps_supported(device) -> bool:
    """True when the device was created with the ``"timestamp-query"`` feature."""
    return "timestamp-query" in device.features


def timestamp_period_ns(device) -> tuple[float, bool]:
    """Nanoseconds per timestamp tick, and whether the driver reported it.

    wgpu-native resolves timestamps in device ticks, not nanoseconds; its
    ``wgpuQueueGetTimestampPeriod`` gives the scale. When the installed
    wgpu-py cannot reach it, 1 ns per tick is assumed (true on most drivers,
    lavapipe included) and the second value is False.
    """
    try:
        from wgpu.backends.wgpu_native._ffi import lib
        return float(lib.wgpuQueueGetTimestampPeriod(device.queue._internal)), True
    except (ImportError, AttributeError):
        return 1.0, False


@dataclass
class PassTimes:
    """Result of :func:`time_passes`.

    Attributes
    ----------
    ms : dict
        Median time per pass in milliseconds, keyed like the input passes.
    method : str
        ``"timestamp-query"`` (GPU time of the pass alone) or
        ``"wall-clock"`` (submit + wait per pass, includes overhead).
    frames : int
        Number of timed frames (after ``warmup`` untimed ones).
    samples_ms : dict
        Every timed sample per pass.
    notes : list of str
    """

    ms: dict
    method: str
    frames: int
    samples_ms: dict = field(repr=False, default_factory=dict)
    notes: list = field(default_factory=list)


def _time_timestamps(device, passes, frames, warmup):
    wgpu = _wgpu()
    names = list(passes)
    count = 2 * len(names)
    qs = device.create_query_set(label="aquaspec timing", type=wgpu.QueryType.timestamp,
                                 count=count)
    resolve = device.create_buffer(label="aquaspec timing resolve", size=8 * count,
                                   usage=wgpu.BufferUsage.QUERY_RESOLVE | wgpu.BufferUsage.COPY_SRC)
    period, known = timestamp_period_ns(device)
    samples = {k: [] for k in names}
    for f in range(warmup + frames):
        enc = device.create_command_encoder()
        for i, name in enumerate(names):
            passes[name].encode(enc, timestamp_writes={
                "query_set": qs, "beginning_of_pass_write_index": 2 * i,
                "end_of_pass_write_index": 2 * i + 1})
        enc.resolve_query_set(qs, 0, count, resolve, 0)
        device.queue.submit([enc.finish()])
        ticks = np.frombuffer(device.queue.read_buffer(resolve), dtype=np.uint64)
        if f < warmup:
            continue
        for i, name in enumerate(names):
            begin, end = int(ticks[2 * i]), int(ticks[2 * i + 1])
            if end < begin or begin == 0:
                return None
            samples[name].append((end - begin) * period * 1e-6)
    notes = [] if known else ["timestamp period not reported by the driver; 1 ns/tick assumed"]
    return samples, notes


def _time_wall_clock(device, passes, frames, warmup):
    wgpu = _wgpu()
    # Waiting on a tiny readback: queue.on_submitted_work_done_sync() fails
    # inside wgpu-py 0.32's callback binding, and a readback is ordered after
    # every earlier submission anyway.
    fence = device.create_buffer(label="aquaspec timing fence", size=BUFFER_ALIGN,
                                 usage=wgpu.BufferUsage.COPY_SRC)
    samples = {k: [] for k in passes}
    for f in range(warmup + frames):
        for name, p in passes.items():
            enc = device.create_command_encoder()
            p.encode(enc)
            t0 = time.perf_counter()
            device.queue.submit([enc.finish()])
            device.queue.read_buffer(fence)
            dt = (time.perf_counter() - t0) * 1e3
            if f >= warmup:
                samples[name].append(dt)
    return samples, []


#: Timing methods accepted by :func:`time_passes` (besides ``"auto"``).
TIMING_METHODS = {"timestamp-query": _time_timestamps, "wall-clock": _time_wall_clock}


def time_passes(passes: Mapping[str, object], *, frames: int = 20, warmup: int = 3,
                method: str = "auto", device=None) -> PassTimes:
    """Median GPU time per pass, in milliseconds.

    Parameters
    ----------
    passes : mapping of str to pass
        Each pass has ``encode(encoder, timestamp_writes=None)`` recording its
        compute (or render) pass into a command encoder, as
        :class:`~aquaspec.gpu.passes.deferred.DeferredPass` and
        :class:`~aquaspec.gpu.passes.copy.CopyPass` do; it must be ready to run.
    frames : int
        Timed frames (>= 1); the median over them is reported.
    warmup : int
        Untimed frames first (>= 0): pipeline compilation and caches.
    method : {"auto", "timestamp-query", "wall-clock"}
        ``"auto"`` uses timestamp queries when the device supports them and
        falls back to the wall clock otherwise (or if the driver returns
        unusable timestamps).
    device : wgpu.GPUDevice, optional
        Default: the shared device.

    Returns
    -------
    PassTimes
    """
    if not passes:
        raise AquaspecError("time_passes needs at least one pass")
    if isinstance(frames, bool) or not isinstance(frames, int) or frames < 1:
        raise AquaspecError(f"frames={frames!r}; accepted: an integer >= 1")
    if isinstance(warmup, bool) or not isinstance(warmup, int) or warmup < 0:
        raise AquaspecError(f"warmup={warmup!r}; accepted: an integer >= 0")
    if method not in ("auto", *TIMING_METHODS):
        raise AquaspecError(f"timing method {method!r} is unknown; accepted: auto, "
                            f"{', '.join(TIMING_METHODS)}")
    if device is None:
        from aquaspec.gpu.device import get_device
        _, device = get_device()
    notes = []
    result = None
    if method in ("auto", "timestamp-query"):
        if timestamps_supported(device):
            result = _time_timestamps(device, passes, frames, warmup)
            if result is None:
                notes.append("the driver returned unusable timestamps")
        else:
            notes.append("device lacks the 'timestamp-query' feature")
        if result is None and method == "timestamp-query":
            raise AquaspecError("timing method 'timestamp-query' is unavailable: "
                                + "; ".join(notes) + "; use method='wall-clock' or 'auto'")
        used = "timestamp-query"
    if result is None:
        result = _time_wall_clock(device, passes, frames, warmup)
        used = "wall-clock"
    samples, more = result
    return PassTimes(ms={k: float(statistics.median(v)) for k, v in samples.items()},
                     method=used, frames=frames, samples_ms=samples, notes=notes + more)


def record_dispatch(encoder, pipeline, bind_group, workgroups, timestamp_writes=None) -> None:
    """Record one compute pass: ``pipeline`` with ``bind_group`` over ``workgroups``.

    ``timestamp_writes`` (optional) brackets the pass for :func:`time_passes`.
    """
    record_dispatches(encoder, [(pipeline, bind_group, workgroups)], timestamp_writes)


def record_dispatches(encoder, dispatches, timestamp_writes=None) -> None:
    """Record ``(pipeline, bind_group, workgroups)`` dispatches in order in one compute pass.

    Each dispatch is its own usage scope (WebGPU), so a dispatch may read what
    the one before wrote. One pass instead of one per dispatch: on lavapipe a
    compute pass of its own cost a small dispatch 40-90 us, in a shared pass
    20-40 us (measured with 21 dispatches of 1-64 workgroups).
    """
    kwargs = {} if timestamp_writes is None else {"timestamp_writes": timestamp_writes}
    cp = encoder.begin_compute_pass(**kwargs)
    for pipeline, bind_group, workgroups in dispatches:
        cp.set_pipeline(pipeline)
        cp.set_bind_group(0, bind_group)
        cp.dispatch_workgroups(*workgroups)
    cp.end()


def submit_pass(device, gpu_pass) -> None:
    """Record ``gpu_pass.encode`` into a new encoder and submit it (does not wait)."""
    enc = device.create_command_encoder()
    gpu_pass.encode(enc)
    device.queue.submit([enc.finish()])
