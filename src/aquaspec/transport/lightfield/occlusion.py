"""The water's part of the ambient occlusion: how much light each direction carries.

A surface at depth ``d`` with normal ``n`` is lit by the light field's
irradiance ``E_i(d, n) = int L_i(d, w) max(0, n . w) dw`` (band ``i``;
``L_i(d, w)`` the open-water radiance arriving from direction ``w``, i.e.
seen looking along ``w``: ``LightField.radiance(d, w_y)``). An occluder at
distance ``s`` along ``w`` takes away only what would have come from beyond
it: along the line the field's radiance is, exactly (the delta-M transport
of :mod:`aquaspec.transport.lightfield.field`),

    L(x, w) = int_0^s exp(-c* t) j*(x + t w) dt + exp(-c* s) L(d', w),

with ``d' = d - s w_y`` the occluder's depth and ``c*`` the field's own
(delta-M) extinction (:attr:`LightfieldTables.beam_extinction
<aquaspec.transport.lightfield.tables.LightfieldTables.beam_extinction>`):
the water in front of the occluder still scatters light towards the point
(first order: its own shadowing is the water's ambient shadow), so the loss
is ``exp(-c* s) L(d', w)``, less the light the occluder reflects (left out
here: ``reflected`` is its place). Above the water surface (``s > d / w_y``)
the loss is the surface's radiance, ``s`` cut there.

On the fixed direction set of :class:`aquaspec.scene.occlusion.OcclusionMaps`
(``w_k``, solid angles ``dw_k``), with visibility ``V_k`` and distance
``s_k`` per receiver, the ambient term of a surface is multiplied per band by

    O_i = 1 - sum_k (1 - V_k) W_ik(d'_k) exp(-c*_i s_k) / sum_k W_ik(d),
    W_ik(d) = L_i(d, w_k) max(0, n . w_k) dw_k,

the same discrete sum above and below, so that open water gives exactly 1
and the errors of the direction set largely cancel (:func:`occlusion_factor`).
``L_i(d, w_k)`` is tabulated over depth once per scene and water
(:class:`OcclusionWeights`: one lookup per direction and pixel).

*Compressed form* (:func:`occlusion_moments`, :func:`factor_from_moments`),
what a GPU pass evaluates: per pixel a few band-independent numbers, the
occluded and the total geometric weight in a basis of ``M`` functions of
``w_y`` (:data:`BASES`), the occluder distance's mean and variance and the
mean rise; per band
the ratio from those with the radiance's coefficients in that basis
(least-squares fit over the directions, tabulated over depth).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.transport.lightfield.tables import table_depth_index, table_depths

#: Functions of ``w_y`` the compressed form may use: ``"bins"`` piecewise
#: constant on ``M`` intervals equal in ``w_y``, ``"angle_bins"`` equal in
#: zenith angle, ``"hats"`` piecewise linear through ``M`` nodes equal in
#: zenith angle, ``"legendre"`` polynomials of degree < M.
BASES = ("bins", "angle_bins", "hats", "legendre")
#: Weights of the compressed form's mean distance: ``"geometric"``
#: ``(1 - V) max(0, n.w) dw``, ``"radiance"`` that times the band-mean
#: normalised radiance.
MEAN_WEIGHTS = ("geometric", "radiance")
#: Receivers per chunk (the per-direction, per-band arrays are P x K x n).
_CHUNK = 8192


@dataclass(frozen=True, eq=False)
class OcclusionWeights:
    """The open-water radiance ``L_i(d, w_k)`` per unit ``E0`` on the
    directions ``w_k``, over depth.

    ``log_radiance`` (n_depth, K, n) is ``ln L`` on the depth axis
    :func:`aquaspec.transport.lightfield.tables.table_depths` (uniform in
    ``sqrt(d)``, read as the light-field tables are); beyond ``max_depth_m``
    in deep water ``L`` decays as ``exp(-k_inf (d - D))``. ``extinction``
    (n,) is ``c*``; ``seabed_depth_m`` inf in deep water.
    """

    directions: np.ndarray
    solid_angle: np.ndarray
    log_radiance: np.ndarray
    max_depth_m: float
    extinction: np.ndarray
    k_inf: np.ndarray
    seabed_depth_m: float = float("inf")

    @property
    def n_bands(self) -> int:
        return self.extinction.size

    def radiance(self, depth_m) -> np.ndarray:
        """``L_i(d, w_k)`` (..., K, n) at depths (..., K): direction ``k`` at its own depth."""
        d = np.asarray(depth_m, dtype=float)
        n_depth, k_dirs = self.log_radiance.shape[:2]
        i, f = table_depth_index(d, self.max_depth_m, n_depth)
        kk = np.broadcast_to(np.arange(k_dirs), d.shape)
        lo, hi = self.log_radiance[i, kk], self.log_radiance[i + 1, kk]
        out = (1.0 - f)[..., None] * lo + f[..., None] * hi
        if not np.isfinite(self.seabed_depth_m):
            out = out - self.k_inf * np.maximum(d - self.max_depth_m, 0.0)[..., None]
        return np.exp(out)


def _weights(directions, solid_angle, depths, radiance_of, *, max_depth_m, extinction, k_inf,
             seabed_depth_m):
    dirs = np.asarray(directions, dtype=float)
    omega = np.asarray(solid_angle, dtype=float)
    if dirs.ndim != 2 or dirs.shape[1] != 3 or omega.shape != dirs.shape[:1]:
        raise AquaspecError(f"occlusion directions {dirs.shape}, solid angles {omega.shape}; "
                            "accepted: (K, 3) and (K,)")
    lrad = radiance_of(depths, dirs[:, 1])                     # (n_depth, K, n)
    if not np.all(np.isfinite(lrad)):
        raise AquaspecError("the light field's radiance came out non-finite on the occlusion "
                            "directions")
    tiny = np.finfo(float).tiny
    return OcclusionWeights(dirs, omega, np.log(np.maximum(lrad, tiny)), float(max_depth_m),
                            np.asarray(extinction, dtype=float), np.asarray(k_inf, dtype=float),
                            float(seabed_depth_m))


def weights_from_tables(tables, directions, solid_angle, *, a, b) -> OcclusionWeights:
    """:class:`OcclusionWeights` from the renderer's
    :class:`~aquaspec.transport.lightfield.tables.LightfieldTables` (the
    open-water radiance of :meth:`LightfieldTables.pixel_radiance
    <aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance>`
    with ``S = inf``) on the tables' own depth axis; ``a``, ``b`` (n,) 1/m."""
    depths = table_depths(tables.max_depth_m, tables.depth_m.size)

    def radiance_of(d, v):
        dd, vv = np.meshgrid(d, v, indexing="ij")
        out = tables.pixel_radiance(a=a, b=b, e0=1.0, depth_o=dd.reshape(-1, 1),
                                    v_y=vv.reshape(-1, 1), s=np.full((dd.size, 1), np.inf))
        return out.reshape(dd.shape + (-1,))

    return _weights(directions, solid_angle, depths, radiance_of, max_depth_m=tables.max_depth_m,
                    extinction=tables.beam_extinction, k_inf=tables.k_inf,
                    seabed_depth_m=tables.seabed_depth_m)


