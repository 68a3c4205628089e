"""Refractive indices of the media a camera port's rays cross: seawater and glass.

Wavelengths are vacuum wavelengths in nm; indices are relative to air
(taken as 1, its 400-700 nm dispersion, about 3e-6, neglected).

- Seawater: the empirical formula of Quan & Fry (1995) [1]_, fitted to the
  measurements of Austin & Halikas (1976) over 400-700 nm, 0-30 degC and
  0-35 per mille salinity (accuracy about 3e-5 there)::

      n(S, T, lambda) = n0 + (n1 + n2 T + n3 T^2) S + n4 T^2
                        + (n5 + n6 S + n7 T) / lambda + n8 / lambda^2 + n9 / lambda^3

  with lambda in nm, T in degC, S in per mille (g/kg).
- Glass: the Sellmeier equation
  ``n^2 = 1 + sum_k B_k L^2 / (L^2 - C_k)`` (L in um) with the
  manufacturer's coefficients: Schott N-BK7 [2]_ and fused silica
  (Malitson 1965) [3]_; choose one by name through :data:`GLASSES` /
  :func:`get_glass` (the ``method=`` habit of the package).

References
----------
.. [1] X. Quan, E. S. Fry, "Empirical equation for the index of refraction of
   seawater", Applied Optics 34(18), 3477-3480 (1995), doi:10.1364/AO.34.003477.
.. [2] SCHOTT optical glass data sheet N-BK7 (Sellmeier coefficients B1-3, C1-3).
.. [3] I. H. Malitson, "Interspecimen comparison of the refractive index of fused
   silica", JOSA 55(10), 1205-1209 (1965), doi:10.1364/JOSA.55.001205.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError

#: Quan & Fry (1995) coefficients n0 ... n9.
_QUAN_FRY = (1.31405, 1.779e-4, -1.05e-6, 1.6e-8, -2.02e-6, 15.868, 0.01155, -0.00423,
             -4382.0, 1.1455e6)
#: Seawater defaults: 35 per mille, 20 degC (open ocean, temperate).
DEFAULT_SALINITY = 35.0
DEFAULT_TEMPERATURE_C = 20.0


def _check_wavelengths(wavelength_nm) -> np.ndarray:
    wl = np.asarray(wavelength_nm, dtype=float)
    if not np.all(np.isfinite(wl)) or np.any(wl < 300.0) or np.any(wl > 1100.0):
        raise AquaspecError(f"wavelength {wavelength_nm!r} nm; accepted: 300 to 1100 nm "
                            "(the dispersion formulas' range of use)")
    return wl


def water_index_QuanFry1995(wavelength_nm, salinity: float = DEFAULT_SALINITY,
                            temperature_c: float = DEFAULT_TEMPERATURE_C) -> np.ndarray:
    """Refractive index of seawater at ``wavelength_nm`` (Quan & Fry 1995).

    Parameters
    ----------
    wavelength_nm : array_like
        Vacuum wavelengths, nm (fitted over 400-700 nm).
    salinity : float
        Per mille (g/kg), 0 (fresh water) to 35 (accepted 0 to 45).
    temperature_c : float
        Degrees Celsius, 0 to 30 (accepted -2 to 40).

    Examples
    --------
    >>> round(float(water_index_QuanFry1995(589.3)), 4)
    1.3394
    """
    wl = _check_wavelengths(wavelength_nm)
    if not 0.0 <= salinity <= 45.0:
        raise AquaspecError(f"salinity {salinity!r} per mille; accepted: 0 to 45")
    if not -2.0 <= temperature_c <= 40.0:
        raise AquaspecError(f"water temperature {temperature_c!r} degC; accepted: -2 to 40")
    n0, n1, n2, n3, n4, n5, n6, n7, n8, n9 = _QUAN_FRY
    s, t = float(salinity), float(temperature_c)
    return (n0 + (n1 + n2 * t + n3 * t * t) * s + n4 * t * t
            + (n5 + n6 * s + n7 * t) / wl + n8 / wl ** 2 + n9 / wl ** 3)


@dataclass(frozen=True)
class Glass:
    """A glass by its Sellmeier coefficients (B dimensionless, C in um^2)."""

    name: str
    b: tuple[float, float, float]
    c_um2: tuple[float, float, float]
    source: str

    def index(self, wavelength_nm) -> np.ndarray:
        """Refractive index at ``wavelength_nm`` (vacuum, nm)."""
        l2 = (_check_wavelengths(wavelength_nm) * 1e-3) ** 2
        n2 = 1.0 + sum(b * l2 / (l2 - c) for b, c in zip(self.b, self.c_um2))
        return np.sqrt(n2)

    def describe(self) -> dict:
        return {"name": self.name, "sellmeier_b": list(self.b),
                "sellmeier_c_um2": list(self.c_um2), "source": self.source}


#: Port glasses by name.
GLASSES = {
    "bk7": Glass("bk7", (1.03961212, 0.231792344, 1.01046945),
                 (0.00600069867, 0.0200179144, 103.560653), "SCHOTT N-BK7 data sheet"),
    "fused-silica": Glass("fused-silica", (0.6961663, 0.4079426, 0.8974794),
                          (0.0684043 ** 2, 0.1162414 ** 2, 9.896161 ** 2),
                          "Malitson 1965, JOSA 55, 1205"),
}


def get_glass(name) -> Glass:
    """The :class:`Glass` called ``name`` (or ``name`` itself if it is one)."""
    if isinstance(name, Glass):
        return name
    try:
        return GLASSES[str(name).lower()]
    except KeyError:
        raise AquaspecError(f"port glass {name!r} is unknown; accepted: "
                            f"{', '.join(GLASSES)}") from None
