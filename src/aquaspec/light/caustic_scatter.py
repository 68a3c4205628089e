"""Caustics carried by the light the water scatters through small angles.

Conventions as in :mod:`aquaspec.light.caustics` (metres, y up, the mean
surface at ``y = 0``, depth ``d = -y``, coefficients in 1/m, wavevectors in
rad/m). The derivation is docs/model.md, "Caustics in the scattered light".

The small-angle picture
-----------------------
Under waves the beam's irradiance on a plane at depth ``d`` is a pattern
``C(x)`` (mean 1, :func:`aquaspec.light.caustics.caustic_slices`) times the
mean. Light that the water scatters at slant distance ``s'`` along the beam
by a small angle ``theta`` still goes down, displaced sideways by
``(s - s') tan(theta)`` by the time it reaches slant distance ``s``, so it
carries the pattern, shifted. Summed over all orders of scattering (each an
independent random displacement, a Poisson number of them) the pattern's
Fourier component at transverse wavevector ``q`` is multiplied by
(Wells 1973; Zege, Ivanov & Katsev 1991, ch. 2)

    M(q, s) = exp(-a s - b int_0^s [1 - P(q u)] du)

where ``P(v)`` is the 2-D Fourier transform of the phase function's
distribution of ``tan(theta)`` over the forward hemisphere,

    P(v) = 2 pi int_0^{pi/2} p(theta) J0(v tan theta) sin(theta) dtheta

(:func:`displacement_transform`; ``P(0) = 1 - B``, the backward share ``B``
leaves the pattern and never comes back in this picture). With
``Q(x) = int_0^x P(v) dv`` the integral is closed:
``int_0^s P(q u) du = Q(q s) / q``.

The renderer carries the pattern on its beam, whose extinction is the
light field's delta-M ``c* = c - f b``
(``beam_extinction`` of :class:`aquaspec.transport.lightfield.tables.LightfieldTables`),
the diffuse field being uniform. For the irradiance's fluctuation to be
``M`` times the geometric one, the beam's factor is

    C_s(x) = 1 + F^-1[ G(q, s) F[C - 1] ],
    G(q, s) = M(q, s) exp(c* s) = exp(b [Q(q s) / q - f s]).

At large ``q`` (``Q(qs)/q -> 0``) ``G = exp(-f b s)``: only the
unscattered beam keeps the fine pattern (what the path tracer's
comparison, :mod:`aquaspec.validation.caustics_check`, measures).
At small ``q`` ``G`` grows above 1: there the light the light field counts
as diffuse still carries the pattern. A beam's factor below 0 is allowed by
this sum (it is the fluctuation of light that the diffuse field holds);
:func:`scattered_slices` keeps the factor as it is and reports how much of
it is negative.

The beam is slanted (zenith cosine ``mu0`` under water) while the maps are
on horizontal planes: a sideways displacement ``delta`` across the beam
lands on the plane stretched by ``1 / mu0`` along the sun's horizontal
direction, so a horizontal wavevector ``(k_par, k_perp)`` sees
``q = |(k_par / mu0, k_perp)|`` and ``s = d / mu0``.

The phase function is the water's own (:mod:`aquaspec.medium.phase`; for
Petzold mixed with pure water per band, :mod:`aquaspec.medium.phase_bands`):
nothing here is fitted.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import lru_cache

import numpy as np
import scipy.fft as sfft
from numpy.polynomial.legendre import leggauss
from scipy.special import j0

from aquaspec.errors import AquaspecError
from aquaspec.light.photon_map import half_wavenumbers
from aquaspec.medium.phase import PhaseFunction, get_phase
from aquaspec.medium.phase_bands import band_mixture
from aquaspec.parallel import workers

#: Smallest angle of the quadrature (rad); the mass below it counts as undeflected.
THETA_MIN_RAD = 1e-7
#: ``P(v)`` is tabulated at :data:`TABLE_SIZE` wavenumbers ``v`` (rad per unit
#: ``tan theta``) from 0 and geometrically from ``V_MIN`` to ``V_MAX``.
V_MIN, V_MAX, TABLE_SIZE = 1e-3, 1e7, 401
#: The factor's bound (half floats end at 65504): ``G`` grows as
#: ``exp(b (1 - B - f) s)`` at coarse scales, beyond float range deep in
#: turbid water, where the beam's share of the light is below ``1 / FACTOR_LIMIT``.
FACTOR_LIMIT = 1.0e4
#: ``ln G`` is capped here (float32 range) before the transform.
LOG_GAIN_LIMIT = 60.0
#: Displacements beyond ``2 TAPER_CYCLES / v`` (J0's oscillation averages them
#: out) are tapered off with a cos^2 from ``TAPER_CYCLES / v``.
TAPER_CYCLES = 40.0


def _theta_nodes(panels_per_unit_log: int = 20, order: int = 8):
    """Gauss nodes and weights in ``theta`` on ``[THETA_MIN_RAD, pi/2]``, uniform in ``ln theta``."""
    lo, hi = np.log(THETA_MIN_RAD), np.log(np.pi / 2)
    edges = np.linspace(lo, hi, int(np.ceil((hi - lo) * panels_per_unit_log)) + 1)
    x, w = leggauss(order)
    a, b = edges[:-1, None], edges[1:, None]
    lt = (0.5 * (b - a) * x + 0.5 * (b + a)).ravel()
    wt = (0.5 * (b - a) * w).ravel()
    theta = np.exp(lt)
    return theta, wt * theta


def _taper(x):
    """1 up to ``x = TAPER_CYCLES``, a cos^2 down to 0 at ``2 TAPER_CYCLES``."""
    y = np.clip(x / TAPER_CYCLES - 1.0, 0.0, 1.0)
    return np.cos(0.5 * np.pi * y) ** 2


def transform_of(phase: PhaseFunction, v) -> np.ndarray:
    """``P(v)`` of one phase function at ``v`` (V,) (see the module docstring):
    Gauss quadrature in ``ln theta``, the mass below :data:`THETA_MIN_RAD`
    undeflected, normalised by the function's integral on the same nodes
    plus that mass (:meth:`PhaseFunction.normalisation` for the moments' grid)."""
    v = np.asarray(v, dtype=float)
    theta, w = _theta_nodes()
    dens = 2.0 * np.pi * phase.value(np.cos(theta)) * np.sin(theta) * w
    mass = phase._forward_mass()
    rho = np.tan(theta)
    out = np.empty(v.shape)
    for i, vi in enumerate(v.ravel()):
        x = vi * rho
        out.flat[i] = np.sum(dens * j0(x) * _taper(x)) + mass
    return out / phase.normalisation()


def displacement_transform(phase, v, b=None, wavelength_nm=None, **params) -> np.ndarray:
    """``P(v)`` per band, shape ``(n_bands, V)``: each band's phase function
    (Petzold mixed with pure water by ``b``'s split at ``wavelength_nm``,
    :func:`aquaspec.medium.phase_bands.band_mixture`)."""
    ph = phase if isinstance(phase, PhaseFunction) else get_phase(phase, **params)
    b_arr = np.atleast_1d(np.asarray(1.0 if b is None else b, dtype=float))
    return band_mixture(ph, lambda p: transform_of(p, v), b_arr, wavelength_nm)


def table_wavenumbers() -> np.ndarray:
    """The ``v`` of the tables: 0, then :data:`TABLE_SIZE` from ``V_MIN`` to ``V_MAX``."""
    return np.concatenate([[0.0], np.geomspace(V_MIN, V_MAX, TABLE_SIZE)])


def cumulative(v, p) -> np.ndarray:
    """``Q(v) = int_0^v P`` (trapezoids; ``v`` from 0), along the last axis."""
    p = np.asarray(p, dtype=float)
    steps = 0.5 * (p[..., 1:] + p[..., :-1]) * np.diff(v)
    return np.concatenate([np.zeros(p.shape[:-1] + (1,)), np.cumsum(steps, axis=-1)], axis=-1)


@dataclass(frozen=True)
class ScatterTransfer:
    """What the caustic factor's transfer ``G`` needs (see the module docstring).

    One tuple entry per band: ``b`` (1/m), ``beam_gap`` ``c - c_sun`` (1/m,
    the scattering the beam's extinction leaves out: ``f b`` with the light
    field's delta-M, 0 when the beam's extinction is ``c``) and the band
    centres ``wavelength_nm``; ``phase``/``phase_params`` the water's phase
    function (a :func:`aquaspec.medium.phase.get_phase` name or a
    :class:`aquaspec.medium.phase.PhaseFunction`); ``mu0`` the refracted
    beam's zenith cosine and ``sun_xz`` the unit horizontal direction towards
    the sun under water (any unit vector for a sun at the zenith).

    With several bands the transfer is their geometric mean (the exponent's
    mean): the renderer's caustic texture is one factor for every band.
    """

    b: tuple
    beam_gap: tuple
    wavelength_nm: tuple
    mu0: float
    sun_xz: tuple = (1.0, 0.0)
    phase: str | PhaseFunction = "petzold"
    phase_params: tuple = ()

    def __post_init__(self):
        b = np.asarray(self.b, dtype=float).ravel()
        gap = np.asarray(self.beam_gap, dtype=float).ravel()
        wl = np.asarray(self.wavelength_nm, dtype=float).ravel()
        if b.size == 0 or gap.shape != b.shape or wl.shape != b.shape:
            raise AquaspecError(f"scatter transfer: b {self.b!r}, beam_gap {self.beam_gap!r} "
                                f"and wavelength_nm {self.wavelength_nm!r}; accepted: one "
                                "value per band each, at least one band")
        if not (np.all(np.isfinite(b)) and np.all(b >= 0)):
            raise AquaspecError(f"scattering b {self.b!r} 1/m; accepted: finite, >= 0")
        if not (np.all(np.isfinite(gap)) and np.all(gap >= -1e-9 * (1 + b))
                and np.all(gap <= b * (1 + 1e-9) + 1e-12)):
            raise AquaspecError(f"beam_gap {self.beam_gap!r} 1/m (c - c_sun); accepted: "
                                "0 <= c - c_sun <= b in every band")
        mu0 = float(self.mu0)
        if not (np.isfinite(mu0) and 0.0 < mu0 <= 1.0):
            raise AquaspecError(f"beam zenith cosine mu0 {self.mu0!r}; accepted: 0 < mu0 <= 1")
        d = np.asarray(self.sun_xz, dtype=float)
        if d.shape != (2,) or not np.isclose(np.hypot(*d), 1.0):
            raise AquaspecError(f"sun_xz {self.sun_xz!r}; accepted: a unit (x, z) vector")
        object.__setattr__(self, "b", tuple(float(x) for x in b))
        object.__setattr__(self, "beam_gap", tuple(float(x) for x in np.clip(gap, 0.0, b)))
        object.__setattr__(self, "wavelength_nm", tuple(float(x) for x in wl))
        object.__setattr__(self, "mu0", mu0)
        object.__setattr__(self, "sun_xz", (float(d[0]), float(d[1])))
        object.__setattr__(self, "phase_params", tuple(self.phase_params))

    @classmethod
    def for_beam(cls, *, b, c, c_sun, wavelength_nm, to_sun, phase="petzold",
                 phase_params=()) -> "ScatterTransfer":
        """The transfer of a renderer's beam: per band ``b``, ``c``, the beam's
        extinction ``c_sun`` (1/m) and band centres; ``to_sun`` (3,) the unit
        vector towards the sun under water."""
        s = np.asarray(to_sun, dtype=float)
        horiz = float(np.hypot(s[0], s[2]))
        sun_xz = (s[0] / horiz, s[2] / horiz) if horiz > 1e-12 else (1.0, 0.0)
        gap = np.atleast_1d(np.asarray(c, dtype=float) - np.asarray(c_sun, dtype=float))
        return cls(b=tuple(np.atleast_1d(np.asarray(b, dtype=float))), beam_gap=tuple(gap),
                   wavelength_nm=tuple(np.atleast_1d(np.asarray(wavelength_nm, dtype=float))),
                   mu0=float(s[1]), sun_xz=sun_xz, phase=phase,
                   phase_params=tuple(sorted(dict(phase_params).items())))

    def describe(self) -> dict:
        return {"model": "small-angle transfer (Wells 1973)", "b_per_m": list(self.b),
                "beam_gap_per_m": list(self.beam_gap), "wavelength_nm": list(self.wavelength_nm),
                "phase": self.phase if isinstance(self.phase, str) else self.phase.name,
                "phase_params": dict(self.phase_params), "mu0": self.mu0}

    def band(self, i: int) -> "ScatterTransfer":
        """The transfer of band ``i`` alone (its own ``G``, not the bands' mean)."""
        if not 0 <= int(i) < len(self.b):
            raise AquaspecError(f"band {i!r}; accepted: 0 to {len(self.b) - 1}")
        i = int(i)
        return replace(self, b=(self.b[i],), beam_gap=(self.beam_gap[i],),
                       wavelength_nm=(self.wavelength_nm[i],))

    def table(self):
        """``(v, bQ)``: the bands' mean of ``b Q(v)`` (1/m) on :func:`table_wavenumbers`."""
        return _table(self.phase, self.phase_params, self.b, self.wavelength_nm)

    def band_tables(self):
        """``(v, bQ)``: each band's ``b Q(v)`` (n_bands, V) (1/m)."""
        return _band_tables(self.phase, self.phase_params, self.b, self.wavelength_nm)

    def beam_wavenumber(self, kx, kz) -> np.ndarray:
        """``q = |(k_par / mu0, k_perp)|`` (rad/m) of horizontal wavevectors ``(kx, kz)``."""
        ux, uz = self.sun_xz
        kx, kz = np.asarray(kx, dtype=float), np.asarray(kz, dtype=float)
        return np.hypot((kx * ux + kz * uz) / self.mu0, kz * ux - kx * uz)

    def log_gain(self, kx, kz, depth_m) -> np.ndarray:
        """``ln G`` at horizontal wavevectors ``(kx, kz)`` (rad/m) and depth
        ``depth_m`` (m, >= 0); 0 at ``k = 0`` (the mean is kept)."""
        kx, kz = np.asarray(kx, dtype=float), np.asarray(kz, dtype=float)
        d = float(depth_m)
        if not (np.isfinite(d) and d >= 0):
            raise AquaspecError(f"depth {depth_m!r} m; accepted: finite, >= 0")
        s = d / self.mu0
        q = self.beam_wavenumber(kx, kz)
        v, bq = self.table()
        qs = np.where(q > 0, q, 1.0)
        along = np.where(q > 0, np.interp(q * s, v, bq) / qs, bq[1] / v[1] * s)
        out = along - float(np.mean(self.beam_gap)) * s
        return np.where(q > 0, out, 0.0)

    def gain(self, kx, kz, depth_m) -> np.ndarray:
        """``G`` (see :meth:`log_gain`)."""
        return np.exp(self.log_gain(kx, kz, depth_m))


@lru_cache(maxsize=16)
def _band_tables(phase, phase_params, b, wavelength_nm):
    v = table_wavenumbers()
    p = displacement_transform(phase, v, b=np.array(b), wavelength_nm=np.array(wavelength_nm),
                               **dict(phase_params))
    bq = np.asarray(b)[:, None] * cumulative(v, p)
    bq.setflags(write=False)
    return v, bq


@lru_cache(maxsize=16)
def _table(phase, phase_params, b, wavelength_nm):
    v, bq = _band_tables(phase, phase_params, b, wavelength_nm)
    mean = np.mean(bq, axis=0)
    mean.setflags(write=False)
    return v, mean


def scatter_slices(level0, depths, tile_m: float, transfer: ScatterTransfer) -> np.ndarray:
    """The caustic factor's slices (K, n, n) at ``depths`` (K,) m of a tile
    ``tile_m`` wide carried into the scattered light: each slice times
    :meth:`ScatterTransfer.gain` in Fourier space (float32; the mean kept;
    ``ln G`` capped at :data:`LOG_GAIN_LIMIT`, the factor at
    +-:data:`FACTOR_LIMIT`).
    The gains are computed once per transfer, depths and tile
    (:func:`slice_gains`): a loop's frames only pay the transforms."""
    c = np.asarray(level0, dtype=np.float32)
    depths = np.asarray(depths, dtype=float)
    if c.ndim != 3 or c.shape[0] != depths.size or c.shape[1] != c.shape[2]:
        raise AquaspecError(f"caustic slices of shape {c.shape} at {depths.size} depths; "
                            "accepted: (K, n, n) with K depths")
    n = c.shape[-1]
    gains = slice_gains(transfer, tuple(float(d) for d in depths), n, float(tile_m))
    spec = sfft.rfft2(c, workers=workers())
    spec *= gains
    out = sfft.irfft2(spec, s=(n, n), workers=workers())
    return np.clip(out, -FACTOR_LIMIT, FACTOR_LIMIT).astype(np.float32)


@lru_cache(maxsize=8)
def slice_gains(transfer: ScatterTransfer, depths: tuple, n: int, tile_m: float) -> np.ndarray:
    """``G`` (K, n, n/2 + 1) float32 on a real FFT's wavevectors
    (:func:`aquaspec.light.photon_map.half_wavenumbers`) at ``depths``."""
    kx, kz = half_wavenumbers(n, tile_m)
    out = np.exp(np.minimum(np.stack([transfer.log_gain(kx, kz, d) for d in depths]),
                            LOG_GAIN_LIMIT)).astype(np.float32)
    out.setflags(write=False)
    return out



#: Log-spaced wavenumber bins over which a slice's power is summed for
#: :func:`band_scales` (``G`` at each bin's mean ``q``).
SCALE_BINS = 512


def _binned_power(level0, tile_m: float, transfer: ScatterTransfer):
    """``(q, power)``: the mean beam wavenumber ``q`` (B,) of each occupied
    bin and each slice's power in it (K, B), the mean left out (Parseval on
    the real FFT: its columns held once for two counted twice)."""
    c = np.asarray(level0, dtype=np.float32)
    if c.ndim != 3 or c.shape[1] != c.shape[2]:
        raise AquaspecError(f"caustic slices of shape {c.shape}; accepted: (K, n, n)")
    n = c.shape[-1]
    power = np.abs(sfft.rfft2(c, workers=workers())).astype(float) ** 2
    power[:, :, 1:(n + 1) // 2] *= 2.0
    q = transfer.beam_wavenumber(*half_wavenumbers(n, float(tile_m)))
    pos = q > 0
    edges = np.geomspace(q[pos].min(), q[pos].max() * (1.0 + 1e-9), SCALE_BINS + 1)
    idx = np.where(pos, np.clip(np.searchsorted(edges, q, side="right") - 1, 0,
                                SCALE_BINS - 1), SCALE_BINS).ravel()
    count = np.bincount(idx, minlength=SCALE_BINS + 1)[:SCALE_BINS]
    keep = count > 0
    q_mean = np.bincount(idx, weights=q.ravel(), minlength=SCALE_BINS + 1)[:SCALE_BINS][keep]
    per = np.stack([np.bincount(idx, weights=p.ravel(), minlength=SCALE_BINS + 1)[:SCALE_BINS]
                    for p in power])
    return q_mean / count[keep], per[:, keep]


def _check_depths(level0, depths):
    depths = np.asarray(depths, dtype=float)
    if np.ndim(level0) != 3 or np.shape(level0)[0] != depths.size:
        raise AquaspecError(f"caustic slices of shape {np.shape(level0)} at {depths.size} "
                            "depths; accepted: (K, n, n) with K depths")
    return depths


def band_scales(level0, depths, tile_m: float, transfer: ScatterTransfer) -> np.ndarray:
    """Per slice and band (K, n_bands): the standard deviation of ``level0``
    (K, n, n; before any transfer) carried by each band's own transfer over
    that carried by the bands' shared one (:meth:`ScatterTransfer.log_gain`,
    the mean exponent). The renderer's texture holds the shared factor
    ``C``; band ``i`` reads ``1 + s_i (C - 1)``, as contrasted as its own
    transfer would make it (its pattern blurred as the bands' mean: the
    shapes of ``G`` differ less than their levels). Sums of the power over
    :data:`SCALE_BINS` wavenumber bins; the factor's clip at
    +-:data:`FACTOR_LIMIT` is not applied; 1 where the shared transfer
    leaves no fluctuation."""
    depths = _check_depths(level0, depths)
    q, power = _binned_power(level0, tile_m, transfer)
    v, bq = transfer.band_tables()
    gap = np.asarray(transfer.beam_gap)
    out = np.ones((depths.size, len(transfer.b)))
    for k, d in enumerate(depths):
        s = float(d) / transfer.mu0
        lg = np.minimum(np.stack([np.interp(q * s, v, row) / q for row in bq])
                        - gap[:, None] * s, LOG_GAIN_LIMIT)
        shared = np.minimum(np.mean(lg, axis=0), LOG_GAIN_LIMIT)
        ref = np.sum(power[k] * np.exp(2.0 * shared))
        if ref > 0:
            out[k] = np.sqrt(np.sum(power[k] * np.exp(2.0 * lg), axis=1) / ref)
    return out


def texture_scales(level0, depths, tile_m: float, transfer: ScatterTransfer | None):
    """:func:`band_scales` as float32 for a texture read by several bands
    (None without a transfer or with one band: every band reads ``C``)."""
    if transfer is None or len(transfer.b) < 2:
        return None
    return band_scales(np.asarray(level0, np.float32), depths, tile_m,
                       transfer).astype(np.float32)
