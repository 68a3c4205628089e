"""The dome port: a hemisphere of glass centred on the camera's entrance pupil.

Every chief ray leaves the pupil along a radius of the dome and crosses
both glass surfaces at normal incidence, so it goes on undeviated: the
camera keeps its field of view in air, with no distortion and no lateral
chromatic aberration (a dome is concentric only if the pupil sits at its
centre; a misplaced pupil is not modelled). What a dome does change is
focus: the water-glass-air surfaces form a thick negative meniscus lens,
and the lens sees a *virtual image* of the scene close in front of the
dome.

Paraxially about each chief ray (Hecht, *Optics*, 5th ed., Sec. 5.2:
``n1/s_o + n2/s_i = (n2 - n1)/R``, R > 0 with the centre of curvature on the
outgoing side, as both centres are here): an object at distance ``u`` from
the centre is imaged by the outer surface (radius ``R_o``, water -> glass)
and then by the inner one (``R_i = R_o - thickness``, glass -> air). For a
thin dome and ``u`` -> infinity the virtual image lies ``R n_w / (n_w - 1)``,
about 4 R, from the centre (3 R in front of the dome); a real object at
``u`` appears at ``v(u) < u``, and the camera has to focus on ``v``.

Indices: :mod:`aquaspec.optics.dispersion` (the focus shift is evaluated at
one wavelength, its spread over 400-700 nm is a few tenths of a percent of
``v``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import fresnel_transmittance
from aquaspec.optics.dispersion import (DEFAULT_SALINITY, DEFAULT_TEMPERATURE_C, Glass,
                                        get_glass, water_index_QuanFry1995)


@dataclass(frozen=True)
class DomePort:
    """A concentric spherical dome.

    Parameters
    ----------
    radius_m : float
        Outer radius, m (0.02 to 1).
    thickness_m : float
        Glass thickness, m (0 to half the radius).
    glass : str or Glass
    salinity, temperature_c : float
    """

    radius_m: float = 0.05
    thickness_m: float = 0.005
    glass: Glass | str = "bk7"
    salinity: float = DEFAULT_SALINITY
    temperature_c: float = DEFAULT_TEMPERATURE_C

    kind = "dome"

    def __post_init__(self):
        r, t = self.radius_m, self.thickness_m
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not 0.02 <= r <= 1.0:
            raise AquaspecError(f"dome radius_m={r!r}; accepted: 0.02 to 1 m")
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0.0 <= t <= 0.5 * r:
            raise AquaspecError(f"dome thickness_m={t!r}; accepted: 0 to half the radius "
                                f"({0.5 * r:g} m)")
        object.__setattr__(self, "glass", get_glass(self.glass))
        water_index_QuanFry1995(550.0, self.salinity, self.temperature_c)

    def virtual_distance(self, distance_m, wavelength_nm: float = 550.0) -> np.ndarray:
        """Distance from the centre of the virtual image of a point ``distance_m``
        from the centre (beyond the dome), m; inf maps to the image of infinity."""
        u = np.asarray(distance_m, dtype=float)
        if np.any(u <= self.radius_m):
            raise AquaspecError(f"object distance {distance_m!r} m is inside the dome "
                                f"(radius {self.radius_m:g} m); accepted: beyond it")
        n_w = float(water_index_QuanFry1995(wavelength_nm, self.salinity, self.temperature_c))
        n_g = float(self.glass.index(wavelength_nm))
        r_o, r_i = self.radius_m, self.radius_m - self.thickness_m
        with np.errstate(divide="ignore"):
            inv_so1 = np.where(np.isfinite(u), 1.0 / (u - r_o), 0.0)
        s_i1 = n_g / ((n_g - n_w) / r_o - n_w * inv_so1)   # from the outer vertex
        s_o2 = self.thickness_m - s_i1                      # from the inner vertex
        s_i2 = 1.0 / ((1.0 - n_g) / r_i - n_g / s_o2)
        return r_i - s_i2

    def radiance_factor(self, wavelength_nm) -> np.ndarray:
        """Air-side radiance per unit of water radiance: ``T / n_w^2`` (the
        basic radiance ``L / n^2`` kept, as
        :meth:`aquaspec.optics.flat_port.FlatPort.radiance_factor`), with the
        two faces' Fresnel transmittance at normal incidence (every chief ray
        crosses the dome along a radius)."""
        n_w = water_index_QuanFry1995(wavelength_nm, self.salinity, self.temperature_c)
        n_g = self.glass.index(wavelength_nm)
        t = fresnel_transmittance(1.0, n_g) * fresnel_transmittance(1.0, n_g / n_w)
        return t / n_w ** 2

    def describe(self) -> dict:
        return {"kind": "dome", "radius_m": self.radius_m, "thickness_m": self.thickness_m,
                "glass": self.glass.describe(), "salinity": self.salinity,
                "temperature_c": self.temperature_c,
                "virtual_image_of_infinity_m": float(self.virtual_distance(np.inf)),
                "image": "concentric: no distortion; the lens focuses on the virtual image"}