def weights_from_field(field, directions, solid_angle, *, n_depth: int = 64,
                       max_depth_m: float = 50.0) -> OcclusionWeights:
    """:class:`OcclusionWeights` from a solved
    :class:`~aquaspec.transport.lightfield.field.LightField` (its radiance
    at any direction, per unit of its ``e0``); the depth axis ends at the
    seabed when there is one."""
    d_max = field.seabed_depth_m if field.has_seabed else float(max_depth_m)
    depths = table_depths(d_max, n_depth)

    def radiance_of(d, v):
        dd, vv = np.meshgrid(d, v, indexing="ij")
        e0 = np.asarray(field.e0, dtype=float).reshape(-1, 1, 1)
        return np.moveaxis(field.radiance(dd, vv) / e0, 0, -1)

    return _weights(directions, solid_angle, depths, radiance_of, max_depth_m=d_max,
                    extinction=field.c_star, k_inf=field.k_inf,
                    seabed_depth_m=field.seabed_depth_m)


def _geometry(weights: OcclusionWeights, depth_m, normals, dist):
    """``(cos dw (P, K), s cut at the surface (P, K), occluder depth (P, K))``."""
    d = np.asarray(depth_m, dtype=float)[:, None]
    w_y = weights.directions[:, 1][None, :]
    g = np.maximum(normals @ weights.directions.T, 0.0) * weights.solid_angle
    up = w_y > 0
    to_top = np.where(up, d / np.where(up, w_y, 1.0), np.inf)
    s = np.minimum(dist, to_top)
    finite = np.isfinite(s)
    d_occ = np.clip(d - np.where(finite, s, 0.0) * w_y, 0.0, weights.seabed_depth_m)
    return g, s, d_occ


