"""The geometry pass: meshes -> G-buffer, on the GPU.

:class:`RasterPass` rasterises a :class:`~aquaspec.scene.Scene` from a
:class:`~aquaspec.scene.camera.Camera` with a wgpu render pipeline and a depth
buffer (WGSL: ``raster.wgsl`` beside this module). Per pixel it writes

- the distance ``S`` in metres from the camera centre to the surface point
  (the length of the camera-relative position, *not* the z-depth), ``inf``
  where the ray sees open water;
- the world normal, turned to the camera's side of the triangle (the
  interpolated vertex normal is flipped when it points to the far side of
  its triangle, so the mesh's winding does not matter);
- the material index, or :data:`~aquaspec.scene.gbuffer.PER_PIXEL` for textured
  and vertex-coloured meshes, whose Jakob-Hanika sigmoid coefficients are
  fitted once per texel / vertex and interpolated (textures: mip-mapped,
  trilinear with repeat wrapping, the level of detail from the uv's
  screen-space derivatives, :mod:`aquaspec.scene.texture`; vertex colours:
  barycentrically);
- with a tangent-space normal map on the mesh (``Mesh.normal_map``), the
  normal perturbed by the mip-mapped map in the tangent frame of
  :meth:`~aquaspec.scene.mesh.Mesh.tangents`.

Textures and normal maps are uploaded with their whole mip chain
(:data:`COEFF_FORMATS`, :data:`NORMAL_FORMAT`) and sampled by the texture
units with a repeating trilinear sampler; the level of detail is the GPU's
own approximation of the isotropic rule, so the tests hold the pass to the
reference's samples over a range of levels (:mod:`aquaspec.scene.texture`).

The targets are in the G-buffer layout of :mod:`aquaspec.gpu.gbuffer`
(:attr:`RasterPass.targets`, valid after :meth:`RasterPass.encode`):
``"surface"`` rgba32uint (S, n_y, octahedral normal, material index; open
water: S = ``OPEN_WATER_DISTANCE``) and, only when the scene has textured or
vertex-coloured meshes (:attr:`RasterPass.per_pixel`), ``"sigmoid"``
rgba32float (the three coefficients). Each draw mode has a pipeline per
target set. :meth:`RasterPass.render_to` renders straight into a
:class:`~aquaspec.gpu.gbuffer.GBufferTextures`, the shading passes' input (no
read-back, no copy).

Its NumPy reference is :func:`aquaspec.scene.raycast.raycast_gbuffer`
(float64 ray casting); ``tests/gpu/passes/test_raster_pass.py`` holds the two
together.
"""

from __future__ import annotations

import numpy as np

import wgpu

from aquaspec.scene.camera import Camera
from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.raycast import (MODE_MATERIAL, MODE_TEXTURE, MODE_VERTEX, check_scene,
                                    reflectance_mode)
from aquaspec.gpu.device import get_device
from aquaspec.gpu.gbuffer import OPEN_WATER_DISTANCE, GBufferTextures, unpack_surface
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.shaders import load_wgsl

CAMERA_LAYOUT = UniformLayout("RasterCamera", [("view_proj", "mat4x4<f32>"),
                                               ("position", "vec3<f32>")])

#: Depth buffer format.
DEPTH_FORMAT = "depth32float"

#: Vertex and fragment entry points of each reflectance mode
#: (:func:`aquaspec.scene.raycast.reflectance_mode`); each mode has its own
#: vertex layout and pipeline.
_ENTRY = {MODE_MATERIAL: "material", MODE_TEXTURE: "texture", MODE_VERTEX: "vertex"}
#: 4-byte words of each mode's attribute after position and normal.
_EXTRA_WORDS = {MODE_MATERIAL: 1, MODE_TEXTURE: 2, MODE_VERTEX: 3}
#: Bytes per vertex of each mode: position, normal, then the mode's attribute.
VERTEX_STRIDE = {m: 4 * (6 + k) for m, k in _EXTRA_WORDS.items()}
#: Words a normal map adds: uv (2 f32, not for the texture mode, which has
#: them already) and the tangent with its handedness (4 f32).
_NM_WORDS = {MODE_MATERIAL: 6, MODE_TEXTURE: 4, MODE_VERTEX: 6}


