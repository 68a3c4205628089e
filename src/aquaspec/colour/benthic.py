"""Reflectances of seabed materials for the detailed built-in scene, with provenance.

Each entry is a :class:`~aquaspec.colour.reflectance.Reflectance` whose
``source`` says where its numbers come from. Measured where a spectrum was
available to this project with a clear citation and licence; otherwise the
Jakob-Hanika upsampling of a linear RGB albedo, and the ``source`` says so.

- **Seagrass / algae blades**: CIE test colour sample 14, "leaf green", a
  measured reflectance of a green leaf (CIE 13.3-1995, *Method of measuring
  and specifying colour rendering properties of light sources*), as
  tabulated by colour-science 0.4.7 (``colour.quality.datasets.tcs``,
  ``SDS_TCS_CIE1995["TCS14"]``), here every 10 nm from 380 to 780 nm
  (``tests/colour/test_benthic.py`` compares the table with colour-science's).
  A terrestrial leaf: the chlorophyll absorption (a minimum near 670 nm and
  the peak near 550 nm) that seagrass shares, not a seagrass measurement.
- **Sand, rock, coral, fouling growth, rust**: RGB upsampling. In-water
  spectra of sand, coral, crustose coralline algae and macroalgae exist as
  data (e.g. the WaterQuality package of Koenig et al. 2023, ``data/R_b.txt``,
  averages of 24-751 ASD measurements), but under a modified CC BY-SA 4.0
  licence with a patent clause, which was not cleared for this project; they
  are not copied. The RGB triples are linear sRGB albedos chosen by eye for
  wet materials (as the classic scene's), so these spectra are smooth and
  carry no absorption features.
"""

from __future__ import annotations

import functools

import numpy as np

from aquaspec.colour.reflectance import Reflectance
from aquaspec.errors import AquaspecError

#: CIE 13.3-1995 TCS 14 (leaf green), 380-780 nm every 10 nm, via colour-science 0.4.7.
TCS14_WAVELENGTH_NM = np.arange(380.0, 781.0, 10.0)
TCS14_VALUES = np.array([
    0.036, 0.037, 0.039, 0.040, 0.042, 0.043, 0.044, 0.045, 0.047, 0.050, 0.055,
    0.062, 0.075, 0.092, 0.108, 0.133, 0.150, 0.155, 0.147, 0.133, 0.118, 0.106,
    0.098, 0.093, 0.089, 0.086, 0.084, 0.084, 0.085, 0.092, 0.102, 0.123, 0.152,
    0.188, 0.226, 0.260, 0.294, 0.325, 0.353, 0.379, 0.399])

#: Linear sRGB albedos (by eye, wet materials) of the upsampled materials.
RGB_ALBEDOS = {
    "sand": (0.42, 0.36, 0.22),
    "rock": (0.19, 0.16, 0.12),
    "rock crevice": (0.07, 0.06, 0.045),
    "coral": (0.36, 0.24, 0.14),
    "fouling": (0.30, 0.26, 0.16),
    "rust": (0.30, 0.12, 0.05),
    "concrete": (0.36, 0.35, 0.32),
}


@functools.lru_cache(maxsize=None)
def benthic_reflectance(name: str) -> Reflectance:
    """The reflectance of ``name``: ``"seagrass"`` or a key of :data:`RGB_ALBEDOS`."""
    if name == "seagrass":
        return Reflectance("seagrass (leaf green, CIE TCS 14)", TCS14_WAVELENGTH_NM,
                           TCS14_VALUES,
                           source="measured: CIE 13.3-1995 TCS 14 leaf green (colour-science)")
    if name not in RGB_ALBEDOS:
        raise AquaspecError(f"unknown benthic material {name!r}; accepted: seagrass, "
                            f"{', '.join(RGB_ALBEDOS)}")
    return Reflectance.from_rgb(RGB_ALBEDOS[name], name=name)


def provenance() -> dict:
    """Material name -> where its spectrum comes from (for a scene's metadata)."""
    return {name: benthic_reflectance(name).source for name in ("seagrass", *RGB_ALBEDOS)}
