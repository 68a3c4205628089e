"""Light at the surface: E0(lambda), the downwelling irradiance just below it.

Four kinds (:data:`LIGHTS`), each but ``none`` scaled by a total irradiance:

- ``overcast``: an equal-energy spectrum, the thesis's validation setting
  (a uniform sky of constant spectral radiance).
- ``d65``: CIE standard illuminant D65 (CIE 015:2018, via colour-science).
- ``sun-sky``: direct sun plus diffuse sky on a horizontal plane from the
  SPECTRL2 clear-sky model (Bird & Riordan 1986, "Simple solar spectral model
  for direct and diffuse irradiance on horizontal and tilted planes at the
  earth's surface for cloudless atmospheres", J. Climate Appl. Meteor. 25,
  87-97), as implemented by pvlib, for a sun elevation; each part is then
  carried through the flat water surface with its Fresnel transmittance
  (unpolarised light, n = 1.33, :func:`aquaspec.medium.interface.fresnel_transmittance`):
  the sun's at its zenith angle, the sky's averaged over a uniform sky (0.934).
- ``none``: no daylight at all (the deep sea, night): ``E0 = 0``; the scene
  is lit by its lamps alone (:mod:`aquaspec.light.lamp`).

``total_w_m2`` is the irradiance integrated over 400-700 nm (W m^-2) after
scaling; by default 100 W m^-2 for ``overcast`` and ``d65``, and SPECTRL2's
own absolute level for ``sun-sky``.

``sun-sky`` also carries its sun (:attr:`SurfaceLight.sun`, an
:class:`aquaspec.light.sun.Sun` at ``sun_azimuth_deg``): the renderer lights
surfaces with the refracted beam, shadows it and scatters it once towards
the camera; :attr:`SurfaceLight.values` stays the whole ``E0``, sky and sun
(the sun's share is ``mu0 * beam_normal``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from aquaspec.colour import data as colourdata
from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light.sun import Sun, check_azimuth, check_elevation, refracted_to_sun
from aquaspec.medium.interface import fresnel_transmittance

LIGHTS = ("overcast", "d65", "sun-sky", "none")
DEFAULT_TOTAL_W_M2 = 100.0
#: Range over which ``total_w_m2`` is measured.
TOTAL_RANGE_NM = (400.0, 700.0)


@dataclass(frozen=True)
class SurfaceLight:
    """Spectral downwelling irradiance just below the surface, W m^-2 nm^-1."""

    name: str
    wavelength_nm: np.ndarray
    values: np.ndarray
    params: dict
    #: The direct sun (:class:`aquaspec.light.sun.Sun`), or None (sky only).
    sun: Sun | None = None

    def on_bands(self, bands: Bands) -> np.ndarray:
        """``E0`` per band: everything, sky and sun."""
        return bands.average(self.wavelength_nm, self.values, name=f"light {self.name}")

    def sun_horizontal_on(self, bands: Bands) -> np.ndarray:
        """The sun's share of ``E0`` per band (0 without a sun)."""
        if self.sun is None:
            return np.zeros(bands.n)
        return self.sun.mu0 * self.sun.beam_on(bands)

    def sun_horizontal_values(self) -> np.ndarray:
        """The sun's share of ``E0``, ``mu0 * beam_normal``, on :attr:`wavelength_nm`
        (0 without a sun, and outside the sun's spectrum)."""
        wl = np.asarray(self.wavelength_nm, dtype=float)
        if self.sun is None:
            return np.zeros_like(wl)
        sun = self.sun
        # (On the sun's own grid np.interp returns its values exactly.)
        return sun.mu0 * np.interp(wl, sun.wavelength_nm, sun.beam_normal, left=0.0, right=0.0)

    def sky_values(self) -> np.ndarray:
        """The diffuse sky's share of ``E0`` on :attr:`wavelength_nm` (clipped at 0)."""
        return np.maximum(np.asarray(self.values, dtype=float) - self.sun_horizontal_values(),
                          0.0)

    def sky_on(self, bands: Bands) -> np.ndarray:
        """The diffuse sky's share of ``E0`` per band."""
        return np.maximum(self.on_bands(bands) - self.sun_horizontal_on(bands), 0.0)

    def without_sun(self) -> "SurfaceLight":
        """The same ``E0`` with the sun's beam not rendered separately
        (the whole light taken as diffuse sky, as before the sun existed)."""
        return SurfaceLight(self.name, self.wavelength_nm, self.values,
                            {**self.params, "sun_rendered": False}, None)

    def total_w_m2(self, lo_nm=TOTAL_RANGE_NM[0], hi_nm=TOTAL_RANGE_NM[1]) -> float:
        return float(Bands(1, lo_nm, hi_nm).average(self.wavelength_nm, self.values)[0]
                     * (hi_nm - lo_nm))

    def describe(self) -> dict:
        out = {"name": self.name, "total_w_m2_400_700": self.total_w_m2(), **self.params}
        if self.sun is not None:
            out["sun"] = self.sun.describe()
        return out


