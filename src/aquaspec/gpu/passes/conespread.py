"""The forward cone's light spread over the image on the GPU (an image pyramid).

Twin of :func:`aquaspec.transport.lightfield.conespread.spread` (WGSL: ``conespread.wgsl``
beside this module; ``tests/gpu/passes/test_conespread_pass.py`` holds this pass
against the NumPy reference, ``tests/gpu/passes/test_lightfield_pass.py`` the
light-field pass with the spread against
its NumPy twin). The light-field pass's COARSE pipeline writes the cone term
at the spread's start level (:attr:`ConeSpreadPass.cone_texture`,
``rgba32float`` storage texture, :mod:`aquaspec.transport.lightfield.compiled`); this
pass halves it ``L`` times and sums the levels back up with their weights into
:attr:`ConeSpreadPass.result`, which the full-resolution light-field pass adds
with one bilinear sample.

All of it is one dispatch of one workgroup (:data:`WORKGROUP` invocations
looping over each level, a storage barrier between levels) instead of one
dispatch per level and direction (2L): on lavapipe a small dispatch costs
20-40 us of overhead, more than the work of most levels. The levels above 0
(and, in place, the partial sums ``U_1 .. U_{L-1}``) live in one storage
buffer. Level sizes, offsets and weights are in a uniform, so one shader
serves every size and level count (literal sizes were about 10 % faster to
run but cost a 1.2-1.8 s compile for every new size on lavapipe) and new
weights need no new pipeline. Measured on lavapipe (2 cores, the pyramid
recorded 50 times in one compute pass): 160x90 with 5 levels (1280x720)
0.36-0.38 ms against 0.60-0.67 ms for the per-level dispatches, 240x135 with
6 levels (1920x1080) 0.76-0.80 ms against 0.95-1.16 ms; in the 1280x720
frame (``aquaspec bench``, 8 bands, medians of six runs) the light-field
pass went from 21.05 to 20.70 ms, lightfield / seeds from 1.103 to 1.094.
What is left is mostly level 0's work on one thread (its halving, and the
textureStore of U_0, about 5 ns a texel), so the one thread loses for large
images: at 3840x2160 (480x270 with 8 levels) 3.1 ms against 2.4 ms for the
per-level dispatches, under 1 % of such a frame.

Bindings of conespread.wgsl:

==  ==================================  ==========================================
0   uniform ``Pyramid``                 L; per level ``(width, height, offset
                                        in binding 2, 0)``; weights ``a_0 ..
                                        a_L``, four to a vec4 (sized for
                                        :data:`MAX_LEVELS`)
1   texture ``rgba32float``             level 0 (:attr:`cone_texture`), read
                                        with textureLoad
2   storage ``array<vec4<f32>>``        levels 1 .. L, row-major, one after the
                                        other (:attr:`ConeSpreadPass.offsets`)
3   storage texture ``rgba32float``     U_0 (:attr:`result`)
4   storage ``array<vec4<f32>>``        added to level 0 when :meth:`set_extra`
                                        is on (one slot only):
                                        :attr:`extra`, the lamps' lit surfaces'
                                        cone share
                                        (:meth:`aquaspec.gpu.passes.lamps.LampPass.encode_cone`)
==  ==================================  ==========================================

The lamps' share (:attr:`extra`) is written by their pass before the light
field's and added where level 0 is read: the lamps' forward-scattered light
spreads with the daylight's kernel (:mod:`aquaspec.shading.lamp`).
"""

from __future__ import annotations

import numpy as np

from aquaspec.transport.lightfield.conespread import level_shapes
from aquaspec.errors import AquaspecError
from aquaspec.gpu.bindings import bind_group_entries, bind_group_layout
from aquaspec.gpu.buffers import create_storage_buffer, create_texture, create_uniform_buffer, upload_buffer
from aquaspec.gpu.dispatch import compute_pipeline, record_dispatches
from aquaspec.gpu.shaders import load_wgsl

