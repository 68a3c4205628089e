"""The flat port: a camera looking into the water through a plane glass window.

Geometry, in the camera's own axes (x right, y down, z forward, metres):
the entrance pupil (the pinhole) is at the origin; the window is a plate of
glass perpendicular to the optical axis, its inner face at ``z = gap_m``
and its outer face, wet, at ``z = gap_m + thickness_m``. A chief ray leaving
the pupil at angle ``theta_a`` to the axis (radial tangent ``rho = tan
theta_a``) is refracted by Snell's law at both faces::

    sin theta_a = n_g(lambda) sin theta_g = n_w(lambda) sin theta_w

(the plate's faces are parallel, so the direction in water depends on the
water's index alone; the glass shifts the ray sideways). It crosses the
inner face at radius ``r1 = gap tan theta_a``, the outer face at
``r2 = r1 + thickness tan theta_g``, and in the water at axial distance z
it is at radius::

    r(z) = r2 + (z - gap - thickness) tan theta_w = z tan theta_w + delta,
    delta = gap (tan theta_a - tan theta_w) + thickness (tan theta_g - tan theta_w)

So a flat port is not a central camera: its rays in water do not meet in
one point. The pinhole (central) camera in water that sees the same point
at axial distance z sees it at radial tangent ``tan theta_w + delta / z``;
with z = infinity (or gap = thickness = 0) the port is central and the
mapping from the sensor's angle to the water's is ``sin theta_a = n_w sin
theta_w``: the field of view shrinks by about n_w = 1.34 at the centre,
more towards the edges (pincushion distortion), and by a little more in
red than in blue (``n_w`` falls with wavelength: lateral chromatic
aberration). Indices: :mod:`aquaspec.optics.dispersion`.

The image is made by resampling a pinhole render in water
(:func:`aquaspec.optics.remap.port_image`): :meth:`FlatPort.pinhole_tangent`
is where each sensor pixel's ray meets a surface at axial distance z, per
band; the depth of the surface comes from the pinhole render's G-buffer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import fresnel_transmittance
from aquaspec.optics.dispersion import (DEFAULT_SALINITY, DEFAULT_TEMPERATURE_C, Glass,
                                        get_glass, water_index_QuanFry1995)

#: Closest distance (axial, m) the pinhole render in water is made wide enough
#: for: nearer surfaces at the image's edge are clamped to the render's edge.
DEFAULT_MIN_DISTANCE_M = 0.3


@dataclass(frozen=True)
class FlatPort:
    """A plane window of glass between the camera (in air) and the water.

    Parameters
    ----------
    thickness_m : float
        Glass thickness, m (0 to 0.1).
    gap_m : float
        Entrance pupil to the window's inner face, m (0 to 0.5).
    glass : str or Glass
        :data:`aquaspec.optics.dispersion.GLASSES` name.
    salinity, temperature_c : float
        The water's, for its index (:func:`aquaspec.optics.dispersion.water_index_QuanFry1995`).
    """

    thickness_m: float = 0.01
    gap_m: float = 0.03
    glass: Glass | str = "bk7"
    salinity: float = DEFAULT_SALINITY
    temperature_c: float = DEFAULT_TEMPERATURE_C

    kind = "flat"

    def __post_init__(self):
        for name, hi in (("thickness_m", 0.1), ("gap_m", 0.5)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= v <= hi:
                raise AquaspecError(f"flat port {name}={v!r}; accepted: 0 to {hi:g} m")
        object.__setattr__(self, "glass", get_glass(self.glass))
        water_index_QuanFry1995(550.0, self.salinity, self.temperature_c)

    def indices(self, wavelength_nm) -> tuple[np.ndarray, np.ndarray]:
        """``(n_water, n_glass)`` at ``wavelength_nm``."""
        return (water_index_QuanFry1995(wavelength_nm, self.salinity, self.temperature_c),
                self.glass.index(wavelength_nm))

    def water_ray(self, tan_air, wavelength_nm) -> tuple[np.ndarray, np.ndarray]:
        """The ray in water of the chief ray at radial tangent ``tan_air``.

        Parameters
        ----------
        tan_air : array_like
            ``tan theta_a`` (>= 0) of the ray leaving the pupil.
        wavelength_nm : float or array_like
            Broadcast against ``tan_air``.

        Returns
        -------
        tan_water, delta_m : ndarray
            The water ray's radial tangent and its lateral offset
            ``r(z) = z tan_water + delta_m`` (module docstring).
        """
        rho = np.asarray(tan_air, dtype=float)
        n_w, n_g = self.indices(wavelength_nm)
        sin_a = rho / np.sqrt(1.0 + rho * rho)
        tan_g = _tan_of_sin(sin_a / n_g)
        tan_w = _tan_of_sin(sin_a / n_w)
        delta = self.gap_m * (rho - tan_w) + self.thickness_m * (tan_g - tan_w)
        return tan_w, delta

    def pinhole_tangent(self, tan_air, wavelength_nm, z_m) -> np.ndarray:
        """Radial tangent, seen from the pupil, of where the ray of ``tan_air``
        is at axial distance ``z_m`` (inf: the direction in water)."""
        tan_w, delta = self.water_ray(tan_air, wavelength_nm)
        z = np.asarray(z_m, dtype=float)
        return tan_w + np.where(np.isfinite(z), delta / np.where(np.isfinite(z), z, 1.0), 0.0)

    def centre_ratio(self, wavelength_nm, min_distance_m: float = DEFAULT_MIN_DISTANCE_M):
        """The largest ``pinhole tangent / tan_air`` over the image (at its
        centre, for surfaces ``min_distance_m`` away): the pinhole render in
        water with focal length ``f / ratio`` holds every sensor pixel's ray."""
        n_w, n_g = self.indices(wavelength_nm)
        lead = self.gap_m * (1.0 - 1.0 / n_w) + self.thickness_m * (1.0 / n_g - 1.0 / n_w)
        return float(np.max(1.0 / n_w + lead / float(min_distance_m)))

    def radiance_factor(self, tan_air, wavelength_nm) -> np.ndarray:
        """Air-side radiance per unit of water radiance along the chief ray of
        ``tan_air``: ``T / n_w^2``. The basic radiance ``L / n^2`` is kept
        along a ray through lossless refraction (Nicodemus, "Radiance", Am. J.
        Phys. 31, 368, 1963), so the camera behind the port sees ``1/n_w^2``
        (about 0.56) of the water's radiance, times the unpolarised Fresnel
        transmittance of the two faces (about 0.95 on the axis, 0.93 at 50
        degrees in air; the light reflected back and forth in the glass is
        left out)."""
        rho = np.asarray(tan_air, dtype=float)
        n_w, n_g = self.indices(wavelength_nm)
        cos_a = 1.0 / np.sqrt(1.0 + rho * rho)
        cos_w = np.sqrt(1.0 - (rho * cos_a / n_w) ** 2)
        # Each face's transmittance is the same both ways (Stokes): taken from
        # the lower index's side.
        t = fresnel_transmittance(cos_a, n_g) * fresnel_transmittance(cos_w, n_g / n_w)
        return t / n_w ** 2

    def virtual_distance(self, tan_air, wavelength_nm, distance_m) -> np.ndarray:
        """Where the lens must focus to see sharp a point ``distance_m`` along
        the water ray (from the outer face), m from the pupil along the chief
        ray: the paraxial image of the window about that ray, the mean of
        its sagittal and tangential image distances (the circle of least
        confusion lies between them). A plane interface images a point at
        ``s`` from it at ``s n'/n`` (sagittal) and ``s n' cos^2 t' / (n
        cos^2 t)`` (tangential)."""
        rho = np.asarray(tan_air, dtype=float)
        n_w, n_g = self.indices(wavelength_nm)
        cos_a = 1.0 / np.sqrt(1.0 + rho * rho)
        sin_a = rho * cos_a
        cos_g2, cos_w2 = 1.0 - (sin_a / n_g) ** 2, 1.0 - (sin_a / n_w) ** 2
        s = np.asarray(distance_m, dtype=float)
        t_g = self.thickness_m / np.sqrt(cos_g2)
        sag = s / n_w + t_g / n_g
        tan = (s * n_g * cos_g2 / (n_w * cos_w2) + t_g) * cos_a ** 2 / (n_g * cos_g2)
        return self.gap_m / cos_a + 0.5 * (sag + tan)

    def describe(self) -> dict:
        return {"kind": "flat", "thickness_m": self.thickness_m, "gap_m": self.gap_m,
                "glass": self.glass.describe(), "salinity": self.salinity,
                "temperature_c": self.temperature_c,
                "water_index": "Quan & Fry 1995, Appl. Opt. 34, 3477",
                "image": "a pinhole render in water resampled per band at where each "
                         "sensor ray meets the G-buffer's surface (Snell at both faces)"}


def _tan_of_sin(s):
    return s / np.sqrt(1.0 - s * s)
