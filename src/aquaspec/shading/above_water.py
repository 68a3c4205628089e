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
  so ``L_sky = E_sky / pi``, and with a sun ``E_sky / pi`` times the CIE
  standard clear sky's distribution about it, of unit mean on a horizontal
  plane (:func:`sky_shape`; the light field below keeps the uniform sky);
- ``t``: the refracted ray (Snell, n = 1.33), and ``L_w(0, t)`` the radiance
  in the water just below the surface looking along it: the light field's
  path radiance along ``t`` down to the seabed it sees, if the tables have
  one (its Lambertian radiance attenuated on the way), else to infinity
  (:meth:`~aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance`
  with a camera at depth 0); ``1 / n^2``: radiance leaving a denser medium
  spreads over a larger solid angle.

Rays going level or up see the sky. The tables must be the flat surface's
(``SpectralSetup(surface="flat")``): the light that the surface reflects
back down is part of the light field the water's colour comes from.

With a sun (``sun``: the renderer's :class:`aquaspec.transport.sun_scattering.SunInputs`)
two terms join, and the tables are the sky's and the sun's (their diffuse
field holds every order of the beam's scattering but the first, and their
seabed the beam's light on it):

- the beam scattered once towards the surface along ``t``
  (:func:`sun_scattering_below`: ``b p(cos theta) F0 int exp(-c* z / mu0)
  exp(-c_view z / |t_y|) dz / |t_y|`` down to the seabed, the closed form of
  :func:`aquaspec.transport.sun_scattering.single_scattering_open` with a
  camera at depth 0), added to ``L_w``;
- the sun's glint (:func:`sun_glint`): where the mirrored ray ``r = (v_x,
  -v_y, v_z)`` falls inside the sun's disc (angular radius
  :data:`SUN_RADIUS_DEG`, or half a pixel's diagonal if larger:
  :func:`glint_radius`), ``R(mu_i)`` times the sun's radiance in air,
  ``E_sun / Omega_sun`` (its normal irradiance in air over the disc's solid
  angle; the beam under water is ``E_sun cos z T(cos z) / mu0``,
  :mod:`aquaspec.light.sky`).

Meshes under the water and the sun's caustics on them and on the seabed
are :mod:`aquaspec.shading.above_meshes`' (``under=``).
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.light.sky import clear_sky_norm, clear_sky_shape
from aquaspec.light.wave_facets import glitter
from aquaspec.medium.interface import (FLAT_NORMAL, N_WATER, diffuse_transmittance,
                                       fresnel_transmittance, refract)
from aquaspec.transport.sun_scattering import (phase_from_log_table, scattering_cosine,
                                               single_scattering_open)

