"""The sun's shadow map on the GPU: the scene rasterised depth-only along the refracted beam.

The scene's draw calls (:meth:`aquaspec.gpu.passes.raster.RasterPass.draws`,
the geometry pass's vertex buffers) drawn with ``sun_shadow.wgsl`` beside
this module through :meth:`aquaspec.scene.shadowmap.ShadowMapSpec.clip_matrix`
into a ``depth32float`` texture of :data:`aquaspec.scene.shadowmap.DEFAULT_MAP_SIZE`
texels a side, which :class:`aquaspec.gpu.passes.sun.SunPass` reads. NumPy
twin: :mod:`aquaspec.scene.shadowmap` (the same map, read the same way).

The map is kept from frame to frame, as real-time renderers keep the shadow
maps of static geometry: it is drawn again only when the sun, the scene's
bounds or its uploaded vertex and index buffers change, or the camera crosses
into another cell of the map's snapped centre (cells of twice
:data:`aquaspec.scene.shadowmap.DEFAULT_MAP_MARGIN_M` across the beam; a
2048^2 map cost 10-15 ms a 1280x720 frame on lavapipe).
"""

from __future__ import annotations

import numpy as np
import wgpu

from aquaspec.scene.shadowmap import (DEFAULT_MAP_MARGIN_M, DEFAULT_MAP_RADIUS_M, DEFAULT_MAP_SIZE,
                                      ShadowMapSpec, shadow_map_spec)
from aquaspec.gpu.buffers import create_uniform_buffer, upload_buffer
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.passes.raster import VERTEX_STRIDE
from aquaspec.gpu.shaders import load_wgsl

CLIP_LAYOUT = UniformLayout("ShadowClip", [("clip", "mat4x4<f32>")])
DEPTH_FORMAT = "depth32float"


def _spec_key(spec: ShadowMapSpec) -> tuple:
    """The map's geometry as a hashable value (equal specs draw equal maps)."""
    return (tuple(np.asarray(spec.to_sun, float)), tuple(np.asarray(spec.e1, float)),
            tuple(np.asarray(spec.e2, float)), spec.u0, spec.v0, spec.texel, spec.size,
            spec.h_min, spec.h_max)


