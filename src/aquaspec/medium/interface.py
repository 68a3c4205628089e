"""The air-water interface: refractive index, Snell's law, Fresnel, Snell's window.

Conventions as everywhere in aquaspec: y up, the water surface is the plane
``y = 0``, unit directions. Light going down into the water crosses the
interface from air (index 1) into water (index :data:`N_WATER`).

- :func:`refract`: Snell's law for a direction through a facet of any
  orientation (a flat surface has the normal ``(0, 1, 0)``).
- :func:`fresnel_transmittance`: the share of unpolarised light that enters
  the water.
- :func:`snell_window_cos` and :func:`surface_from_below`: looking up from
  below, the sky is seen only within the critical angle (Snell's window).
- :func:`below_surface`: the surface as the light field's top boundary, in
  one of :data:`SURFACES`' models.

The sun's direction under a flat surface, :func:`aquaspec.light.sun.refracted_to_sun`,
is :func:`refract` of its ray in air.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError

#: Refractive index of sea water (for the interface and Snell's window).
N_WATER = 1.33
#: Models of the flat surface seen from below (:func:`below_surface`).
SURFACES = ("null", "refracted", "fresnel")
#: The normal of a flat water surface.
FLAT_NORMAL = np.array([0.0, 1.0, 0.0])


def refract(d, normal, n_water: float = N_WATER):
    """Refract unit directions ``d`` (..., 3) travelling down through a surface
    with unit upward normals (..., 3): ``(t, cos_i)``; ``cos_i <= 0`` where the
    facet faces away from the ray (``t`` then is ``d``)."""
    cos_i = -np.sum(d * normal, axis=-1)
    eta = 1.0 / n_water
    sin2_t = eta * eta * np.clip(1.0 - cos_i * cos_i, 0.0, 1.0)
    cos_t = np.sqrt(1.0 - sin2_t)
    t = eta * d + (eta * cos_i - cos_t)[..., None] * normal
    return np.where((cos_i > 0)[..., None], t, d), cos_i


def fresnel_transmittance(cos_i, n: float = N_WATER):
    """Unpolarised Fresnel transmittance from air into water at incidence cosine ``cos_i``."""
    cos_i = np.clip(np.asarray(cos_i, dtype=float), 0.0, 1.0)
    sin_t = np.sqrt(1.0 - cos_i ** 2) / n
    cos_t = np.sqrt(1.0 - sin_t ** 2)
    rs = ((cos_i - n * cos_t) / (cos_i + n * cos_t)) ** 2
    rp = ((cos_t - n * cos_i) / (cos_t + n * cos_i)) ** 2
    return 1.0 - 0.5 * (rs + rp)


def fresnel_transmittance_out(cos_i, n_water: float = N_WATER):
    """Unpolarised Fresnel transmittance from water into air at incidence
    cosine ``cos_i`` on the water side: by reciprocity the air side's
    :func:`fresnel_transmittance` at the refracted angle; 0 beyond the
    critical angle (total internal reflection)."""
    cos_i = np.clip(np.asarray(cos_i, dtype=float), 0.0, 1.0)
    sin2_air = n_water * n_water * (1.0 - cos_i * cos_i)
    cos_air = np.sqrt(np.clip(1.0 - sin2_air, 0.0, 1.0))
    return np.where(sin2_air < 1.0, fresnel_transmittance(cos_air, n_water), 0.0)


def snell_window_cos(n_water: float = N_WATER) -> float:
    """Cosine of the critical angle: up-rays with ``v_y`` above it see the sky."""
    return float(np.sqrt(1.0 - 1.0 / n_water ** 2))


def diffuse_transmittance(n_water: float = N_WATER) -> float:
    """The share of a uniform (overcast) sky's irradiance that crosses the flat
    surface into the water, ``2 int_0^1 T(mu) mu dmu`` over the incidence
    cosines in air (Gauss-Legendre, 200 nodes: T is smooth in ``mu``):
    0.934 at n = 1.33, i.e. the sea reflects 6.6 % of an overcast sky."""
    x, w = np.polynomial.legendre.leggauss(200)
    mu = 0.5 * (x + 1.0)
    return float(np.sum(w * mu * fresnel_transmittance(mu, n_water)))


def index_of_window(window_cos: float) -> float:
    """The refractive index whose Snell's window has cosine ``window_cos``
    (:func:`snell_window_cos` inverted; 1 for a window at the horizon)."""
    return float(1.0 / np.sqrt(1.0 - window_cos ** 2))


def surface_from_below(e0, v_y, n_water: float = N_WATER):
    """Radiance of the water surface seen from below along an up-going ray.

    Inside Snell's window the sky is seen; for a uniform (overcast) sky the
    radiance there is uniform, and integrating it over the window (half-angle
    ``theta_c``, ``sin theta_c = 1/n``) must give the downwelling irradiance
    just below the surface, so ``L = E0 n^2 / pi``. Outside the window the
    surface totally reflects the (much dimmer) water below; that reflection is
    neglected (radiance 0), so the surface is the window disc on black.
    """
    inside = np.asarray(v_y, dtype=float) > snell_window_cos(n_water)
    return np.where(inside, np.asarray(e0, dtype=float) * n_water ** 2 / np.pi, 0.0)


def below_surface(mu_up, surface: str, n_water: float = N_WATER):
    """The flat surface seen from just below it at up-cosines ``mu_up``:
    ``(shape, mirror, window_cos)``.

    A uniform (overcast) sky's radiance seen looking up is ``shape`` times a
    constant; the light going up is sent back down with the share ``mirror``;
    ``window_cos`` is Snell's window's cosine. The models (:data:`SURFACES`):

    - ``null``: no interface (the index-matched surface of the path-traced
      validation): the sky everywhere, nothing mirrored, window 0;
    - ``refracted``: the sky only inside Snell's window, nothing mirrored;
    - ``fresnel``: the sky inside the window entering with the Fresnel
      transmittance ``T`` of its ray in air (the radiance's ``n^2`` is a
      constant, left in the scale), the light going up mirrored with
      ``1 - T`` inside the window (the same from both sides, by reciprocity)
      and totally outside it.
    """
    mu_up = np.asarray(mu_up, dtype=float)
    if surface not in SURFACES:
        raise AquaspecError(f"unknown surface {surface!r}; known: {', '.join(SURFACES)}")
    if surface == "null":
        return np.ones_like(mu_up), np.zeros_like(mu_up), 0.0
    window = snell_window_cos(n_water)
    inside = mu_up > window
    if surface == "refracted":
        return inside.astype(float), np.zeros_like(mu_up), window
    cos_air = np.sqrt(np.clip(1.0 - n_water ** 2 * (1.0 - mu_up ** 2), 0.0, 1.0))
    t = np.where(inside, fresnel_transmittance(cos_air, n_water), 0.0)
    return t, 1.0 - t, window