#: Nodes of :func:`water_below_table` over the refracted rays' ``t_y``.
TABLE_NODES = 1024
#: Under a wavy surface the refracted rays' ``t_y`` is at most ``-WAVE_T_TOP``
#: (tilted facets refract rays down to near level; the tables stop short of it).
WAVE_T_TOP = 0.02
#: A facet this close to edge-on to a ray (cosine) or facing away counts as flat.
MIN_FACET_COS = 0.02
#: The sun's mean angular radius seen from the Earth, degrees (its angular
#: diameter 0.533 deg: 1.392e6 km at 1 au = 1.496e8 km).
SUN_RADIUS_DEG = 0.2666


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
                   exact: bool = False, sun=None, glint: bool = True,
                   facets=None, under=None) -> np.ndarray:
    """Band radiance (H, W, n) reaching a camera above the sea (module
    docstring). ``tables``: the flat surface's light-field tables (with the
    seabed, if any, as their lower boundary; with ``sun``, the sky's and the
    sun's); ``a``, ``b``, ``e0``: per band. The water's radiance is
    interpolated in :func:`water_below_table` (``exact``: evaluated per ray
    from the tables instead). ``sun``: the sun's
    :class:`~aquaspec.transport.sun_scattering.SunInputs` (None: no sun);
    ``glint``: draw its disc (or glitter) mirrored in the surface.
    ``facets``: a wind sea (:class:`aquaspec.light.wave_facets.SurfaceFacets`):
    each ray is mirrored and refracted by the tile's facet where it meets the
    mean plane, and the sun's glint becomes Cox & Munk's glitter over the
    slopes the tile does not resolve; None: the flat surface. ``under``:
    ``(hit (H, W), L_w (P, n))``, the pixels whose refracted rays meet a mesh
    and the radiance just below the surface along them
    (:func:`aquaspec.shading.above_meshes.water_to_hits`), in place of the
    light field's (and the beam's scattering to the seabed)."""
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
    sky_at = sky_shape(sun, n_water)
    out = sky[None, :] * sky_at(v)[:, None]
    if np.any(down):
        vd = v[down]
        normal = facet_normals(camera, vd, facets)
        cos_i = -np.sum(vd * normal, axis=1)
        t, _ = refract(vd, normal, n_water)
        t[:, 1] = np.minimum(t[:, 1], -WAVE_T_TOP if facets is not None else -1e-12)
        r = 1.0 - fresnel_transmittance(cos_i, n_water)
        if exact:
            t_y = t[:, 1:2]
            water = tables.pixel_radiance(a=np.asarray(a, float), b=np.asarray(b, float),
                                          e0=np.asarray(e0, float), depth_o=np.zeros_like(t_y),
                                          v_y=t_y, s=np.full_like(t_y, np.inf))
        else:
            nodes, table = water_below_table(tables, a=a, b=b, e0=e0, n_water=n_water,
                                             t_top=None if facets is None else WAVE_T_TOP)
            water = np.stack([np.interp(t[:, 1], nodes, table[:, i])
                              for i in range(table.shape[1])], axis=-1)
        if sun is not None:
            water = water + sun_scattering_below(tables, sun, t)
        if under is not None:
            hit, l_hit, *spread = under
            water[np.asarray(hit).reshape(-1)[down]] = l_hit
            if spread and spread[0] is not None:
                water = water + spread[0].reshape(-1, sky.size)[down]
        mirrored = vd + 2.0 * cos_i[:, None] * normal
        out[down] = (r * sky_at(mirrored))[:, None] * sky \
            + ((1.0 - r) / n_water ** 2)[:, None] * water
        if sun is not None and glint:
            if facets is not None and facets.s2 > 0:
                to_air, e_air = sun_in_air(sun, n_water)
                out[down] += glitter(vd, normal, to_air, e_air, facets.s2, n_water)
            else:
                out[down] += sun_glint(vd, sun, n_water, glint_radius(camera), normal)
    return out.reshape(shape + (sky.size,))


def sky_shape(sun, n_water: float = N_WATER):
    """The sky's radiance distribution in air, as a function of unit
    directions (R, 3) -> (R,) relative to the uniform sky of the same
    irradiance (:func:`sky_radiance_above` times it): uniform (ones) without
    a sun (overcast), the CIE standard clear sky around the sun's direction
    in air with one (:func:`aquaspec.light.sky.clear_sky_shape`)."""
    if sun is None:
        return lambda d: np.ones(np.shape(d)[:-1])
    to_air, _ = sun_in_air(sun, n_water)
    norm = clear_sky_norm(to_air)
    return lambda d: clear_sky_shape(d, to_air, norm)


def facet_normals(camera, v, facets=None) -> np.ndarray:
    """The surface's unit normals (R, 3) where rays ``v`` (R, 3) from
    ``camera`` (above the sea) meet the mean plane: up for a flat sea, the
    wave tile's facets (:class:`aquaspec.light.wave_facets.SurfaceFacets`)
    otherwise, up again where a facet would face away from the ray (a
    grazing ray behind a crest, which the mean-plane model cannot follow)."""
    v = np.asarray(v, dtype=float)
    up = np.broadcast_to(FLAT_NORMAL, v.shape)
    if facets is None:
        return up.copy()
    o = np.asarray(camera.position, dtype=float)
    s = o[1] / -v[:, 1]
    n = facets.normals(o[0] + s * v[:, 0], o[2] + s * v[:, 2])
    facing = -np.sum(v * n, axis=1) > MIN_FACET_COS
    return np.where(facing[:, None], n, up)