def _vertex_data(mesh: Mesh) -> np.ndarray:
    """Interleaved vertices of ``mesh`` for its mode's pipeline, (V, k) 32-bit words.

    Every mode: position (3 f32), normal (3 f32); then material mode: the
    material index (u32); texture mode: uv (2 f32); vertex mode: the sigmoid
    coefficients (3 f32). With a normal map: then uv (2 f32; not repeated in
    texture mode) and the tangent (4 f32, :meth:`Mesh.tangents`).
    """
    mode = reflectance_mode(mesh)
    k = 6 + _EXTRA_WORDS[mode]
    nm = mesh.normal_map is not None
    data = np.zeros((len(mesh.vertices), k + (_NM_WORDS[mode] if nm else 0)), dtype=np.float32)
    data[:, 0:3] = mesh.vertices
    data[:, 3:6] = mesh.normals
    if mode == MODE_MATERIAL:
        data[:, 6].view(np.uint32)[:] = mesh.material
    elif mode == MODE_TEXTURE:
        data[:, 6:8] = mesh.uv
    else:
        data[:, 6:9] = mesh.vertex_sigmoid()
    if nm:
        if mode != MODE_TEXTURE:
            data[:, k:k + 2] = mesh.uv
            k += 2
        data[:, k:k + 4] = mesh.tangents()
    return data


class _Draw:
    """One draw call: vertex/index buffers of one or more meshes of one mode.

    Meshes without a texture are merged per mode (the material index is a
    vertex attribute): lavapipe processes the vertices of a draw on one
    thread, and per-draw overhead was a measurable part of the pass with
    the built-in scene's 39 meshes. A textured mesh is its own draw with
    its own bind group.
    """

    def __init__(self, device, mode, meshes, bind_group, normal_map=False):
        self.mode = mode
        self.normal_map = normal_map
        data = [_vertex_data(m) for m in meshes]
        #: Bytes per vertex (the depth-map passes read the positions).
        self.stride = 4 * data[0].shape[1]
        offsets = np.cumsum([0] + [len(d) for d in data])[:-1]
        faces = np.concatenate([m.faces + o for m, o in zip(meshes, offsets)])
        self.vertex = device.create_buffer_with_data(
            data=np.concatenate(data).tobytes(), usage=wgpu.BufferUsage.VERTEX)
        # 16-bit indices where they fit: half the index bytes to fetch.
        small = offsets[-1] + len(data[-1]) <= 0xFFFF
        self.index_format = wgpu.IndexFormat.uint16 if small else wgpu.IndexFormat.uint32
        idx = faces.astype(np.uint16 if small else np.uint32).reshape(-1)
        if idx.size % 2:
            idx = np.concatenate([idx, idx[-1:]])   # buffer sizes in multiples of 4 bytes
        self.index = device.create_buffer_with_data(data=idx.tobytes(),
                                                    usage=wgpu.BufferUsage.INDEX)
        self.count = int(faces.size)
        self.bind_group = bind_group


#: Texture formats of the coefficient textures: 32-bit floats where the
#: device can filter them (the ``float32-filterable`` feature), 16-bit floats
#: (always filterable) elsewhere.
COEFF_FORMATS = ("rgba32float", "rgba16float")
#: Normal maps are stored as 8-bit unorm, (n + 1) / 2 (as normal-map images
#: are): lavapipe filters 8-bit textures on a fast path, about 2x faster per
#: sample than 32-bit floats; :meth:`Mesh.normal_mips` holds the same
#: quantised values for the NumPy reference.
NORMAL_FORMAT = "rgba8unorm"


def _mip_texture_view(device, levels, what, fmt):
    """A texture of format ``fmt`` holding the mip chain ``levels`` (each (h, w, 3));
    its view. ``rgba8unorm`` stores (x + 1) / 2 of values in [-1, 1]."""
    h, w = levels[0].shape[:2]
    limit = device.limits["max-texture-dimension-2d"]
    if max(h, w) > limit:
        raise AquaspecError(f"{what} is {w}x{h}; this GPU accepts textures up to {limit} "
                            "pixels a side")
    tex = device.create_texture(size=(w, h, 1), format=fmt, mip_level_count=len(levels),
                                usage=wgpu.TextureUsage.TEXTURE_BINDING
                                | wgpu.TextureUsage.COPY_DST)
    for k, level in enumerate(levels):
        lh, lw = level.shape[:2]
        if fmt == "rgba8unorm":
            rgba = np.full((lh, lw, 4), 255, np.uint8)
            rgba[..., :3] = np.clip(np.rint((np.asarray(level) + 1.0) * 127.5), 0, 255)
        else:
            rgba = np.zeros((lh, lw, 4), np.float32 if fmt == "rgba32float" else np.float16)
            rgba[..., :3] = level
        device.queue.write_texture({"texture": tex, "mip_level": k, "origin": (0, 0, 0)},
                                   rgba, {"offset": 0, "bytes_per_row": rgba.itemsize * 4 * lw,
                                          "rows_per_image": lh}, (lw, lh, 1))
    return tex.create_view()


