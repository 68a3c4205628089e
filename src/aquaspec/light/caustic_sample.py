"""Reading a caustic map: foot coordinates, the mip level of a footprint and
the trilinear lookup (the NumPy twin of the GPU's ``caustic()`` in
``gpu/wgsl/sunlight.wgsl``). Conventions and the map itself:
:mod:`aquaspec.light.caustics` (re-exported there).
"""

from __future__ import annotations

import numpy as np

from aquaspec.light.photon_map import periodic_cell
from aquaspec.numerics import bilinear_blend


def foot(points, to_sun) -> np.ndarray:
    """Foot coordinates (..., 2) of points (..., 3): where the flat surface's
    refracted beam through each point leaves the surface."""
    p = np.asarray(points, dtype=float)
    d = -p[..., 1]
    s = np.asarray(to_sun, dtype=float)
    return np.stack([p[..., 0] + d / s[1] * s[0], p[..., 2] + d / s[1] * s[2]], axis=-1)


def _bilinear_wrap(level, k, u, tile_m):
    """Bilinear periodic read of slice ``k`` (...) of one level at foot ``u`` (..., 2)."""
    i0, i1, j0, j1, fz, fx = periodic_cell(u, level.shape[-1], tile_m)

    def at(i, j):
        return level[k, i, j].astype(float)

    return bilinear_blend(at(i0, j0), at(i0, j1), at(i1, j0), at(i1, j1), fz, fx)


def lod_of(footprint_m, texel_m, n_levels):
    """Mip level for a footprint (m): ``log2(footprint / texel)`` clamped to the pyramid."""
    f = np.maximum(np.asarray(footprint_m, dtype=float) / texel_m, 1.0)
    return np.clip(np.log2(f), 0.0, n_levels - 1.0)


def slice_position(depth_m, max_depth_m: float, n_slices: int):
    """Where the lookup reads depth ``depth_m`` (...): slice ``k0`` and the
    fraction ``fk`` towards ``k0 + 1`` (slices at ``D (k / (K - 1))^2``,
    linear between them in ``sqrt(d / D)``, clamped to ``[0, D]``)."""
    d = np.clip(np.asarray(depth_m, dtype=float), 0.0, max_depth_m)
    x = np.sqrt(d / max_depth_m) * (n_slices - 1)
    k0 = np.minimum(np.floor(x), n_slices - 2).astype(np.int64)
    return k0, x - k0


def slice_interp(values, depth_m, max_depth_m: float) -> np.ndarray:
    """Per-slice ``values`` (K, ...) read at ``depth_m`` (D,) as the lookup
    reads the slices (:func:`slice_position`): (D, ...)."""
    v = np.asarray(values, dtype=float)
    k0, fk = slice_position(np.atleast_1d(depth_m), max_depth_m, v.shape[0])
    fk = fk.reshape(fk.shape + (1,) * (v.ndim - 1))
    return (1.0 - fk) * v[k0] + fk * v[k0 + 1]


def sample(cmap, points, footprint_m=0.0) -> np.ndarray:
    """The caustic factor of ``cmap`` (:class:`aquaspec.light.caustics.CausticMap`)
    at points (..., 3), each averaged over about
    ``footprint_m`` metres (trilinear in the mip pyramid; linear between depth
    slices in ``sqrt(d / D)``)."""
    p = np.asarray(points, dtype=float)
    u = foot(p, cmap.to_sun)
    d = np.clip(-p[..., 1], 0.0, cmap.max_depth)
    k0, fk = slice_position(d, cmap.max_depth, cmap.depths.size)
    lod = np.broadcast_to(lod_of(footprint_m, cmap.texel, len(cmap.levels)), d.shape)
    m0 = np.floor(lod).astype(np.int64)
    fm = lod - m0
    m1 = np.minimum(m0 + 1, len(cmap.levels) - 1)
    out = np.zeros(d.shape)
    for m in np.unique(np.concatenate([m0.ravel(), m1.ravel()])):
        wm = np.where(m0 == m, 1.0 - fm, 0.0) + np.where(m1 == m, fm, 0.0)
        sel = wm > 0
        if not np.any(sel):
            continue
        lv = cmap.levels[m]
        v = ((1 - fk[sel]) * _bilinear_wrap(lv, k0[sel], u[sel], cmap.waves.tile_m)
             + fk[sel] * _bilinear_wrap(lv, k0[sel] + 1, u[sel], cmap.waves.tile_m))
        out[sel] += wm[sel] * v
    return out
