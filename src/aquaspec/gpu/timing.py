"""Timing GPU passes.

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
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.gpu.buffers import BUFFER_ALIGN
from aquaspec.gpu.device import get_device


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
        # deferred: wgpu-native's private bindings, absent from other backends
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
        every pass of :mod:`aquaspec.gpu.passes` does; it must be ready to run.
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