#: Fresnel transmittance of a uniform sky into flat water (cosine-weighted mean of
#: :func:`aquaspec.medium.interface.fresnel_transmittance`).
SKY_TRANSMITTANCE = 0.934


def _sun_sky(elevation_deg, azimuth_deg):
    import pvlib  # deferred: pvlib (with pandas) takes about a second to import; only sun-sky needs it
    zen = 90.0 - elevation_deg
    airmass = float(pvlib.atmosphere.get_relative_airmass(zen))
    r = pvlib.spectrum.spectrl2(apparent_zenith=zen, aoi=zen, surface_tilt=0.0,
                                ground_albedo=0.1, surface_pressure=101325.0,
                                relative_airmass=airmass, precipitable_water=1.42,
                                ozone=0.344, aerosol_turbidity_500nm=0.1, dayofyear=172)
    wl = np.asarray(r["wavelength"], dtype=float)
    cos_z = np.cos(np.radians(zen))
    direct = np.ravel(r["dni"]) * cos_z * fresnel_transmittance(cos_z)
    diffuse = np.ravel(r["dhi"]) * SKY_TRANSMITTANCE
    mu0 = refracted_to_sun(elevation_deg, azimuth_deg)[1]
    sun = Sun(elevation_deg, azimuth_deg, wl, direct / mu0)
    return wl, direct + diffuse, {"sun_elevation_deg": elevation_deg,
                                  "sun_azimuth_deg": sun.azimuth_deg,
                                  "model": "SPECTRL2 (pvlib), Fresnel through a flat surface"}, sun


#: Default sun azimuth: behind the built-in camera's right shoulder.
DEFAULT_SUN_AZIMUTH_DEG = 150.0


def surface_light(kind: str = "overcast", *, total_w_m2: float | None = None,
                  sun_elevation_deg: float = 60.0,
                  sun_azimuth_deg: float = DEFAULT_SUN_AZIMUTH_DEG) -> SurfaceLight:
    """E0(lambda) just below the surface.

    Parameters
    ----------
    kind : {"overcast", "d65", "sun-sky", "none"}
    total_w_m2 : float, optional
        Irradiance over 400-700 nm after scaling, W m^-2 (> 0); not for ``none``.
    sun_elevation_deg : float
        For ``sun-sky``: elevation of the sun above the horizon, 1-90 deg.
    sun_azimuth_deg : float
        For ``sun-sky``: compass angle of the sun from ``-z`` towards ``+x``
        (:mod:`aquaspec.light.sun`; 0 in front of the built-in camera, 180 behind).
    """
    if kind not in LIGHTS:
        raise AquaspecError(f"unknown surface light {kind!r}; known: {', '.join(LIGHTS)}")
    if total_w_m2 is not None and not (np.isfinite(total_w_m2) and total_w_m2 > 0):
        raise AquaspecError(f"total irradiance {total_w_m2!r} W/m^2 must be a positive number")
    sun = None
    if kind == "none":
        if total_w_m2 is not None:
            raise AquaspecError(f"light 'none' has no daylight; total irradiance {total_w_m2!r} "
                                "W/m^2 is not accepted with it")
        return SurfaceLight(kind, np.array([300.0, 830.0]), np.zeros(2),
                            {"daylight": "none: lit by lamps alone"})
    if kind == "overcast":
        wl, val, params = np.array([300.0, 830.0]), np.ones(2), {}
    elif kind == "d65":
        wl, val = colourdata.d65()
        params = {}
    else:
        wl, val, params, sun = _sun_sky(check_elevation(sun_elevation_deg),
                                        check_azimuth(sun_azimuth_deg))
    light = SurfaceLight(kind, wl, val, params, sun)
    if total_w_m2 is None and kind != "sun-sky":
        total_w_m2 = DEFAULT_TOTAL_W_M2
    if total_w_m2 is not None:
        scale = total_w_m2 / light.total_w_m2()
        light = SurfaceLight(kind, wl, val * scale, params,
                             None if sun is None else sun.scaled(scale))
    return light