def _check(weights, depth_m, normals, vis, dist):
    d = np.asarray(depth_m, dtype=float).reshape(-1)
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    v = np.asarray(vis, dtype=float).reshape(-1, weights.directions.shape[0])
    s = np.asarray(dist, dtype=float).reshape(-1, weights.directions.shape[0])
    if not (len(d) == len(n) == len(v) == len(s)):
        raise AquaspecError(f"occlusion: {len(d)} depths, {len(n)} normals, {len(v)} "
                            f"visibilities and {len(s)} distances; accepted: one each per "
                            "receiver (K per receiver for the last two)")
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(n)) and np.all(np.isfinite(v))):
        raise AquaspecError("occlusion: depths, normals and visibilities must be finite")
    if np.any(np.isnan(s)) or np.any(s < 0):
        raise AquaspecError("occlusion: distances must be >= 0 or inf, never NaN")
    return np.maximum(d, 0.0), n, np.clip(v, 0.0, 1.0), s


def occlusion_factor(weights: OcclusionWeights, depth_m, normals, vis, dist, *,
                     reflected=None) -> np.ndarray:
    """``O_i`` (P, n) of receivers at depths (P,) with unit normals (P, 3),
    visibility and occluder distance (P, K) (:meth:`OcclusionMaps.visibility
    <aquaspec.scene.occlusion.OcclusionMaps.visibility>`): the direct
    K-direction sum of the module docstring.

    ``reflected``: the light the occluders reflect towards the receivers
    (issue 36 item 3), to be added to the numerator's kept light; not
    modelled yet (None).
    """
    if reflected is not None:
        raise AquaspecError("occlusion: the occluders' reflected light is not modelled yet; "
                            "accepted: reflected=None")
    d, n, v, s = _check(weights, depth_m, normals, vis, dist)
    out = np.ones((len(d), weights.n_bands))
    c = weights.extinction
    for p0 in range(0, len(d), _CHUNK):
        sl = slice(p0, p0 + _CHUNK)
        occluded = np.any((v[sl] < 1.0) & np.isfinite(s[sl]), axis=1)
        if not np.any(occluded):
            continue
        idx = np.flatnonzero(occluded) + p0
        g, s_cut, d_occ = _geometry(weights, d[idx], n[idx], s[idx])
        here = weights.radiance(np.broadcast_to(d[idx, None], g.shape))   # (P, K, n)
        there = weights.radiance(d_occ)
        total = np.einsum("pk,pkn->pn", g, here)
        keep = np.isfinite(s_cut)
        lost_w = (1.0 - v[idx]) * g
        atten = np.exp(-c * np.where(keep, s_cut, 0.0)[..., None])
        lost = np.einsum("pk,pkn->pn", np.where(keep, lost_w, 0.0), there * atten)
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(total > 0, lost / np.where(total > 0, total, 1.0), 0.0)
        out[idx] = np.clip(1.0 - ratio, 0.0, 1.0)
    return out


# ---- the compressed form ----------------------------------------------------
def basis_matrix(kind: str, m: int, w_y) -> np.ndarray:
    """The basis functions at up components ``w_y`` (K,): (K, M)."""
    if kind not in BASES:
        raise AquaspecError(f"occlusion basis {kind!r}; accepted: {', '.join(BASES)}")
    if isinstance(m, bool) or not isinstance(m, (int, np.integer)) or not 1 <= m <= 64:
        raise AquaspecError(f"occlusion basis size {m!r}; accepted: an integer 1 ... 64")
    y = np.clip(np.asarray(w_y, dtype=float), -1.0, 1.0)
    theta = np.arccos(y) / np.pi                                 # 0 (up) ... 1 (down)
    if kind == "bins":
        cell = np.minimum(((1.0 - y) / 2.0 * m).astype(int), m - 1)
        return np.eye(m)[cell]
    if kind == "angle_bins":
        return np.eye(m)[np.minimum((theta * m).astype(int), m - 1)]
    if kind == "hats":
        if m < 2:
            raise AquaspecError("occlusion basis 'hats' needs M >= 2 nodes")
        x = theta * (m - 1)
        lo = np.minimum(np.floor(x).astype(int), m - 2)
        f = x - lo
        out = np.zeros((y.size, m))
        out[np.arange(y.size), lo] = 1.0 - f
        out[np.arange(y.size), lo + 1] = f
        return out
    return np.polynomial.legendre.legvander(y, m - 1)