def sun_in_air(sun, n_water: float = N_WATER):
    """``(to_sun, E_sun)``: the unit vector towards the sun in air (3,) and its
    beam's normal irradiance in air per band (n,), from the refracted beam of
    ``sun`` (:class:`~aquaspec.transport.sun_scattering.SunInputs`: ``to_sun``
    under water, ``beam0`` its normal irradiance just below the surface):
    Snell back out, and ``E_sun = beam0 mu0 / (cos z T(cos z))``."""
    to_w = np.asarray(sun.to_sun, dtype=float)
    horiz = to_w * np.array([1.0, 0.0, 1.0])
    sin_w = float(np.linalg.norm(horiz))
    sin_z = min(n_water * sin_w, 1.0)
    cos_z = float(np.sqrt(1.0 - sin_z * sin_z))
    to_air = (horiz / sin_w * sin_z if sin_w > 0 else np.zeros(3)) + np.array([0.0, cos_z, 0.0])
    beam_air = (np.asarray(sun.beam0, dtype=float) * float(to_w[1])
                / (cos_z * fresnel_transmittance(cos_z, n_water)))
    return to_air, beam_air


def sun_scattering_below(tables, sun, t) -> np.ndarray:
    """The sun's beam scattered once towards the surface along refracted rays
    ``t`` (R, 3) going down from depth 0, to the tables' seabed or to
    infinity: (R, n) (module docstring)."""
    t = np.asarray(t, dtype=float)
    cos = scattering_cosine(-np.asarray(sun.to_sun, dtype=float), t)
    bed = tables.seabed_depth_m
    s = np.full(t.shape[0], np.inf) if not np.isfinite(bed) else bed / np.maximum(-t[:, 1], 1e-12)
    return single_scattering_open(b=sun.b, phase_value=phase_from_log_table(sun.log_phase, cos),
                                  beam0=sun.beam0, c_sun=sun.c_sun, c_view=sun.c_view,
                                  depth_o=np.zeros(t.shape[0]), v_y=t[:, 1], s=s, mu0=sun.mu0)


def glint_radius(camera, radius_deg: float = SUN_RADIUS_DEG) -> float:
    """The angular radius (radians) the glint is drawn with in ``camera``'s
    image: the sun's, or half a pixel's diagonal where that is larger (a
    disc smaller than a pixel could fall between pixel centres and vanish;
    drawn over a disc of at least that size, with its radiance lowered to
    match, the glint always lights a pixel, and the image keeps its energy
    on average: the pixel centres within a disc are its area over a
    pixel's)."""
    pixel = 1.0 / max(float(camera.fx), float(camera.fy))
    return max(float(np.radians(radius_deg)), pixel / np.sqrt(2.0))


def sun_glint(v, sun, n_water: float = N_WATER, radius_rad=None, normals=None) -> np.ndarray:
    """The sun mirrored in the surface along rays ``v`` (R, 3) going down:
    ``R(mu_i) E_sun / Omega`` where the mirrored ray is within ``radius_rad``
    of the sun (default: the sun's own radius, :data:`SUN_RADIUS_DEG`), else
    0; (R, n). ``Omega = 2 pi (1 - cos radius)``. ``normals`` (R, 3): the
    facets' (default: the flat surface's, up)."""
    v = np.asarray(v, dtype=float)
    n = np.broadcast_to(FLAT_NORMAL, v.shape) if normals is None else np.asarray(normals, float)
    to_air, beam_air = sun_in_air(sun, n_water)
    cos_i = -np.sum(v * n, axis=1)
    mirrored = v + 2.0 * cos_i[:, None] * n
    radius = np.radians(SUN_RADIUS_DEG) if radius_rad is None else float(radius_rad)
    cos_r = np.cos(radius)
    inside = (mirrored @ to_air) >= cos_r
    r = 1.0 - fresnel_transmittance(cos_i, n_water)
    radiance = beam_air / (2.0 * np.pi * (1.0 - cos_r))
    return np.where(inside, r, 0.0)[:, None] * radiance


