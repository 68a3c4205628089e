"""The forward cone's light spread over the image on the GPU (an image pyramid).

Twin of :func:`aquaspec.conespread.spread` (WGSL: ``shaders/conespread.wgsl``;
``tests/test_gpu_lightfield.py`` holds the light-field pass with the spread
against its NumPy twin). The light-field pass's COARSE pipeline writes the
cone term at the spread's start level (:attr:`ConeSpreadPass.cone_texture`,
``rgba32float`` storage texture, :mod:`aquaspec.lightfield_compiled`); this
pass halves it ``L`` times (``down``) and sums the levels back up with their
weights (``compose``) into :attr:`ConeSpreadPass.result`, which the
full-resolution light-field pass adds with one bilinear sample.

Bindings of conespread.wgsl (one layout for both entry points):

==  ==================================  ==========================================
0   uniform :data:`PARAMS_LAYOUT`       sizes of the source, destination and
                                        coarse level; weights ``a``, ``b``
1   texture ``rgba32float``             source level
2   texture ``rgba32float``             coarse level (read bilinearly)
3   sampler                             linear (``filtering``) or nearest
4   storage texture ``rgba32float``     destination level
==  ==================================  ==========================================
"""

from __future__ import annotations

import numpy as np

from ..conespread import level_shapes
from ..errors import AquaspecError
from .buffers import create_texture, upload_buffer
from .layout import UniformLayout
from .shaders import load_wgsl

PARAMS_LAYOUT = UniformLayout("ConeSpreadParams", [
    ("src_size", "vec2<u32>"), ("dst_size", "vec2<u32>"), ("coarse_size", "vec2<u32>"),
    ("a", "f32"), ("b", "f32"),
])

#: Workgroup size of all three entry points.
WORKGROUP = (8, 8)


class ConeSpreadPass:
    """Pyramid levels and dispatches for one image size and level count."""

    def __init__(self, device, width: int, height: int, levels: int, *, filtering: bool):
        import wgpu
        from .deferred import bind_group_layout
        self.device = device
        self.width, self.height, self.levels = int(width), int(height), int(levels)
        self.filtering = bool(filtering)
        self.shapes = level_shapes(self.height, self.width, self.levels)
        usage = (wgpu.TextureUsage.STORAGE_BINDING | wgpu.TextureUsage.TEXTURE_BINDING)
        #: Level 0: the cone term written by the light-field pass (COARSE).
        self.cone_texture = create_texture(device, self.width, self.height, "rgba32float",
                                           label="cone level 0", usage=usage)
        #: The spread cone term at level 0's size (U_0).
        self.result = create_texture(device, self.width, self.height, "rgba32float",
                                     label="cone spread", usage=usage)
        # P_1 .. P_L, and U_0 .. U_{L-1} (U_L is P_L weighted).
        self._p = [self.cone_texture] + [
            create_texture(device, w, h, "rgba32float", label=f"cone level {k}", usage=usage)
            for k, (h, w) in enumerate(self.shapes[1:], start=1)]
        self._u = [self.result] + [
            create_texture(device, w, h, "rgba32float", label=f"cone sum {k}", usage=usage)
            for k, (h, w) in enumerate(self.shapes[1:-1], start=1)]
        tex = "filterable" if self.filtering else "float"
        self._layout = bind_group_layout(device, {
            0: "uniform", 1: tex, 2: tex, 3: "sampler" if self.filtering else "nonfiltering_sampler",
            4: "storage_rgba32float"})
        mode = "linear" if self.filtering else "nearest"
        self._sampler = device.create_sampler(label="cone spread", mag_filter=mode,
                                              min_filter=mode, address_mode_u="clamp-to-edge",
                                              address_mode_v="clamp-to-edge")
        self._pipelines = {}
        self._steps = None
        self._weights = None

    # ------------------------------------------------------------ pipelines
    def _pipeline(self, entry):
        key = entry
        if key not in self._pipelines:
            src = load_wgsl("conespread.wgsl", params_struct=PARAMS_LAYOUT.wgsl(),
                            params_struct_name=PARAMS_LAYOUT.name,
                            filter="true" if self.filtering else "false")
            module = self.device.create_shader_module(label="conespread.wgsl", code=src)
            self._pipelines[key] = self.device.create_compute_pipeline(
                label=f"cone spread {entry}",
                layout=self.device.create_pipeline_layout(bind_group_layouts=[self._layout]),
                compute={"module": module, "entry_point": entry})
        return self._pipelines[key]

    def set_weights(self, weights) -> None:
        """Level weights (levels + 1,), :func:`aquaspec.conespread.fit_weights`."""
        w = np.asarray(weights, dtype=float)
        if w.shape != (self.levels + 1,):
            raise AquaspecError(f"{w.size} pyramid weights for {self.levels} levels; "
                                f"accepted: {self.levels + 1}")
        if self._weights is not None and np.array_equal(w, self._weights):
            return
        self._weights = w
        self._steps = self._build_steps(w)

    def _build_steps(self, w):
        """(entry, bind group, workgroups) per dispatch, uniforms uploaded."""
        from .buffers import create_uniform_buffer
        from .deferred import bind_group_entries
        dev = self.device
        L = self.levels
        steps = []

        def step(entry, src, coarse, dst, a, b, dst_shape, src_shape, coarse_shape):
            buf = create_uniform_buffer(dev, PARAMS_LAYOUT, label=f"cone {entry}")
            upload_buffer(dev, buf, PARAMS_LAYOUT.pack(
                src_size=(src_shape[1], src_shape[0]), dst_size=(dst_shape[1], dst_shape[0]),
                coarse_size=(coarse_shape[1], coarse_shape[0]), a=a, b=b))
            res = {0: buf, 1: src, 2: coarse, 3: self._sampler, 4: dst}
            group = dev.create_bind_group(layout=self._layout, entries=bind_group_entries(res))
            groups = (-(-dst_shape[1] // WORKGROUP[0]), -(-dst_shape[0] // WORKGROUP[1]), 1)
            steps.append((entry, group, groups))

        sh = self.shapes
        for k in range(1, L + 1):
            # `down` does not read the coarse binding; it gets the source level
            # again (a texture may not be read and written in one dispatch).
            step("down", self._p[k - 1], self._p[k - 1], self._p[k], 0.0, 0.0,
                 sh[k], sh[k - 1], sh[k - 1])
        if L == 0:
            # One level: U_0 = a_0 P_0 (the coarse binding is not used, b = 0).
            step("compose", self._p[0], self._p[0], self._u[0], w[0], 0.0, sh[0], sh[0], sh[0])
        for k in range(L - 1, -1, -1):
            coarse, b = (self._p[L], w[L]) if k == L - 1 else (self._u[k + 1], 1.0)
            step("compose", self._p[k], coarse, self._u[k], w[k], b, sh[k], sh[k], sh[k + 1])
        return steps

    def dispatches(self) -> list:
        """The pyramid's ``(pipeline, bind group, workgroups)`` in order, to record
        after the light-field pass's COARSE dispatch (weights set first)."""
        if self._steps is None:
            raise AquaspecError("ConeSpreadPass needs set_weights() before dispatches()")
        return [(self._pipeline(entry), group, groups) for entry, group, groups in self._steps]
