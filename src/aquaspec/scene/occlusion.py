"""What a surface point sees of the water around it: the scene's occlusion maps.

Geometry only (no water): :func:`occlusion_maps` draws one orthographic depth
map of the scene's occluders per direction of a fixed set of ``K``
directions over the whole sphere (:func:`sphere_directions`, spherical
Fibonacci, equal solid angle ``4 pi / K``), built once for a static scene
with the sun's shadow-map machinery (:mod:`aquaspec.scene.shadowmap`: the
same :class:`~aquaspec.scene.shadowmap.ShadowMapSpec` and raster, so the GPU
draws the same layers, :mod:`aquaspec.gpu.passes.depth_maps`).
:meth:`OcclusionMaps.visibility` then gives, per receiver point and normal
and per direction ``w_k`` (pointing *towards* where the light comes from),
the visibility ``V_k`` in [0, 1] and the distance ``s_k`` (m) along ``w_k``
to the occluder. The water's part (how much light each direction carries,
how much of it the water between the point and the occluder still
scatters towards it) is :mod:`aquaspec.transport.lightfield.occlusion`.

What occludes
-------------
- Not the seabed: the light field's lower boundary (``scene.seabed``)
  already holds the seabed's light. Meshes named ``"seabed"`` (the
  built-in terrain, :func:`aquaspec.scene.seabed.with_seabed_plane`, the
  validation scenes' floor) and every triangle lying within
  :data:`SEABED_TOLERANCE_M` above ``scene.seabed``'s plane or below it are
  left out. There is no water-surface mesh; geometry above the surface
  still blocks the sky (the water's part cuts the distance at the surface).
- Closed meshes (every edge shared by two triangles, vertices welded by
  position) are drawn with only the triangles *facing the receiver* along
  ``w_k`` (outward normal ``. w_k < 0``: second-depth shadow mapping). The
  map then holds the occluder's near side, so ``s_k`` is the distance to
  the surface the point faces (the far side would add the occluder's
  thickness: a 0.2 m ledge over a 0.3 m gap would read 0.5 m), and a point
  on a closed mesh cannot shadow itself. Open meshes (single quads) are
  drawn whole.
- RGB-D photographs hold no geometry behind what they show. Their
  approximation (:func:`visible_surface_occluders`) is the visible surface
  itself as an open mesh, cut where the depth jumps: a crevice or an
  overhang the camera sees into occludes, but what is hidden behind the
  visible surfaces (the back of a rock, a ledge's top) does not, and the
  surface's silhouettes hang in the water as thin sheets.
- A point does not shadow itself: it is looked up ``normal_offset_texels``
  along its normal and counts as visible up to ``bias_texels`` below the
  map (as the sun's map). Directions behind the surface (``n . w_k <= 0``)
  are visible by definition: the light they carry does not reach it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.shadowmap import (BIAS_TEXELS, DEFAULT_MAP_MARGIN_M, DEFAULT_MAP_RADIUS_M,
                                      NORMAL_OFFSET_TEXELS, ShadowMapSpec, shadow_map_numpy,
                                      shadow_map_spec)

#: Directions of the default set. Measured on the validation's ledge (grey
#: card under it, Jerlov IB, 5 m): the error of ``O`` against 2048 directions
#: is up to 0.12 with 32, 0.026 with 64, 0.007 with 128 (RMS over rotations
#: of the set 0.049 / 0.041; seabed under it 0.021 / 0.009).
DEFAULT_DIRECTIONS = 64
#: Side of each occlusion map in texels (a scene a few metres across gets
#: millimetre texels; the full 44 m region 4.3 cm ones).
DEFAULT_OCCLUSION_MAP_SIZE = 1024
#: Triangles this close above the seabed's plane, or below it, are the seabed, m.
SEABED_TOLERANCE_M = 1e-3
#: Meshes of this name are the seabed (the built-in terrain, seabed planes).
SEABED_MESH_NAME = "seabed"
#: The golden angle, radians (the azimuth step of the spherical Fibonacci set).
_GOLDEN_ANGLE = np.pi * (3.0 - np.sqrt(5.0))


def sphere_directions(k: int) -> tuple[np.ndarray, np.ndarray]:
    """``(directions (k, 3), solid_angle (k,))``: the spherical Fibonacci set.

    ``w_y = 1 - (2 j + 1) / k`` (each direction the centre of a zone of equal
    area, none exactly horizontal or vertical), azimuth ``j`` times the
    golden angle; each direction stands for the solid angle ``4 pi / k``.
    """
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 4 <= k <= 4096:
        raise AquaspecError(f"occlusion directions {k!r}; accepted: an integer 4 ... 4096")
    j = np.arange(int(k))
    y = 1.0 - (2.0 * j + 1.0) / k
    r = np.sqrt(np.maximum(1.0 - y * y, 0.0))
    phi = _GOLDEN_ANGLE * j
    dirs = np.stack([r * np.cos(phi), y, r * np.sin(phi)], axis=1)
    return dirs, np.full(int(k), 4.0 * np.pi / k)


@dataclass(frozen=True)
class _Triangles:
    """Occluder triangles (T, 3, 3), their outward normals (T, 3) and whether
    each belongs to a closed mesh (T,)."""

    corners: np.ndarray
    normals: np.ndarray
    closed: np.ndarray


@dataclass(frozen=True)
class _Soup:
    """Triangles (T, 3, 3) as the mesh-like object :func:`shadow_map_numpy` reads."""

    corners: np.ndarray

    @property
    def vertices(self):
        return self.corners.reshape(-1, 3)

    @property
    def faces(self):
        return np.arange(3 * len(self.corners)).reshape(-1, 3)

    def select(self, keep):
        return _Soup(self.corners[keep])


def _is_closed(vertices, faces) -> bool:
    """Every edge (vertices welded by position to 1e-6 of the mesh's size)
    shared by exactly two triangles."""
    v = np.asarray(vertices, dtype=float)
    scale = max(float(np.ptp(v, axis=0).max()), 1e-9) * 1e-6
    _, weld = np.unique(np.round(v / scale).astype(np.int64), axis=0, return_inverse=True)
    f = weld.reshape(-1)[np.asarray(faces)]
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    edges = edges[edges[:, 0] != edges[:, 1]]
    if edges.size == 0:
        return False
    _, counts = np.unique(edges, axis=0, return_counts=True)
    return bool(np.all(counts == 2))


def occluder_triangles(scene) -> _Triangles:
    """The scene's occluders (module docstring: the seabed left out), with
    outward normals (the winding's, turned to agree with the mesh's own
    normals where it has them) and closedness."""
    bed = getattr(scene, "seabed", None)
    floor_y = -float(bed.depth_m) + SEABED_TOLERANCE_M if bed is not None else -np.inf
    corners, normals, closed = [], [], []
    for m in scene.meshes:
        if m.name == SEABED_MESH_NAME:
            continue
        tri = np.asarray(m.vertices, dtype=float)[m.faces]
        keep = tri[:, :, 1].max(axis=1) > floor_y
        if not np.any(keep):
            continue
        geo = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        if m.normals is not None:
            shade = np.asarray(m.normals, dtype=float)[m.faces].sum(axis=1)
            geo = geo * np.where(np.einsum("ij,ij->i", geo, shade) < 0, -1.0, 1.0)[:, None]
        corners.append(tri[keep])
        normals.append(geo[keep])
        closed.append(np.full(int(keep.sum()), _is_closed(m.vertices, m.faces)))
    if not corners:
        return _Triangles(np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros(0, bool))
    return _Triangles(np.concatenate(corners), np.concatenate(normals), np.concatenate(closed))


@dataclass(frozen=True, eq=False)
class OcclusionMaps:
    """The occlusion maps of a static scene (:func:`occlusion_maps`).

    ``directions`` (K, 3) unit vectors towards where the light comes from,
    ``solid_angle`` (K,) sr each; ``height_maps[k]`` (size, size) and
    ``specs[k]`` the map along ``directions[k]`` (both None: nothing to
    occlude along it), heights ``h = p . w_k``.
    """

    directions: np.ndarray
    solid_angle: np.ndarray
    height_maps: tuple
    specs: tuple
    bias_texels: float = BIAS_TEXELS
    normal_offset_texels: float = NORMAL_OFFSET_TEXELS

    @property
    def k(self) -> int:
        return len(self.directions)

    @property
    def empty(self) -> bool:
        """Nothing occludes anything."""
        return all(s is None for s in self.specs)

    def visibility(self, points, normals) -> tuple[np.ndarray, np.ndarray]:
        """``(V, s)``, each ``points.shape[:-1] + (K,)``: visibility in [0, 1]
        of direction ``k`` from each point (normals (..., 3), unit) and the
        distance (m) along it to the occluder (``inf`` where visible).

        The four texels around the point are compared (bilinear weights, as
        :func:`aquaspec.scene.shadowmap.map_visibility`); ``s`` is the mean
        of ``h_map`` over the occluding ones, with their weights, less the
        point's own ``h`` (measured from the point, not from where it is
        looked up).
        Directions with ``n . w_k <= 0`` are visible (module docstring).
        """
        p = np.asarray(points, dtype=float)
        n = np.asarray(normals, dtype=float)
        if p.shape[-1:] != (3,) or n.shape != p.shape:
            raise AquaspecError(f"occlusion receivers: points {p.shape} and normals {n.shape}; "
                                "accepted: two arrays of the same shape (..., 3)")
        if not (np.all(np.isfinite(p)) and np.all(np.isfinite(n))):
            raise AquaspecError("occlusion receivers: points and normals must be finite "
                                "(open-water pixels have no receiver)")
        shape = p.shape[:-1]
        p, n = p.reshape(-1, 3), n.reshape(-1, 3)
        vis = np.ones((len(p), self.k))
        dist = np.full((len(p), self.k), np.inf)
        facing = n @ self.directions.T > 0.0
        for k, (hmap, spec) in enumerate(zip(self.height_maps, self.specs)):
            if spec is None:
                continue
            sel = np.flatnonzero(facing[:, k])
            if sel.size == 0:
                continue
            q = p[sel] + n[sel] * (self.normal_offset_texels * spec.texel)
            vis[sel, k], occ_h = _sample(hmap, spec, q, self.bias_texels * spec.texel)
            # The distance from the point itself (the offset only keeps it off its surface).
            dist[sel, k] = np.maximum(occ_h - p[sel] @ spec.to_sun, 0.0)
        return vis.reshape(shape + (self.k,)), dist.reshape(shape + (self.k,))

    def describe(self) -> dict:
        used = [s for s in self.specs if s is not None]
        return {"directions": self.k, "maps": len(used),
                "size": used[0].size if used else None,
                "texel_m": [float(s.texel) for s in used]}


def _sample(hmap, spec: ShadowMapSpec, points, bias):
    """Visibility of points (P, 3) in one map and the mean height of the
    texels that hide them (weighted as in the visibility; inf: none)."""
    x, y, h = spec.texel_coords(points)
    size = spec.size
    j0, i0 = np.floor(x), np.floor(y)
    fx, fy = x - j0, y - i0
    j0, i0 = j0.astype(np.int64), i0.astype(np.int64)
    occ_w = np.zeros(len(points))
    occ_s = np.zeros(len(points))
    for di, wy in ((0, 1.0 - fy), (1, fy)):
        for dj, wx in ((0, 1.0 - fx), (1, fx)):
            ii, jj = i0 + di, j0 + dj
            inside = (ii >= 0) & (ii < size) & (jj >= 0) & (jj < size)
            hm = np.where(inside, hmap[np.clip(ii, 0, size - 1), np.clip(jj, 0, size - 1)],
                          -np.inf)
            lit = h >= hm - bias
            wt = wx * wy
            occ_w += np.where(lit, 0.0, wt)
            occ_s += np.where(lit, 0.0, wt * hm)
    with np.errstate(invalid="ignore", divide="ignore"):
        occ_h = np.where(occ_w > 0, occ_s / np.where(occ_w > 0, occ_w, 1.0), np.inf)
    # 1 - (hidden share): exactly 1 where nothing hides the point.
    return np.clip(1.0 - occ_w, 0.0, 1.0), occ_h


def _direction_set(directions):
    if isinstance(directions, tuple):
        dirs, omega = (np.asarray(x, dtype=float) for x in directions)
        if dirs.ndim != 2 or dirs.shape[1] != 3 or omega.shape != dirs.shape[:1] \
                or not np.all(np.isfinite(dirs)) or not np.all(omega > 0):
            raise AquaspecError(f"occlusion directions of shapes {dirs.shape}, {omega.shape}; "
                                "accepted: (K, 3) unit vectors and (K,) solid angles > 0")
        return dirs / np.linalg.norm(dirs, axis=1, keepdims=True), omega
    return sphere_directions(directions)


@dataclass(frozen=True, eq=False)
class OcclusionLayout:
    """What the occlusion maps of a scene are before they are drawn
    (:func:`occlusion_layout`): the directions ``dirs`` (K, 3), their solid
    angles (K,), the occluder triangles and one
    :class:`~aquaspec.scene.shadowmap.ShadowMapSpec` per direction (None:
    nothing to occlude along it). The NumPy maps and the GPU's
    (:mod:`aquaspec.gpu.passes.occlusion`) are drawn from the same layout."""

    directions: np.ndarray
    solid_angle: np.ndarray
    triangles: _Triangles
    specs: tuple


def occlusion_layout(scene, camera, *, directions=DEFAULT_DIRECTIONS,
                     size: int = DEFAULT_OCCLUSION_MAP_SIZE,
                     radius_m: float = DEFAULT_MAP_RADIUS_M,
                     margin_m: float = DEFAULT_MAP_MARGIN_M, triangles=None) -> OcclusionLayout:
    """The directions, occluders and map geometry of :func:`occlusion_maps`
    (same arguments); ``triangles``: the scene's
    :func:`occluder_triangles` when the caller keeps them (a static scene)."""
    dirs, omega = _direction_set(directions)
    tris = triangles if triangles is not None else (
        occluder_triangles(scene) if scene is not None else None)
    if tris is None or len(tris.corners) == 0:
        empty = _Triangles(np.zeros((0, 3, 3)), np.zeros((0, 3)), np.zeros(0, bool))
        return OcclusionLayout(dirs, omega, empty, (None,) * len(dirs))
    flat = tris.corners.reshape(-1, 3)
    bounds = np.stack([flat.min(axis=0), flat.max(axis=0)])
    specs = tuple(shadow_map_spec(bounds, camera.position, w, size=size, radius_m=radius_m,
                                  margin_m=margin_m) for w in dirs)
    return OcclusionLayout(dirs, omega, tris, specs)


def occlusion_maps(scene, camera, *, directions=DEFAULT_DIRECTIONS,
                   size: int = DEFAULT_OCCLUSION_MAP_SIZE,
                   radius_m: float = DEFAULT_MAP_RADIUS_M,
                   margin_m: float = DEFAULT_MAP_MARGIN_M) -> OcclusionMaps:
    """The occlusion maps of ``scene`` seen around ``camera`` (module docstring).

    ``directions``: the number ``K`` of the spherical Fibonacci set
    (:func:`sphere_directions`) or ``(dirs (K, 3), solid_angle (K,))``. Each
    map covers the occluders' bounds cut to ``radius_m + margin_m`` around the
    camera snapped to cells as the sun's map
    (:func:`aquaspec.scene.shadowmap.shadow_map_spec`); receivers or
    occluders outside it count as seeing open water.
    """
    lay = occlusion_layout(scene, camera, directions=directions, size=size, radius_m=radius_m,
                           margin_m=margin_m)
    tris = lay.triangles
    soup = _Soup(tris.corners)
    maps = []
    for w, spec in zip(lay.directions, lay.specs):
        if spec is None:
            maps.append(None)
            continue
        keep = ~tris.closed | (tris.normals @ w < 0.0)
        maps.append(shadow_map_numpy(_Scene([soup.select(keep)]), spec))
    return OcclusionMaps(lay.directions, lay.solid_angle, tuple(maps), lay.specs)


#: Visible-surface occluders of an RGB-D G-buffer: a vertex every this many pixels.
RGBD_OCCLUDER_STEP = 2
#: ... and no triangle seen more edge-on than this (``|cos|`` between its
#: normal and the view ray): those bridge depth jumps (a board's edge and
#: the wall behind it), not surfaces.
RGBD_MIN_FACING = 0.1


def visible_surface_occluders(gbuffer, *, step: int = RGBD_OCCLUDER_STEP,
                              min_facing: float = RGBD_MIN_FACING):
    """The visible surface of a G-buffer (an RGB-D photograph's) as an occluder
    scene (module docstring): vertices every ``step`` pixels where the ray
    hits, two triangles per cell of four hit corners, those seen more
    edge-on than ``min_facing`` dropped (they bridge depth jumps). Returns a
    :class:`aquaspec.scene.mesh.Scene` with one mesh (none if nothing qualifies)."""
    if isinstance(step, bool) or not isinstance(step, (int, np.integer)) or step < 1:
        raise AquaspecError(f"occluder step {step!r}; accepted: an integer >= 1 (pixels)")
    if not 0 <= min_facing < 1:
        raise AquaspecError(f"occluder min_facing {min_facing!r}; accepted: 0 <= value < 1")
    cam = gbuffer.camera
    dist = np.asarray(gbuffer.distance, dtype=float)[::step, ::step]
    ok = gbuffer.hit[::step, ::step] & np.isfinite(dist)
    pts = cam.position + cam.ray_directions()[::step, ::step] * np.where(ok, dist, 0.0)[..., None]
    h, w = dist.shape
    idx = np.arange(h * w).reshape(h, w)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, :-1], idx[1:, 1:]
    cell = ok[:-1, :-1] & ok[:-1, 1:] & ok[1:, :-1] & ok[1:, 1:]
    faces = np.concatenate([np.stack([a[cell], c[cell], b[cell]], 1),
                            np.stack([b[cell], c[cell], d[cell]], 1)])
    flat = pts.reshape(-1, 3)
    tri = flat[faces]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    view = tri.mean(axis=1) - cam.position
    with np.errstate(invalid="ignore", divide="ignore"):
        facing = np.abs(np.einsum("ij,ij->i", normal, view)) / (
            np.linalg.norm(normal, axis=1) * np.linalg.norm(view, axis=1))
    faces = faces[np.nan_to_num(facing) > min_facing]
    scene = Scene()
    if len(faces) == 0:
        return scene
    used, inverse = np.unique(faces, return_inverse=True)
    scene.add(Mesh.flat(flat[used], inverse.reshape(-1, 3), material=0,
                        name="rgbd visible surface"))
    return scene


@dataclass(frozen=True)
class _Scene:
    """The few occluder triangles :func:`shadow_map_numpy` draws into one map."""

    meshes: list
