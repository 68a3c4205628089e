"""Sensors: three spectral response curves and their wavelength range.

A sensor maps band radiance to three values: ``RGB_c = sum_i w_i L_i R_c,i``
(thesis Eq. 4.8) with ``R_c,i`` the response averaged over band ``i`` and
``w_i`` the band width in nm (:meth:`Sensor.band_weights`).

Built in:

- ``human``: the CIE 1931 2-degree colour-matching functions (CIE 015:2018)
  followed by the XYZ to linear sRGB matrix (IEC 61966-2-1, D65 white), so
  the three values are linear sRGB of the radiance (Y normalised so that
  ``int ybar = 1`` per nm-weighted unit, i.e. no 683 lm/W factor).
- ``nikon5100-npl`` and ``sigma-sdmerrill-npl``: the two DSLRs measured by
  the UK National Physical Laboratory, as shipped by colour-science
  (``colour.MSDS_CAMERA_SENSITIVITIES``).

Loaders: plain CSV (``wavelength_nm,r,g,b``) and the camspec database format
of J. Jiang, D. Liu, J. Gu, S. Susstrunk, "What is the space of spectral
sensitivity functions for digital color cameras?", WACV 2013 (28 cameras,
400-720 nm in 10 nm steps; a header, then per camera a name line and three
lines R, G, B). That file may not be redistributed: aquaspec reads it from a
path the user gives.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from aquaspec.colour import data as colourdata
from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import colorchecker
from aquaspec.colour.srgb import XYZ_TO_SRGB
from aquaspec.errors import AquaspecError, DataRangeError
from aquaspec.io.csv import read_csv_columns
from aquaspec.io.limits import read_text

#: XYZ to the sharpened cone responses of CAT02, CIECAM02's chromatic
#: adaptation transform (CIE 159:2004; Moroney et al. 2002, "The CIECAM02
#: color appearance model", IS&T/SID CIC 10).
XYZ_TO_CAT02 = np.array([[0.7328, 0.4296, -0.1624],
                         [-0.7036, 1.6975, 0.0061],
                         [0.0030, 0.0136, 0.9834]])


@dataclass(frozen=True)
class Sensor:
    """Three response curves sampled at ``wavelength_nm``.

    Attributes
    ----------
    name : str
    wavelength_nm : ndarray (m,)
    response : ndarray (3, m)
        R, G, B responses (dimensionless; the human sensor's may be negative).
    source : str
        Where the curves came from.
    """

    name: str
    wavelength_nm: np.ndarray
    response: np.ndarray
    source: str = ""

    def __post_init__(self):
        wl = np.asarray(self.wavelength_nm, dtype=float)
        r = np.asarray(self.response, dtype=float)
        if r.shape != (3, wl.size):
            raise AquaspecError(f"sensor {self.name!r}: response must be 3 curves of "
                                f"{wl.size} values, got shape {r.shape}")
        if not np.all(np.isfinite(r)):
            raise AquaspecError(f"sensor {self.name!r}: response contains NaN or infinity")
        if wl.size < 2 or np.any(np.diff(wl) <= 0):
            raise AquaspecError(f"sensor {self.name!r}: wavelengths must strictly ascend")
        dead = [c for c, curve in zip("rgb", r) if not np.any(curve != 0)]
        if dead:
            where = f" ({self.source})" if self.source else ""
            raise AquaspecError(f"sensor {self.name!r}{where}: channel(s) {', '.join(dead)} "
                                "are zero at every wavelength; accepted: three response "
                                "curves, each non-zero somewhere")
        object.__setattr__(self, "wavelength_nm", wl)
        object.__setattr__(self, "response", r)

    @property
    def range_nm(self) -> tuple[float, float]:
        return float(self.wavelength_nm[0]), float(self.wavelength_nm[-1])

    def on_bands(self, bands: Bands, *, outside: str = "error") -> np.ndarray:
        """Band-averaged responses, shape (n, 3).

        ``outside="error"`` raises when a band lies outside the sensor's
        range; ``"zero"`` takes the response as zero there.
        """
        lo, hi = self.range_nm
        if outside == "error" and (bands.lo_nm < lo or bands.hi_nm > hi):
            raise DataRangeError(
                f"sensor {self.name!r} covers {lo:g}-{hi:g} nm, but the bands span "
                f"{bands.lo_nm:g}-{bands.hi_nm:g} nm; choose a range inside {lo:g}-{hi:g} nm "
                "or ask for zero response outside it (--outside-zero)")
        return bands.average(self.wavelength_nm, self.response,
                             name=f"sensor {self.name}", outside=outside).T

    def band_weights(self, bands: Bands, *, outside: str = "error") -> np.ndarray:
        """``w_i R_c,i``, shape (n, 3): band radiance @ weights = camera RGB."""
        return self.on_bands(bands, outside=outside) * bands.width_nm

    def describe(self) -> dict:
        return {"name": self.name, "source": self.source, "range_nm": list(self.range_nm)}

    def srgb_matrix(self) -> np.ndarray:
        """3x3 matrix from this sensor's RGB to linear sRGB, fitted on the ColorChecker.

        As a camera pipeline (or pbrt-v4's ``PixelSensor``) does: the 24
        ColorChecker patches under D65 are seen by this sensor and by the
        CIE 1931 observer (-> linear sRGB); ``M`` minimises the squared
        error of ``M @ rgb_sensor`` against the sRGB values, then is scaled
        so the white patch keeps its mean level. Fitted over 400-700 nm (or
        the sensor's range inside it). The human sensor gets the identity.
        """
        if self.name == "human":
            return np.eye(3)
        return _fit_srgb_matrix(self)

    def cone_matrix(self) -> np.ndarray | None:
        """3x3 matrix from this sensor's RGB to cone responses (CAT02) where
        its RGB is colorimetric (the human sensor's linear sRGB), else None:
        a camera's white balance scales its own channels, an eye's adaptation
        its cones' (:func:`aquaspec.colour.display.von_kries`)."""
        if self.name == "human":
            return XYZ_TO_CAT02 @ np.linalg.inv(XYZ_TO_SRGB)
        return None


def radiance_to_rgb(radiance, response_weights):
    """Camera RGB from band radiance: ``RGB_c = sum_i w_i L_i R_c,i``.

    ``radiance`` has the band axis last, shape (..., n); ``response_weights``
    is (n, 3), the band-averaged response curves times the band width (see
    :meth:`Sensor.band_weights`).
    """
    return np.asarray(radiance, dtype=float) @ np.asarray(response_weights, dtype=float)


def _fit_srgb_matrix(sensor: Sensor) -> np.ndarray:
    lo, hi = max(400.0, sensor.range_nm[0]), min(700.0, sensor.range_nm[1])
    bands = Bands(int(round(hi - lo)), lo, hi)
    e = bands.average(*colourdata.d65())
    refl = np.stack([r.on_bands(bands) for r in colorchecker()])        # (24, n)
    cam = (refl * e) @ sensor.band_weights(bands)                         # (24, 3)
    blind = [c for c, col in zip("rgb", cam.T) if not np.any(col != 0)]
    if blind:
        raise AquaspecError(f"sensor {sensor.name!r}: channel(s) {', '.join(blind)} see "
                            f"nothing over {lo:g}-{hi:g} nm, where the colour matrix is "
                            "fitted on the ColorChecker; accepted: a response there in each "
                            "channel, or no colour matrix (--colour-matrix none)")
    ref = (refl * e) @ human_sensor().band_weights(bands)
    m, *_ = np.linalg.lstsq(cam, ref, rcond=None)
    m = m.T
    # Keep the white patch's level: scale so M maps its camera RGB to the
    # same mean as its sRGB.
    white = 18
    m *= ref[white].mean() / (m @ cam[white]).mean()
    return m


def _slug(name: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", name.lower()).strip("-")


def human_sensor() -> Sensor:
    """CIE 1931 2-degree observer followed by XYZ -> linear sRGB."""
    wl, cmfs = colourdata.cmfs_1931()
    return Sensor("human", wl, XYZ_TO_SRGB @ cmfs.T,
                  source="CIE 1931 2-degree observer (colour-science) -> linear sRGB "
                         "(IEC 61966-2-1)")


def _npl_sensors() -> dict:
    out = {}
    for key, (wl, rgb) in colourdata.camera_sensitivities().items():
        out[_slug(key)] = Sensor(_slug(key), wl, rgb.T,
                                 source=f"{key}, colour-science MSDS_CAMERA_SENSITIVITIES")
    return out


def builtin_sensors() -> dict:
    """Name -> Sensor for the built-in sensors."""
    return {"human": human_sensor(), **_npl_sensors()}


_HEADER_RANGE = re.compile(r"(\d+(?:\.\d+)?)\s*nm\s*-\s*(\d+(?:\.\d+)?)\s*nm\s*,\s*step\s*"
                           r"(\d+(?:\.\d+)?)\s*nm", re.IGNORECASE)


def _numeric(line: str):
    parts = line.split()
    if not parts:
        return None
    try:
        return [float(p) for p in parts]
    except ValueError:
        return None


def load_camspec(path) -> dict:
    """Cameras from a file in the camspec database format (Jiang et al. 2013).

    Returns name -> Sensor. The header line ``400nm-720nm, step 10nm`` gives
    the wavelengths when present (otherwise 400-720 nm in 10 nm steps).

    Raises
    ------
    AquaspecError
        A missing, binary or oversized file (:func:`aquaspec.io.limits.read_text`),
        no camera in it, a response line of the wrong length, or a camera
        cut short (a name followed by fewer than three response lines: a
        truncated file, refused rather than losing that camera unnoticed).
    """
    p = Path(path)
    lines = read_text(p, "camspec", "camspec file", errors="replace").splitlines()
    lo, hi, step = 400.0, 720.0, 10.0
    for line in lines[:10]:
        m = _HEADER_RANGE.search(line)
        if m:
            lo, hi, step = (float(g) for g in m.groups())
            break
    wl = np.arange(lo, hi + step / 2, step)
    cams, i = {}, 0
    while i < len(lines):
        line = lines[i].strip()
        if not line or _numeric(line) is not None:
            i += 1
            continue
        rows = [_numeric(lines[i + k]) if i + k < len(lines) else None for k in (1, 2, 3)]
        if rows[0] is not None and None in rows:
            got = rows.index(None)
            end = "the end of the file" if i + got + 1 >= len(lines) else f"line {i + got + 2}"
            raise AquaspecError(
                f"{path}: camera {line!r} (line {i + 1}) has {got} of its 3 response lines "
                f"(R, G, B) before {end}; is the file truncated? Expected the camspec format "
                "(Jiang et al. 2013): a name line followed by three lines of numbers")
        if all(r is not None for r in rows):
            for k, r in enumerate(rows):
                if len(r) != wl.size:
                    raise AquaspecError(
                        f"{path}: camera {line!r}, line {i + k + 2}: {len(r)} values, expected "
                        f"{wl.size} ({lo:g}-{hi:g} nm in {step:g} nm steps)")
            cams[line] = Sensor(line, wl, np.array(rows), source=f"camspec file {p.name}")
            i += 4
        else:
            i += 1
    if not cams:
        raise AquaspecError(
            f"{path}: no cameras found; expected the camspec format (Jiang et al. 2013): a "
            "header, then for each camera a name line followed by three lines of numbers (R, G, B)")
    return cams


def sensor_from_csv(path, name: str | None = None) -> Sensor:
    """A sensor from a CSV with columns ``wavelength_nm,r,g,b``."""
    cols = read_csv_columns(path, ("wavelength_nm", "r", "g", "b"), what="sensor")
    return Sensor(name or Path(path).stem, cols["wavelength_nm"],
                  np.stack([cols["r"], cols["g"], cols["b"]]), source=f"csv:{path}")


def _match_key(name: str) -> str:
    return re.sub(r"[^a-z0-9]", "", name.lower())


def list_sensors(camspec=None) -> list[str]:
    names = list(builtin_sensors())
    if camspec:
        names += list(load_camspec(camspec))
    return names


def get_sensor(name: str = "human", camspec=None) -> Sensor:
    """A sensor by name: built-in, a camera of ``camspec``, or a CSV path.

    Camera names match case-insensitively, ignoring spaces and punctuation
    (``"Canon 5DMarkII"`` = ``canon-5d-mark-ii``).
    """
    if str(name).lower().endswith(".csv"):
        return sensor_from_csv(name)
    builtin = builtin_sensors()
    key = _match_key(str(name))
    by_key = {_match_key(k): v for k, v in builtin.items()}
    if key in by_key:
        return by_key[key]
    known = list(builtin)
    if camspec:
        cams = load_camspec(camspec)
        by_key = {_match_key(k): v for k, v in cams.items()}
        if key in by_key:
            return by_key[key]
        known += list(cams)
    hint = "" if camspec else " (give --camspec PATH to use the cameras of a camspec file)"
    raise AquaspecError(f"unknown sensor {name!r}; known: {', '.join(known)}{hint}")
