"""The sun under water: the refracted beam, its light on surfaces and its single scattering.

Conventions (as everywhere in aquaspec): metres, y up, the water surface is
y = 0, depth ``d = -p.y``; coefficients in 1/m; wavelengths in nm.

Geometry
--------
The sun stands at ``elevation_deg`` above the horizon (in air) and at
``azimuth_deg``, a compass angle measured in the horizontal plane from the
``-z`` axis (the built-in camera's view direction: azimuth 0 puts the sun in
front of that camera, 180 behind it) towards ``+x``. The direction towards
the sun in air is ``(cos e sin az, sin e, -cos e cos az)``. Through a flat
surface (Snell, ``n = 1.33``) the beam's zenith angle under water is
``theta_w`` with ``sin theta_w = cos e / n``; ``mu0 = cos theta_w`` (>= 0.66:
the beam is never flatter than the edge of Snell's window). :attr:`Sun.to_sun`
is the unit vector towards the sun under water, :attr:`Sun.direction` the way
the light travels (``-to_sun``).

Beam
----
``beam_normal(lambda)`` is the beam's irradiance on a plane normal to it just
below the surface, W m^-2 nm^-1: the direct normal irradiance in air times
``cos z`` (the horizontal irradiance), the Fresnel transmittance at ``z``,
divided by ``mu0`` (the refracted beam is narrower). Its horizontal
irradiance just below the surface is ``mu0 * beam_normal``, the share of the
light's ``E0`` that the sun brings.

The model, per band
-------------------
At a point at depth ``d`` the beam's normal irradiance is
``E_b(d) = beam_normal * exp(-c_sun d / mu0)``: the path from the surface is
``d / mu0``. ``c_sun`` is the extinction of the beam; with the light-field
model it is that model's delta-M ``c* = c - f b`` (light scattered into the
phase function's narrowest forward peak stays in the beam, as in the
discrete-ordinates solution whose diffuse field complements it); with the
seeds' model it is ``c``.

- A Lambertian surface of reflectance ``rho`` and normal ``n`` gets
  ``E_b(d) max(0, n . to_sun) V`` and sends ``rho / pi`` of it towards the
  camera (``V`` = 1 where the surface sees the sun, 0 in a shadow).
- Along a camera ray ``x(t) = o + t v`` (depth ``d(t) = d_o - t v_y``) the
  beam scattered once towards the camera is

      L_SS = b p(cos theta) int_0^S V(x(t)) E_b(d(t)) exp(-c_view t) dt,
      cos theta = direction . (-v)

  with ``p`` the band's phase function (for ``petzold`` mixed with pure water
  by band, as the light field does) and ``c_view`` the extinction the
  renderer applies to a surface's light on its way to the camera. Without
  shadows (``V = 1``) it is closed form,
  ``b p E_b(0) ms_path_integral(c_view, c_sun / mu0, d_o, v_y, S)``
  (:func:`aquaspec.model.ms_path_integral`, stable for every sign of
  ``k = c_view - c_sun v_y / mu0``). With shadows the integral is taken over
  ``N`` equal steps up to ``S`` or a length beyond which the beam adds less
  than :data:`TAIL` of the term, with ``V`` at each step's middle and each
  step's exponential integrated exactly (:func:`march_weights`); the GPU pass
  does the same with ``V`` read from a shadow map.

The multiple scattering of the sun's light is not here: it is part of the
ambient term (the light field's diffuse field, or the seeds' Kd model).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import model
from .bands import Bands
from .errors import AquaspecError

#: Steps along a camera ray for the shadowed single scattering.
DEFAULT_STEPS = 48
#: The march stops where the rest of the unshadowed integral is below this share.
TAIL = 1e-3


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


def refracted_to_sun(elevation_deg, azimuth_deg, n_water: float = model.N_WATER) -> np.ndarray:
    """Unit vector towards the sun under a flat surface (Snell)."""
    air = air_to_sun(elevation_deg, azimuth_deg)
    sin_w = np.hypot(air[0], air[2]) / n_water
    h = np.hypot(air[0], air[2])
    horiz = air[[0, 2]] / h if h > 0 else np.zeros(2)
    mu0 = np.sqrt(1.0 - sin_w ** 2)
    return np.array([sin_w * horiz[0], mu0, sin_w * horiz[1]])


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
    n_water: float = model.N_WATER

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


# ---- the model (NumPy reference) -------------------------------------------

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


def scattering_cosine(direction, v):
    """``cos theta`` between the beam and light leaving towards the camera: ``direction . (-v)``."""
    return -(np.asarray(v, dtype=float) @ np.asarray(direction, dtype=float))


def single_scattering_open(*, b, phase_value, beam0, c_sun, c_view, depth_o, v_y, s, mu0):
    """``L_SS`` without shadows (closed form), shape ``(..., n_bands)``.

    ``phase_value`` (..., n_bands): the band phase function at each ray's
    scattering angle. Per-ray ``depth_o, v_y, s`` (...).
    """
    d = np.asarray(depth_o, dtype=float)[..., None]
    vy = np.asarray(v_y, dtype=float)[..., None]
    ss = np.asarray(s, dtype=float)[..., None]
    path = model.ms_path_integral(np.asarray(c_view), np.asarray(c_sun) / mu0, d, vy, ss)
    return np.asarray(b) * phase_value * np.asarray(beam0) * path


def march_length(c_sun, c_view, depth_o, v_y, s, mu0, tail: float = TAIL):
    """Where the march along a ray stops, m, per ray: ``S`` (cut at the surface),
    or earlier where the unshadowed integral's rest is below ``tail``.

    The slowest band sets it: the integrand is ``exp(-k t)`` with
    ``k = c_view - c_sun v_y / mu0``; for ``k > 0`` the rest beyond ``t`` is
    ``exp(-k t)`` of the whole, so ``t = -ln(tail) / k``.
    """
    s_cut = model.ray_length(np.asarray(s, dtype=float), np.asarray(depth_o, dtype=float),
                             np.asarray(v_y, dtype=float))
    k = np.asarray(c_view) - np.asarray(c_sun) * np.asarray(v_y, dtype=float)[..., None] / mu0
    k_min = np.min(k, axis=-1)
    t_tail = np.where(k_min > 0, -np.log(tail) / np.where(k_min > 0, k_min, 1.0), np.inf)
    out = np.minimum(s_cut, t_tail)
    if not np.all(np.isfinite(out)):
        raise AquaspecError("a camera ray has no end: open water with k <= 0 "
                            "(this cannot happen under water; please report it)")
    return out


def march_weights(k, length, n_steps: int):
    """Weights of the ``n_steps`` equal steps over ``[0, length]``:
    ``w_j = int_{t_j}^{t_j+1} exp(-k t) dt``, shape ``(..., n_steps, n_bands)``.

    ``k`` (..., n_bands), ``length`` (...). Exact per step for any sign of k
    (the exponent's caller guarantees it stays bounded under water).
    """
    k = np.asarray(k, dtype=float)
    dt = np.asarray(length, dtype=float)[..., None] / n_steps           # (..., 1)
    j = np.arange(n_steps)
    t0 = j[None, :] * dt                                               # (..., N)
    kk = k[..., None, :]
    x = kk * dt[..., None]                                             # (..., 1, n)
    # int_0^dt exp(-k u) du = dt * (1 - e^-x)/x, = dt at x = 0.
    small = np.abs(x) < 1e-8
    step = np.where(small, dt[..., None], -np.expm1(-x) / np.where(small, 1.0, kk))
    return np.exp(-kk * t0[..., None]) * step


def single_scattering_marched(*, b, phase_value, beam0, c_sun, c_view, depth_o, v_y, s, mu0,
                              visibility, n_steps: int = DEFAULT_STEPS, tail: float = TAIL):
    """``L_SS`` with shadows, shape ``(..., n_bands)``.

    ``visibility(t_mid)`` gets the steps' middles ``(..., n_steps)`` (m along
    each ray) and returns ``V`` there (same shape, 0 ... 1).
    """
    d = np.asarray(depth_o, dtype=float)
    vy = np.asarray(v_y, dtype=float)
    length = march_length(c_sun, c_view, d, vy, s, mu0, tail)
    k = np.asarray(c_view) - np.asarray(c_sun) * vy[..., None] / mu0
    w = march_weights(k, length, n_steps)
    t_mid = (np.arange(n_steps) + 0.5) * (length[..., None] / n_steps)
    vis = np.asarray(visibility(t_mid), dtype=float)
    integral = np.einsum("...j,...jb->...b", vis, w)
    start = np.exp(-np.asarray(c_sun) * d[..., None] / mu0)
    return np.asarray(b) * phase_value * np.asarray(beam0) * start * integral


def band_phase(phase: str, cos_theta, *, b, wavelength_nm, **params):
    """The band phase function at ``cos_theta`` (...), shape ``(..., n_bands)``.

    For the phase functions mixed with pure water (``petzold``) the mixture
    ``(b_w p_w + b_p p) / b`` per band, as :func:`aquaspec.phase.band_moments`.
    """
    from .phase import MIXED_WITH_WATER, PureWaterPhase, get_phase, pure_water_fraction
    ph = get_phase(phase, **params)
    mu = np.clip(np.asarray(cos_theta, dtype=float), -1.0, 1.0)
    b_arr = np.atleast_1d(np.asarray(b, dtype=float))
    base = ph.value(mu)[..., None] * np.ones(b_arr.size)
    if ph.name in MIXED_WITH_WATER:
        fw = pure_water_fraction(ph, b_arr, wavelength_nm)
        base = fw * PureWaterPhase().value(mu)[..., None] + (1.0 - fw) * base
    return base
