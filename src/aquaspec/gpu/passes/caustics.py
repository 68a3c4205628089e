"""The caustics of a moving sea on the GPU: a loop's two frames mixed per frame.

A caustic map costs most of a second to build on the CPU
(:mod:`aquaspec.light.caustics`; on lavapipe the photon splat alone, with
fixed-point atomics, measured 1.1-2.1 s per instant), so the moving sea is a
:class:`aquaspec.light.caustics.CausticLoop` built once per sea state and
sun, kept here as one storage buffer per frame. Per frame, ``caustics.wgsl``
mixes the two frames around the waves' time (NumPy twin
:meth:`aquaspec.light.caustics.CausticLoop.levels_at`) into a buffer that is
copied into the ``r16float`` 2-D array texture with mips that the sun pass
samples (:meth:`aquaspec.gpu.passes.sun.SunPass.use_caustic_texture`).
A loop still being built in the background is uploaded frame by frame as
its frames arrive and read between those uploaded (as
:meth:`aquaspec.light.caustics.CausticLoop.frame_weights` says for them);
with one frame, or without the mix, a frame is copied as it is (0.6-1 ms
against 5-6 ms for the mix at the default size on lavapipe).

Bindings of caustics.wgsl: 0 uniform ``LoopParams`` (the mix weight, the
word count); 1, 2 the two frames (read); 3 the mixed frame (written).
A frame's layout: level by level, slice by slice, rows of half floats
padded to :data:`ROW_ALIGN` bytes (the texture copy's row pitch).
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_storage_buffer, upload_buffer
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatch
from aquaspec.gpu.shaders import load_wgsl
from aquaspec.light.caustics import CausticGeometry, CausticLoop

#: The texture format the sun pass samples (half floats, filterable in core WebGPU).
CAUSTIC_FORMAT = "r16float"
#: Row pitch of buffer -> texture copies, bytes (WebGPU).
ROW_ALIGN = 256
#: Invocations per workgroup of caustics.wgsl, and vec4 words per dispatch row.
WORKGROUP = 64
ROW_WORDS = 64 * 1024
#: Frames of a loop still being built uploaded per :meth:`CausticLoopPass.encode`.
UPLOADS_PER_ENCODE = 1


def level_layout(n: int, slices: int, levels: int) -> list:
    """``(offset_bytes, row_bytes, side)`` of each mip level in a frame's buffer."""
    out, offset = [], 0
    for m in range(levels):
        side = max(1, n >> m)
        row = -(-2 * side // ROW_ALIGN) * ROW_ALIGN
        out.append((offset, row, side))
        offset += row * side * slices
    return out


def pack_frame(levels) -> np.ndarray:
    """A frame's mip levels (each (K, n_m, n_m)) as half floats in the buffer
    layout of :func:`level_layout`, padded to a whole number of vec4 words."""
    k, n = levels[0].shape[0], levels[0].shape[-1]
    parts = []
    for (_, row, side), lv in zip(level_layout(n, k, len(levels)), levels):
        padded = np.zeros((k, side, row // 2), np.float16)
        padded[:, :, :side] = lv
        parts.append(padded.reshape(-1))
    flat = np.concatenate(parts)
    return np.concatenate([flat, np.zeros(-flat.size % 8, np.float16)])


class CausticLoopPass:
    """A caustic loop on the GPU and the texture of its current instant.

    Parameters
    ----------
    device : wgpu.GPUDevice
    loop : CausticLoop
        Its frames are uploaded once each (every frame's levels: about 6.3 MB
        a frame at the default 256 texels and 32 slices): those ready now,
        the others as the loop's background build makes them
        (:meth:`encode`).
    smooth : bool
        Mix the two frames around the time (continuous in time; on lavapipe
        4.4-5.3 ms at the default size); False: copy the nearest frame (no
        compute pass, 0.6 ms, but the factor steps from frame to frame).
    """

    def __init__(self, device, loop: CausticLoop, *, smooth: bool = True):
        self.device = device
        self.loop = loop
        self.smooth = bool(smooth)
        geo = loop.geometry
        self.geometry: CausticGeometry = geo
        n = loop.level0.shape[-1]
        self._layout = level_layout(n, geo.slices, geo.levels)
        #: The frames on the GPU (one storage buffer each; None: not yet).
        self._frames = [None] * loop.frames
        self.uploaded = np.zeros(loop.frames, bool)
        self._upload(np.flatnonzero(loop.ready))
        self.words = self._frames[0].size // 16
        self._mixed = create_storage_buffer(device, self._frames[0].size,
                                            label="caustics now")
        self._params = device.create_buffer(
            label="caustic loop params", size=16,
            usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
        #: The texture the sun samples: (n, n, K) r16float with the loop's mip levels.
        self.texture = device.create_texture(
            label="caustics now", size=(n, n, geo.slices), format=CAUSTIC_FORMAT,
            mip_level_count=geo.levels, dimension="2d",
            usage=wgpu.TextureUsage.TEXTURE_BINDING | wgpu.TextureUsage.COPY_DST
            | wgpu.TextureUsage.COPY_SRC)
        self.view = self.texture.create_view(dimension="2d-array")
        self._bind_layout = bind_group_layout(device, {0: "uniform", 1: "read", 2: "read",
                                                       3: "write"})
        self._pipeline = compute_pipeline(device, self._bind_layout,
                                          load_wgsl("caustics.wgsl"), "caustics.wgsl")
        self._groups = {}
        #: The waves' time of the last :meth:`encode`, s.
        self.time_s = None
        self._held = None

    def _upload(self, frames) -> None:
        for f in frames:
            self._frames[f] = create_storage_buffer(
                self.device, pack_frame(self.loop.frame_levels(f)),
                label=f"caustic loop frame {f}")
            self.uploaded[f] = True

    def _group(self, f0: int, f1: int):
        if (f0, f1) not in self._groups:
            self._groups[(f0, f1)] = self.device.create_bind_group(
                layout=self._bind_layout, entries=bind_group_entries(
                    {0: self._params, 1: self._frames[f0], 2: self._frames[f1],
                     3: self._mixed}))
        return self._groups[(f0, f1)]

    def encode(self, encoder, time_s: float, timestamp_writes=None) -> None:
        """Record the caustics at ``time_s`` into :attr:`texture` (the mix
        weight is uploaded now: one :meth:`encode` per submission;
        ``timestamp_writes`` bracket the mix's compute pass). Nothing is
        recorded when the texture holds that time already (waves standing
        still cost nothing), unless ``timestamp_writes`` asks for a timing.

        A loop still being built (:attr:`CausticLoop.ready`) is read between
        the frames uploaded so far; each call uploads at most
        :data:`UPLOADS_PER_ENCODE` newly built frames (30-50 ms each on lavapipe).
        """
        new = np.flatnonzero(self.loop.ready & ~self.uploaded)[:UPLOADS_PER_ENCODE]
        self._upload(new)
        f0, f1, a = self.loop.frame_weights(time_s, ready=self.uploaded)
        held = (float(time_s), self.smooth, int(self.uploaded.sum()))
        if held == self._held and timestamp_writes is None:
            return
        if self.smooth and f1 != f0:
            upload_buffer(self.device, self._params, _params(a, self.words))
            record_dispatch(encoder, self._pipeline, self._group(f0, f1),
                            (ROW_WORDS // WORKGROUP, -(-self.words // ROW_WORDS), 1),
                            timestamp_writes)
            source = self._mixed
        else:
            source = self._frames[f1 if a >= 0.5 else f0]
        k = self.geometry.slices
        for m, (offset, row, side) in enumerate(self._layout):
            encoder.copy_buffer_to_texture(
                {"buffer": source, "offset": offset, "bytes_per_row": row,
                 "rows_per_image": side},
                {"texture": self.texture, "mip_level": m, "origin": (0, 0, 0)},
                (side, side, k))
        self.time_s = float(time_s)
        self._held = held

    def read_levels(self) -> list:
        """The texture's levels as float32 arrays (K, n_m, n_m) (tests)."""
        if self.time_s is None:
            raise AquaspecError("CausticLoopPass.encode() first")
        out = []
        k = self.geometry.slices
        for m, (_, row, side) in enumerate(self._layout):
            raw = self.device.queue.read_texture(
                {"texture": self.texture, "mip_level": m, "origin": (0, 0, 0)},
                {"offset": 0, "bytes_per_row": row, "rows_per_image": side}, (side, side, k))
            a = np.frombuffer(raw, np.float16, count=k * side * row // 2)
            out.append(a.reshape(k, side, row // 2)[:, :, :side].astype(np.float32))
        return out


def _params(a: float, words: int) -> np.ndarray:
    p = np.zeros(4, np.uint32)
    p[0] = np.float32(a).view(np.uint32)
    p[1], p[2] = words, ROW_WORDS
    return p
