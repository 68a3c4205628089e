"""The sea seen from above a flat surface: the NumPy reference.

A camera above the water (``position.y > 0``; y up, the surface is the plane
``y = 0``) looks at the sea. A ray ``v`` going down meets the flat surface at
incidence cosine ``mu_i = -v_y``; there, per band (Iwasaki, Dobashi and
Nishita 2003, Eq. 1-2, with the light field in place of their single and
second-order scattering):

    L = R(mu_i) L_sky(reflected) + (1 - R(mu_i)) / n^2 L_w(0, t)

- ``R``: the unpolarised Fresnel reflectance
  (:func:`aquaspec.medium.interface.fresnel_transmittance`), the same for
  the ray leaving the water (reciprocity);
- ``L_sky``: the sky in air. The light's ``E0`` is, as everywhere in
  aquaspec, the downwelling irradiance just *below* the surface; above it a
  uniform (overcast) sky of irradiance ``E_sky = E0 s / t_d`` gives it, with
  ``t_d`` the share of such a sky the surface lets in
  (:func:`aquaspec.medium.interface.diffuse_transmittance`, 0.934) and ``s``
  the sky's share of ``E0`` (the rest is the water's light mirrored back
  down: :meth:`~aquaspec.transport.lightfield.tables.LightfieldTables.sky_share`);
  so ``L_sky = E_sky / pi``;
- ``t``: the refracted ray (Snell, n = 1.33), and ``L_w(0, t)`` the radiance
  in the water just below the surface looking along it: the light field's
  path radiance along ``t`` down to the seabed it sees, if the tables have
  one (its Lambertian radiance attenuated on the way), else to infinity
  (:meth:`~aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance`
  with a camera at depth 0); ``1 / n^2``: radiance leaving a denser medium
  spreads over a larger solid angle.

Rays going level or up see the sky. The tables must be the flat surface's
(``SpectralSetup(surface="flat")``): the light that the surface reflects
back down is part of the light field the water's colour comes from. Not in
this model yet: the direct sun (its disc, its glint on the surface and its
single scattering in the water), clear-sky radiance distributions, waves,
and meshes under the water (only the seabed of the tables is seen).
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import (FLAT_NORMAL, N_WATER, diffuse_transmittance,
                                       fresnel_transmittance, refract)

#: Nodes of :func:`water_below_table` over the refracted rays' ``t_y``.
TABLE_NODES = 1024


def sky_irradiance_above(tables, e0) -> np.ndarray:
    """The uniform sky's irradiance in air that gives ``E0`` below the flat
    surface, ``E_sky = E0 s / t_d`` per band (n,) (module docstring)."""
    return np.asarray(e0, dtype=float) * tables.sky_share() / diffuse_transmittance()


def e0_below(tables, e_sky) -> np.ndarray:
    """``E0`` below the flat surface under a uniform sky of irradiance
    ``e_sky`` in air: :func:`sky_irradiance_above` inverted, ``t_d E_sky / s``."""
    return diffuse_transmittance() * np.asarray(e_sky, dtype=float) / tables.sky_share()


def sky_radiance_above(tables, e0) -> np.ndarray:
    """The uniform sky's radiance in air, ``E_sky / pi`` per band (n,)."""
    return sky_irradiance_above(tables, e0) / np.pi


def sea_from_above(camera, tables, *, a, b, e0, n_water: float = N_WATER,
                   exact: bool = False) -> np.ndarray:
    """Band radiance (H, W, n) reaching a camera above the flat sea (module
    docstring). ``tables``: the flat surface's light-field tables (with the
    seabed, if any, as their lower boundary); ``a``, ``b``, ``e0``: per band.
    The water's radiance is interpolated in :func:`water_below_table`
    (``exact``: evaluated per ray from the tables instead)."""
    if tables.surface != "fresnel":
        raise AquaspecError("the sea seen from above needs the flat surface's light field "
                            f"(surface 'flat'); these tables have surface {tables.surface!r}")
    height = float(camera.position[1])
    if not height > 0:
        raise AquaspecError(f"camera at y = {height:g} m: the sea is seen from above with "
                            "the camera above the surface (y > 0)")
    v = camera.ray_directions()
    shape = v.shape[:-1]
    v = v.reshape(-1, 3)
    down = v[:, 1] < 0
    sky = sky_radiance_above(tables, e0)
    out = np.broadcast_to(sky, (v.shape[0], sky.size)).copy()
    if np.any(down):
        vd = v[down]
        mu_i = -vd[:, 1]
        t, _ = refract(vd, FLAT_NORMAL, n_water)
        r = 1.0 - fresnel_transmittance(mu_i, n_water)
        if exact:
            t_y = t[:, 1:2]
            water = tables.pixel_radiance(a=np.asarray(a, float), b=np.asarray(b, float),
                                          e0=np.asarray(e0, float), depth_o=np.zeros_like(t_y),
                                          v_y=t_y, s=np.full_like(t_y, np.inf))
        else:
            nodes, table = water_below_table(tables, a=a, b=b, e0=e0, n_water=n_water)
            water = np.stack([np.interp(t[:, 1], nodes, table[:, i])
                              for i in range(table.shape[1])], axis=-1)
        out[down] = r[:, None] * sky + ((1.0 - r) / n_water ** 2)[:, None] * water
    return out.reshape(shape + (sky.size,))


def water_below_table(tables, *, a, b, e0, n_water: float = N_WATER,
                      nodes: int = TABLE_NODES):
    """``(t_y, L_w)``: the light field's radiance just below the surface
    looking down along ``t_y`` (ascending nodes over the refracted rays'
    range ``[-1, -cos theta_c]``), (nodes,) and (nodes, n). It depends on the
    ray only through ``t_y`` (the water is horizontally uniform), so a frame
    needs it once: interpolated linearly in ``t_y`` it is within 1e-5 of the
    direct evaluation at :data:`TABLE_NODES` nodes (tested), and the frame
    costs a lookup per pixel instead of the tables' per-ray evaluation
    (about 27 s at 1280x720 with 8 bands)."""
    edge = np.sqrt(1.0 - 1.0 / n_water ** 2)
    t_y = np.linspace(-1.0, -edge, nodes)[:, None]
    water = tables.pixel_radiance(a=np.asarray(a, float), b=np.asarray(b, float),
                                  e0=np.asarray(e0, float), depth_o=np.zeros_like(t_y),
                                  v_y=t_y, s=np.full_like(t_y, np.inf))
    return t_y[:, 0], np.asarray(water, dtype=float)
