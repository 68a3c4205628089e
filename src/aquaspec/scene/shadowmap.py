"""The NumPy shadow map: which points the sun's beam reaches.

An orthographic height map seen from the sun (the sun's direction is given
as the unit vector ``to_sun`` towards it under water, e.g.
:attr:`aquaspec.light.sun.Sun.to_sun`): texel (row i, column j) holds the
largest ``h = p . to_sun`` of the scene over the line through its centre
parallel to the beam (the first surface the beam meets), or nothing. A point
is lit where its own ``h`` is at least the map's (less a bias); the four
texels around it are compared and the results interpolated bilinearly
(percentage-closer filtering), so shadow edges are soft over one texel
instead of stair-stepped. The GPU rasterises the same map
(:mod:`aquaspec.gpu.passes.sun`) and reads it the same way.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError

#: Shadow-map side in texels.
DEFAULT_MAP_SIZE = 2048
#: Shadows are resolved within this distance of the camera, m (beyond it
#: everything is lit): with the margin, at 2048 texels, 4.3 cm texels.
DEFAULT_MAP_RADIUS_M = 40.0
#: The map reaches this much further than :data:`DEFAULT_MAP_RADIUS_M`, m, and
#: its centre across the beam snaps to a grid of twice this pitch (as cascaded
#: shadow maps snap theirs), so every camera in a cell of the grid gets the
#: same map: a camera moving about a metre a frame redraws it when it crosses
#: into another cell instead of every frame, and a moving camera's frame
#: equals a still render of it.
DEFAULT_MAP_MARGIN_M = 4.0
#: Depth bias, in texels (a point counts as lit up to this far below the map).
BIAS_TEXELS = 1.0
#: Surface points are looked up this far along their normal, in texels.
NORMAL_OFFSET_TEXELS = 1.5


def _basis(to_sun):
    """Two unit axes across the beam ``to_sun``."""
    w = np.asarray(to_sun, dtype=float)
    ref = np.array([0.0, 0.0, 1.0]) if abs(w[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    e1 = np.cross(w, ref)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(w, e1)


@dataclass(frozen=True)
class ShadowMapSpec:
    """Where the shadow map lies: axes ``e1, e2`` across the beam, ``to_sun``
    along it; texel ``(i, j)`` is centred at ``u = u0 + (j + 0.5) texel``,
    ``v = v0 + (i + 0.5) texel`` (``u = p . e1``, ``v = p . e2``); heights
    ``h = p . to_sun`` within ``[h_min, h_max]``."""

    to_sun: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    u0: float
    v0: float
    texel: float
    size: int
    h_min: float
    h_max: float

    def texel_coords(self, points):
        """Continuous texel coordinates ``(x, y, h)`` of points (..., 3); texel
        ``(i, j)``'s centre is at ``x = j``, ``y = i``."""
        p = np.asarray(points, dtype=float)
        x = (p @ self.e1 - self.u0) / self.texel - 0.5
        y = (p @ self.e2 - self.v0) / self.texel - 0.5
        return x, y, p @ self.to_sun

    def clip_matrix(self) -> np.ndarray:
        """4x4 world -> clip matrix of the GPU raster (x right = +u, y up =
        -v so that row 0 is ``v0``; depth 0 at ``h_max``, 1 at ``h_min``)."""
        span = self.size * self.texel
        m = np.zeros((4, 4))
        m[0, :3] = 2.0 * self.e1 / span
        m[0, 3] = -1.0 - 2.0 * self.u0 / span
        m[1, :3] = -2.0 * self.e2 / span
        m[1, 3] = 1.0 + 2.0 * self.v0 / span
        m[2, :3] = -self.to_sun / (self.h_max - self.h_min)
        m[2, 3] = self.h_max / (self.h_max - self.h_min)
        m[3, 3] = 1.0
        return m

    def describe(self) -> dict:
        return {"size": self.size, "texel_m": self.texel,
                "extent_m": self.size * self.texel}


def shadow_map_spec(scene_bounds, camera_position, to_sun, *, size: int = DEFAULT_MAP_SIZE,
                    radius_m: float = DEFAULT_MAP_RADIUS_M,
                    margin_m: float = DEFAULT_MAP_MARGIN_M) -> ShadowMapSpec | None:
    """The map over the scene's bounds ((2, 3): low and high corners), cut to
    ``radius_m + margin_m`` around the camera's place across the beam snapped
    to a grid of pitch ``2 margin_m`` (so within ``margin_m`` of the camera
    each way: the map holds everything within ``radius_m`` of it, and is the
    same for every camera of the grid's cell); None for an empty scene."""
    if not (isinstance(size, (int, np.integer)) and 16 <= size <= 8192):
        raise AquaspecError(f"shadow map size {size!r}; accepted: an integer 16 ... 8192")
    if not (np.isfinite(radius_m) and radius_m > 0):
        raise AquaspecError(f"shadow map radius {radius_m!r} m; accepted: a distance > 0")
    if not (np.isfinite(margin_m) and margin_m >= 0):
        raise AquaspecError(f"shadow map margin {margin_m!r} m; accepted: a distance >= 0")
    lo, hi = np.asarray(scene_bounds, dtype=float)
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        return None
    w = np.asarray(to_sun, dtype=float)
    e1, e2 = _basis(w)
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    cam = np.asarray(camera_position, dtype=float)
    cu, cv = float(cam @ e1), float(cam @ e2)
    if margin_m > 0:
        pitch = 2.0 * margin_m
        cu, cv = pitch * np.round(cu / pitch), pitch * np.round(cv / pitch)
    reach = radius_m + margin_m
    u_lo = max((corners @ e1).min(), cu - reach)
    u_hi = min((corners @ e1).max(), cu + reach)
    v_lo = max((corners @ e2).min(), cv - reach)
    v_hi = min((corners @ e2).max(), cv + reach)
    if u_hi <= u_lo or v_hi <= v_lo:
        return None
    extent = max(u_hi - u_lo, v_hi - v_lo) * (1.0 + 1e-6)
    texel = extent / size
    h = corners @ w
    margin = 1e-3 * (h.max() - h.min()) + 1e-3
    return ShadowMapSpec(w, e1, e2, u_lo, v_lo, texel, int(size),
                         float(h.min() - margin), float(h.max() + margin))


