"""The geometry pass: meshes -> G-buffer, on the GPU, and its NumPy reference.

:class:`RasterPass` rasterises a :class:`~aquaspec.scene.Scene` from a
:class:`~aquaspec.scene.camera.Camera` with a wgpu render pipeline and a depth
buffer (shader ``shaders/gbuffer.wgsl``). Per pixel it writes

- the distance ``S`` in metres from the camera centre to the surface point
  (the length of the camera-relative position, *not* the z-depth), ``inf``
  where the ray sees open water;
- the world normal, turned to the camera's side of the triangle (the
  interpolated vertex normal is flipped when it points to the far side of
  its triangle, so the mesh's winding does not matter);
- the material index, or :data:`~aquaspec.scene.gbuffer.PER_PIXEL` for textured
  and vertex-coloured meshes, whose Jakob-Hanika sigmoid coefficients are
  fitted once per texel / vertex and interpolated (bilinearly between
  texels, repeat wrapping; barycentrically between vertices).

GPU-resident layout (:attr:`RasterPass.targets`, valid after
:meth:`RasterPass.encode`, the same as the deferred pass's G-buffer textures,
:mod:`aquaspec.gpu.passes.deferred`): ``"surface"`` rgba32uint (S, n_y, octahedral
normal, material index; open water: S = ``OPEN_WATER_DISTANCE``) and, only
when the scene has textured or vertex-coloured meshes
(:attr:`RasterPass.per_pixel`), ``"sigmoid"`` rgba32float (the three
coefficients). Each draw mode has a pipeline per target set.

:func:`raycast_gbuffer` computes the same G-buffer by ray-triangle
intersection in float64 (vectorised, triangles binned into pixel tiles by
their projected bounding boxes) and is what the tests compare
:class:`RasterPass` against.

:meth:`RasterPass.render_to` renders straight into a
:class:`~aquaspec.gpu.passes.deferred.DeferredPass`'s G-buffer textures (no
read-back, no copy).
"""

from __future__ import annotations

import numpy as np

from aquaspec.scene.camera import Camera
from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.gpu.passes.deferred import unpack_surface
from aquaspec.gpu.layout import UniformLayout
from aquaspec.gpu.shaders import load_wgsl

CAMERA_LAYOUT = UniformLayout("RasterCamera", [("view_proj", "mat4x4<f32>"),
                                               ("position", "vec3<f32>")])

#: Depth buffer format.
DEPTH_FORMAT = "depth32float"

#: Reflectance modes of a mesh; each has its own vertex layout and vertex and
#: fragment entry points (and pipeline), :data:`_ENTRY`.
MODE_MATERIAL, MODE_TEXTURE, MODE_VERTEX = 0, 1, 2
_ENTRY = {MODE_MATERIAL: "material", MODE_TEXTURE: "texture", MODE_VERTEX: "vertex"}
#: 4-byte words of each mode's attribute after position and normal.
_EXTRA_WORDS = {MODE_MATERIAL: 1, MODE_TEXTURE: 2, MODE_VERTEX: 3}
#: Bytes per vertex of each mode: position, normal, then the mode's attribute.
VERTEX_STRIDE = {m: 4 * (6 + k) for m, k in _EXTRA_WORDS.items()}


def _mode(mesh: Mesh) -> int:
    if mesh.texture is not None:
        return MODE_TEXTURE
    if mesh.vertex_rgb is not None:
        return MODE_VERTEX
    return MODE_MATERIAL


def _vertex_data(mesh: Mesh) -> np.ndarray:
    """Interleaved vertices of ``mesh`` for its mode's pipeline, (V, k) 32-bit words.

    Every mode: position (3 f32), normal (3 f32); then material mode: the
    material index (u32); texture mode: uv (2 f32); vertex mode: the sigmoid
    coefficients (3 f32).
    """
    mode = _mode(mesh)
    data = np.zeros((len(mesh.vertices), 6 + _EXTRA_WORDS[mode]), dtype=np.float32)
    data[:, 0:3] = mesh.vertices
    data[:, 3:6] = mesh.normals
    if mode == MODE_MATERIAL:
        data[:, 6].view(np.uint32)[:] = mesh.material
    elif mode == MODE_TEXTURE:
        data[:, 6:8] = mesh.uv
    else:
        data[:, 6:9] = mesh.vertex_sigmoid()
    return data