@dataclass(frozen=True, eq=False)
class CompressedWeights:
    """The radiance in a basis of ``w_y``: ``coef`` (n_depth, M, n) with
    ``L_i(d, w_k) ~ sum_m basis[k, m] coef[d, m, i]`` (least squares over the
    directions, weighted by their solid angles); ``basis`` (K, M)."""

    weights: OcclusionWeights
    kind: str
    basis: np.ndarray
    coef: np.ndarray
    ref_radiance: np.ndarray    # (n_depth, K): band-mean radiance, each band over its mean

    def coef_at(self, depth_m) -> np.ndarray:
        """Coefficients (P, M, n) at depths (P,), linear on the depth axis."""
        d = np.asarray(depth_m, dtype=float)
        i, f = table_depth_index(d, self.weights.max_depth_m, self.coef.shape[0])
        out = (1.0 - f)[:, None, None] * self.coef[i] + f[:, None, None] * self.coef[i + 1]
        if not np.isfinite(self.weights.seabed_depth_m):
            out = out * np.exp(-self.weights.k_inf
                               * np.maximum(d - self.weights.max_depth_m, 0.0)[:, None, None])
        return out


def compress(weights: OcclusionWeights, kind: str = "hats", m: int = 8) -> CompressedWeights:
    """The radiance of ``weights`` in the basis ``kind`` of ``m`` functions."""
    basis = basis_matrix(kind, m, weights.directions[:, 1])
    lrad = np.exp(weights.log_radiance)                                  # (D, K, n)
    sw = np.sqrt(weights.solid_angle)[:, None]
    coef_flat, *_ = np.linalg.lstsq(basis * sw, np.moveaxis(lrad, 1, 0).reshape(
        basis.shape[0], -1) * sw, rcond=None)
    coef = np.moveaxis(coef_flat.reshape(m, lrad.shape[0], lrad.shape[2]), 0, 1)
    ref = (lrad / np.mean(lrad, axis=1, keepdims=True)).mean(axis=2)
    return CompressedWeights(weights, kind, basis, coef, ref)


@dataclass(frozen=True, eq=False)
class OcclusionMoments:
    """Band-independent numbers per receiver: ``occluded`` and ``total``
    (P, M) geometric weights ``sum_k (1 - V_k) g_k B_km`` and ``sum_k g_k
    B_km`` (``g_k = max(0, n.w_k) dw_k``), the mean occluder distance
    ``mean_s`` (P,) (cut at the surface), its variance ``var_s`` (P,) and
    the mean rise ``mean_rise`` (P,) ``= mean of s_k w_ky`` (the occluder's
    height above the receiver)."""

    occluded: np.ndarray
    total: np.ndarray
    mean_s: np.ndarray
    var_s: np.ndarray
    mean_rise: np.ndarray
    extinctions: np.ndarray | None = None
    occluded_at: np.ndarray | None = None