#: Invocations of the one workgroup. On lavapipe (8-wide SIMD) 8 measured
#: about 4 % faster than 32 (one group of lanes, nothing to switch at a
#: barrier), 64 alike, 256 25-30 % slower; 32 keeps a whole warp on a GPU.
WORKGROUP = 32
#: Rows one invocation walks down a level (carrying the rows the next one
#: shares): 16-64 measured alike, 4 1.1x slower, 1 (no sharing) 1.6-1.8x.
ROWS = 32
#: Most levels below level 0 (the uniform's arrays are this long, plus one).
MAX_LEVELS = 15


def _uniform_layout(slots: int = 1):
    """(byte offset of the weights, of the node masks, size) of
    conespread.wgsl's ``Pyramid``: count (vec4<u32>), one vec4<u32> per level
    (MAX_LEVELS + 1), the weights four to a vec4<f32>, then 3 ``slots``
    vec4<f32> per level (the node masks)."""
    weight = 16 + 16 * (MAX_LEVELS + 1)
    mask = weight + 16 * ((MAX_LEVELS + 4) // 4)
    return weight, mask, mask + 16 * 3 * slots * (MAX_LEVELS + 1)


def slots_for(nodes: int) -> int:
    """Vec4 per texel for ``nodes`` node images of camera RGB (1 for one image)."""
    return 1 if nodes <= 1 else -(-3 * nodes // 4)


def node_masks(weights) -> np.ndarray:
    """conespread.wgsl's node masks for node weights ``(K, levels + 1)``:
    ``(levels + 1, slots, 3, 4)``, value ``q = 4 m + j`` of slot ``m`` being
    node ``q // 3``, channel ``q % 3``: mask ``[l, m, c, j] = a[q // 3, l]``
    where ``q % 3 == c`` (and ``q < 3 K``), else 0."""
    a = np.asarray(weights, dtype=float)
    k, n = a.shape
    slots = slots_for(k)
    out = np.zeros((n, slots, 3, 4))
    for q in range(3 * k):
        out[:, q // 4, q % 3, q % 4] = a[q // 3]
    return out


class ConeSpreadPass:
    """The pyramid's buffers and its one dispatch for one image size and level count
    (every level read with exact fetches: no sampler, so no need for
    float32-filterable)."""

    def __init__(self, device, width: int, height: int, levels: int, nodes: int = 1):
        self.device = device
        self.width, self.height, self.levels = int(width), int(height), int(levels)
        if self.width < 1 or self.height < 1 or not 0 <= self.levels <= MAX_LEVELS:
            raise AquaspecError(f"cone spread of {width}x{height} with {levels} levels; "
                                f"accepted: at least 1x1, 0 to {MAX_LEVELS} levels")
        self.shapes = level_shapes(self.height, self.width, self.levels)
        #: Node images per texel (the multiple-scattering spread) and the vec4
        #: they take (:func:`slots_for`); level 0's slot ``m`` is the cone
        #: texture's columns ``m width .. (m + 1) width - 1``.
        self.nodes, self.slots = int(nodes), slots_for(int(nodes))
        sizes = [h * w for h, w in self.shapes]
        #: First element of each level in the level buffer (level 0 is the
        #: texture: 0, unused).
        self.offsets = [0] + [int(sum(sizes[1:k])) for k in range(1, self.levels + 1)]
        # Both textures also allow copies (the tests upload level 0 and read
        # the result).
        #: Level 0: the cone term written by the light-field pass (COARSE).
        self.cone_texture = create_texture(device, self.width * self.slots, self.height,
                                           "rgba32float", label="cone level 0")
        #: The spread cone term at level 0's size (U_0).
        self.result = create_texture(device, self.width, self.height, "rgba32float",
                                     label="cone spread")
        self._levels_buffer = create_storage_buffer(
            device, 16 * self.slots * max(1, sum(sizes[1:])), label="cone levels")
        #: Level 0's extra input (vec4 per texel, row-major), added with
        #: :meth:`set_extra` on: the lamps' cone share.
        self.extra = create_storage_buffer(device, 16 * self.width * self.height,
                                           label="cone level 0 extra")
        self.extra_on = False
        self._weight_at, self._mask_at, nbytes = _uniform_layout(self.slots)
        self._uniform = create_uniform_buffer(device, nbytes, label="cone spread")
        table = np.zeros((1 + MAX_LEVELS + 1, 4), np.uint32)
        table[0, 0] = self.levels
        for k, ((h, w), off) in enumerate(zip(self.shapes, self.offsets)):
            table[1 + k, :3] = (w, h, off)
        upload_buffer(device, self._uniform, table)
        self._layout = bind_group_layout(device, {0: "uniform", 1: "float", 2: "write",
                                                  3: "storage_rgba32float", 4: "read"})
        self._group = device.create_bind_group(layout=self._layout, entries=bind_group_entries(
            {0: self._uniform, 1: self.cone_texture, 2: self._levels_buffer,
             3: self.result, 4: self.extra}))
        self._pipeline = None
        self._weights = None

    def pipeline(self):
        """The compute pipeline (made when first used)."""
        if self._pipeline is None:
            src = load_wgsl("conespread.wgsl", workgroup=WORKGROUP, rows=ROWS,
                            max_levels=MAX_LEVELS, slots=self.slots)
            self._pipeline = compute_pipeline(self.device, self._layout, src, "conespread.wgsl")
        return self._pipeline

    def set_extra(self, on: bool) -> None:
        """Add :attr:`extra` to level 0 (from the next submission) or not; one
        slot only (the single-scattering spread)."""
        on = bool(on)
        if on and self.slots != 1:
            raise AquaspecError("the cone spread's extra input takes one image (the "
                                f"single-scattering spread); this pass has {self.nodes} nodes")
        if on != self.extra_on:
            upload_buffer(self.device, self._uniform, np.array([int(on)], np.uint32), 4)
            self.extra_on = on

    def set_weights(self, weights) -> None:
        """Level weights (levels + 1,), :func:`aquaspec.transport.lightfield.conespread.fit_weights`
        (written to the uniform: the next submission uses them); with nodes,
        each node's ``(nodes, levels + 1)`` (:func:`aquaspec.transport.lightfield.conespread.spread_nodes`)."""
        w = np.asarray(weights, dtype=float)
        if self.nodes > 1:
            want = (self.nodes, self.levels + 1)
            if w.shape != want:
                raise AquaspecError(f"node weights of shape {w.shape} for {self.nodes} nodes "
                                    f"and {self.levels} levels; accepted: {want}")
        elif w.shape != (self.levels + 1,):
            raise AquaspecError(f"{w.size} pyramid weights for {self.levels} levels; "
                                f"accepted: {self.levels + 1}")
        if self._weights is not None and np.array_equal(w, self._weights):
            return
        if self.nodes > 1:
            upload_buffer(self.device, self._uniform, node_masks(w).astype(np.float32),
                          self._mask_at)
        else:
            upload_buffer(self.device, self._uniform, w.astype(np.float32), self._weight_at)
        self._weights = w

    def dispatches(self) -> list:
        """The pyramid's ``(pipeline, bind group, workgroups)``: one dispatch of
        one workgroup, to record after the light-field pass's COARSE dispatch
        (weights set first)."""
        if self._weights is None:
            raise AquaspecError("ConeSpreadPass needs set_weights() before dispatches()")
        return [(self.pipeline(), self._group, (1, 1, 1))]

    def encode(self, encoder, timestamp_writes=None) -> None:
        """Record the pyramid alone into ``encoder`` (the light-field pass records
        :meth:`dispatches` in its own compute pass instead)."""
        record_dispatches(encoder, self.dispatches(), timestamp_writes)
