"""Water: absorption a, scattering b and diffuse attenuation Kd, in 1/m.

Sources (through the PyPI package ``jerlov``):

- ``solonenko2015``: M. G. Solonenko and C. D. Mobley, "Inherent optical
  properties of Jerlov water types", Appl. Opt. 54, 5392-5401 (2015),
  doi:10.1364/AO.54.005392. All ten Jerlov types (I, IA, IB, II, III, 1C, 3C,
  5C, 7C, 9C), a, b and Kd at 17 wavelengths (300-700 nm). The default.
- ``williamson2022``: C. A. Williamson and R. C. Hollins, "Measured IOPs of
  Jerlov water types", Appl. Opt. 61, 9951-9961 (2022),
  doi:10.1364/AO.470464. Six types (IB, II, III, 1C, 3C, 5C), a and b at
  1 nm (300-800 nm). No Kd: a derived Kd is offered (see below).
- A user's CSV with columns ``wavelength_nm,a,b,Kd`` (Kd may be left out, in
  which case it is derived).

Filling gaps
------------
Solonenko & Mobley's Table 7 has no a or Kd for 3C at 675-700 nm and 5C at
600-700 nm (``jerlov`` returns NaN there on purpose). aquaspec fills them,
and warns naming the type, quantity and wavelengths:

- a: pure-water absorption plus the non-water absorption of the last
  published wavelength decaying exponentially with slope
  ``S = 0.014 /nm`` (the typical spectral slope of dissolved and detrital
  absorption, Bricaud, Morel & Prieur 1981, Limnol. Oceanogr. 26, 43-53)::

      a(l) = a_w(l) + (a(l*) - a_w(l*)) exp(-S (l - l*))

- Kd: the derived Kd of the filled a and the published b (formula below),
  scaled by the ratio published/derived at the last published wavelength l*
  so that the spectrum is continuous there.

Derived Kd
----------
Kirk's parameterisation of Monte Carlo results (J. T. O. Kirk, "Volume
scattering function, average cosines, and the underwater light field",
Limnol. Oceanogr. 36, 455-467, 1991)::

    Kd = sqrt(a^2 + G(mu0) a b) / mu0,   G(mu0) = 0.425 mu0 - 0.19

with ``mu0`` the cosine of the refracted direction of the light just below
the surface; for an overcast sky aquaspec uses ``mu0 = 0.84``, the mean
cosine of a uniform sky refracted into water (n = 1.33). A derived Kd is
marked ``kd_derived = True`` everywhere it travels (metadata, tables).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path

import jerlov
import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError, DataRangeError
from aquaspec.io.csv import read_csv_columns

JERLOV_TYPES = ("I", "IA", "IB", "II", "III", "1C", "3C", "5C", "7C", "9C")
SOURCES = ("solonenko2015", "williamson2022")
DEFAULT_SOURCE = "solonenko2015"

#: Spectral slope of non-water absorption used to fill gaps, 1/nm.
FILL_SLOPE_PER_NM = 0.014
#: Cosine of the refracted light used for the derived Kd (overcast sky).
DERIVED_KD_MU0 = 0.84


class WaterDataWarning(UserWarning):
    """A published value was missing and has been filled (message says how)."""


def derived_kd(a, b, mu0: float = DERIVED_KD_MU0):
    """Kd from a and b by Kirk (1991): ``sqrt(a^2 + G a b) / mu0``.

    ``G(mu0) = 0.425 mu0 - 0.19``; a, b in 1/m; ``mu0`` in (0.5, 1].
    """
    if not 0.5 < mu0 <= 1.0:
        raise AquaspecError(f"mu0={mu0!r} is outside Kirk's range; accepted: 0.5 < mu0 <= 1")
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    g = 0.425 * mu0 - 0.19
    return np.sqrt(a * a + g * a * b) / mu0


@dataclass(frozen=True)
class BandWater:
    """Water coefficients averaged over wavelength bands, each shape (n,)."""

    water: "Water"
    bands: Bands
    a: np.ndarray
    b: np.ndarray
    kd: np.ndarray

    @property
    def c(self) -> np.ndarray:
        """Extinction ``c = a + b`` in 1/m."""
        return self.a + self.b


@dataclass(frozen=True)
class Water:
    """Spectral a, b and Kd of a body of water, with provenance.

    Attributes
    ----------
    name : str
        Jerlov type (e.g. ``"IB"``) or the user's label.
    source : str
        ``solonenko2015``, ``williamson2022`` or ``csv:<path>``.
    wavelength_nm : ndarray (m,)
        Strictly ascending sample wavelengths.
    a, b, kd : ndarray (m,)
        Absorption, scattering and diffuse attenuation in 1/m, all finite.
    kd_derived : bool
        True when Kd was computed by :func:`derived_kd` rather than published.
    filled : tuple of str
        One line per value that was filled, naming quantity and wavelengths.
    notes : tuple of str
        Caveats of the source and of the data package.
    citation : str
    """

    name: str
    source: str
    wavelength_nm: np.ndarray
    a: np.ndarray
    b: np.ndarray
    kd: np.ndarray
    kd_derived: bool = False
    filled: tuple = ()
    notes: tuple = ()
    citation: str = ""

    def __post_init__(self):
        wl = np.asarray(self.wavelength_nm, dtype=float)
        for q in ("a", "b", "kd"):
            v = np.asarray(getattr(self, q), dtype=float)
            if v.shape != wl.shape:
                raise AquaspecError(f"water {self.name!r}: {q} has {v.size} values for "
                                    f"{wl.size} wavelengths")
            if not np.all(np.isfinite(v)):
                raise AquaspecError(f"water {self.name!r}: {q} contains NaN or infinity")
            if np.any(v < 0):
                i = int(np.argmax(v < 0))
                raise AquaspecError(f"water {self.name!r}: negative {q}={v[i]:g} at "
                                    f"{wl[i]:g} nm; coefficients must be >= 0 (1/m)")
            v.setflags(write=False)
            object.__setattr__(self, q, v)
        wl.setflags(write=False)
        object.__setattr__(self, "wavelength_nm", wl)
        if np.any(self.a + self.b <= 0):
            raise AquaspecError(f"water {self.name!r}: extinction a + b must be > 0 everywhere")

    @property
    def c(self) -> np.ndarray:
        return self.a + self.b

    @property
    def range_nm(self) -> tuple[float, float]:
        return float(self.wavelength_nm[0]), float(self.wavelength_nm[-1])

    def on_bands(self, bands: Bands) -> BandWater:
        """Band-averaged a, b, Kd; raises DataRangeError if the bands leave the data."""
        lo, hi = self.range_nm
        if bands.lo_nm < lo or bands.hi_nm > hi:
            raise DataRangeError(
                f"water {self.name!r} ({self.source}) covers {lo:g}-{hi:g} nm, but the bands "
                f"span {bands.lo_nm:g}-{bands.hi_nm:g} nm; choose a range inside {lo:g}-{hi:g} nm")
        vals = bands.average(self.wavelength_nm, np.stack([self.a, self.b, self.kd]),
                             name=f"water {self.name}")
        return BandWater(self, bands, vals[0], vals[1], vals[2])

    def describe(self) -> dict:
        return {"name": self.name, "source": self.source, "citation": self.citation,
                "kd_derived": self.kd_derived, "filled": list(self.filled),
                "range_nm": list(self.range_nm)}


def _fill_gaps(name, source, wl, a, b, kd):
    """Fill NaN a and Kd as the module docstring describes."""
    gap = np.isnan(a) | np.isnan(kd)
    if np.isnan(b).any():
        raise AquaspecError(f"Jerlov {name} ({source}): b is missing at "
                            f"{wl[np.isnan(b)].tolist()} nm and cannot be filled")
    good = np.flatnonzero(~gap)
    aw = np.asarray(jerlov.pure_water_absorption(wl), dtype=float)
    a, kd = a.copy(), kd.copy()
    for i in np.flatnonzero(gap):
        # The nearest published wavelength anchors the extrapolation.
        j = good[np.argmin(np.abs(good - i))]
        if np.isnan(a[i]):
            a_nw = max(a[j] - aw[j], 0.0)
            a[i] = aw[i] + a_nw * np.exp(-FILL_SLOPE_PER_NM * (wl[i] - wl[j]))
        if np.isnan(kd[i]):
            kd[i] = derived_kd(a[i], b[i]) * kd[j] / derived_kd(a[j], b[j])
    return a, kd


def load_water(name: str, source: str = DEFAULT_SOURCE) -> Water:
    """A Jerlov water type from a published source.

    Parameters
    ----------
    name : str
        One of I, IA, IB, II, III, 1C, 3C, 5C, 7C, 9C (case-insensitive;
        ``williamson2022`` has only IB, II, III, 1C, 3C, 5C).
    source : str
        ``solonenko2015`` (default) or ``williamson2022``.

    Warns
    -----
    WaterDataWarning
        When published values are missing and have been filled.
    """
    if source not in SOURCES:
        raise AquaspecError(f"unknown water source {source!r}; known: {', '.join(SOURCES)}")
    src = jerlov.get_source(source)
    key = str(name).strip().upper()
    if key not in src.water_types:
        raise AquaspecError(
            f"unknown water type {name!r} for source {source}; known: "
            f"{', '.join(src.water_types)}")
    with warnings.catch_warnings(record=True) as rec:
        warnings.simplefilter("always")
        w = jerlov.water(key, source=source)
        wl = np.asarray(w.wavelengths, dtype=float)
        a = np.asarray(w.a(wl), dtype=float)
        b = np.asarray(w.b(wl), dtype=float)
        kd = np.asarray(w.kd(wl), dtype=float) if w.has("Kd") else None
    notes = [str(r.message) for r in rec] + list(src.caveats)
    kd_derived = kd is None
    filled = []
    if kd_derived:
        missing_a = np.isnan(a)
        kd = np.full_like(a, np.nan)
    else:
        missing_a, missing_kd = np.isnan(a), np.isnan(kd)
    a_f, kd_f = a, kd
    if not kd_derived and (missing_a.any() or missing_kd.any()):
        a_f, kd_f = _fill_gaps(key, source, wl, a, b, kd)
        for q, miss in (("a", missing_a), ("Kd", missing_kd)):
            if miss.any():
                where = ", ".join(f"{x:g}" for x in wl[miss])
                rule = ("pure-water absorption + non-water part decaying with slope "
                        f"{FILL_SLOPE_PER_NM}/nm" if q == "a" else
                        "Kirk (1991) derived Kd scaled to the last published value")
                msg = (f"Jerlov {key} ({source}): {q} is missing in the published table at "
                       f"{where} nm; filled by {rule}")
                filled.append(msg)
                warnings.warn(msg, WaterDataWarning, stacklevel=2)
    elif missing_a.any():
        where = ", ".join(f"{x:g}" for x in wl[missing_a])
        raise AquaspecError(f"Jerlov {key} ({source}): a is missing at {where} nm")
    if kd_derived:
        kd_f = derived_kd(a_f, b)
        notes.append("Kd is derived from a and b by Kirk (1991) with mu0 = "
                     f"{DERIVED_KD_MU0}; it is not a published value")
    return Water(name=key, source=source, wavelength_nm=wl, a=a_f, b=b, kd=kd_f,
                 kd_derived=kd_derived, filled=tuple(filled), notes=tuple(notes),
                 citation=src.citation + (f", doi:{src.doi}" if src.doi else ""))


def water_from_csv(path, name: str | None = None) -> Water:
    """User water spectra from a CSV with columns ``wavelength_nm,a,b[,Kd]`` (1/m).

    Without a Kd column, Kd is derived (:func:`derived_kd`) and marked so.
    """
    cols = read_csv_columns(path, ("wavelength_nm", "a", "b"), ("Kd",), what="water")
    for q in ("a", "b", "Kd"):
        if q in cols and np.any(cols[q] < 0):
            i = int(np.argmax(cols[q] < 0))
            raise AquaspecError(f"{path}: negative {q}={cols[q][i]:g} at "
                                f"{cols['wavelength_nm'][i]:g} nm; coefficients must be >= 0 (1/m)")
    derived = "Kd" not in cols
    kd = derived_kd(cols["a"], cols["b"]) if derived else cols["Kd"]
    return Water(name=name or Path(path).stem, source=f"csv:{path}",
                 wavelength_nm=cols["wavelength_nm"], a=cols["a"], b=cols["b"], kd=kd,
                 kd_derived=derived, citation="user measurement")


def get_water(spec: str, source: str = DEFAULT_SOURCE) -> Water:
    """A water from a Jerlov type name or, if ``spec`` ends in .csv, a CSV path."""
    if str(spec).lower().endswith(".csv"):
        return water_from_csv(spec)
    return load_water(spec, source)


def list_waters() -> list[tuple[str, str]]:
    """``(source, type)`` pairs of every built-in water."""
    return [(s, t) for s in SOURCES for t in jerlov.get_source(s).water_types]
