"""Reading a caustic map: foot coordinates, the mip level of a footprint and
the trilinear lookup (the NumPy twin of the GPU's ``caustic()`` in
``gpu/wgsl/sunlight.wgsl``), and each band's factor from it (of its
``caustic_band``). Conventions and the map itself:
:mod:`aquaspec.light.caustics` (re-exported there).
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
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


#: Degree of the polynomial in ``x = sqrt(d / D)`` of a band's ``ln s``
#: (:func:`scale_polynomial`; the GPU holds its coefficients in two vec4).
SCALE_DEGREE = 8


def scale_polynomial(scale) -> np.ndarray:
    """``ln`` of the bands' contrast scales (K, n) at the slices
    (``x_k = k / (K - 1)``) as polynomials ``sum_p c_p x^p``, ``p = 1 ...``
    :data:`SCALE_DEGREE` (``s = 1`` at the surface), least squares: the
    coefficients (n, SCALE_DEGREE). (Within 0.011 of ``ln s`` at every slice
    of the 16 bands of Darecki et al.'s water, validation.fluctuations.)"""
    s = np.asarray(scale, dtype=float)
    if s.ndim != 2 or s.shape[0] < 2 or not np.all(np.isfinite(s) & (s > 0)):
        raise AquaspecError(f"band scales of shape {s.shape}; accepted: (K >= 2, n), "
                            "finite and > 0")
    x = np.arange(s.shape[0]) / (s.shape[0] - 1.0)
    basis = x[:, None] ** np.arange(1, SCALE_DEGREE + 1)
    return np.linalg.lstsq(basis, np.log(s), rcond=None)[0].T


def scale_at(coeffs, depth_m, max_depth_m: float) -> np.ndarray:
    """The bands' scales (..., n) at depths ``depth_m`` (...) from their
    polynomials ``coeffs`` (n, SCALE_DEGREE) (:func:`scale_polynomial`;
    depths clamped to ``[0, D]``, a depth that is not a number reads 0)."""
    d = np.asarray(depth_m, dtype=float)
    x = np.sqrt(np.where(d > 0, np.minimum(d, max_depth_m), 0.0) / max_depth_m)[..., None]
    c = np.asarray(coeffs, dtype=float)
    p = np.zeros(x.shape[:-1] + (c.shape[0],))
    for k in range(c.shape[1] - 1, -1, -1):          # Horner, as the GPU
        p = x * (c[:, k] + p)
    return np.exp(p)


def band_factor(cmap, factor, depth_m) -> np.ndarray:
    """Each band's caustic factor (..., n_bands) from the shared ``factor``
    (...) of ``cmap`` read at depths ``depth_m`` (..., m): ``1 + s (C - 1)``
    with the scale ``s`` of ``cmap.band_scale`` (K, n_bands) at that depth
    (:func:`scale_at` of its :func:`scale_polynomial`); (..., 1), the factor
    itself, when the map has no band scales."""
    c = np.asarray(factor, dtype=float)
    if getattr(cmap, "band_scale", None) is None:
        return c[..., None]
    d = np.broadcast_to(np.asarray(depth_m, dtype=float), c.shape)
    s = scale_at(scale_polynomial(cmap.band_scale), d, cmap.max_depth)
    return 1.0 + s * (c[..., None] - 1.0)