class SunShadowPass:
    """The shadow map of ``map_size`` texels a side on ``device``."""

    def __init__(self, device, map_size: int = DEFAULT_MAP_SIZE):
        self.device = device
        self.map_size = int(map_size)
        self._clip = create_uniform_buffer(device, CLIP_LAYOUT, label="sun shadow clip")
        self._map = device.create_texture(
            label="sun shadow map", size=(self.map_size, self.map_size, 1), format=DEPTH_FORMAT,
            usage=wgpu.TextureUsage.RENDER_ATTACHMENT | wgpu.TextureUsage.TEXTURE_BINDING
            | wgpu.TextureUsage.COPY_SRC)
        #: The map's texture view (what the sun pass binds).
        self.view = self._map.create_view()
        self._module = device.create_shader_module(label="sun_shadow.wgsl",
                                                   code=load_wgsl("sun_shadow.wgsl"))
        self._pipelines = {}
        # One layout for every vertex stride's pipeline (an "auto" layout is
        # its own pipeline's only: a scene with several mesh modes needs one
        # bind group that all of them accept).
        clip_layout = device.create_bind_group_layout(entries=[
            {"binding": 0, "visibility": wgpu.ShaderStage.VERTEX,
             "buffer": {"type": wgpu.BufferBindingType.uniform}}])
        self._layout = device.create_pipeline_layout(bind_group_layouts=[clip_layout])
        self._clip_group = device.create_bind_group(layout=clip_layout, entries=[
            {"binding": 0, "resource": {"buffer": self._clip, "offset": 0,
                                        "size": CLIP_LAYOUT.size}}])
        #: The map's geometry of the last :meth:`encode` (None: nothing shadowed).
        self.spec: ShadowMapSpec | None = None
        self.shadowed = False
        self._drawn = None          # what the map holds: (spec fields, draw buffers)
        #: Maps drawn so far (the others were kept from an earlier frame).
        self.draw_count = 0

    def pipeline(self, stride: int):
        """The render pipeline for vertices of ``stride`` bytes (made when first used)."""
        if stride not in self._pipelines:
            self._pipelines[stride] = self.device.create_render_pipeline(
                label="sun shadow map", layout=self._layout,
                vertex={"module": self._module, "entry_point": "vs_main", "buffers": [{
                    "array_stride": stride, "step_mode": wgpu.VertexStepMode.vertex,
                    "attributes": [{"format": wgpu.VertexFormat.float32x3, "offset": 0,
                                    "shader_location": 0}]}]},
                primitive={"topology": wgpu.PrimitiveTopology.triangle_list,
                           "cull_mode": wgpu.CullMode.none},
                depth_stencil={"format": DEPTH_FORMAT, "depth_write_enabled": True,
                               "depth_compare": wgpu.CompareFunction.less},
                multisample={"count": 1}, fragment=None)
        return self._pipelines[stride]

    def encode(self, encoder, raster, scene, camera, to_sun, *,
               radius_m: float = DEFAULT_MAP_RADIUS_M,
               margin_m: float = DEFAULT_MAP_MARGIN_M) -> ShadowMapSpec | None:
        """Record the shadow map of ``scene`` around ``camera`` for a sun in direction
        ``to_sun`` (under water); None for no scene: nothing is shadowed.

        The map is kept (not drawn again) while its geometry
        (:func:`aquaspec.scene.shadowmap.shadow_map_spec`: the same for every
        camera in a cell of ``2 margin_m`` across the beam) and the scene's
        buffers are the same."""
        spec = None
        if scene is not None and scene.meshes:
            spec = shadow_map_spec(scene.bounds(), camera.position, to_sun,
                                   size=self.map_size, radius_m=radius_m, margin_m=margin_m)
        self.spec, self.shadowed = spec, spec is not None
        if spec is None:
            return None
        draws = raster.draws(scene)
        key = (_spec_key(spec), tuple((id(d.vertex), id(d.index), d.count) for d in draws))
        if key == self._drawn:
            return spec
        self._drawn = None
        upload_buffer(self.device, self._clip, CLIP_LAYOUT.pack(
            clip=np.asarray(spec.clip_matrix().T, np.float32).reshape(-1)))
        rp = encoder.begin_render_pass(
            color_attachments=[],
            depth_stencil_attachment={"view": self.view, "depth_clear_value": 1.0,
                                      "depth_load_op": wgpu.LoadOp.clear,
                                      "depth_store_op": wgpu.StoreOp.store})
        for d in draws:
            rp.set_pipeline(self.pipeline(VERTEX_STRIDE[d.mode]))
            rp.set_bind_group(0, self._clip_group)
            rp.set_vertex_buffer(0, d.vertex)
            rp.set_index_buffer(d.index, d.index_format)
            rp.draw_indexed(d.count)
        rp.end()
        self._drawn = key
        self.draw_count += 1
        return spec

    def forget(self) -> None:
        """Draw the map again on the next :meth:`encode` (e.g. after editing a mesh's
        vertices in place, as :meth:`aquaspec.gpu.passes.raster.RasterPass.invalidate`)."""
        self._drawn = None

    def no_shadows(self) -> None:
        """Nothing shadows the sun until the next :meth:`encode` (e.g. RGB-D images)."""
        self.spec, self.shadowed = None, False

    def read(self) -> np.ndarray | None:
        """The last shadow map as heights ``h`` (size, size) float64 (``-inf``
        where no surface), for tests; None when nothing is shadowed."""
        if not self.shadowed:
            return None
        n = self.map_size
        row = -(-4 * n // 256) * 256
        buf = self.device.create_buffer(size=row * n, usage=wgpu.BufferUsage.COPY_DST
                                        | wgpu.BufferUsage.MAP_READ)
        enc = self.device.create_command_encoder()
        enc.copy_texture_to_buffer({"texture": self._map, "mip_level": 0, "origin": (0, 0, 0),
                                    "aspect": wgpu.TextureAspect.depth_only},
                                   {"buffer": buf, "offset": 0, "bytes_per_row": row,
                                    "rows_per_image": n}, (n, n, 1))
        self.device.queue.submit([enc.finish()])
        buf.map_sync(wgpu.MapMode.READ)
        z = np.frombuffer(buf.read_mapped(), np.float32).reshape(n, row // 4)[:, :n].copy()
        buf.unmap()
        spec = self.spec
        h = spec.h_max - z.astype(float) * (spec.h_max - spec.h_min)
        return np.where(z >= 1.0, -np.inf, h)
