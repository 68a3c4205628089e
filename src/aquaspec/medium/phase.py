"""Scattering phase functions of sea water, normalised over the sphere.

A phase function ``p(mu)`` of the scattering cosine ``mu = cos(Theta)`` is in
1/sr and integrates to one over the sphere::

    2 pi int_{-1}^{1} p(mu) dmu = 1.

Each :class:`PhaseFunction` gives its value, its backscatter fraction
``B = 2 pi int_{-1}^{0} p dmu`` and its Legendre moments
``chi_l = 2 pi int p(mu) P_l(mu) dmu`` (``chi_0 = 1``; ``chi_1`` is the mean
cosine g), from which :func:`aquaspec.medium.phase_bands.redistribution_matrix`
builds the azimuthally averaged redistribution matrix that the discrete-ordinates solver
(:mod:`aquaspec.transport.lightfield.solve`) needs. Moments are integrated on a fine grid in
the scattering angle, graded geometrically towards 0 degrees, so strongly
forward-peaked functions (Petzold, Fournier-Forand, HG with g = 0.95) are
integrated accurately.

Registry: :data:`PHASE_FUNCTIONS` maps a ``method`` name to a factory;
:func:`get_phase` looks it up with a clear error. Water's own (Rayleigh-like)
scattering is a separate phase function (:class:`PureWaterPhase`); the
``"petzold"`` method mixes it with Petzold's particle phase function by the
``b_w / b_p`` split of each band, because the b of the Jerlov types includes
pure water's scattering: the per-band quantities, that mixture written once,
are :mod:`aquaspec.medium.phase_bands`.

``"tabulated"`` (:func:`tabulated_phase`, :class:`TabulatedPhase`) is any of
them on a regular grid in ``mu``, linear in between: the representation of
Mitsuba 3's ``tabphase``, so the validation's path tracer and the light-field
model use one function (its integrals are exact for the table). A table is
one function for every wavelength: tabulated ``"petzold"`` is the particle
phase function alone, not mixed with pure water.

References
----------
.. [HG1941] L. G. Henyey and J. L. Greenstein, "Diffuse radiation in the
   galaxy", Astrophys. J. 93, 70-83 (1941).
.. [FF1994] G. R. Fournier and J. L. Forand, "Analytic phase function for
   ocean water", Proc. SPIE 2258, Ocean Optics XII, 194-201 (1994).
.. [Mobley2002] C. D. Mobley, L. K. Sundman and E. Boss, "Phase function
   effects on oceanic light fields", Appl. Opt. 41, 1035-1050 (2002),
   doi:10.1364/AO.41.001035 (FF in closed form, its backscatter fraction, and
   the choice ``n = 1.01 + 0.1542 (mu - 3)`` that ties n to the slope mu, so
   that B alone selects the function).
.. [Petzold1972] T. J. Petzold, "Volume scattering functions for selected ocean
   waters", SIO Ref. 72-78, Scripps Institution of Oceanography (1972), via
   the PyPI package ``jerlov`` (``jerlov.petzold_scattering``).
.. [Mobley1994] C. D. Mobley, "Light and Water", Academic Press (1994),
   Sec. 3.8: the "average particle" phase function from Petzold's clear
   ocean (AUTEC 8), coastal (HAOCE 11) and turbid harbour (NUC 2240) VSFs
   with pure water removed, backscatter fraction about 0.018.
.. [Morel1974] A. Morel, "Optical properties of pure water and pure sea
   water" (1974); pure water VSF ``beta_w ~ 1 + r cos^2``, ``r = (1 -
   delta)/(1 + delta)``, depolarisation ``delta = 0.09``, through
   ``jerlov.pure_water_vsf``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import warnings

import jerlov
import numpy as np
from numpy.polynomial.legendre import leggauss

from aquaspec.errors import AquaspecError
from aquaspec.numerics import legendre_table

_FOUR_PI = 4.0 * np.pi

#: Smallest scattering angle (rad) of the moment grid; below it the mass of a
#: forward peak is added to every moment at P_l(1) = 1 (error < (l theta)^2/4).
_THETA_MIN_RAD = 1e-7

@lru_cache(maxsize=4)
def _theta_grid(n_decades: int = 8, per_decade: int = 24, order: int = 8):
    """Composite Gauss nodes/weights in theta on [theta_min, pi], graded to 0."""
    edges = np.concatenate([
        np.geomspace(_THETA_MIN_RAD, 0.1, n_decades * per_decade // 1 + 1)[:-1],
        np.linspace(0.1, np.pi, 160)])
    x, w = leggauss(order)
    lo, hi = edges[:-1, None], edges[1:, None]
    theta = (0.5 * (hi - lo) * x + 0.5 * (hi + lo)).ravel()
    weight = (0.5 * (hi - lo) * w).ravel()
    return theta, weight


class PhaseFunction:
    """Base class: subclasses define :meth:`value` (1/sr) of ``mu = cos Theta``.

    Moments and backscatter are integrated numerically on a graded grid in
    the scattering angle; subclasses with closed forms override them.
    """

    name = "phase"

    def value(self, mu):
        raise NotImplementedError

    def __call__(self, mu):
        return self.value(mu)

    def _forward_mass(self) -> float:
        """Probability of scattering by less than ``_THETA_MIN_RAD``."""
        return 0.0

    def legendre_moments(self, lmax: int) -> np.ndarray:
        """``chi_l = 2 pi int_{-1}^{1} p(mu) P_l(mu) dmu`` for ``l = 0..lmax``.

        Integrated in the scattering angle on a grid graded geometrically from
        1e-7 rad, so forward peaks are resolved; ``chi_0`` is normalised to 1
        exactly (the correction is reported by :meth:`normalisation`).
        """
        theta, w = _theta_grid()
        mu = np.cos(theta)
        dens = 2.0 * np.pi * self.value(mu) * np.sin(theta) * w
        chi = legendre_table(lmax, mu) @ dens + self._forward_mass()
        return chi / chi[0]

    def normalisation(self) -> float:
        """``2 pi int p dmu`` on the moment grid (1 for a normalised function)."""
        theta, w = _theta_grid()
        return float(2.0 * np.pi * np.sum(self.value(np.cos(theta)) * np.sin(theta) * w)
                     + self._forward_mass())

    def backscatter_fraction(self) -> float:
        """``B = 2 pi int_{-1}^{0} p(mu) dmu``, the share of b scattered backwards."""
        x, w = leggauss(64)
        edges = np.linspace(np.pi / 2, np.pi, 9)
        lo, hi = edges[:-1, None], edges[1:, None]
        theta = (0.5 * (hi - lo) * x + 0.5 * (hi + lo)).ravel()
        wt = (0.5 * (hi - lo) * w).ravel()
        return float(2.0 * np.pi * np.sum(self.value(np.cos(theta)) * np.sin(theta) * wt)
                     / self.normalisation())

    def cone_fraction(self, half_angle_rad: float) -> float:
        """Share of scattering within ``half_angle_rad`` of forward.

        Composite Gauss in ``ln theta`` from 1e-7 rad (plus the mass below).
        """
        tc = float(half_angle_rad)
        if tc <= _THETA_MIN_RAD:
            return 0.0
        edges = np.linspace(np.log(_THETA_MIN_RAD), np.log(tc), 241)
        x, w = leggauss(8)
        lo, hi = edges[:-1, None], edges[1:, None]
        theta = np.exp((0.5 * (hi - lo) * x + 0.5 * (hi + lo)).ravel())
        wt = (0.5 * (hi - lo) * w).ravel() * theta
        mass = 2.0 * np.pi * np.sum(self.value(np.cos(theta)) * np.sin(theta) * wt)
        return float((mass + self._forward_mass()) / self.normalisation())

    def describe(self) -> dict:
        return {"name": self.name}


class Isotropic(PhaseFunction):
    """``p = 1 / (4 pi)``; moments ``chi_l = delta_l0``, B = 1/2."""

    name = "isotropic"

    def value(self, mu):
        return np.full(np.shape(mu), 1.0 / _FOUR_PI)

    def legendre_moments(self, lmax: int) -> np.ndarray:
        chi = np.zeros(lmax + 1)
        chi[0] = 1.0
        return chi

    def backscatter_fraction(self) -> float:
        return 0.5


@dataclass(frozen=True)
class HenyeyGreenstein(PhaseFunction):
    """Henyey-Greenstein [HG1941]: ``(1 - g^2) / (4 pi (1 + g^2 - 2 g mu)^1.5)``.

    Closed forms: ``chi_l = g^l`` and
    ``B = (1 - g)/(2 g) ((1 + g)/sqrt(1 + g^2) - 1)``. The moments here are
    still integrated numerically (tests compare them with ``g^l``).
    """

    g: float = 0.92
    name = "hg"

    def __post_init__(self):
        if not (np.isfinite(self.g) and -1.0 < self.g < 1.0):
            raise AquaspecError(f"Henyey-Greenstein g={self.g!r} is not accepted; "
                                "accepted: -1 < g < 1")

    def value(self, mu):
        g = self.g
        mu = np.asarray(mu, dtype=float)
        return (1.0 - g * g) / (_FOUR_PI * (1.0 + g * g - 2.0 * g * mu) ** 1.5)

    def describe(self) -> dict:
        return {"name": self.name, "g": self.g}


def hg_backscatter_fraction(g):
    """Closed-form B of Henyey-Greenstein (1/2 at g = 0)."""
    g = np.asarray(g, dtype=float)
    safe = np.where(np.abs(g) < 1e-12, 1.0, g)
    b = (1.0 - safe) / (2.0 * safe) * ((1.0 + safe) / np.sqrt(1.0 + safe * safe) - 1.0)
    return np.where(np.abs(g) < 1e-12, 0.5, b)


def _ff_delta(n, theta):
    return 4.0 / (3.0 * (n - 1.0) ** 2) * np.sin(0.5 * theta) ** 2


def ff_backscatter_fraction(n: float, mu_slope: float) -> float:
    """B of Fournier-Forand in closed form ([Mobley2002] Eq. 7)."""
    nu = 0.5 * (3.0 - mu_slope)
    d90 = _ff_delta(n, np.pi / 2)
    return float(1.0 - (1.0 - d90 ** (nu + 1.0) - 0.5 * (1.0 - d90 ** nu))
                 / ((1.0 - d90) * d90 ** nu))


def ff_parameters(backscatter_fraction: float) -> tuple[float, float]:
    """``(n, mu)`` of Fournier-Forand with the given B.

    [Mobley2002] tie the real refractive index n of the particles to the
    slope mu of their Junge size distribution by ``n = 1.01 + 0.1542 (mu -
    3)``; along that line B increases monotonically with mu, so B selects one
    function (B = 0.0183, Petzold's average particle, gives n = 1.10,
    mu = 3.5835). Solved by bisection on ``mu`` in (3.0005, 5).
    """
    bf = float(backscatter_fraction)
    lo, hi = 3.0005, 5.0

    def b_of(m):
        return ff_backscatter_fraction(1.01 + 0.1542 * (m - 3.0), m)

    b_lo, b_hi = b_of(lo), b_of(hi)
    if not (np.isfinite(bf) and b_lo < bf < b_hi):
        raise AquaspecError(f"Fournier-Forand backscatter fraction B={backscatter_fraction!r} "
                            f"is not accepted; accepted: {b_lo:.2e} < B < {b_hi:.3f} "
                            "(Mobley et al. 2002 parameterisation)")
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if b_of(mid) < bf:
            lo = mid
        else:
            hi = mid
    m = 0.5 * (lo + hi)
    return 1.01 + 0.1542 * (m - 3.0), m


@dataclass(frozen=True)
class FournierForand(PhaseFunction):
    """Fournier-Forand [FF1994] in the form of [Mobley2002] Eq. 5, from B.

    ``p(theta) = 1/(4 pi (1 - d)^2 d^nu) [nu (1 - d) - (1 - d^nu)
    + (d (1 - d^nu) - nu (1 - d)) / sin^2(theta/2)]
    + (1 - d180^nu) / (16 pi (d180 - 1) d180^nu) (3 cos^2 theta - 1)``
    with ``nu = (3 - mu)/2``, ``d = 4 sin^2(theta/2) / (3 (n - 1)^2)``.
    """

    backscatter: float = 0.0183
    name = "ff"
    n: float = field(init=False)
    mu_slope: float = field(init=False)

    def __post_init__(self):
        n, m = ff_parameters(self.backscatter)
        object.__setattr__(self, "n", n)
        object.__setattr__(self, "mu_slope", m)

    def value(self, mu):
        mu = np.clip(np.asarray(mu, dtype=float), -1.0, 1.0)
        theta = np.arccos(mu)
        nu = 0.5 * (3.0 - self.mu_slope)
        # The forward singularity p ~ theta^-(5 - mu) is integrable; the value
        # at exactly 0 is taken at the moment grid's smallest angle.
        theta = np.maximum(theta, _THETA_MIN_RAD)
        d = _ff_delta(self.n, theta)
        s2 = np.sin(0.5 * theta) ** 2
        dn = d ** nu
        d180 = _ff_delta(self.n, np.pi)
        main = (nu * (1.0 - d) - (1.0 - dn) + (d * (1.0 - dn) - nu * (1.0 - d)) / s2) \
            / (_FOUR_PI * (1.0 - d) ** 2 * dn)
        back = (1.0 - d180 ** nu) / (4.0 * _FOUR_PI * (d180 - 1.0) * d180 ** nu) \
            * (3.0 * mu * mu - 1.0)
        return main + back

    def _forward_mass(self) -> float:
        # Below theta0, d << 1 and p ~ theta^-k with k = 2 + 2 nu = 5 - mu,
        # so its mass is 2 pi int p theta dtheta = 2 pi p(theta0) theta0^2 / (2 - k).
        t0 = _THETA_MIN_RAD
        k = 5.0 - self.mu_slope
        p0 = float(self.value(np.cos(t0)))
        return 2.0 * np.pi * p0 * t0 ** 2 / (2.0 - k)

    def describe(self) -> dict:
        return {"name": self.name, "backscatter_fraction": self.backscatter,
                "n": self.n, "mu": self.mu_slope}


#: Petzold stations of [Mobley1994]'s average particle phase function.
PETZOLD_AVERAGE_STATIONS = ("AUTEC 8", "HAOCE 11", "NUC 2240")


@lru_cache(maxsize=1)
def _petzold_average():
    """Angles (rad), particle phase (1/sr) and sub-0.1-degree mass, averaged."""
    phases, below = [], []
    angles = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for st in PETZOLD_AVERAGE_STATIONS:
            s = jerlov.petzold_scattering(st)
            angles = np.radians(np.asarray(s.angles_deg, dtype=float))
            bw = float(jerlov.pure_water_scattering(s.wavelength_nm))
            vsf_p = np.asarray(s.vsf, dtype=float) - np.asarray(
                jerlov.pure_water_vsf(s.angles_deg, s.wavelength_nm), dtype=float)
            b_p = s.b - bw
            phases.append(np.maximum(vsf_p, 0.0) / b_p)
            # Pure water scatters almost nothing below 0.1 degree, so that
            # share of b belongs to the particles.
            below.append(s.fraction_below_0_1_deg * s.b / b_p)
    return angles, np.mean(phases, axis=0), float(np.mean(below))


class PetzoldParticles(PhaseFunction):
    """Petzold's average particle phase function ([Mobley1994] Sec. 3.8).

    The mean of the particle phase functions (measured VSF minus Morel's pure
    water VSF, divided by ``b - b_w``) of AUTEC 8, HAOCE 11 and NUC 2240,
    interpolated log-log between Petzold's 55 angles. Below 0.1 degree,
    where Petzold extended his data, the function continues as a power law
    ``p(0.1 deg) (theta/0.1 deg)^-s`` with ``s`` chosen so that its mass is
    the stations' average share of b below 0.1 degree; the whole is then
    renormalised to one (the measured values integrate to within a few
    percent of one).
    """

    name = "petzold"

    def __init__(self):
        ang, p, below = _petzold_average()
        self._log_t = np.log(ang)
        self._log_p = np.log(p)
        t0, p0 = ang[0], p[0]
        # mass below t0 of p0 (t/t0)^-s: 2 pi p0 t0^2 / (2 - s) (small angles).
        self._t0, self._p0 = t0, p0
        self._s = 2.0 - 2.0 * np.pi * p0 * t0 * t0 / below
        self._scale = 1.0
        self._scale = 1.0 / self.normalisation()

    def value(self, mu):
        theta = np.arccos(np.clip(np.asarray(mu, dtype=float), -1.0, 1.0))
        th = np.maximum(theta, _THETA_MIN_RAD)
        tab = np.exp(np.interp(np.log(th), self._log_t, self._log_p))
        ext = self._p0 * (th / self._t0) ** (-self._s)
        return self._scale * np.where(th < self._t0, ext, tab)

    def _forward_mass(self) -> float:
        t = _THETA_MIN_RAD
        return self._scale * 2.0 * np.pi * self._p0 * self._t0 ** 2 / (2.0 - self._s) \
            * (t / self._t0) ** (2.0 - self._s)

    def describe(self) -> dict:
        return {"name": self.name, "stations": list(PETZOLD_AVERAGE_STATIONS),
                "backscatter_fraction": self.backscatter_fraction()}


@dataclass(frozen=True)
class PureWaterPhase(PhaseFunction):
    """Pure (sea) water: ``(1 + r mu^2) / (4 pi (1 + r/3))`` ([Morel1974]).

    ``r = (1 - delta)/(1 + delta)`` with depolarisation ratio ``delta``
    (0.09, as ``jerlov.pure_water_vsf``). Closed-form moments:
    ``chi_2 = 2 r / (15 (1 + r/3))``, all others but ``chi_0`` zero; B = 1/2.
    """

    depolarisation: float = 0.09
    name = "pure_water"

    @property
    def r(self) -> float:
        return (1.0 - self.depolarisation) / (1.0 + self.depolarisation)

    def value(self, mu):
        mu = np.asarray(mu, dtype=float)
        return (1.0 + self.r * mu * mu) / (_FOUR_PI * (1.0 + self.r / 3.0))

    def legendre_moments(self, lmax: int) -> np.ndarray:
        chi = np.zeros(lmax + 1)
        chi[0] = 1.0
        if lmax >= 2:
            chi[2] = 2.0 * self.r / (15.0 * (1.0 + self.r / 3.0))
        return chi

    def backscatter_fraction(self) -> float:
        return 0.5


#: Nodes of the regular grid in mu of :class:`TabulatedPhase` by default. A
#: grid step ``dmu = 2/(N - 1)`` resolves scattering angles down to about
#: ``sqrt(2 dmu)`` (0.36 degree at 10^5 + 1 nodes).
DEFAULT_TABLE_NODES = 100_001
#: Cells next to forward whose mass :func:`tabulate` matches to the function's.
TABLE_PEAK_CELLS = 100


class TabulatedPhase(PhaseFunction):
    """A phase function tabulated on a regular grid in ``mu``, linear between nodes.

    ``values[i]`` is the phase function at ``mu_i = -1 + 2 i/(N - 1)``; in
    between it is interpolated linearly. This is the representation of
    Mitsuba 3's ``tabphase`` plugin (regular grid over [-1, 1], ``mu = 1``
    forward, piecewise linear, normalised by the plugin), so the path tracer
    and aquaspec can use one and the same function (:func:`tabulate`).

    The values are normalised exactly for the piecewise-linear function
    (trapezoidal sum = 1/(2 pi)), and its backscatter fraction, forward cone
    fractions and Legendre moments are exact for it (closed-form integrals of
    ``(v_i + s_i (mu - mu_i)) P_l(mu)`` over each cell; rounding leaves about
    ``1e-16 * 2 pi max(values) / dmu`` in ``chi_l``, l >= 1: ~1e-8 for
    Fournier-Forand at 10^5 nodes).
    """

    name = "tabulated"

    def __init__(self, values, source: dict | None = None):
        v = np.asarray(values, dtype=float)
        if v.ndim != 1 or v.size < 2 or not np.all(np.isfinite(v)) or np.any(v < 0) \
                or not np.any(v > 0):
            raise AquaspecError("a tabulated phase function needs at least 2 finite, "
                                "non-negative values, not all zero")
        n = v.size
        self._dmu = 2.0 / (n - 1)
        cells = 0.5 * (v[:-1] + v[1:]) * self._dmu
        v = v / (2.0 * np.pi * cells.sum())
        self._values = v
        self._cdf = np.concatenate([[0.0], np.cumsum(2.0 * np.pi * 0.5 * (v[:-1] + v[1:])
                                                     * self._dmu)])
        self.source = dict(source or {})
        self._moments: dict[int, np.ndarray] = {}

    @property
    def values(self) -> np.ndarray:
        """The normalised node values (1/sr), a read-only copy."""
        out = self._values.copy()
        out.flags.writeable = False
        return out

    @property
    def nodes(self) -> np.ndarray:
        """``mu_i``, the regular grid on [-1, 1]."""
        return np.linspace(-1.0, 1.0, self._values.size)

    def value(self, mu):
        mu = np.clip(np.asarray(mu, dtype=float), -1.0, 1.0)
        return np.interp(mu, self.nodes, self._values)

    def cumulative(self, mu):
        """``2 pi int_{-1}^{mu} p dmu'``, exact for the piecewise-linear function."""
        x = np.clip(np.asarray(mu, dtype=float), -1.0, 1.0)
        v = self._values
        i = np.clip(np.floor((x + 1.0) / self._dmu).astype(int), 0, v.size - 2)
        t = x - (-1.0 + i * self._dmu)
        slope = (v[i + 1] - v[i]) / self._dmu
        return self._cdf[i] + 2.0 * np.pi * (v[i] * t + 0.5 * slope * t * t)

    def normalisation(self) -> float:
        return float(self._cdf[-1])

    def backscatter_fraction(self) -> float:
        return float(self.cumulative(0.0))

    def cone_fraction(self, half_angle_rad: float) -> float:
        """Share of scattering within ``half_angle_rad`` of forward (exact)."""
        return float(1.0 - self.cumulative(np.cos(half_angle_rad)))

    def legendre_moments(self, lmax: int) -> np.ndarray:
        """Exact ``chi_l`` of the piecewise-linear function, ``l = 0..lmax``.

        On a cell ``p = v_i + s_i (mu - mu_i)``; with the antiderivatives
        ``I_l = (P_{l+1} - P_{l-1})/(2l + 1)`` of ``P_l`` and
        ``J_l = ((l + 1) I_{l+1} + l I_{l-1})/(2l + 1)`` of ``mu P_l``
        (from ``mu P_l = ((l + 1) P_{l+1} + l P_{l-1})/(2l + 1)``),
        ``chi_l = 2 pi sum_i [(v_i - s_i mu_i) dI_l + s_i dJ_l]``.
        """
        lmax = int(lmax)
        for have, chi in self._moments.items():
            if have >= lmax:
                return chi[: lmax + 1].copy()
        x = self.nodes
        v = self._values
        s = np.diff(v) / self._dmu
        c0 = v[:-1] - s * x[:-1]

        def cell(d_i, d_j):
            return 2.0 * np.pi * (np.dot(c0, d_i) + np.dot(s, d_j))

        chi = np.empty(lmax + 1)
        chi[0] = self.normalisation()          # the trapezoidal sum: exact
        # Rolling window: P_{k-1}, P_k and the cell differences of I_{k-2}, I_{k-1}.
        p_prev, p_cur = np.ones_like(x), x.copy()
        d_i = [None, np.diff(x)]                      # dI_{k-2}, dI_{k-1} at k = 1
        for k in range(1, lmax + 2):
            p_next = ((2 * k + 1) * x * p_cur - k * p_prev) / (k + 1)
            d_ik = np.diff((p_next - p_prev) / (2 * k + 1))     # dI_k
            if k - 1 >= 1 and k - 1 <= lmax:
                l = k - 1                                       # chi_l needs I_{l-1}, I_{l+1}
                d_j = ((l + 1) * d_ik + l * d_i[0]) / (2 * l + 1)
                chi[l] = cell(d_i[1], d_j)
            d_i = [d_i[1], d_ik]
            p_prev, p_cur = p_cur, p_next
        self._moments[lmax] = chi
        return chi.copy()

    def describe(self) -> dict:
        return {"name": self.name, "nodes": int(self._values.size), "of": dict(self.source)}