def _check_inputs(scene, camera):
    if not isinstance(scene, Scene):
        raise AquaspecError(f"expected an aquaspec.scene.Scene, got {type(scene).__name__}")
    if not isinstance(camera, Camera):
        raise AquaspecError(f"expected an aquaspec.scene.camera.Camera, got {type(camera).__name__}")
    scene.validate()


class _Draw:
    """One draw call: vertex/index buffers of one or more meshes of one mode.

    Meshes without a texture are merged per mode (the material index is a
    vertex attribute): lavapipe processes the vertices of a draw on one
    thread, and per-draw overhead was a measurable part of the pass with
    the built-in scene's 39 meshes. A textured mesh is its own draw with
    its own bind group.
    """

    def __init__(self, device, mode, meshes, bind_group):
        import wgpu
        self.mode = mode
        data = [_vertex_data(m) for m in meshes]
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


def _texture_view(device, mesh: Mesh):
    import wgpu
    coeffs = mesh.texture_sigmoid()
    h, w = coeffs.shape[:2]
    limit = device.limits["max-texture-dimension-2d"]
    if max(h, w) > limit:
        raise AquaspecError(f"texture of mesh {mesh.name!r} is {w}x{h}; this GPU "
                            f"accepts textures up to {limit} pixels a side")
    rgba = np.zeros((h, w, 4), np.float32)
    rgba[..., :3] = coeffs
    tex = device.create_texture(size=(w, h, 1), format=wgpu.TextureFormat.rgba32float,
                                usage=wgpu.TextureUsage.TEXTURE_BINDING
                                | wgpu.TextureUsage.COPY_DST)
    device.queue.write_texture({"texture": tex, "mip_level": 0, "origin": (0, 0, 0)},
                               rgba, {"offset": 0, "bytes_per_row": 16 * w,
                                      "rows_per_image": h}, (w, h, 1))
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
        import wgpu
        if device is None:
            from aquaspec.gpu.device import get_device
            _, device = get_device()
        self.device = device
        src = load_wgsl("gbuffer.wgsl", camera_struct=CAMERA_LAYOUT.wgsl())
        self._module = device.create_shader_module(label="gbuffer.wgsl", code=src)
        #: Whether the last scene encoded has per-pixel materials (two targets).
        self.per_pixel = False
        self._cam_layout = device.create_bind_group_layout(entries=[
            {"binding": 0, "visibility": wgpu.ShaderStage.VERTEX | wgpu.ShaderStage.FRAGMENT,
             "buffer": {"type": wgpu.BufferBindingType.uniform}}])
        self._tex_layout = device.create_bind_group_layout(entries=[
            {"binding": 1, "visibility": wgpu.ShaderStage.FRAGMENT,
             "texture": {"sample_type": wgpu.TextureSampleType.unfilterable_float,
                         "view_dimension": wgpu.TextureViewDimension.d2}}])
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

    def _pipeline(self, mode, per_pixel):
        import wgpu
        key = (mode, per_pixel)
        if key in self._pipelines:
            return self._pipelines[key]
        module = self._module
        f32x3, f32x2 = wgpu.VertexFormat.float32x3, wgpu.VertexFormat.float32x2
        extra = {MODE_MATERIAL: wgpu.VertexFormat.uint32, MODE_TEXTURE: f32x2,
                 MODE_VERTEX: f32x3}[mode]
        name = _ENTRY[mode]
        fragment = f"fs_{name}2" if per_pixel and mode == MODE_MATERIAL else f"fs_{name}"
        targets = [{"format": wgpu.TextureFormat.rgba32uint}]
        if per_pixel:
            targets.append({"format": wgpu.TextureFormat.rgba32float})
        pipe = self.device.create_render_pipeline(
            label=f"gbuffer {name}",
            layout=self._pipeline_layouts[mode == MODE_TEXTURE],
            vertex={"module": module, "entry_point": f"vs_{name}", "buffers": [{
                "array_stride": VERTEX_STRIDE[mode],
                "step_mode": wgpu.VertexStepMode.vertex,
                "attributes": [
                    {"format": f32x3, "offset": 0, "shader_location": 0},
                    {"format": f32x3, "offset": 12, "shader_location": 1},
                    {"format": extra, "offset": 24, "shader_location": 2}]}]},
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
        ``vertex`` (position at offset 0, :data:`VERTEX_STRIDE` of its mode),
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
            meshes = [m for m in scene.meshes if _mode(m) == mode]
            if meshes:
                draws.append(_Draw(self.device, mode, meshes, None))
        for m in scene.meshes:
            if _mode(m) == MODE_TEXTURE:
                group = self.device.create_bind_group(layout=self._tex_layout, entries=[
                    {"binding": 1, "resource": _texture_view(self.device, m)}])
                draws.append(_Draw(self.device, MODE_TEXTURE, [m], group))
        self._draws = draws
        self._scene = scene
        self.per_pixel = any(d.mode != MODE_MATERIAL for d in draws)

    def _ensure_targets(self, width, height):
        import wgpu
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
        formats of :mod:`aquaspec.gpu.passes.deferred`) when given; the sigmoid
        target is written only when the scene has per-pixel materials
        (:attr:`per_pixel` tells after the call). Open water is cleared to
        distance :data:`~aquaspec.gpu.passes.deferred.OPEN_WATER_DISTANCE`, normal
        0 and material 0.
        """
        import wgpu
        from aquaspec.gpu.passes.deferred import OPEN_WATER_DISTANCE
        _check_inputs(scene, camera)
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
            if d.mode != mode:
                mode = d.mode
                rp.set_pipeline(self._pipeline(mode, self.per_pixel))
            if d.bind_group is not None:
                rp.set_bind_group(1, d.bind_group)
            rp.set_vertex_buffer(0, d.vertex)
            rp.set_index_buffer(d.index, d.index_format)
            rp.draw_indexed(d.count)
        rp.end()

    def render_to(self, deferred_pass, scene: Scene, camera: Camera, encoder=None,
                  timestamp_writes=None):
        """Rasterise straight into a :class:`~aquaspec.gpu.passes.deferred.DeferredPass`'s G-buffer.

        Renders into ``deferred_pass.gbuffer_textures`` (nothing is read
        back, nothing is copied) and sets the deferred pass's camera and
        ``per_pixel``. With ``encoder`` the commands are only recorded;
        without, they are submitted.
        """
        if (camera.width, camera.height) != (deferred_pass.width, deferred_pass.height):
            raise AquaspecError(f"camera is {camera.width}x{camera.height} but the deferred "
                                f"pass is {deferred_pass.width}x{deferred_pass.height}")
        own = encoder is None
        if own:
            encoder = self.device.create_command_encoder()
        self.encode(encoder, scene, camera, timestamp_writes=timestamp_writes,
                    targets=deferred_pass.gbuffer_textures)
        deferred_pass.set_camera(camera)
        deferred_pass.per_pixel = self.per_pixel
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
        :class:`~aquaspec.gpu.passes.deferred.DeferredPass`'s after :meth:`render_to`)."""
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


