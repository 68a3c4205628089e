"""Surface reflectance spectra.

Three ways to get a spectrum:

- measured spectra (``Reflectance(name, wavelength_nm, values)``, or a CSV
  with columns ``wavelength_nm,reflectance``);
- the 24 ColorChecker patches, "BabelColor Average" measurements (D. Pascale,
  BabelColor, 2006) as shipped by colour-science: :func:`colorchecker`;
- an RGB albedo upsampled to a smooth spectrum with the sigmoid-polynomial
  model of W. Jakob and J. Hanika, "A low-dimensional function space for
  efficient spectral upsampling", Computer Graphics Forum 38(2), 2019::

      R(lambda) = 1/2 + x / (2 sqrt(1 + x^2)),   x = c0 t^2 + c1 t + c2

  aquaspec writes the polynomial in normalised wavelength
  ``t = (lambda - 550 nm) / 100 nm`` (so float32 on the GPU keeps precision)
  and fits ``c`` so that the spectrum, seen by the CIE 1931 observer under
  D65, reproduces the given linear sRGB (Gauss-Newton with continuation from
  grey, as in the paper, vectorised over many colours at once).

Measured spectra are band-averaged (:meth:`Reflectance.on_bands`); per-pixel
sigmoid reflectances (textures, RGB-D images) are evaluated at band centres
(:func:`sigmoid_band_values`), which is what the GPU does too.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .bands import Bands
from .errors import AquaspecError, DataRangeError
from .water import read_csv_columns

SIGMOID_CENTER_NM = 550.0
SIGMOID_SCALE_NM = 100.0
#: Fitting grid for the sigmoid coefficients.
_FIT_WL = np.arange(380.0, 731.0, 5.0)


#: Sigmoid polynomial values are clamped to +-SIGMOID_X_MAX before
#: ``x / sqrt(1 + x^2)``: beyond it the reflectance is 0 or 1 to 1e-12, and
#: the clamp keeps ``x^2`` finite in float32 on the GPU (same clamp there).
SIGMOID_X_MAX = 1.0e6


def sigmoid(x):
    """``1/2 + x / (2 sqrt(1 + x^2))``, the Jakob-Hanika sigmoid (in (0, 1))."""
    x = np.clip(np.asarray(x, dtype=float), -SIGMOID_X_MAX, SIGMOID_X_MAX)
    return 0.5 + 0.5 * x / np.sqrt(1.0 + x * x)


def normalised_wavelength(wavelength_nm):
    """``t = (lambda - 550) / 100``, the variable of the sigmoid polynomial."""
    return (np.asarray(wavelength_nm, dtype=float) - SIGMOID_CENTER_NM) / SIGMOID_SCALE_NM


def sigmoid_at(coeffs, t):
    """Reflectance of sigmoid coefficients ``(..., 3)`` at normalised wavelengths ``t`` (n,).

    Returns ``(..., n)``. WGSL twin: ``sigmoid_reflectance`` in
    ``shaders/common.wgsl`` (same Horner form and clamp).
    """
    c = np.asarray(coeffs, dtype=float)
    t = np.asarray(t, dtype=float)
    return sigmoid((c[..., 0:1] * t + c[..., 1:2]) * t + c[..., 2:3])


def sigmoid_spectrum(coeffs, wavelength_nm):
    """Reflectance of sigmoid coefficients ``(..., 3)`` at wavelengths ``(m,)`` -> ``(..., m)``."""
    return sigmoid_at(coeffs, normalised_wavelength(wavelength_nm))


def sigmoid_band_values(coeffs, bands: Bands):
    """Per-pixel reflectance at band centres, ``(..., 3) -> (..., n)`` (NumPy reference of the GPU)."""
    return sigmoid_spectrum(coeffs, bands.centers_nm)


@functools.lru_cache(maxsize=1)
def _srgb_matrix():
    """(3, m) matrix: reflectance on _FIT_WL -> linear sRGB under D65 (white -> ~1)."""
    from . import colourdata
    from .sensors import XYZ_TO_SRGB
    cmfs_wl, cmfs = colourdata.cmfs_1931()
    xyz = np.stack([np.interp(_FIT_WL, cmfs_wl, cmfs[:, k]) for k in range(3)])
    e = np.interp(_FIT_WL, *colourdata.d65())
    w = xyz * e
    w /= w[1].sum()
    return XYZ_TO_SRGB @ w


def fit_sigmoid(rgb, *, steps: int = 8, iterations: int = 8):
    """Jakob-Hanika coefficients (normalised wavelength) for linear sRGB albedos.

    Parameters
    ----------
    rgb : array_like (..., 3)
        Linear sRGB in [0, 1]; values are clipped to [0.001, 0.999] (the
        sigmoid never reaches 0 or 1).

    Returns
    -------
    coeffs : ndarray (..., 3)
    residual : ndarray (...)
        Max abs RGB error of the fit (about 1e-6 inside the sRGB gamut of
        reflectances; larger for colours no reflectance can have).
    """
    rgb = np.asarray(rgb, dtype=float)
    if rgb.shape[-1:] != (3,):
        raise AquaspecError(f"RGB albedo must have 3 channels, got shape {rgb.shape}")
    if not np.all(np.isfinite(rgb)):
        raise AquaspecError("RGB albedo contains NaN or infinity")
    shape = rgb.shape[:-1]
    target = np.clip(rgb.reshape(-1, 3), 1e-3, 1 - 1e-3)
    M = _srgb_matrix()
    t = normalised_wavelength(_FIT_WL)
    basis = np.stack([t * t, t, np.ones_like(t)])        # (3, m)
    c = np.zeros_like(target)

    def residual(coef, goal):
        x = coef @ basis
        return sigmoid(x) @ M.T - goal, x

    for s in range(1, steps + 1):
        goal = 0.5 + (target - 0.5) * s / steps
        for _ in range(iterations):
            r, x = residual(c, goal)
            ds = 0.5 / (1.0 + x * x) ** 1.5                 # dS/dx, (N, m)
            J = np.einsum("km,nm,jm->nkj", M, ds, basis)   # d rgb_k / d c_j
            try:
                step = np.linalg.solve(J, -r[..., None])[..., 0]
            except np.linalg.LinAlgError:
                step = np.linalg.lstsq(J.reshape(-1, 3), -r.reshape(-1), rcond=None)[0]
            # Damped: halve the step where it does not reduce the residual.
            err0 = np.abs(r).max(axis=1)
            scale = np.ones(len(c))
            for _half in range(6):
                trial = c + step * scale[:, None]
                err1 = np.abs(residual(trial, goal)[0]).max(axis=1)
                worse = err1 > err0
                if not worse.any():
                    break
                scale = np.where(worse, scale * 0.5, scale)
            c = c + step * scale[:, None]
    r, _ = residual(c, target)
    return c.reshape(shape + (3,)), np.abs(r).max(axis=1).reshape(shape)


def fit_sigmoid_image(rgb_image):
    """Sigmoid coefficients for an image of linear sRGB albedo ``(H, W, 3)``.

    Colours are fitted once per distinct value (quantised to 1/1024), which
    keeps photographs with many pixels to seconds.
    """
    img = np.asarray(rgb_image, dtype=float)
    q = np.round(np.clip(img, 0, 1).reshape(-1, 3) * 1023).astype(np.int32)
    keys = (q[:, 0] << 20) | (q[:, 1] << 10) | q[:, 2]
    uniq, inverse = np.unique(keys, return_inverse=True)
    colours = np.stack([(uniq >> 20) & 1023, (uniq >> 10) & 1023, uniq & 1023], axis=1) / 1023
    coeffs = np.empty((len(uniq), 3))
    for start in range(0, len(uniq), 50000):
        coeffs[start:start + 50000] = fit_sigmoid(colours[start:start + 50000])[0]
    return coeffs[inverse].reshape(img.shape)


@dataclass(frozen=True)
class Reflectance:
    """A reflectance spectrum (values in [0, 1]) with a name and provenance."""

    name: str
    wavelength_nm: np.ndarray
    values: np.ndarray
    source: str = ""
    rgb: tuple | None = None

    def __post_init__(self):
        wl = np.asarray(self.wavelength_nm, dtype=float)
        v = np.asarray(self.values, dtype=float)
        if v.shape != wl.shape or wl.size < 2:
            raise AquaspecError(f"reflectance {self.name!r}: {v.size} values for {wl.size} "
                                "wavelengths (need at least two)")
        if not np.all(np.isfinite(v)) or np.any(v < 0) or np.any(v > 1):
            raise AquaspecError(f"reflectance {self.name!r}: values must be finite and in [0, 1]")
        if np.any(np.diff(wl) <= 0):
            raise AquaspecError(f"reflectance {self.name!r}: wavelengths must strictly ascend")
        object.__setattr__(self, "wavelength_nm", wl)
        object.__setattr__(self, "values", v)

    @classmethod
    def from_rgb(cls, rgb, name: str | None = None) -> "Reflectance":
        """Smooth spectrum of a linear sRGB albedo (Jakob & Hanika 2019)."""
        rgb = np.asarray(rgb, dtype=float)
        if rgb.shape != (3,) or np.any(rgb < 0) or np.any(rgb > 1):
            raise AquaspecError(f"albedo {rgb.tolist()!r} must be three linear RGB values in [0, 1]")
        coeffs, _ = fit_sigmoid(rgb)
        wl = np.arange(360.0, 831.0, 1.0)
        return cls(name or f"rgb({rgb[0]:.3g},{rgb[1]:.3g},{rgb[2]:.3g})", wl,
                   sigmoid_spectrum(coeffs, wl), source="Jakob & Hanika 2019 upsampling",
                   rgb=tuple(float(x) for x in rgb))

    @classmethod
    def constant(cls, value: float, name: str | None = None) -> "Reflectance":
        """A spectrally flat (grey) reflectance."""
        return cls(name or f"grey {value:g}", np.array([300.0, 900.0]), np.full(2, float(value)),
                   source="constant")

    def on_bands(self, bands: Bands) -> np.ndarray:
        lo, hi = self.wavelength_nm[0], self.wavelength_nm[-1]
        if bands.lo_nm < lo or bands.hi_nm > hi:
            raise DataRangeError(f"reflectance {self.name!r} covers {lo:g}-{hi:g} nm, but the "
                                 f"bands span {bands.lo_nm:g}-{bands.hi_nm:g} nm")
        return bands.average(self.wavelength_nm, self.values, name=f"reflectance {self.name}")


def reflectance_from_csv(path, name: str | None = None) -> Reflectance:
    """A measured reflectance from a CSV with columns ``wavelength_nm,reflectance``."""
    from pathlib import Path
    cols = read_csv_columns(path, ("wavelength_nm", "reflectance"), what="reflectance")
    return Reflectance(name or Path(path).stem, cols["wavelength_nm"], cols["reflectance"],
                       source=f"csv:{path}")


@functools.lru_cache(maxsize=1)
def colorchecker() -> tuple:
    """The 24 ColorChecker patches in chart order (row by row, grey row last)."""
    from . import colourdata
    return tuple(Reflectance(name, wl, np.clip(values, 0, 1),
                             source="ColorChecker, BabelColor Average (colour-science)")
                 for name, wl, values in colourdata.colorchecker_spectra())
