"""The colour-science datasets aquaspec uses, kept as plain arrays.

``import colour`` takes 1.2-1.5 s (colour-science 0.4.7 imports its plotting
module, hence matplotlib, pandas and much of SciPy), longer than the rest of a
one-image render's start. aquaspec needs only a few datasets from it, all
wavelength tables:

- ``MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]`` (CIE 015:2018),
- ``SDS_ILLUMINANTS["D65"]`` (CIE 015:2018),
- ``SDS_COLOURCHECKERS["BabelColor Average"]`` (BabelColor, Pascale 2012),
- ``MSDS_CAMERA_SENSITIVITIES`` (two DSLRs measured by Darrodi et al. 2015),
- ``SDS_ILLUMINANTS`` ``"LED-B4"`` and ``"HP5"`` (CIE 015:2018: a phosphor-converted
  white LED, 5111 K, and a metal-halide high-pressure lamp, 4050 K), the
  lamps' spectra of :mod:`aquaspec.light.lamp`.

The first call imports colour-science once, copies those tables into a
``.npz`` file in the user's cache (named by the installed colour-science
version, so an upgrade rebuilds it; written to a temporary file, then
renamed; :mod:`aquaspec.cache`) and later processes read that file instead.
Nothing is shipped: the file is made on the user's machine from the installed
package. Set ``AQUASPEC_CACHE`` to move the cache or to ``off`` to always
import colour-science; an unwritable cache only costs the import.
"""

from __future__ import annotations

import functools

import numpy as np

from aquaspec.cache import cached_arrays, package_version

CMFS_NAME = "CIE 1931 2 Degree Standard Observer"
CHECKER_NAME = "BabelColor Average"
# Bumped when the file's layout changes.
_LAYOUT = 2
#: CIE 015:2018 illuminants kept for the lamps (:func:`cie_illuminant`).
LAMP_ILLUMINANTS = ("LED-B4", "HP5")


def _from_colour() -> dict:
    """The datasets from colour-science, flattened to named arrays."""
    import colour  # deferred: colour-science takes 1.2-1.5 s to import; only a cache miss needs it
    out = {}
    cmfs = colour.MSDS_CMFS[CMFS_NAME]
    out["cmfs/wl"] = np.asarray(cmfs.wavelengths, float)
    out["cmfs/values"] = np.asarray(cmfs.values, float)
    d65 = colour.SDS_ILLUMINANTS["D65"]
    out["d65/wl"] = np.asarray(d65.wavelengths, float)
    out["d65/values"] = np.asarray(d65.values, float)
    for name in LAMP_ILLUMINANTS:
        sd = colour.SDS_ILLUMINANTS[name]
        out[f"illuminant/{name}/wl"] = np.asarray(sd.wavelengths, float)
        out[f"illuminant/{name}/values"] = np.asarray(sd.values, float)
    sds = colour.SDS_COLOURCHECKERS[CHECKER_NAME]
    out["checker/names"] = np.array(list(sds.keys()))
    out["checker/wl"] = np.stack([np.asarray(sd.wavelengths, float) for sd in sds.values()])
    out["checker/values"] = np.stack([np.asarray(sd.values, float) for sd in sds.values()])
    keys = list(colour.MSDS_CAMERA_SENSITIVITIES)
    out["cameras/names"] = np.array(keys)
    for k, key in enumerate(keys):
        msds = colour.MSDS_CAMERA_SENSITIVITIES[key]
        out[f"cameras/{k}/wl"] = np.asarray(msds.wavelengths, float)
        out[f"cameras/{k}/values"] = np.asarray(msds.values, float)
    return out


@functools.lru_cache(maxsize=1)
def tables() -> dict:
    """All the datasets as ``name -> array`` (read from the cache when it is there).

    Shared between calls: the functions below hand out copies.
    """
    return cached_arrays("colour-science", f"{package_version('colour-science')}-v{_LAYOUT}",
                         _from_colour)


def cmfs_1931() -> tuple[np.ndarray, np.ndarray]:
    """CIE 1931 2-degree colour-matching functions: wavelengths (nm), ``(m, 3)`` x, y, z."""
    t = tables()
    return t["cmfs/wl"].copy(), t["cmfs/values"].copy()


def d65() -> tuple[np.ndarray, np.ndarray]:
    """CIE illuminant D65: wavelengths (nm), relative spectral power."""
    t = tables()
    return t["d65/wl"].copy(), t["d65/values"].copy()


def cie_illuminant(name: str) -> tuple[np.ndarray, np.ndarray]:
    """A CIE 015:2018 illuminant of :data:`LAMP_ILLUMINANTS`: wavelengths (nm), relative power."""
    t = tables()
    return t[f"illuminant/{name}/wl"].copy(), t[f"illuminant/{name}/values"].copy()


def colorchecker_spectra() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """The BabelColor average ColorChecker: ``(name, wavelengths nm, reflectance)`` in chart order."""
    t = tables()
    return [(str(name), t["checker/wl"][k].copy(), t["checker/values"][k].copy())
            for k, name in enumerate(t["checker/names"])]


def camera_sensitivities() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """colour-science's measured camera sensitivities: name -> (wavelengths nm, ``(m, 3)`` RGB)."""
    t = tables()
    return {str(name): (t[f"cameras/{k}/wl"].copy(), t[f"cameras/{k}/values"].copy())
            for k, name in enumerate(t["cameras/names"])}
