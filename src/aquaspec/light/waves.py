"""The wind sea over a periodic tile: the surface that makes caustics.

Conventions as in :mod:`aquaspec.light.sun` (metres, y up, the mean surface at
``y = 0``, compass azimuths from ``-z`` towards ``+x``).

A periodic tile ``L`` metres wide sampled on ``N x N`` points carries a
random linear sea (Tessendorf's construction, "Simulating Ocean Water",
SIGGRAPH course notes 2001):

    h(x, t) = Re sum_k A(k) exp(i (k . x - omega(k) t)),   omega^2 = g |k|

with ``A(k)`` complex normal, ``E|A|^2 = 2 F(k) dk^2`` (``dk = 2 pi / L``),
so that ``h`` has the spectrum ``F``. ``F`` is the Pierson-Moskowitz spectrum
of a fully developed sea in wavenumber form (Pierson & Moskowitz 1964,
J. Geophys. Res. 69, 5181; ``alpha = 8.1e-3``, ``beta = 0.74``, wind speed
``U`` at 19.5 m),

    S(k) = alpha / (2 k^3) exp(-beta g^2 / (k^2 U^4)),

spread over directions as ``(2 / pi) cos^2(theta)`` about the wind (waves run
downwind only): ``F(k) = S(k) D(theta) / k``. Wavenumbers above the tile's
Nyquist ``pi N / L`` are not represented. The slope variance of what is
represented, ``sum k^2 F dk^2``, is :func:`resolved_slope_variance`; Cox &
Munk's sun-glitter measurement (1954, J. Opt. Soc. Am. 44, 838: clean
surface, ``sigma^2 = 0.003 + 5.12e-3 U``, ``U`` at 12.5 m) is
:func:`cox_munk_slope_variance`, the check that the default tile is a
plausible sea (:meth:`Waves.describe` reports both).

A looping sea (``Waves.period_s = T``) has every frequency rounded to a
whole number of turns per ``T``, ``omega_T = (2 pi / T) max(1, round(omega T
/ 2 pi))`` (:func:`angular_frequency`; the habit of real-time ocean renderers,
which make a repeating sequence of a tile): ``h(x, t + T) = h(x, t)`` exactly,
each frequency moves by at most ``pi / T`` (so each wave's phase drifts from
the true sea's by at most ``pi t / T``) and the surface at ``t = 0`` is the
true sea's. Caustics are then a loop of frames built once
(:class:`aquaspec.light.caustics.CausticLoop`).

Waves shorter than the tile's samples (down to capillaries) and longer than
the tile are not in it: :func:`unresolved_slope_variance` is what Cox & Munk
measured beyond what the tile and the longer waves
(:func:`long_wave_slope_variance`) carry; the caustics blur by it
(:mod:`aquaspec.light.caustics`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
import scipy.fft as sfft
from scipy.special import exp1

from aquaspec.errors import AquaspecError
from aquaspec.parallel import workers

GRAVITY = 9.81
#: Pierson & Moskowitz (1964): the equilibrium constant and the peak factor.
PM_ALPHA = 8.1e-3
PM_BETA = 0.74

DEFAULT_TILE_M = 8.0
DEFAULT_GRID = 256
#: A looping sea's period when none is given (:func:`looping`), s.
DEFAULT_LOOP_PERIOD_S = 2.0
#: Accepted wind speeds, m/s (PM's spectrum is for a fully developed sea).
WIND_RANGE = (0.5, 25.0)


@dataclass(frozen=True)
class Waves:
    """A wind sea over a periodic tile.

    Attributes
    ----------
    wind_speed : float
        m/s at 19.5 m (Pierson-Moskowitz's reference height).
    wind_azimuth_deg : float
        The way the wind blows (and the waves run), compass as the sun's.
    time_s : float
        The instant (waves move with ``omega^2 = g k``).
    seed : int
        The random phases' seed: the same seed gives the same sea.
    tile_m, grid : float, int
        Tile width and samples per side.
    period_s : float or None
        A looping sea: the frequencies rounded to whole turns per
        ``period_s`` seconds (:func:`angular_frequency`); None: the true sea.
    """

    wind_speed: float
    wind_azimuth_deg: float = 0.0
    time_s: float = 0.0
    seed: int = 0
    tile_m: float = DEFAULT_TILE_M
    grid: int = DEFAULT_GRID
    period_s: float | None = None

    def __post_init__(self):
        u = float(self.wind_speed)
        if not (np.isfinite(u) and WIND_RANGE[0] <= u <= WIND_RANGE[1]):
            raise AquaspecError(f"wind speed {self.wind_speed!r} m/s; accepted: "
                                f"{WIND_RANGE[0]} to {WIND_RANGE[1]}")
        az = float(self.wind_azimuth_deg)
        if not np.isfinite(az):
            raise AquaspecError(f"wind azimuth {self.wind_azimuth_deg!r} deg; accepted: a "
                                "finite angle")
        t = float(self.time_s)
        if not np.isfinite(t):
            raise AquaspecError(f"wave time {self.time_s!r} s; accepted: a finite number")
        tile = float(self.tile_m)
        if not (np.isfinite(tile) and 0.5 <= tile <= 200.0):
            raise AquaspecError(f"wave tile {self.tile_m!r} m; accepted: 0.5 to 200")
        g = int(self.grid)
        if g != self.grid or g < 16 or g > 4096 or g & (g - 1):
            raise AquaspecError(f"wave grid {self.grid!r}; accepted: a power of two, 16 to 4096")
        seed = int(self.seed)
        if seed != self.seed or seed < 0:
            raise AquaspecError(f"wave seed {self.seed!r}; accepted: an integer >= 0")
        if self.period_s is not None:
            period = float(self.period_s)
            if not (np.isfinite(period) and period > 0):
                raise AquaspecError(f"wave loop period {self.period_s!r} s; accepted: None or "
                                    "a finite number > 0")
            object.__setattr__(self, "period_s", period)
        object.__setattr__(self, "wind_speed", u)
        object.__setattr__(self, "wind_azimuth_deg", az % 360.0)
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "tile_m", tile)
        object.__setattr__(self, "seed", seed)

    def describe(self) -> dict:
        return {"spectrum": "Pierson-Moskowitz 1964, cos^2 spreading",
                "wind_speed_m_s": self.wind_speed, "wind_azimuth_deg": self.wind_azimuth_deg,
                "time_s": self.time_s, "seed": self.seed, "tile_m": self.tile_m,
                "grid": self.grid, "loop_period_s": self.period_s,
                "resolved_slope_variance": resolved_slope_variance(self),
                "cox_munk_slope_variance": cox_munk_slope_variance(self.wind_speed),
                "longer_than_tile_slope_variance": long_wave_slope_variance(self),
                "unresolved_slope_variance": unresolved_slope_variance(self)}


def looping(waves: Waves, period_s: float | None = None) -> Waves:
    """``waves`` as a looping sea: its own ``period_s``, else ``period_s``,
    else :data:`DEFAULT_LOOP_PERIOD_S`."""
    if waves.period_s is not None:
        return waves
    return replace(waves, period_s=DEFAULT_LOOP_PERIOD_S if period_s is None else period_s)


def pm_spectrum(k, wind_speed):
    """Pierson-Moskowitz omnidirectional elevation spectrum ``S(k)``, m^3 (k in rad/m)."""
    k = np.asarray(k, dtype=float)
    safe = np.where(k > 0, k, 1.0)
    out = PM_ALPHA / (2.0 * safe ** 3) * np.exp(-PM_BETA * GRAVITY ** 2
                                                / (safe ** 2 * float(wind_speed) ** 4))
    return np.where(k > 0, out, 0.0)


def cox_munk_slope_variance(wind_speed) -> float:
    """Cox & Munk's (1954) total slope variance of a clean sea surface."""
    return 0.003 + 5.12e-3 * float(wind_speed)


def pm_slope_variance(k_lo, k_hi, wind_speed) -> float:
    """The Pierson-Moskowitz sea's slope variance from wavenumbers ``k_lo`` to
    ``k_hi`` (rad/m; ``k_lo`` may be 0, ``k_hi`` not inf: the integral of
    ``k^2 S(k)`` has no upper bound over all k):
    ``alpha / 4 (E1(c / k_hi^2) - E1(c / k_lo^2))``, ``c = beta g^2 / U^4``."""
    c = PM_BETA * GRAVITY ** 2 / float(wind_speed) ** 4
    lo, hi = float(k_lo), float(k_hi)
    if not (0.0 <= lo <= hi < np.inf):
        raise AquaspecError(f"wavenumbers {k_lo!r}..{k_hi!r} rad/m; accepted: "
                            "0 <= k_lo <= k_hi, finite")
    lower = exp1(c / lo ** 2) if lo > 0 else 0.0
    return float(PM_ALPHA / 4.0 * (exp1(c / hi ** 2) - lower))


def long_wave_slope_variance(waves) -> float:
    """Slope variance of the Pierson-Moskowitz waves longer than the tile
    (``k < 2 pi / L``)."""
    return pm_slope_variance(0.0, 2.0 * np.pi / waves.tile_m, waves.wind_speed)


def unresolved_slope_variance(waves) -> float:
    """Cox & Munk's slope variance that neither the tile nor the waves longer
    than it carry: the short waves' (see the module docstring), >= 0."""
    return max(0.0, cox_munk_slope_variance(waves.wind_speed) - resolved_slope_variance(waves)
               - long_wave_slope_variance(waves))


def wavenumbers(n: int, tile_m: float):
    """``(kx, kz)`` (n, n), rad/m, of the FFT grid of a tile ``tile_m`` wide on
    ``n x n`` points; ``[i, j]``: row i is z, column j is x."""
    k1 = 2.0 * np.pi * np.fft.fftfreq(n, tile_m / n)
    kx, kz = np.meshgrid(k1, k1)
    return kx, kz


def _wind_direction(azimuth_deg):
    a = np.radians(azimuth_deg)
    return np.sin(a), -np.cos(a)


def directional_spectrum(waves: Waves):
    """``F(k)`` on the tile's FFT grid, (N, N) in m^4, and ``(kx, kz)``."""
    kx, kz = wavenumbers(waves.grid, waves.tile_m)
    k = np.hypot(kx, kz)
    wx, wz = _wind_direction(waves.wind_azimuth_deg)
    cos_t = np.where(k > 0, (kx * wx + kz * wz) / np.where(k > 0, k, 1.0), 0.0)
    spread = np.where(cos_t > 0, 2.0 / np.pi * cos_t ** 2, 0.0)
    f = pm_spectrum(k, waves.wind_speed) * spread / np.where(k > 0, k, 1.0)
    return np.where(k > 0, f, 0.0), kx, kz


def resolved_slope_variance(waves: Waves) -> float:
    """Mean square slope (both axes) of the tile's spectrum, ``sum k^2 F dk^2``."""
    f, kx, kz = directional_spectrum(waves)
    dk = 2.0 * np.pi / waves.tile_m
    return float(np.sum((kx ** 2 + kz ** 2) * f) * dk * dk)


def angular_frequency(k, period_s: float | None = None):
    """``omega`` (rad/s) of deep-water waves of wavenumbers ``k`` (rad/m),
    ``omega^2 = g k``; with ``period_s``, rounded to whole turns per period
    (at least one; ``k = 0`` stays at rest): see the module docstring."""
    omega = np.sqrt(GRAVITY * np.asarray(k, dtype=float))
    if period_s is None:
        return omega
    step = 2.0 * np.pi / float(period_s)
    return np.where(omega > 0, step * np.maximum(1.0, np.round(omega / step)), 0.0)


def _amplitudes(waves: Waves):
    f, kx, kz = directional_spectrum(waves)
    dk = 2.0 * np.pi / waves.tile_m
    rng = np.random.default_rng(waves.seed)
    xi = rng.standard_normal((2,) + f.shape)
    amp = (xi[0] + 1j * xi[1]) * np.sqrt(f) * dk
    omega = angular_frequency(np.hypot(kx, kz), waves.period_s)
    return amp * np.exp(-1j * omega * waves.time_s)


def surface(waves: Waves, oversample: int = 1):
    """The height and its slopes on ``(oversample N)^2`` points, each (M, M):
    ``(h, dh/dx, dh/dz)``; point ``[i, j]`` is at ``x = j L / M``, ``z = i L / M``.
    ``oversample > 1`` evaluates the same band-limited surface between the samples."""
    n = waves.grid
    m = n * int(oversample)
    amp = _amplitudes(waves)
    big = np.zeros((m, m), complex)
    idx = np.fft.fftfreq(n, 1.0 / n).astype(np.int64) % m
    big[np.ix_(idx, idx)] = amp
    kx, kz = wavenumbers(m, waves.tile_m)
    scale = float(m) * m
    h, hx, hz = (sfft.ifft2(spectrum, workers=workers()).real * scale
                 for spectrum in (big, 1j * kx * big, 1j * kz * big))
    return h, hx, hz

