"""The sun under water: its direction, its refracted beam and the beam's light on surfaces.

Conventions (as everywhere in aquaspec): metres, y up, the water surface is
y = 0, depth ``d = -p.y``; coefficients in 1/m; wavelengths in nm.

Geometry
--------
The sun stands at ``elevation_deg`` above the horizon (in air) and at
``azimuth_deg``, a compass angle measured in the horizontal plane from the
``-z`` axis (the built-in camera's view direction: azimuth 0 puts the sun in
front of that camera, 180 behind it) towards ``+x``. The direction towards
the sun in air is ``(cos e sin az, sin e, -cos e cos az)``. Through a flat
surface (Snell, :func:`aquaspec.medium.interface.refract`, ``n = 1.33``) the
beam's zenith angle under water is ``theta_w`` with ``sin theta_w = cos e / n``;
``mu0 = cos theta_w`` (>= 0.66: the beam is never flatter than the edge of
Snell's window). :attr:`Sun.to_sun` is the unit vector towards the sun under
water, :attr:`Sun.direction` the way the light travels (``-to_sun``).

Beam
----
``beam_normal(lambda)`` is the beam's irradiance on a plane normal to it just
below the surface, W m^-2 nm^-1: the direct normal irradiance in air times
``cos z`` (the horizontal irradiance), the Fresnel transmittance at ``z``,
divided by ``mu0`` (the refracted beam is narrower). Its horizontal
irradiance just below the surface is ``mu0 * beam_normal``, the share of the
light's ``E0`` that the sun brings.

At a point at depth ``d`` the beam's normal irradiance is
``E_b(d) = beam_normal * exp(-c_sun d / mu0)`` (:func:`beam_irradiance`): the
path from the surface is ``d / mu0``. ``c_sun`` is the extinction of the
beam; with the light-field model it is that model's delta-M ``c* = c - f b``
(light scattered into the phase function's narrowest forward peak stays in
the beam, as in the discrete-ordinates solution whose diffuse field
complements it); with the thesis's model (``monzon2022``) it is ``c``. A
Lambertian surface of normal ``n`` gets ``E_b(d) max(0, n . to_sun) V``
(:func:`surface_irradiance`; ``V`` = 1 where the surface sees the sun, 0 in
a shadow, times the caustic factor under waves).

Elsewhere: the beam's single scattering in the water is
:mod:`aquaspec.transport.sun_scattering` (with its froxels,
:mod:`aquaspec.transport.froxels`), its shadows :mod:`aquaspec.scene.shadowmap`,
its caustics :mod:`aquaspec.light.caustics`, and the sun's terms of a
G-buffer :mod:`aquaspec.shading.sun`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import FLAT_NORMAL, N_WATER, refract


def check_elevation(elevation_deg) -> float:
    e = float(elevation_deg)
    if not (np.isfinite(e) and 1.0 <= e <= 90.0):
        raise AquaspecError(f"sun elevation {elevation_deg!r} deg; accepted: 1 to 90")
    return e


def check_azimuth(azimuth_deg) -> float:
    az = float(azimuth_deg)
    if not np.isfinite(az):
        raise AquaspecError(f"sun azimuth {azimuth_deg!r} deg; accepted: a finite angle "
                            "(0 = towards -z, 90 = towards +x)")
    return az % 360.0


def air_to_sun(elevation_deg, azimuth_deg) -> np.ndarray:
    """Unit vector towards the sun in air."""
    e, az = np.radians(elevation_deg), np.radians(azimuth_deg)
    return np.array([np.cos(e) * np.sin(az), np.sin(e), -np.cos(e) * np.cos(az)])


def refracted_to_sun(elevation_deg, azimuth_deg, n_water: float = N_WATER) -> np.ndarray:
    """Unit vector towards the sun under a flat surface: its ray in air refracted
    (:func:`aquaspec.medium.interface.refract`), reversed."""
    return -refract(-air_to_sun(elevation_deg, azimuth_deg), FLAT_NORMAL, n_water)[0]


@dataclass(frozen=True)
class Sun:
    """The sun's beam under a flat water surface.

    Attributes
    ----------
    elevation_deg, azimuth_deg : float
        In air (see the module docstring for the azimuth's convention).
    wavelength_nm, beam_normal : ndarray
        The beam's irradiance normal to it just below the surface,
        W m^-2 nm^-1.
    n_water : float
    """

    elevation_deg: float
    azimuth_deg: float
    wavelength_nm: np.ndarray
    beam_normal: np.ndarray
    n_water: float = N_WATER

    def __post_init__(self):
        object.__setattr__(self, "elevation_deg", check_elevation(self.elevation_deg))
        object.__setattr__(self, "azimuth_deg", check_azimuth(self.azimuth_deg))
        wl = np.asarray(self.wavelength_nm, dtype=float)
        val = np.asarray(self.beam_normal, dtype=float)
        if wl.shape != val.shape or wl.ndim != 1 or wl.size < 2 or not np.all(np.diff(wl) > 0):
            raise AquaspecError("the sun's spectrum needs increasing wavelengths and one "
                                "value per wavelength")
        if not np.all(np.isfinite(val)) or np.any(val < 0):
            raise AquaspecError("the sun's beam irradiance must be finite and >= 0")
        object.__setattr__(self, "wavelength_nm", wl)
        object.__setattr__(self, "beam_normal", val)

    @property
    def to_sun(self) -> np.ndarray:
        """Unit vector towards the sun under water (y > 0)."""
        return refracted_to_sun(self.elevation_deg, self.azimuth_deg, self.n_water)

    @property
    def direction(self) -> np.ndarray:
        """The way the beam travels under water (y < 0)."""
        return -self.to_sun

    @property
    def mu0(self) -> float:
        """Cosine of the beam's zenith angle under water."""
        return float(self.to_sun[1])

    def beam_on(self, bands: Bands) -> np.ndarray:
        """The beam's normal irradiance just below the surface, per band."""
        return bands.average(self.wavelength_nm, self.beam_normal, name="sun beam")

    def scaled(self, factor: float) -> "Sun":
        return Sun(self.elevation_deg, self.azimuth_deg, self.wavelength_nm,
                   self.beam_normal * float(factor), self.n_water)

    def describe(self) -> dict:
        return {"elevation_deg": self.elevation_deg, "azimuth_deg": self.azimuth_deg,
                "underwater_zenith_deg": float(np.degrees(np.arccos(self.mu0))),
                "to_sun_underwater": self.to_sun.tolist(),
                "beam_normal_w_m2_400_700": float(
                    Bands(1, 400.0, 700.0).average(self.wavelength_nm, self.beam_normal)[0]
                    * 300.0)}


def beam_irradiance(beam0, c_sun, depth_m, mu0):
    """``E_b(d) = beam0 exp(-c_sun d / mu0)``; per-point arrays need a trailing band axis."""
    return np.asarray(beam0) * np.exp(-np.asarray(c_sun) * np.maximum(depth_m, 0.0) / mu0)


def surface_irradiance(beam0, c_sun, depth_m, normal, to_sun, visible=1.0):
    """Sun irradiance on surfaces: ``E_b(d) max(0, n . to_sun) V``, shape ``(..., n_bands)``.

    ``depth_m`` (...), ``normal`` (..., 3), ``visible`` (...) broadcast.
    """
    to_sun = np.asarray(to_sun, dtype=float)
    cos_n = np.maximum(np.asarray(normal, dtype=float) @ to_sun, 0.0)
    d = np.asarray(depth_m, dtype=float)
    return beam_irradiance(beam0, c_sun, d[..., None], to_sun[1]) \
        * (cos_n * np.asarray(visible, dtype=float))[..., None]
