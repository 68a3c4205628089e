"""Orthographic depth maps of the scene on the GPU, one per direction, in one texture array.

Each layer is the scene rasterised depth-only along one direction
(:class:`aquaspec.scene.shadowmap.ShadowMapSpec`: axes across the direction,
heights ``h = p . w`` along it, depth ``(h_max - h) / (h_max - h_min)``)
with ``depth_maps.wgsl`` beside this module, into a ``depth32float`` texture
array of ``size`` texels a side. The sun's shadow map is one such layer; the
ambient occlusion's maps (one per direction of its set) are many
(:class:`aquaspec.gpu.passes.sun_shadow.SunShadowPass` draws through this). A
layer may as well be a perspective view (a spec with its own ``clip_matrix``
and ``key``, such as a lamp's face, :mod:`aquaspec.scene.lamp_shadow`, drawn
by :class:`aquaspec.gpu.passes.lamps.LampPass`). NumPy twin:
:func:`aquaspec.scene.shadowmap.shadow_map_numpy` (the same map per layer).

Maps of static geometry are kept: :meth:`DepthMapArray.encode` draws again
only when the specs or the draw buffers change.

A draw may carry ``stride`` (bytes per vertex, position first; default the
geometry pass's :data:`aquaspec.gpu.passes.raster.VERTEX_STRIDE` of its
``mode``) and ``cull``: ``"none"`` (default) or ``"toward"``, which keeps
only the triangles whose outward normal (counter-clockwise winding) points
away from the map's direction, i.e. the side facing a receiver below it
(second-depth maps of closed occluders, :mod:`aquaspec.scene.occlusion`).
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.errors import AquaspecError
from aquaspec.scene.shadowmap import ShadowMapSpec
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.passes.raster import VERTEX_STRIDE
from aquaspec.gpu.shaders import load_wgsl

CLIP_LAYOUT = UniformLayout("DepthClip", [("clip", "mat4x4<f32>")])
DEPTH_FORMAT = "depth32float"


def spec_key(spec) -> tuple:
    """A map's geometry as a hashable value (equal specs draw equal maps); a
    spec with a ``key()`` of its own (a lamp's perspective face,
    :class:`aquaspec.scene.lamp_shadow.LampShadowFace`) gives that."""
    if hasattr(spec, "key"):
        return spec.key()
    return (tuple(np.asarray(spec.to_sun, float)), tuple(np.asarray(spec.e1, float)),
            tuple(np.asarray(spec.e2, float)), spec.u0, spec.v0, spec.texel, spec.size,
            spec.h_min, spec.h_max)


def draws_key(draws) -> tuple:
    """The draw calls' buffers as a hashable value (same buffers, same geometry)."""
    return tuple((id(d.vertex), id(d.index), d.count) for d in draws)


def _cull_mode(cull: str, spec: ShadowMapSpec) -> str:
    """The raster's cull mode for a draw's ``cull`` in ``spec``'s map."""
    if cull == "none":
        return "none"
    if cull != "toward":
        raise AquaspecError(f"depth map cull {cull!r}; accepted: 'none', 'toward'")
    # The clip matrix maps e1 to +x, e2 to -y and looks along -w (the viewer at
    # +w): a triangle whose outward normal points to the viewer (n . w > 0,
    # the side to cull) winds counter-clockwise on screen when (e1, -e2, w)
    # is right-handed.
    right_handed = float(np.dot(np.cross(spec.e1, -np.asarray(spec.e2)), spec.to_sun)) > 0
    return "front" if right_handed else "back"