class RasterPass:
    """Rasterise a scene into a G-buffer with wgpu.

    Parameters
    ----------
    device : wgpu.GPUDevice, optional
        Defaults to :func:`aquaspec.gpu.device.get_device`.

    Notes
    -----
    Scene uploads are cached by scene object: rendering the same
    :class:`Scene` from many cameras uploads its meshes once. After changing
    a scene's meshes in place, call :meth:`invalidate`.
    """

    def __init__(self, device=None):
        if device is None:
            _, device = get_device()
        self.device = device
        src = load_wgsl("raster.wgsl", camera_struct=CAMERA_LAYOUT.wgsl())
        self._module = device.create_shader_module(label="raster.wgsl", code=src)
        #: Whether the last scene encoded has per-pixel materials (two targets).
        self.per_pixel = False
        self._cam_layout = device.create_bind_group_layout(entries=[
            {"binding": 0, "visibility": wgpu.ShaderStage.VERTEX | wgpu.ShaderStage.FRAGMENT,
             "buffer": {"type": wgpu.BufferBindingType.uniform}}])
        # Group 1: the coefficient texture (binding 1) and the normal map
        # (binding 2) of one mesh, each with its mip chain; a 1x1 stand-in
        # fills the one a mesh does not have.
        self._tex_layout = device.create_bind_group_layout(entries=[
            {"binding": b, "visibility": wgpu.ShaderStage.FRAGMENT,
             "texture": {"sample_type": wgpu.TextureSampleType.float,
                         "view_dimension": wgpu.TextureViewDimension.d2}} for b in (1, 2)] + [
            {"binding": 3, "visibility": wgpu.ShaderStage.FRAGMENT,
             "sampler": {"type": wgpu.SamplerBindingType.filtering}}])
        self._sampler = device.create_sampler(
            address_mode_u="repeat", address_mode_v="repeat", mag_filter="linear",
            min_filter="linear", mipmap_filter="linear")
        self.coeff_format = COEFF_FORMATS["float32-filterable" not in device.features]
        self._blank = {fmt: _mip_texture_view(device, [np.zeros((1, 1, 3), np.float32)],
                                              "blank", fmt)
                       for fmt in (self.coeff_format, NORMAL_FORMAT)}
        self._pipeline_layouts = {
            False: device.create_pipeline_layout(bind_group_layouts=[self._cam_layout]),
            True: device.create_pipeline_layout(
                bind_group_layouts=[self._cam_layout, self._tex_layout])}
        # Render pipelines by mode, made when a scene first needs them.
        self._pipelines = {}
        self._cam_buffer = device.create_buffer(
            size=CAMERA_LAYOUT.size, usage=wgpu.BufferUsage.UNIFORM | wgpu.BufferUsage.COPY_DST)
        self._cam_group = device.create_bind_group(layout=self._cam_layout, entries=[
            {"binding": 0, "resource": {"buffer": self._cam_buffer, "offset": 0,
                                        "size": CAMERA_LAYOUT.size}}])
        self._scene = None
        self._draws = []
        self._size = None
        self.targets = {}

    def _pipeline(self, mode, normal_map, per_pixel):
        key = (mode, normal_map, per_pixel)
        if key in self._pipelines:
            return self._pipelines[key]
        module = self._module
        f32x3, f32x2 = wgpu.VertexFormat.float32x3, wgpu.VertexFormat.float32x2
        extra = {MODE_MATERIAL: wgpu.VertexFormat.uint32, MODE_TEXTURE: f32x2,
                 MODE_VERTEX: f32x3}[mode]
        name = _ENTRY[mode] + ("_nm" if normal_map else "")
        fragment = f"fs_{name}2" if per_pixel and mode == MODE_MATERIAL else f"fs_{name}"
        targets = [{"format": wgpu.TextureFormat.rgba32uint}]
        if per_pixel:
            targets.append({"format": wgpu.TextureFormat.rgba32float})
        attributes = [{"format": f32x3, "offset": 0, "shader_location": 0},
                      {"format": f32x3, "offset": 12, "shader_location": 1},
                      {"format": extra, "offset": 24, "shader_location": 2}]
        offset = 4 * (6 + _EXTRA_WORDS[mode])
        if normal_map:
            # uv at location 3 (the texture mode has it at 2), the tangent at 4.
            if mode != MODE_TEXTURE:
                attributes.append({"format": f32x2, "offset": offset, "shader_location": 3})
                offset += 8
            attributes.append({"format": wgpu.VertexFormat.float32x4, "offset": offset,
                               "shader_location": 4})
            offset += 16
        pipe = self.device.create_render_pipeline(
            label=f"gbuffer {name}",
            layout=self._pipeline_layouts[mode == MODE_TEXTURE or normal_map],
            vertex={"module": module, "entry_point": f"vs_{name}", "buffers": [{
                "array_stride": offset, "step_mode": wgpu.VertexStepMode.vertex,
                "attributes": attributes}]},
            primitive={"topology": wgpu.PrimitiveTopology.triangle_list,
                       "cull_mode": wgpu.CullMode.none},
            depth_stencil={"format": DEPTH_FORMAT,
                           "depth_write_enabled": True,
                           "depth_compare": wgpu.CompareFunction.less},
            multisample={"count": 1},
            fragment={"module": module, "entry_point": fragment, "targets": targets})
        self._pipelines[key] = pipe
        return pipe

    def draws(self, scene: Scene) -> list:
        """The scene's draw calls (uploaded once per scene): each has ``mode``,
        ``vertex`` (position at offset 0, ``stride`` bytes a vertex),
        ``index``, ``index_format`` and ``count``. The sun's shadow map
        (:mod:`aquaspec.gpu.passes.sun`) draws the same buffers."""
        self._upload(scene)
        return list(self._draws)

    def invalidate(self):
        """Forget the uploaded scene (call after editing its meshes in place)."""
        self._scene = None
        self._draws = []

    def _upload(self, scene: Scene):
        if scene is self._scene:
            return
        draws = []
        # Drawn grouped by mode, one pipeline switch per mode, meshes in scene
        # order within a mode (the depth test decides what is seen, exact ties
        # aside).
        for mode in (MODE_MATERIAL, MODE_VERTEX):
            meshes = [m for m in scene.meshes if reflectance_mode(m) == mode
                      and m.normal_map is None]
            if meshes:
                draws.append(_Draw(self.device, mode, meshes, None))
        # Meshes with their own textures: one draw each, grouped by pipeline.
        own = [m for m in scene.meshes
               if reflectance_mode(m) == MODE_TEXTURE or m.normal_map is not None]
        for m in sorted(own, key=lambda m: (reflectance_mode(m), m.normal_map is None)):
            coeff = (_mip_texture_view(self.device, m.texture_mips(), f"texture of mesh "
                                       f"{m.name!r}", self.coeff_format)
                     if m.texture is not None else self._blank[self.coeff_format])
            normal = (_mip_texture_view(self.device, m.normal_mips(), f"normal map of mesh "
                                        f"{m.name!r}", NORMAL_FORMAT)
                      if m.normal_map is not None else self._blank[NORMAL_FORMAT])
            group = self.device.create_bind_group(layout=self._tex_layout, entries=[
                {"binding": 1, "resource": coeff}, {"binding": 2, "resource": normal},
                {"binding": 3, "resource": self._sampler}])
            draws.append(_Draw(self.device, reflectance_mode(m), [m], group,
                               m.normal_map is not None))
        self._draws = draws
        self._scene = scene
        self.per_pixel = any(d.mode != MODE_MATERIAL for d in draws)

    def _ensure_targets(self, width, height):
        if self._size == (width, height):
            return
        usage = (wgpu.TextureUsage.RENDER_ATTACHMENT | wgpu.TextureUsage.COPY_SRC
                 | wgpu.TextureUsage.TEXTURE_BINDING)
        self.targets = {
            "surface": self.device.create_texture(
                size=(width, height, 1), format=wgpu.TextureFormat.rgba32uint, usage=usage),
            "sigmoid": self.device.create_texture(
                size=(width, height, 1), format=wgpu.TextureFormat.rgba32float, usage=usage),
            "depth": self.device.create_texture(
                size=(width, height, 1), format=DEPTH_FORMAT,
                usage=wgpu.TextureUsage.RENDER_ATTACHMENT),
        }
        self._size = (width, height)

    def encode(self, encoder, scene: Scene, camera: Camera, timestamp_writes=None, *,
               targets=None):
        """Record the geometry pass into ``encoder``.

        The results land in :attr:`targets`, or in ``targets``
        (``{"surface", "sigmoid"}`` textures of the camera's size in the
        formats of :mod:`aquaspec.gpu.gbuffer`) when given; the sigmoid
        target is written only when the scene has per-pixel materials
        (:attr:`per_pixel` tells after the call). Open water is cleared to
        distance :data:`~aquaspec.gpu.gbuffer.OPEN_WATER_DISTANCE`, normal
        0 and material 0.
        """
        check_scene(scene, camera)
        self._upload(scene)
        self._ensure_targets(camera.width, camera.height)
        out = self.targets if targets is None else targets
        view_proj = camera.projection_matrix() @ camera.view_matrix()
        self.device.queue.write_buffer(self._cam_buffer, 0, CAMERA_LAYOUT.pack(
            view_proj=np.asarray(view_proj.T, np.float32).reshape(-1),
            position=camera.position))
        open_water = int(np.array(OPEN_WATER_DISTANCE, np.float32).view(np.uint32))
        attachments = [{"view": out["surface"].create_view(),
                        "clear_value": (open_water, 0, 0, 0),
                        "load_op": wgpu.LoadOp.clear, "store_op": wgpu.StoreOp.store}]
        if self.per_pixel:
            attachments.append({"view": out["sigmoid"].create_view(),
                                "clear_value": (0.0, 0.0, 0.0, 0.0),
                                "load_op": wgpu.LoadOp.clear, "store_op": wgpu.StoreOp.store})
        rp = encoder.begin_render_pass(
            color_attachments=attachments,
            depth_stencil_attachment={
                "view": self.targets["depth"].create_view(), "depth_clear_value": 1.0,
                "depth_load_op": wgpu.LoadOp.clear, "depth_store_op": wgpu.StoreOp.discard},
            **({} if timestamp_writes is None else {"timestamp_writes": timestamp_writes}))
        rp.set_bind_group(0, self._cam_group)
        mode = None
        for d in self._draws:
            if (d.mode, d.normal_map) != mode:
                mode = (d.mode, d.normal_map)
                rp.set_pipeline(self._pipeline(d.mode, d.normal_map, self.per_pixel))
            if d.bind_group is not None:
                rp.set_bind_group(1, d.bind_group)
            rp.set_vertex_buffer(0, d.vertex)
            rp.set_index_buffer(d.index, d.index_format)
            rp.draw_indexed(d.count)
        rp.end()

    def render_to(self, gbuffer: GBufferTextures, scene: Scene, camera: Camera, encoder=None,
                  timestamp_writes=None):
        """Rasterise straight into the shading passes' G-buffer.

        Renders into ``gbuffer``'s textures (nothing is read back, nothing is
        copied) and sets its camera and ``per_pixel``. With ``encoder`` the
        commands are only recorded; without, they are submitted.
        """
        if (camera.width, camera.height) != (gbuffer.width, gbuffer.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height} but the G-buffer "
                                f"is {gbuffer.width}x{gbuffer.height}")
        own = encoder is None
        if own:
            encoder = self.device.create_command_encoder()
        self.encode(encoder, scene, camera, timestamp_writes=timestamp_writes,
                    targets=gbuffer.textures)
        gbuffer.set_camera(camera)
        gbuffer.per_pixel = self.per_pixel
        if own:
            self.device.queue.submit([encoder.finish()])

    def render(self, scene: Scene, camera: Camera) -> GBuffer:
        """Rasterise ``scene`` seen by ``camera`` and read the G-buffer back.

        Raises
        ------
        AquaspecError
            A scene without meshes, a mesh whose material index is not in
            ``scene.materials``, or a texture larger than the GPU accepts.
        """
        encoder = self.device.create_command_encoder()
        self.encode(encoder, scene, camera)
        self.device.queue.submit([encoder.finish()])
        return self.read_gbuffer(scene, camera)

    def read_gbuffer(self, scene: Scene, camera: Camera, textures=None) -> GBuffer:
        """The G-buffer of ``scene`` and ``camera`` last rasterised, read back from
        :attr:`targets`, or from ``textures`` (``{"surface", "sigmoid"}``, e.g. a
        :class:`~aquaspec.gpu.gbuffer.GBufferTextures`'s after :meth:`render_to`)."""
        src = self.targets if textures is None else textures
        w, h = camera.width, camera.height
        distance, normal, material = unpack_surface(
            self._read(src["surface"], np.uint32, w, h))
        if self.per_pixel:
            sigmoid = self._read(src["sigmoid"], np.float32, w, h)[..., :3].copy()
        else:
            sigmoid = np.zeros((h, w, 3), np.float32)
        hit = distance >= 0
        normal = np.where(hit[..., None], normal, 0.0)
        material = np.where(hit, material, 0).astype(np.uint32)
        return GBuffer(camera, np.where(hit, distance, np.inf), normal, material, sigmoid,
                       list(scene.materials))

    def _read(self, texture, dtype, w, h):
        data = self.device.queue.read_texture(
            {"texture": texture, "mip_level": 0, "origin": (0, 0, 0)},
            {"offset": 0, "bytes_per_row": 16 * w}, (w, h, 1))
        return np.frombuffer(data, dtype=dtype).reshape(h, w, 4)