def shadow_map_numpy(scene, spec: ShadowMapSpec, *, block: int = 8) -> np.ndarray:
    """The height map (size, size) in float64 (``-inf``: no surface), by
    testing texel centres against each triangle (inside or on its edges).

    Triangles whose bounding box spans at most ``block`` texels each way are
    done together; larger ones one at a time.
    """
    n = spec.size
    out = np.full((n, n), -np.inf)
    tris = [m.vertices[m.faces] for m in scene.meshes]
    if not tris:
        return out
    tri = np.concatenate(tris)
    x, y, h = spec.texel_coords(tri)                       # (T, 3) each
    j_lo = np.maximum(np.ceil(x.min(axis=1)), 0).astype(int)
    j_hi = np.minimum(np.floor(x.max(axis=1)), n - 1).astype(int)
    i_lo = np.maximum(np.ceil(y.min(axis=1)), 0).astype(int)
    i_hi = np.minimum(np.floor(y.max(axis=1)), n - 1).astype(int)
    keep = (j_hi >= j_lo) & (i_hi >= i_lo)
    # Degenerate (edge-on) triangles cover no texel centre in the raster either.
    area = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    keep &= np.abs(area) > 1e-12

    def cover(ids, jj, ii):
        """Texels (ii, jj) (T, K) tested against triangles ``ids`` (T,)."""
        xa, ya, ha = x[ids], y[ids], h[ids]
        ar = area[ids][:, None]
        px, py = jj.astype(float), ii.astype(float)
        w0 = ((xa[:, 1, None] - px) * (ya[:, 2, None] - py)
              - (xa[:, 2, None] - px) * (ya[:, 1, None] - py)) / ar
        w1 = ((xa[:, 2, None] - px) * (ya[:, 0, None] - py)
              - (xa[:, 0, None] - px) * (ya[:, 2, None] - py)) / ar
        w2 = 1.0 - w0 - w1
        tol = -1e-9
        inside = (w0 >= tol) & (w1 >= tol) & (w2 >= tol) & (jj <= j_hi[ids, None]) \
            & (ii <= i_hi[ids, None]) & (jj < n) & (ii < n)
        hv = w0 * ha[:, 0, None] + w1 * ha[:, 1, None] + w2 * ha[:, 2, None]
        ii, jj, hv = ii[inside], jj[inside], hv[inside]
        np.maximum.at(out, (ii, jj), hv)

    span = np.maximum(j_hi - j_lo, i_hi - i_lo) + 1
    small = np.flatnonzero(keep & (span <= block))
    oj, oi = np.meshgrid(np.arange(block), np.arange(block))
    oj, oi = oj.ravel(), oi.ravel()
    chunk = max(1, 2_000_000 // (block * block))
    for s in range(0, small.size, chunk):
        ids = small[s:s + chunk]
        cover(ids, j_lo[ids, None] + oj[None], i_lo[ids, None] + oi[None])
    for t in np.flatnonzero(keep & (span > block)):
        jj, ii = np.meshgrid(np.arange(j_lo[t], j_hi[t] + 1), np.arange(i_lo[t], i_hi[t] + 1))
        cover(np.array([t]), jj.ravel()[None], ii.ravel()[None])
    return out


def map_visibility(height_map, spec: ShadowMapSpec, points, *, bias_texels=BIAS_TEXELS):
    """``V`` in [0, 1] at points (..., 3): four texels compared, bilinear
    weights; texels outside the map or without a surface are lit."""
    x, y, h = spec.texel_coords(points)
    n = spec.size
    j0, i0 = np.floor(x), np.floor(y)
    fx, fy = x - j0, y - i0
    j0, i0 = j0.astype(np.int64), i0.astype(np.int64)
    bias = bias_texels * spec.texel
    vis = np.zeros(np.shape(x))
    for di, wy in ((0, 1.0 - fy), (1, fy)):
        for dj, wx in ((0, 1.0 - fx), (1, fx)):
            ii, jj = i0 + di, j0 + dj
            inside = (ii >= 0) & (ii < n) & (jj >= 0) & (jj < n)
            hm = np.where(inside, height_map[np.clip(ii, 0, n - 1), np.clip(jj, 0, n - 1)],
                          -np.inf)
            vis = vis + wx * wy * (h >= hm - bias)
    return vis


def numpy_shadow_map(scene, camera, to_sun, *, size: int = DEFAULT_MAP_SIZE,
                     radius_m: float = DEFAULT_MAP_RADIUS_M,
                     margin_m: float = DEFAULT_MAP_MARGIN_M):
    """``(height_map, spec)`` of a scene for :func:`aquaspec.shading.sun.sun_radiance`,
    or None (no scene, or nothing near the camera)."""
    if scene is None or not scene.meshes:
        return None
    spec = shadow_map_spec(scene.bounds(), camera.position, to_sun, size=size,
                           radius_m=radius_m, margin_m=margin_m)
    if spec is None:
        return None
    return shadow_map_numpy(scene, spec), spec