# ---------------------------------------------------------------------------
# NumPy reference


def _bilinear_repeat(image, uv):
    """Bilinear sample of ``image`` (H, W, C) at ``uv`` (N, 2), as the shader does."""
    h, w = image.shape[:2]
    px = uv[:, 0] * w - 0.5
    py = (1.0 - uv[:, 1]) * h - 0.5
    x0 = np.floor(px)
    y0 = np.floor(py)
    fx = (px - x0)[:, None]
    fy = (py - y0)[:, None]
    x0 = x0.astype(np.int64)
    y0 = y0.astype(np.int64)
    xa, xb = x0 % w, (x0 + 1) % w
    ya, yb = y0 % h, (y0 + 1) % h
    top = image[ya, xa] * (1 - fx) + image[ya, xb] * fx
    bottom = image[yb, xa] * (1 - fx) + image[yb, xb] * fx
    return top * (1 - fy) + bottom * fy


#: Side of the square pixel tiles :func:`raycast_gbuffer` bins triangles into.
RAYCAST_TILE = 16


def _pixel_boxes(tri, camera: Camera, dirs):
    """Inclusive pixel boxes ``(j0, j1, i0, i1)`` (each (T,)) that hold every
    pixel centre whose ray can meet each triangle ``tri`` (T, 3, 3) beyond
    the near distance: the bounding box, one pixel wider on each side and
    clipped to the image, of the triangle's part in front of the plane
    ``z = z_min`` (camera z; ``z_min`` half the smallest z a pixel ray reaches
    at ``camera.near``; ``dirs`` the pixel rays, (P, 3)), projected. A
    triangle with no such part, or entirely off-screen, gets ``j0 > j1``.
    """
    w, h = camera.width, camera.height
    min_cos = float((dirs @ camera.forward).min())
    z_min = 0.5 * camera.near * min_cos
    rel = tri - camera.position                               # (T, 3, 3)
    z = rel @ camera.forward                                  # (T, 3)
    # Points whose projections bound the clipped triangle: the vertices in
    # front of the plane and where the edges cross it.
    a, b = rel, rel[:, [1, 2, 0]]
    za, zb = z, z[:, [1, 2, 0]]
    cross = (za - z_min) * (zb - z_min) < 0
    f = np.where(cross, (z_min - za) / np.where(cross, zb - za, 1.0), 0.0)
    pts = np.concatenate([a, a + f[..., None] * (b - a)], axis=1)       # (T, 6, 3)
    use = np.concatenate([z > z_min, cross], axis=1)                    # (T, 6)
    pz = np.where(use, pts @ camera.forward, 1.0)
    pj = (pts @ camera.right) / pz * camera.fx + camera.cx - 0.5
    pi = -(pts @ camera.true_up) / pz * camera.fy + camera.cy - 0.5
    j0 = np.floor(np.where(use, pj, np.inf).min(axis=1)) - 1
    j1 = np.ceil(np.where(use, pj, -np.inf).max(axis=1)) + 1
    i0 = np.floor(np.where(use, pi, np.inf).min(axis=1)) - 1
    i1 = np.ceil(np.where(use, pi, -np.inf).max(axis=1)) + 1
    off = ~use.any(axis=1) | (j1 < 0) | (j0 > w - 1) | (i1 < 0) | (i0 > h - 1)
    box = [np.clip(np.where(off, 0, x), 0, lim).astype(np.int64)
           for x, lim in ((j0, w - 1), (j1, w - 1), (i0, h - 1), (i1, h - 1))]
    box[1] = np.where(off, -1, box[1])
    return tuple(box)


