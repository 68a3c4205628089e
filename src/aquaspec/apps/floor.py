"""The floor under a flying camera: the highest scene surface per patch of ground.

:class:`FloorMap` bins a scene's surfaces into square cells of the horizontal
(x, z) plane and keeps the highest point (y) in each, widened by one cell
each way so that a camera near a cell's edge is kept off what stands in the
next one. Surfaces are sampled on each triangle (its corners and a
barycentric grid fine enough for the cell size), so long thin triangles (a
pipe's sides, a box's faces) fill the cells they cross. The camera flight
(:mod:`aquaspec.apps.flight`) keeps the camera above it; a cell with nothing
in it has no floor (the seabed's depth bounds the camera there). It is a
column model: the camera cannot pass under an overhang.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import maximum_filter

from aquaspec.errors import AquaspecError

#: Default cell side, m.
DEFAULT_CELL_M = 0.5
#: Most samples along a triangle's edge (a huge triangle is sampled coarser).
MAX_EDGE_SAMPLES = 64


def _surface_points(vertices: np.ndarray, faces: np.ndarray, cell_m: float) -> np.ndarray:
    """Points on the triangles, no two samples of a triangle farther apart than a cell."""
    tri = vertices[faces]                                     # (n, 3, 3)
    edges = np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2).max(axis=1)
    steps = np.clip(np.ceil(edges / cell_m).astype(int), 1, MAX_EDGE_SAMPLES)
    points = [vertices]
    for k in np.unique(steps[steps > 1]):
        i, j = np.meshgrid(np.arange(k + 1), np.arange(k + 1), indexing="ij")
        keep = i + j <= k
        w = np.stack([i[keep], j[keep], k - i[keep] - j[keep]], axis=1) / k   # (m, 3)
        points.append(np.einsum("mc,ncd->nmd", w, tri[steps == k]).reshape(-1, 3))
    return np.concatenate(points)


class FloorMap:
    """Highest surface per (x, z) cell (module docstring).

    Parameters
    ----------
    points : (n, 3) array
        Points on the surfaces, world metres.
    cell_m : float
        Cell side, m.
    """

    def __init__(self, points, cell_m: float = DEFAULT_CELL_M):
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        if not (np.isfinite(cell_m) and cell_m > 0):
            raise AquaspecError(f"floor cell {cell_m!r} m; accepted: a positive length")
        if len(p) == 0 or not np.all(np.isfinite(p)):
            raise AquaspecError("a floor map needs finite surface points; got none or NaN")
        self.cell_m = float(cell_m)
        self.origin = p[:, [0, 2]].min(axis=0) - self.cell_m
        idx = np.floor((p[:, [0, 2]] - self.origin) / self.cell_m).astype(int)
        shape = tuple(idx.max(axis=0) + 2)
        top = np.full(shape, -np.inf)
        np.maximum.at(top, (idx[:, 0], idx[:, 1]), p[:, 1])
        self.heights = maximum_filter(top, size=3, mode="constant", cval=-np.inf)

    @classmethod
    def from_scene(cls, scene, cell_m: float = DEFAULT_CELL_M) -> "FloorMap":
        """The floor of every mesh of ``scene`` (an :class:`aquaspec.scene.mesh.Scene`)."""
        return cls(np.concatenate([_surface_points(m.vertices, m.faces, cell_m)
                                   for m in scene.meshes]), cell_m)

    def floor_y(self, x: float, z: float) -> float:
        """Height (y, m) of the highest surface around ``(x, z)``; -inf where none."""
        i, j = np.floor((np.array([x, z]) - self.origin) / self.cell_m).astype(int)
        if not (0 <= i < self.heights.shape[0] and 0 <= j < self.heights.shape[1]):
            return -np.inf
        return float(self.heights[i, j])