def occlusion_moments(cw: CompressedWeights, depth_m, normals, vis, dist, *,
                      mean_weight: str = "radiance", extinctions=None) -> OcclusionMoments:
    """The compressed form's per-receiver numbers (:class:`OcclusionMoments`).

    ``extinctions`` (J,) 1/m: also keep the occluded moments with each
    direction's transmittance ``exp(-c_j s_k)`` at these extinctions
    (``occluded_at`` (P, J, M)); :func:`factor_from_moments` then
    interpolates ``ln`` of them in ``c`` for each band instead of using the
    distance's mean and variance (:func:`nodes_for`).
    """
    if mean_weight not in MEAN_WEIGHTS:
        raise AquaspecError(f"occlusion mean weight {mean_weight!r}; accepted: "
                            f"{', '.join(MEAN_WEIGHTS)}")
    d, n, v, s = _check(cw.weights, depth_m, normals, vis, dist)
    g, s_cut, _ = _geometry(cw.weights, d, n, s)
    keep = np.isfinite(s_cut)
    lost = np.where(keep, (1.0 - v) * g, 0.0)
    u = lost
    if mean_weight == "radiance":
        i, f = table_depth_index(d, cw.weights.max_depth_m, cw.ref_radiance.shape[0])
        u = lost * ((1.0 - f)[:, None] * cw.ref_radiance[i] + f[:, None] * cw.ref_radiance[i + 1])
    su = u.sum(axis=1)
    s0 = np.where(keep, s_cut, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_s = np.where(su > 0, (u * s0).sum(axis=1) / np.where(su > 0, su, 1.0), 0.0)
        var_s = np.where(su > 0, (u * (s0 - mean_s[:, None]) ** 2).sum(axis=1)
                         / np.where(su > 0, su, 1.0), 0.0)
        rise = np.where(su > 0, (u * s0 * cw.weights.directions[:, 1]).sum(axis=1)
                        / np.where(su > 0, su, 1.0), 0.0)
    at = None
    if extinctions is not None:
        cj = np.asarray(extinctions, dtype=float)
        at = np.einsum("pk,jpk,km->pjm", lost, np.exp(-cj[:, None, None] * s0[None]), cw.basis)
    return OcclusionMoments(lost @ cw.basis, g @ cw.basis, mean_s, var_s, rise, cj if at
                            is not None else None, at)


def nodes_for(extinction, j: int = 3) -> np.ndarray:
    """``j`` extinctions spaced geometrically over a water's band extinctions (1/m)."""
    c = np.asarray(extinction, dtype=float)
    return np.geomspace(max(float(c.min()), 1e-6), max(float(c.max()), 2e-6), j)


def _interp_log(c_nodes, y0, y_at, c):
    """``Y(c)`` per band from ``Y(0) = y0`` (P, M) and ``Y(c_j) = y_at`` (P, J, M):
    ``ln Y`` piecewise linear in ``c`` (the last segment's slope beyond)."""
    tiny = np.finfo(float).tiny
    xs = np.concatenate([[0.0], c_nodes])
    ly = np.log(np.maximum(np.concatenate([y0[:, None], y_at], axis=1), tiny))   # (P, J+1, M)
    seg = np.clip(np.searchsorted(xs, c, side="right") - 1, 0, xs.size - 2)       # (n,)
    f = (c - xs[seg]) / (xs[seg + 1] - xs[seg])
    out = (1.0 - f)[None, :, None] * ly[:, seg] + f[None, :, None] * ly[:, seg + 1]
    return np.where(y0[:, None, :] > 0, np.exp(out), 0.0)                        # (P, n, M)


def mean_transmittance(c, mean_s, var_s):
    """``<exp(-c s)>`` over distances of mean ``mean_s`` and variance ``var_s``
    (..., broadcasting with ``c``), taken as gamma distributed (exact in both
    moments): ``(1 + c var/mean)^(-mean^2/var)``; ``exp(-c mean)`` for var 0.
    (``exp(-c <s>)`` alone is Jensen's lower bound: too dark where the
    occluded directions see it at very different distances.)"""
    c, m, v = np.broadcast_arrays(np.asarray(c, dtype=float), np.asarray(mean_s, dtype=float),
                                  np.asarray(var_s, dtype=float))
    spread = (v > 1e-12 * m * m) & (m > 0)
    ms = np.where(spread, m, 1.0)
    vs = np.where(spread, v, 1.0)
    return np.where(spread, np.exp(-(ms * ms / vs) * np.log1p(c * vs / ms)), np.exp(-c * m))


def factor_from_moments(cw: CompressedWeights, depth_m, moments: OcclusionMoments) -> np.ndarray:
    """``O_i`` (P, n) from :class:`OcclusionMoments`: ``1 - T_i
    sum_m a_im(d - rise) occluded_m / sum_m a_im(d) total_m`` with ``T_i``
    :func:`mean_transmittance` of ``c*_i``."""
    d = np.maximum(np.asarray(depth_m, dtype=float).reshape(-1), 0.0)
    d_occ = np.clip(d - moments.mean_rise, 0.0, cw.weights.seabed_depth_m)
    if moments.occluded_at is None:
        lost = np.einsum("pm,pmn->pn", moments.occluded, cw.coef_at(d_occ)) * mean_transmittance(
            cw.weights.extinction, moments.mean_s[:, None], moments.var_s[:, None])
    else:
        y = _interp_log(moments.extinctions, moments.occluded, moments.occluded_at,
                        cw.weights.extinction)
        lost = np.einsum("pnm,pmn->pn", y, cw.coef_at(d_occ))
    total = np.einsum("pm,pmn->pn", moments.total, cw.coef_at(d))
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = np.where(total > 0, lost / np.where(total > 0, total, 1.0), 0.0)
    return np.clip(1.0 - ratio, 0.0, 1.0)