#: The CIE standard clear sky's relative radiance distribution (ISO 15469:2004 /
#: CIE S 011/E:2003, sky type 12, "CIE standard clear sky, low luminance
#: turbidity"): gradation ``phi(Z) = 1 + a exp(b / cos Z)`` over the zenith
#: angle Z and indicatrix ``f(chi) = 1 + c (exp(d chi) - exp(d pi / 2)) + e
#: cos^2 chi`` over the angle chi to the sun; ``(a, b, c, d, e)``.
CIE_CLEAR_SKY = (-1.0, -0.32, 10.0, -3.0, 0.45)


def _cie_clear(directions, to_sun) -> np.ndarray:
    """``phi(Z) f(chi)`` of :data:`CIE_CLEAR_SKY` along unit ``directions``
    (..., 3) (y up; directions at or below the horizon take the horizon's)."""
    a, b, c, d, e = CIE_CLEAR_SKY
    v = np.asarray(directions, dtype=float)
    mu = np.maximum(v[..., 1], 0.0)
    with np.errstate(divide="ignore", over="ignore", under="ignore"):
        gradation = 1.0 + a * np.exp(np.where(mu > 0, b / np.where(mu > 0, mu, 1.0), -np.inf))
    cos_chi = np.clip(v @ np.asarray(to_sun, dtype=float), -1.0, 1.0)
    chi = np.arccos(cos_chi)
    indicatrix = 1.0 + c * (np.exp(d * chi) - np.exp(d * np.pi / 2)) + e * cos_chi ** 2
    return gradation * indicatrix


def clear_sky_norm(to_sun, nodes: int = 256) -> float:
    """``pi / int phi f cos(Z) d omega`` for the sun towards ``to_sun``
    (:func:`_clear_sky_norm`, kept per sun: live frames ask every frame)."""
    return _clear_sky_norm(tuple(float(x) for x in np.asarray(to_sun, dtype=float)), int(nodes))


@functools.lru_cache(maxsize=16)
def _clear_sky_norm(to_sun: tuple, nodes: int) -> float:
    """``pi / int phi f cos(Z) d omega`` over the sky for the sun towards
    ``to_sun`` (unit, in air): the factor that makes :func:`clear_sky_shape`
    a shape of unit mean on a horizontal plane. Midpoint rule in
    ``cos Z`` and azimuth (``nodes`` x 2 ``nodes``), within 1e-4 of a rule
    twice as fine (tested)."""
    mu = (np.arange(nodes) + 0.5) / nodes
    az = (np.arange(2 * nodes) + 0.5) * np.pi / nodes
    s = np.sqrt(1.0 - mu ** 2)[:, None]
    dirs = np.stack([s * np.cos(az)[None, :], np.broadcast_to(mu[:, None], (nodes, 2 * nodes)),
                     s * np.sin(az)[None, :]], axis=-1)
    integral = float(np.sum(_cie_clear(dirs, to_sun) * mu[:, None])) * (1.0 / nodes) \
        * (np.pi / nodes)
    return np.pi / integral


def clear_sky_shape(directions, to_sun, norm: float | None = None) -> np.ndarray:
    """The clear sky's radiance along unit ``directions`` (..., 3) relative to
    a uniform sky of the same irradiance on a horizontal plane: ``L = E / pi
    * shape`` with ``int shape cos Z d omega = pi``. :data:`CIE_CLEAR_SKY`'s
    distribution for the sun towards ``to_sun`` (unit, in air), scaled by
    ``norm`` (:func:`clear_sky_norm`, computed when None). The same shape
    for every wavelength (the model is of luminance)."""
    norm = clear_sky_norm(to_sun) if norm is None else float(norm)
    return norm * _cie_clear(directions, to_sun)