def tabulate(phase: PhaseFunction, n_nodes: int = DEFAULT_TABLE_NODES) -> TabulatedPhase:
    """``phase`` on a regular grid of ``n_nodes`` in mu, as :class:`TabulatedPhase`.

    Nodes take ``phase.value(mu_i)``, except near forward, where
    Fournier-Forand and Petzold's extension are singular (``p ~ theta^-k``,
    k ~ 1.4) and linear interpolation between node values would add mass
    (about 0.2 % of b at 10^5 nodes, taken from everywhere else by the
    normalisation: B 0.2 % low). There:

    * the forward node ``mu = 1`` takes the value that puts the function's
      mass within ``arccos(1 - dmu)`` of forward into the last cell
      (:meth:`PhaseFunction.cone_fraction`);
    * the nodes of the last :data:`TABLE_PEAK_CELLS` cells are scaled by one
      factor so that the table's mass in those cells is the function's.

    So the table keeps the function's backscatter fraction and its forward
    cone masses; the table is then normalised exactly.
    """
    if isinstance(phase, TabulatedPhase):
        return phase
    n = n_nodes
    if not (isinstance(n, (int, np.integer)) and 3 <= n <= 2_000_001):
        raise AquaspecError(f"table size n_nodes={n_nodes!r}; accepted: an integer "
                            "3 ... 2000001")
    n = int(n)
    mu = np.linspace(-1.0, 1.0, n)
    v = np.asarray(phase.value(mu), dtype=float).copy()
    dmu = 2.0 / (n - 1)

    def cone(cells):        # mass of the function in the last ``cells`` cells
        return phase.cone_fraction(2.0 * np.arcsin(np.sqrt(0.5 * cells * dmu)))

    last = 2.0 * cone(1) / (2.0 * np.pi * dmu)     # v[-2] + v[-1] for the last cell
    k = min(TABLE_PEAK_CELLS, (n - 1) // 20)
    if k >= 2:
        # Cells n-1-k .. n-2: mass 2 pi dmu (v[n-1-k]/2 + f S + (last - f v[-2])/2).
        s_int = v[n - k:n - 1].sum() - 0.5 * v[-2]
        f = (cone(k) / (2.0 * np.pi * dmu) - 0.5 * v[n - 1 - k] - 0.5 * last) / s_int
        if np.isfinite(f) and f > 0:
            v[n - k:n - 1] *= f
    v[-1] = max(last - v[-2], 0.0)
    return TabulatedPhase(v, source=phase.describe())


@lru_cache(maxsize=8)
def _tabulated_cached(of: str, n_nodes: int, params: tuple) -> TabulatedPhase:
    return tabulate(get_phase(of, **dict(params)), n_nodes)


def tabulated_phase(of: str, n_nodes: int = DEFAULT_TABLE_NODES, **params) -> TabulatedPhase:
    """The phase function ``of`` (with ``params``) tabulated by :func:`tabulate`, cached.

    The ``"tabulated"`` entry of :data:`PHASE_FUNCTIONS`: e.g.
    ``get_phase("tabulated", of="ff", backscatter=0.0183)``. Tabulated
    ``"petzold"`` is Petzold's particle phase function alone: a table is
    one function for all wavelengths, so it is not mixed with pure water.
    """
    if of == "tabulated" or of not in PHASE_FUNCTIONS:
        raise AquaspecError(f"cannot tabulate phase function {of!r}; known: "
                            f"{', '.join(k for k in PHASE_FUNCTIONS if k != 'tabulated')}")
    try:
        key = tuple(sorted((k, float(v)) for k, v in params.items()))
    except (TypeError, ValueError):
        raise AquaspecError(f"bad parameters {params!r} for phase function {of!r}") from None
    return _tabulated_cached(of, n_nodes, key)


#: ``method`` name -> factory(**params) -> PhaseFunction.
PHASE_FUNCTIONS = {
    "isotropic": Isotropic,
    "hg": HenyeyGreenstein,
    "ff": FournierForand,
    "petzold": PetzoldParticles,
    "tabulated": tabulated_phase,
}


def get_phase(method: str, **params) -> PhaseFunction:
    """The phase function named ``method`` (a key of :data:`PHASE_FUNCTIONS`).

    Parameters go to its factory: ``hg`` takes ``g``, ``ff`` takes
    ``backscatter`` (the fraction B).
    """
    try:
        factory = PHASE_FUNCTIONS[method]
    except (KeyError, TypeError):
        raise AquaspecError(f"unknown phase function {method!r}; known: "
                            f"{', '.join(PHASE_FUNCTIONS)}") from None
    try:
        return factory(**params)
    except TypeError as exc:
        raise AquaspecError(f"bad parameters {params!r} for phase function {method!r}: "
                            f"{exc}") from None