class DepthMapArray:
    """``layers`` depth maps of ``size`` texels a side on ``device``."""

    def __init__(self, device, size: int, layers: int = 1, *, label: str = "depth maps"):
        if not (isinstance(size, (int, np.integer)) and 16 <= size <= 8192):
            raise AquaspecError(f"depth map size {size!r}; accepted: an integer 16 ... 8192")
        if not (isinstance(layers, (int, np.integer)) and 1 <= layers <= 256):
            raise AquaspecError(f"depth map layers {layers!r}; accepted: an integer 1 ... 256")
        self.device, self.size, self.layers = device, int(size), int(layers)
        self._texture = device.create_texture(
            label=label, size=(self.size, self.size, self.layers), format=DEPTH_FORMAT,
            usage=wgpu.TextureUsage.RENDER_ATTACHMENT | wgpu.TextureUsage.TEXTURE_BINDING
            | wgpu.TextureUsage.COPY_SRC)
        #: The whole array's view (``texture_depth_2d_array``).
        self.view = self._texture.create_view(dimension="2d-array")
        self._layer_views = [self._texture.create_view(dimension="2d", base_array_layer=k,
                                                       array_layer_count=1)
                             for k in range(self.layers)]
        self._module = device.create_shader_module(label="depth_maps.wgsl",
                                                   code=load_wgsl("depth_maps.wgsl"))
        clip_layout = device.create_bind_group_layout(entries=[
            {"binding": 0, "visibility": wgpu.ShaderStage.VERTEX,
             "buffer": {"type": wgpu.BufferBindingType.uniform}}])
        # One layout for every vertex stride's pipeline (a scene with several
        # mesh modes needs one bind group that all of them accept).
        self._layout = device.create_pipeline_layout(bind_group_layouts=[clip_layout])
        self._clips = [device.create_buffer(label=f"{label} clip {k}", size=CLIP_LAYOUT.size,
                                            usage=wgpu.BufferUsage.UNIFORM
                                            | wgpu.BufferUsage.COPY_DST)
                       for k in range(self.layers)]
        self._groups = [device.create_bind_group(layout=clip_layout, entries=[
            {"binding": 0, "resource": {"buffer": b, "offset": 0, "size": CLIP_LAYOUT.size}}])
            for b in self._clips]
        self._pipelines = {}
        self._drawn = None
        #: Times the maps were drawn (the other encodes kept them).
        self.draw_count = 0

    def layer_view(self, layer: int):
        """Layer ``layer``'s own view (``texture_depth_2d``)."""
        return self._layer_views[int(layer)]

    def pipeline(self, stride: int, cull: str = "none"):
        """The render pipeline for vertices of ``stride`` bytes and ``cull``
        mode (``"none"``, ``"front"``, ``"back"``; made when first used)."""
        if (stride, cull) not in self._pipelines:
            self._pipelines[stride, cull] = self.device.create_render_pipeline(
                label="depth map", layout=self._layout,
                vertex={"module": self._module, "entry_point": "vs_main", "buffers": [{
                    "array_stride": stride, "step_mode": wgpu.VertexStepMode.vertex,
                    "attributes": [{"format": wgpu.VertexFormat.float32x3, "offset": 0,
                                    "shader_location": 0}]}]},
                primitive={"topology": wgpu.PrimitiveTopology.triangle_list,
                           "front_face": wgpu.FrontFace.ccw, "cull_mode": cull},
                depth_stencil={"format": DEPTH_FORMAT, "depth_write_enabled": True,
                               "depth_compare": wgpu.CompareFunction.less},
                multisample={"count": 1}, fragment=None)
        return self._pipelines[stride, cull]

    def encode(self, encoder, draws, specs) -> bool:
        """Record the maps of ``draws`` (:meth:`aquaspec.gpu.passes.raster.RasterPass.draws`)
        for ``specs`` (one :class:`~aquaspec.scene.shadowmap.ShadowMapSpec` per
        layer, of this array's size); returns whether they were drawn (False:
        the maps held already match and were kept)."""
        specs = list(specs)
        if len(specs) != self.layers or any(s.size != self.size for s in specs):
            raise AquaspecError(f"{len(specs)} map specs of sizes {sorted({s.size for s in specs})}; "
                                f"this array holds {self.layers} maps of {self.size} texels")
        key = (tuple(spec_key(s) for s in specs), draws_key(draws))
        if key == self._drawn:
            return False
        self._drawn = None
        for k, spec in enumerate(specs):
            self.device.queue.write_buffer(self._clips[k], 0, np.ascontiguousarray(
                spec.clip_matrix().T, np.float32).tobytes())
            rp = encoder.begin_render_pass(
                color_attachments=[],
                depth_stencil_attachment={"view": self._layer_views[k], "depth_clear_value": 1.0,
                                          "depth_load_op": wgpu.LoadOp.clear,
                                          "depth_store_op": wgpu.StoreOp.store})
            for d in draws:
                stride = getattr(d, "stride", None) or VERTEX_STRIDE[d.mode]
                rp.set_pipeline(self.pipeline(stride, _cull_mode(getattr(d, "cull", "none"),
                                                                 spec)))
                rp.set_bind_group(0, self._groups[k])
                rp.set_vertex_buffer(0, d.vertex)
                rp.set_index_buffer(d.index, d.index_format)
                rp.draw_indexed(d.count)
            rp.end()
        self._drawn = key
        self.draw_count += 1
        return True

    def forget(self) -> None:
        """Draw the maps again on the next :meth:`encode`."""
        self._drawn = None

    def read(self, spec: ShadowMapSpec, layer: int = 0) -> np.ndarray:
        """Layer ``layer`` as heights ``h`` (size, size) float64 along ``spec``'s
        direction (``-inf`` where no surface), for tests."""
        z = self.read_raw(layer).astype(float)
        h = spec.h_max - z * (spec.h_max - spec.h_min)
        return np.where(z >= 1.0, -np.inf, h)

    def read_raw(self, layer: int = 0) -> np.ndarray:
        """Layer ``layer``'s depths as drawn (size, size) float32 (1: no surface), for tests."""
        n = self.size
        row = -(-4 * n // 256) * 256
        buf = self.device.create_buffer(size=row * n, usage=wgpu.BufferUsage.COPY_DST
                                        | wgpu.BufferUsage.MAP_READ)
        enc = self.device.create_command_encoder()
        enc.copy_texture_to_buffer({"texture": self._texture, "mip_level": 0,
                                    "origin": (0, 0, int(layer)),
                                    "aspect": wgpu.TextureAspect.depth_only},
                                   {"buffer": buf, "offset": 0, "bytes_per_row": row,
                                    "rows_per_image": n}, (n, n, 1))
        self.device.queue.submit([enc.finish()])
        buf.map_sync(wgpu.MapMode.READ)
        z = np.frombuffer(buf.read_mapped(), np.float32).reshape(n, row // 4)[:, :n].copy()
        buf.unmap()
        return z