def _tile_candidates(boxes, width: int, height: int, tile: int):
    """Per tile of ``tile`` x ``tile`` pixels (row-major), the triangles whose
    box overlaps it, in ascending order: ``(starts, order)`` with tile k's
    triangles ``order[starts[k]:starts[k + 1]]``."""
    j0, j1, i0, i1 = boxes
    keep = np.nonzero(j1 >= j0)[0]
    tx0, tx1 = j0[keep] // tile, j1[keep] // tile
    ty0, ty1 = i0[keep] // tile, i1[keep] // tile
    nx = (tx1 - tx0 + 1)
    counts = nx * (ty1 - ty0 + 1)
    tiles_x = -(-width // tile)
    tri = np.repeat(keep, counts)
    # The k-th pair of a triangle covers tile (tx0 + k % nx, ty0 + k // nx).
    k = np.arange(tri.size) - np.repeat(np.cumsum(counts) - counts, counts)
    nxr = np.repeat(nx, counts)
    tile_id = (np.repeat(ty0, counts) + k // nxr) * tiles_x + np.repeat(tx0, counts) + k % nxr
    order = np.argsort(tile_id, kind="stable")               # triangles stay ascending
    n_tiles = tiles_x * -(-height // tile)
    starts = np.concatenate([[0], np.cumsum(np.bincount(tile_id, minlength=n_tiles))])
    return starts, tri[order]


def raycast_gbuffer(scene: Scene, camera: Camera, *, max_elements: int = 2_000_000,
                    tile: int | None = RAYCAST_TILE) -> GBuffer:
    """G-buffer by ray-triangle intersection (Moller-Trumbore, float64 reference).

    Pixel-centre rays are tested against the triangles whose projected
    bounding box covers their tile of ``tile`` x ``tile`` pixels
    (:func:`_pixel_boxes`; ``tile=None``: every ray against every triangle,
    the brute force the binning must equal), in chunks of at most
    ``max_elements`` ray-triangle pairs. The per-pixel quantities follow the
    same rules as :class:`RasterPass`. The binning skips only pairs that
    cannot meet, so the result is the brute force's, bit for bit (tested);
    measured on the built-in scene (12084 triangles): 320x180 in 0.16 s
    instead of 26 s, 1280x720 in 0.9 s.
    """
    _check_inputs(scene, camera)
    if tile is not None and not (isinstance(tile, (int, np.integer)) and tile >= 1):
        raise AquaspecError(f"tile={tile!r}; accepted: a positive integer or None")
    dirs = camera.ray_directions().reshape(-1, 3)
    o = camera.position
    n_rays = len(dirs)
    best_t = np.full(n_rays, np.inf)
    best_mesh = np.full(n_rays, -1)
    best_face = np.zeros(n_rays, dtype=np.int64)
    best_uv = np.zeros((n_rays, 2))
    eps = 1e-12
    # All triangles in scene order (mesh, then face): ties keep the first.
    tris = [mesh.vertices[mesh.faces] for mesh in scene.meshes]
    all_tri = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
    tri_mesh = np.concatenate([np.full(len(t), mi) for mi, t in enumerate(tris)]) \
        if tris else np.zeros(0, dtype=np.int64)
    tri_face = np.concatenate([np.arange(len(t)) for t in tris]) \
        if tris else np.zeros(0, dtype=np.int64)

    def cast(rays, cand):
        """Nearest hit of rays ``rays`` (indices) among triangles ``cand`` (ascending)."""
        d = dirs[rays]
        n = len(rays)
        chunk = max(1, max_elements // n)
        for start in range(0, len(cand), chunk):
            idx = cand[start:start + chunk]
            t3 = all_tri[idx]                                     # (T, 3, 3)
            e1 = t3[:, 1] - t3[:, 0]
            e2 = t3[:, 2] - t3[:, 0]
            p = np.cross(d[:, None, :], e2[None])                 # (N, T, 3)
            det = np.einsum("ntk,tk->nt", p, e1)
            ok = np.abs(det) > eps
            inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
            s = o - t3[:, 0]                                      # (T, 3)
            u = np.einsum("ntk,tk->nt", p, s) * inv
            q = np.cross(s, e1)                                   # (T, 3)
            v = np.einsum("nk,tk->nt", d, q) * inv
            t = (e2 * q).sum(axis=1)[None, :] * inv
            valid = ok & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > camera.near)
            t = np.where(valid, t, np.inf)
            k = np.argmin(t, axis=1)
            tk = t[np.arange(n), k]
            closer = tk < best_t[rays]
            hit = rays[closer]
            best_t[hit] = tk[closer]
            best_mesh[hit] = tri_mesh[idx[k[closer]]]
            best_face[hit] = tri_face[idx[k[closer]]]
            best_uv[hit] = np.stack([u[closer, k[closer]], v[closer, k[closer]]], 1)

    w, h = camera.width, camera.height
    if tile is None:
        cast(np.arange(n_rays), np.arange(len(all_tri)))
    else:
        starts, order = _tile_candidates(_pixel_boxes(all_tri, camera, dirs), w, h, int(tile))
        tiles_x = -(-w // tile)
        pix = np.arange(n_rays).reshape(h, w)
        for k in range(len(starts) - 1):
            if starts[k + 1] > starts[k]:
                ty, tx = divmod(k, tiles_x)
                rays = pix[ty * tile:(ty + 1) * tile, tx * tile:(tx + 1) * tile].reshape(-1)
                cast(rays, order[starts[k]:starts[k + 1]])

    normal = np.zeros((n_rays, 3))
    material = np.zeros(n_rays, dtype=np.uint32)
    sigmoid = np.zeros((n_rays, 3))
    for mi, mesh in enumerate(scene.meshes):
        sel = np.nonzero(best_mesh == mi)[0]
        if sel.size == 0:
            continue
        f = mesh.faces[best_face[sel]]
        b1, b2 = best_uv[sel, 0:1], best_uv[sel, 1:2]
        b0 = 1.0 - b1 - b2

        def interp(attr):
            return b0 * attr[f[:, 0]] + b1 * attr[f[:, 1]] + b2 * attr[f[:, 2]]

        n = interp(mesh.normals)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        tri = mesh.vertices[f]
        g = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        g = np.where((np.einsum("ij,ij->i", g, dirs[sel]) > 0)[:, None], -g, g)
        n = np.where((np.einsum("ij,ij->i", n, g) < 0)[:, None], -n, n)
        normal[sel] = n
        mode = _mode(mesh)
        if mode == MODE_MATERIAL:
            material[sel] = mesh.material
        else:
            material[sel] = PER_PIXEL
            if mode == MODE_TEXTURE:
                sigmoid[sel] = _bilinear_repeat(mesh.texture_sigmoid().astype(np.float64),
                                                interp(mesh.uv))
            else:
                sigmoid[sel] = interp(mesh.vertex_sigmoid().astype(np.float64))
    h, w = camera.height, camera.width
    return GBuffer(camera, best_t.reshape(h, w), normal.reshape(h, w, 3),
                   material.reshape(h, w), sigmoid.reshape(h, w, 3), list(scene.materials))
