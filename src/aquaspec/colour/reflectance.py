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
  D65, reproduces the given linear sRGB: Gauss-Newton with continuation from
  grey (:func:`fit_sigmoid`), or, for many colours at once such as an
  image's, Gauss-Newton from coefficients interpolated in a table over the
  RGB cube (:func:`fit_sigmoid_many`). The paper ships such a table for
  lookup alone; here it only starts the steps, so both routes end at the
  same fit, and it is computed on the machine (a few seconds, once; kept in
  aquaspec's cache).

Measured spectra are band-averaged (:meth:`Reflectance.on_bands`); per-pixel
sigmoid reflectances (textures, RGB-D images) are evaluated at band centres
(:func:`sigmoid_band_values`), which is what the GPU does too.
"""

from __future__ import annotations

import functools
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aquaspec.cache import cached_arrays, code_digest
from aquaspec.colour import data as colourdata
from aquaspec.colour.bands import Bands
from aquaspec.colour.srgb import XYZ_TO_SRGB
from aquaspec.errors import AquaspecError, DataRangeError
from aquaspec.io.csv import read_csv_columns

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
    return _sigmoid_in_place(np.array(x, dtype=float))[0]


def _sigmoid_in_place(x: np.ndarray):
    """:func:`sigmoid` of a float array, written over it (the fit's largest
    cost), and ``sqrt(1 + x^2)`` of the clamped x (for derivatives)."""
    np.clip(x, -SIGMOID_X_MAX, SIGMOID_X_MAX, out=x)
    root = x * x
    root += 1.0
    np.sqrt(root, out=root)
    x /= root
    x *= 0.5
    x += 0.5
    return x, root


def normalised_wavelength(wavelength_nm):
    """``t = (lambda - 550) / 100``, the variable of the sigmoid polynomial."""
    return (np.asarray(wavelength_nm, dtype=float) - SIGMOID_CENTER_NM) / SIGMOID_SCALE_NM


def sigmoid_at(coeffs, t):
    """Reflectance of sigmoid coefficients ``(..., 3)`` at normalised wavelengths ``t`` (n,).

    Returns ``(..., n)``. WGSL twin: ``sigmoid_reflectance`` in
    ``gpu/wgsl/common.wgsl`` (same Horner form and clamp).
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
    cmfs_wl, cmfs = colourdata.cmfs_1931()
    xyz = np.stack([np.interp(_FIT_WL, cmfs_wl, cmfs[:, k]) for k in range(3)])
    e = np.interp(_FIT_WL, *colourdata.d65())
    w = xyz * e
    w /= w[1].sum()
    return XYZ_TO_SRGB @ w


@functools.lru_cache(maxsize=1)
def _fit_system():
    """The fit's matrices: M (3, m), the polynomial basis (3, m) and, for the
    Jacobian, ``basis[j] M^T`` (3, m, 3)."""
    M = _srgb_matrix()
    t = normalised_wavelength(_FIT_WL)
    basis = np.stack([t * t, t, np.ones_like(t)])
    return M, basis, basis[:, :, None] * M.T[None, :, :]


def _fit_residual(coeffs, goal):
    """RGB of coefficients (N, 3) minus ``goal`` (N, 3), and ``sqrt(1 + x^2)``
    (N, m) of the clamped polynomial values x (what the Jacobian needs)."""
    M, basis, _ = _fit_system()
    refl, root = _sigmoid_in_place(coeffs @ basis)
    return refl @ M.T - goal, root


def _gauss_newton(coeffs, goal, *, iterations: int, tol: float = 0.0, halvings: int = 6):
    """Damped Gauss-Newton steps from ``coeffs`` (N, 3) towards coefficients
    whose RGB is ``goal`` (N, 3): at most ``iterations``, each step halved
    (up to ``halvings`` times) where it does not lower the largest residual;
    rows whose largest residual is at most ``tol`` are left as they are.
    Returns the coefficients and their largest RGB residuals (N,)."""
    _, _, basis_m = _fit_system()
    c = np.array(coeffs, dtype=float)
    r, root = _fit_residual(c, goal)
    err = np.abs(r).max(axis=1)
    for _ in range(iterations):
        act = np.flatnonzero(err > tol)
        if act.size == 0:
            break
        ds = 0.5 / root[act] ** 3                       # dS/dx
        J = np.stack([ds @ basis_m[j] for j in range(3)], axis=2)   # d rgb_k / d c_j
        try:
            step = np.linalg.solve(J, -r[act][..., None])[..., 0]
        except np.linalg.LinAlgError:
            step = np.stack([np.linalg.lstsq(Jn, -rn, rcond=None)[0]
                             for Jn, rn in zip(J, r[act])])
        c_act, goal_act, e0 = c[act], goal[act], err[act]
        trial = c_act + step
        r1, root1 = _fit_residual(trial, goal_act)
        e1 = np.abs(r1).max(axis=1)
        scale = np.ones(act.size)
        for _half in range(halvings):
            worse = np.flatnonzero(e1 > e0)
            if worse.size == 0:
                break
            scale[worse] *= 0.5
            trial[worse] = c_act[worse] + step[worse] * scale[worse, None]
            r1[worse], root1[worse] = _fit_residual(trial[worse], goal_act[worse])
            e1[worse] = np.abs(r1[worse]).max(axis=1)
        c[act], r[act], root[act], err[act] = trial, r1, root1, e1
    return c, err


def _check_rgb(rgb) -> np.ndarray:
    rgb = np.asarray(rgb, dtype=float)
    if rgb.shape[-1:] != (3,):
        raise AquaspecError(f"RGB albedo must have 3 channels, got shape {rgb.shape}")
    if not np.all(np.isfinite(rgb)):
        raise AquaspecError("RGB albedo contains NaN or infinity")
    return rgb


def fit_sigmoid(rgb, *, steps: int = 8, iterations: int = 8):
    """Jakob-Hanika coefficients (normalised wavelength) for linear sRGB albedos.

    Gauss-Newton with continuation from grey: ``steps`` targets on the way
    from RGB 0.5 to the colour, ``iterations`` steps each. The reference
    fit; :func:`fit_sigmoid_many` reaches the same coefficients from a table
    (for many colours at once, such as an image's).

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
    rgb = _check_rgb(rgb)
    shape = rgb.shape[:-1]
    target = np.clip(rgb.reshape(-1, 3), 1e-3, 1 - 1e-3)
    c = np.zeros_like(target)
    err = np.zeros(len(target))
    for s in range(1, steps + 1):
        goal = target if s == steps else 0.5 + (target - 0.5) * s / steps
        c, err = _gauss_newton(c, goal, iterations=iterations)
    return c.reshape(shape + (3,)), err.reshape(shape)


#: Nodes per axis of the table of coefficients that starts :func:`fit_sigmoid_many`.
SIGMOID_TABLE_SIZE = 32
#: Gauss-Newton steps :func:`fit_sigmoid_many` allows from the table's guess,
#: and the largest RGB residual at which it stops.
_MANY_ITERATIONS = 30
_MANY_TOL = 1e-12
#: A colour whose fit from the table ends above this residual is fitted by
#: continuation too, and keeps the better of the two.
_MANY_FALLBACK = 1e-6
_MANY_CHUNK = 65536


def _table_brightness(n: int) -> np.ndarray:
    """The table's nodes of the largest channel: dense near 0 and 1, where
    the coefficients change fastest (clipped as the fit clips)."""
    z = 0.5 - 0.5 * np.cos(np.pi * np.arange(n) / (n - 1))
    return np.clip(z, 1e-3, 1 - 1e-3)


def _table_colours(n: int, z: float) -> np.ndarray:
    """The table's colours at largest channel ``z``: (3, n, n, 3); table k
    has channel k largest, channels k + 1 and k + 2 (mod 3) at ``x z`` and
    ``y z`` for x, y on n nodes in [0, 1]."""
    u = np.linspace(0.0, 1.0, n)
    x, y = np.meshgrid(u, u, indexing="ij")
    out = np.empty((3, n, n, 3))
    for k in range(3):
        out[k, ..., k] = z
        out[k, ..., (k + 1) % 3] = x * z
        out[k, ..., (k + 2) % 3] = y * z
    return np.clip(out, 1e-3, 1 - 1e-3)


def _build_sigmoid_table(n: int) -> np.ndarray:
    """Coefficients (3, n, n, n, 3) at the table's colours [k, x, y, z]: the
    middle brightness by continuation from grey, then brightness by
    brightness, each slice's Gauss-Newton starting from its neighbour's
    coefficients (so whole slices are solved at once)."""
    z = _table_brightness(n)
    table = np.empty((3, n, n, n, 3))
    mid = n // 2
    table[:, :, :, mid] = fit_sigmoid(_table_colours(n, z[mid]))[0]
    for order in (range(mid + 1, n), range(mid - 1, -1, -1)):
        prev = table[:, :, :, mid].reshape(-1, 3)
        for j in order:
            goal = _table_colours(n, z[j]).reshape(-1, 3)
            prev, _ = _gauss_newton(prev, goal, iterations=_MANY_ITERATIONS, tol=_MANY_TOL,
                                    halvings=8)
            table[:, :, :, j] = prev.reshape(3, n, n, 3)
    return table


@functools.lru_cache(maxsize=1)
def sigmoid_table() -> np.ndarray:
    """The table of coefficients (3, n, n, n, 3) of :func:`fit_sigmoid_many`,
    computed once per machine (a few seconds) and kept in aquaspec's cache."""
    n = SIGMOID_TABLE_SIZE
    M, basis, _ = _fit_system()
    key = code_digest([sys.modules[__name__]], M.tobytes(), basis.tobytes())
    table = cached_arrays("sigmoid-table", key, lambda: {"table": _build_sigmoid_table(n)})
    table = np.asarray(table["table"], dtype=float)
    if table.shape != (3, n, n, n, 3) or not np.all(np.isfinite(table)):
        return _build_sigmoid_table(n)
    return table


def _table_guess(target: np.ndarray) -> np.ndarray:
    """Trilinear interpolation of :func:`sigmoid_table` at clipped colours (N, 3)."""
    table = sigmoid_table()
    n = table.shape[1]
    k = np.argmax(target, axis=1)
    rows = np.arange(len(target))
    z = target[rows, k]
    coords = [target[rows, (k + 1) % 3] / z * (n - 1), target[rows, (k + 2) % 3] / z * (n - 1),
              # (inverse of _table_brightness)
              np.arccos(np.clip(1.0 - 2.0 * z, -1.0, 1.0)) / np.pi * (n - 1)]
    lo = [np.clip(np.floor(c).astype(np.intp), 0, n - 2) for c in coords]
    frac = [np.clip(c - i, 0.0, 1.0)[:, None] for c, i in zip(coords, lo)]
    guess = np.zeros((len(target), 3))
    for dx in (0, 1):
        wx = frac[0] if dx else 1.0 - frac[0]
        for dy in (0, 1):
            wy = frac[1] if dy else 1.0 - frac[1]
            for dz in (0, 1):
                wz = frac[2] if dz else 1.0 - frac[2]
                guess += wx * wy * wz * table[k, lo[0] + dx, lo[1] + dy, lo[2] + dz]
    return guess


def fit_sigmoid_many(rgb):
    """:func:`fit_sigmoid` for many colours at once, 30-40 times faster.

    Each colour starts from coefficients interpolated in a table over the
    RGB cube (:func:`sigmoid_table`) and takes Gauss-Newton steps until its
    RGB residual is under 1e-12 (four to seven steps in the gamut); a colour
    still above 1e-6 is fitted by continuation as well and keeps the better
    fit. Same arguments and results as :func:`fit_sigmoid`.
    """
    rgb = _check_rgb(rgb)
    shape = rgb.shape[:-1]
    target = np.clip(rgb.reshape(-1, 3), 1e-3, 1 - 1e-3)
    coeffs = np.empty_like(target)
    residual = np.empty(len(target))
    for start in range(0, len(target), _MANY_CHUNK):
        part = slice(start, start + _MANY_CHUNK)
        coeffs[part], residual[part] = _gauss_newton(
            _table_guess(target[part]), target[part], iterations=_MANY_ITERATIONS,
            tol=_MANY_TOL, halvings=8)
    hard = np.flatnonzero(residual > _MANY_FALLBACK)
    if hard.size:
        c2, r2 = fit_sigmoid(target[hard])
        better = r2 < residual[hard]
        coeffs[hard[better]] = c2[better]
        residual[hard[better]] = r2[better]
    return coeffs.reshape(shape + (3,)), residual.reshape(shape)


#: Colours :func:`fit_sigmoid_image` keeps fitted across calls (a data set's
#: images share most of their colours), at most this many (32 bytes each).
MEMO_COLOURS = 4_000_000
_memo_lock = threading.Lock()
_memo_keys = np.zeros(0, dtype=np.int64)         # sorted quantised colours
_memo_coeffs = np.zeros((0, 3))


def fit_sigmoid_image(rgb_image):
    """Sigmoid coefficients for an image of linear sRGB albedo ``(H, W, 3)``.

    Colours are fitted once per distinct value (quantised to 1/1024) with
    :func:`fit_sigmoid_many` (a 640x480 photograph with 120 000 distinct
    colours takes about a second), and kept for later calls in this process
    (up to :data:`MEMO_COLOURS`): the images of a data set share most of
    their colours, which are then only looked up.
    """
    global _memo_keys, _memo_coeffs
    img = np.asarray(rgb_image, dtype=float)
    q = np.round(np.clip(img, 0, 1).reshape(-1, 3) * 1023).astype(np.int64)
    uniq, inverse = np.unique((q[:, 0] << 20) | (q[:, 1] << 10) | q[:, 2], return_inverse=True)
    with _memo_lock:
        keys, coeffs = _memo_keys, _memo_coeffs
    pos = np.searchsorted(keys, uniq)
    known = pos < keys.size
    known[known] = keys[pos[known]] == uniq[known]
    new = uniq[~known]
    colours = np.stack([(new >> 20) & 1023, (new >> 10) & 1023, new & 1023], axis=1) / 1023
    fitted = fit_sigmoid_many(colours)[0]
    out = np.empty((uniq.size, 3))
    out[known] = coeffs[pos[known]]
    out[~known] = fitted
    if new.size:
        with _memo_lock:
            if _memo_keys is keys and keys.size + new.size <= MEMO_COLOURS:
                at = np.searchsorted(keys, new)
                _memo_keys = np.insert(keys, at, new)
                _memo_coeffs = np.insert(coeffs, at, fitted, axis=0)
            elif uniq.size <= MEMO_COLOURS:
                _memo_keys, _memo_coeffs = uniq, out.copy()
    return out[inverse.reshape(-1)].reshape(img.shape)


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
    cols = read_csv_columns(path, ("wavelength_nm", "reflectance"), what="reflectance")
    return Reflectance(name or Path(path).stem, cols["wavelength_nm"], cols["reflectance"],
                       source=f"csv:{path}")


@functools.lru_cache(maxsize=1)
def colorchecker() -> tuple:
    """The 24 ColorChecker patches in chart order (row by row, grey row last)."""
    return tuple(Reflectance(name, wl, np.clip(values, 0, 1),
                             source="ColorChecker, BabelColor Average (colour-science)")
                 for name, wl, values in colourdata.colorchecker_spectra())
