"""Wavelength bands and band-averaged resampling of spectra.

The spectrum [lambda_min, lambda_max] (nm) is split into ``n`` equal bands of
width ``w = (lambda_max - lambda_min) / n``. A spectral integral
``int f(lambda) dlambda`` becomes the rectangle rule ``sum_i w * f_i`` (thesis
Eq. 4.8), where ``f_i`` is the *average* of ``f`` over band ``i``. Averaging
(rather than sampling at the band centre) makes every band quantity converge
to the continuous integral as ``n`` grows, and makes a band product of a
narrow feature and a smooth curve behave sensibly at small ``n``.

Spectra given at sample wavelengths are taken as piecewise linear between the
samples; band averages are exact integrals of that interpolant.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError, DataRangeError

#: Accepted number of bands.
MIN_BANDS, MAX_BANDS = 1, 1024


@dataclass(frozen=True)
class Bands:
    """``n`` equal wavelength bands over ``[lo_nm, hi_nm]``.

    Parameters
    ----------
    n : int
        Number of bands, 1 to 1024 (3 is the "RGB implementation", 8-32 is
        the usual spectral range).
    lo_nm, hi_nm : float
        Spectral range in nm, default 400-700.
    """

    n: int
    lo_nm: float = 400.0
    hi_nm: float = 700.0

    def __post_init__(self):
        if isinstance(self.n, bool) or not isinstance(self.n, (int, np.integer)):
            raise AquaspecError(f"number of bands must be an integer, got {self.n!r}")
        if not MIN_BANDS <= self.n <= MAX_BANDS:
            raise AquaspecError(
                f"number of bands n={self.n} is out of range; accepted: "
                f"{MIN_BANDS} to {MAX_BANDS}")
        lo, hi = float(self.lo_nm), float(self.hi_nm)
        if not (np.isfinite(lo) and np.isfinite(hi) and 0 < lo < hi):
            raise AquaspecError(
                f"wavelength range {self.lo_nm!r}-{self.hi_nm!r} nm is invalid; "
                "accepted: 0 < lambda_min < lambda_max, in nm")

    @property
    def width_nm(self) -> float:
        """Band width ``w`` in nm (the rectangle-rule weight)."""
        return (self.hi_nm - self.lo_nm) / self.n

    @property
    def edges_nm(self) -> np.ndarray:
        """Band edges, shape (n + 1,)."""
        return np.linspace(self.lo_nm, self.hi_nm, self.n + 1)

    @property
    def centers_nm(self) -> np.ndarray:
        """Band centres, shape (n,)."""
        e = self.edges_nm
        return 0.5 * (e[:-1] + e[1:])

    @property
    def weights_nm(self) -> np.ndarray:
        """Rectangle-rule weights (all equal to ``width_nm``), shape (n,)."""
        return np.full(self.n, self.width_nm)

    def average(self, wavelength_nm, values, *, name: str = "spectrum",
                outside: str = "error") -> np.ndarray:
        """Average a sampled spectrum over each band.

        Parameters
        ----------
        wavelength_nm : array_like, shape (m,)
            Strictly ascending sample wavelengths.
        values : array_like, shape (..., m)
            Samples; leading axes are kept (e.g. 3 response curves).
        name : str
            Used in error messages.
        outside : {"error", "zero"}
            What to do where a band lies outside the samples' range: raise
            :class:`DataRangeError`, or treat the spectrum as zero there.

        Returns
        -------
        ndarray, shape (..., n)
        """
        return band_average(self.edges_nm, wavelength_nm, values, name=name,
                            outside=outside)

    def describe(self) -> dict:
        """Parameters for metadata sidecars."""
        return {"n": int(self.n), "lambda_min_nm": float(self.lo_nm),
                "lambda_max_nm": float(self.hi_nm), "width_nm": self.width_nm}


def _cumulative_integral(x, y, xq):
    """Integral from x[0] to xq of the piecewise-linear interpolant of (x, y).

    ``y`` has shape (..., m); ``xq`` must lie in [x[0], x[-1]].
    """
    dx = np.diff(x)
    seg = 0.5 * (y[..., 1:] + y[..., :-1]) * dx
    F = np.concatenate([np.zeros(y.shape[:-1] + (1,)), np.cumsum(seg, axis=-1)],
                       axis=-1)
    i = np.clip(np.searchsorted(x, xq, side="right") - 1, 0, x.size - 2)
    t = xq - x[i]
    slope = (y[..., i + 1] - y[..., i]) / dx[i]
    return F[..., i] + y[..., i] * t + 0.5 * slope * t * t


def band_average(edges_nm, wavelength_nm, values, *, name="spectrum",
                 outside="error") -> np.ndarray:
    """Average of a piecewise-linear spectrum over each interval of ``edges_nm``.

    See :meth:`Bands.average`.
    """
    if outside not in ("error", "zero"):
        raise AquaspecError(f"outside={outside!r} is not accepted; use 'error' or 'zero'")
    x = np.asarray(wavelength_nm, dtype=float)
    y = np.asarray(values, dtype=float)
    edges = np.asarray(edges_nm, dtype=float)
    if x.ndim != 1 or x.size < 2:
        raise AquaspecError(f"{name}: need at least two sample wavelengths, got {x.size}")
    if y.shape[-1] != x.size:
        raise AquaspecError(
            f"{name}: {y.shape[-1]} values for {x.size} wavelengths")
    if not np.all(np.isfinite(x)) or np.any(np.diff(x) <= 0):
        raise AquaspecError(f"{name}: wavelengths must be finite and strictly ascending")
    if not np.all(np.isfinite(y)):
        raise AquaspecError(f"{name}: values contain NaN or infinity")
    lo, hi = edges[0], edges[-1]
    if lo < x[0] or hi > x[-1]:
        if outside == "error":
            raise DataRangeError(
                f"{name} covers {x[0]:g}-{x[-1]:g} nm, but the bands span "
                f"{lo:g}-{hi:g} nm; choose a range inside {x[0]:g}-{x[-1]:g} nm"
                " (or ask for zero response outside it)")
        # Zero outside the data: extend with explicit zero samples.
        pad = 1e-9 * max(1.0, hi - lo)
        xs, ys = [x], [y]
        if lo < x[0]:
            xs.insert(0, np.array([min(lo, x[0] - 2 * pad), x[0] - pad]))
            ys.insert(0, np.zeros(y.shape[:-1] + (2,)))
        if hi > x[-1]:
            xs.append(np.array([x[-1] + pad, max(hi, x[-1] + 2 * pad)]))
            ys.append(np.zeros(y.shape[:-1] + (2,)))
        x, y = np.concatenate(xs), np.concatenate(ys, axis=-1)
    F = _cumulative_integral(x, y, edges)
    return np.diff(F, axis=-1) / np.diff(edges)