def water_below_table(tables, *, a, b, e0, n_water: float = N_WATER,
                      nodes: int = TABLE_NODES, t_top=None):
    """``(t_y, L_w)``: the light field's radiance just below the surface
    looking down along ``t_y`` (ascending nodes over the refracted rays'
    range ``[-1, -cos theta_c]``, or ``[-1, -t_top]`` for a wavy surface,
    whose tilted facets refract rays closer to level), (nodes,) and (nodes,
    n). It depends on the ray only through ``t_y`` (the water is horizontally
    uniform), so a frame needs it once: interpolated linearly in ``t_y`` it
    is within 1e-5 of the direct evaluation at :data:`TABLE_NODES` nodes
    (tested), and the frame costs a lookup per pixel instead of the tables'
    per-ray evaluation (about 27 s at 1280x720 with 8 bands)."""
    top = np.sqrt(1.0 - 1.0 / n_water ** 2) if t_top is None else float(t_top)
    t_y = np.linspace(-1.0, -top, nodes)[:, None]
    water = tables.pixel_radiance(a=np.asarray(a, float), b=np.asarray(b, float),
                                  e0=np.asarray(e0, float), depth_o=np.zeros_like(t_y),
                                  v_y=t_y, s=np.full_like(t_y, np.inf))
    return t_y[:, 0], np.asarray(water, dtype=float)


def sun_scattering_table(tables, sun, *, n_water: float = N_WATER, nodes_y: int = 64,
                         nodes_cos: int = 1024, t_top=None):
    """``(t_y, cos, table)``: :func:`sun_scattering_below` tabulated over the
    refracted rays' ``t_y`` (ascending nodes over ``[-1, -cos theta_c]``) and
    the scattering cosine ``cos = to_sun . t`` (ascending nodes over the
    range those rays reach for this sun), (nodes_y,), (nodes_cos,) and
    (nodes_y, nodes_cos, n), for the GPU to read bilinearly. The path's part
    is smooth in ``t_y`` (within 1e-5 at 64 nodes); the phase function's,
    read from :func:`aquaspec.transport.sun_scattering.phase_from_log_table`
    (linear in ``ln p`` over ``sqrt(theta)``), has kinks, so the cosine gets
    more nodes: at 1024 the table is within 0.3 % of the direct evaluation
    (tested; 0.5-0.7 % at 128 nodes). ``t_top``: as :func:`water_below_table`'s."""
    edge = np.sqrt(1.0 - 1.0 / n_water ** 2) if t_top is None else float(t_top)
    t_y = np.linspace(-1.0, -edge, nodes_y)
    to_sun = np.asarray(sun.to_sun, dtype=float)
    s_h = float(np.hypot(to_sun[0], to_sun[2]))
    dense = np.linspace(-1.0, -edge, 4 * nodes_y)
    reach = s_h * np.sqrt(1.0 - dense ** 2)
    lo = float(np.min(to_sun[1] * dense - reach))
    hi = float(np.max(to_sun[1] * dense + reach))
    cos = np.linspace(lo, max(hi, lo + 1e-6), nodes_cos)
    bed = tables.seabed_depth_m
    s = np.full(nodes_y, np.inf) if not np.isfinite(bed) else bed / -t_y
    path = single_scattering_open(b=sun.b, phase_value=1.0, beam0=sun.beam0, c_sun=sun.c_sun,
                                  c_view=sun.c_view, depth_o=np.zeros(nodes_y), v_y=t_y, s=s,
                                  mu0=sun.mu0)                                  # (ny, n)
    phase = phase_from_log_table(sun.log_phase, cos)                           # (nc, n)
    return t_y, cos, path[:, None, :] * phase[None, :, :]
