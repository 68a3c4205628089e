"""The wind sea seen from below: Snell's window broken by the waves (NumPy reference).

Conventions: metres, y up, the mean surface the plane ``y = 0``, depth ``d =
-y``; unit view directions ``v`` from the camera (at depth ``d_o``). A ray
going up through open water meets the mean plane at ``S = d_o / v_y``; the
flat surface's light field puts there its own top boundary
(:meth:`aquaspec.transport.lightfield.tables.LightfieldTables.top_radiance`:
the sky through Snell's window, the water mirrored outside it). A wind sea
(:class:`aquaspec.light.wave_facets.SurfaceFacets`, the caustics' tile)
tilts the facet the ray meets, so per band

    L_surface(v, n) = T_out(v . n) n^2 L_sky + (1 - T_out(v . n)) L_w(r)

with ``T_out`` the Fresnel transmittance out of the water (0 beyond the
critical angle: total internal reflection), ``L_sky`` the uniform sky in air
(:func:`aquaspec.shading.above_water.sky_radiance_above`), ``r`` the ray
mirrored about the facet and ``L_w(r)`` the water's radiance just below the
surface looking along it (:func:`aquaspec.shading.above_water.water_below_table`;
``r_y`` kept at or below ``-WAVE_T_TOP``). The image gains, on those pixels,

    Delta = exp(-c S) (L_surface(v, n) - L_surface(v, up))

(the light field's line of sight reaches the surface attenuated by
``exp(-c S)``, its two-point form), which is zero for a flat sea. The
light field itself stays the flat surface's (the waves change where the
window is, not, to first order, how much light goes in); the waves'
heights are left out (the facet is taken where the ray meets the mean
plane).

The sun's disc seen through the surface (:func:`sun_through_surface`, with
a sun, flat sea or waves): where the ray refracted out of the water by the
facet falls inside the sun's disc in air, the pixel gains ``exp(-c S)
T_out n^2 E_sun / Omega``, the sun's radiance in air gaining ``n^2`` on the
way in. The disc is drawn at least three quarters of a pixel wide as the
pixel's angle maps into the air (:func:`sun_radius_below`), its radiance
lowered to match, as the glint from above is
(:func:`aquaspec.shading.above_water.glint_radius`).

Under a wind sea whose tile leaves slopes unresolved (``facets.s2 > 0``),
the disc becomes the sun's *transmitted glitter* (:func:`glitter_below`),
the refraction analogue of Cox & Munk's: the many small facets a pixel
sees, tilted about the tile's facet with the isotropic Gaussian slope law,
refract the sun's beam into the view ray where their normal is ``h`` along
``n v - t`` (``t`` towards the sun in air), and (Walter et al. 2007's
microfacet transmission with ``D(h) = p(zeta) / cos^4 beta``, no shadowing)

    L_g = E_sun T_out(v.h) n^2 (t.h)(v.h) p(zeta) / (mu_v |n v - t|^2 cos^4 beta)

with ``mu_v`` the ray's cosine to the tile's facet and ``beta`` ``h``'s tilt
from it (docs/model.md derives it; its integral over the view directions is
the transmitted beam's irradiance, tested). The scene mirrored in the
surface is :mod:`aquaspec.shading.below_mirror`'s.
"""

from __future__ import annotations

import numpy as np

from aquaspec.medium.interface import FLAT_NORMAL, N_WATER, fresnel_transmittance_out
from aquaspec.shading.above_water import (SUN_RADIUS_DEG, WAVE_T_TOP, sky_radiance_above,
                                          water_below_table)


def surface_from_below(v, normals, sky, water_nodes, water_table, n_water: float = N_WATER,
                       sky_at=None):
    """``L_surface(v, n)`` (R, n) for rays ``v`` (R, 3) going up meeting
    facets of unit ``normals`` (R, 3) (module docstring); ``sky`` (n,) the
    uniform sky's radiance, times ``sky_at(t)`` (R,) along the ray refracted
    into the air when given (:func:`aquaspec.shading.above_water.sky_shape`);
    ``water_nodes`` (K,), ``water_table`` (K, n): :func:`water_below_table`."""
    v = np.asarray(v, dtype=float)
    n = np.asarray(normals, dtype=float)
    cos_i = np.sum(v * n, axis=1)
    facing = cos_i > 0
    n = np.where(facing[:, None], n, FLAT_NORMAL)
    cos_i = np.where(facing, cos_i, v[:, 1])
    t_out = fresnel_transmittance_out(cos_i, n_water)
    r_y = np.minimum(v[:, 1] - 2.0 * cos_i * n[:, 1], -WAVE_T_TOP)
    water = np.stack([np.interp(r_y, water_nodes, water_table[:, i])
                      for i in range(water_table.shape[1])], axis=-1)
    gain = t_out * n_water ** 2
    if sky_at is not None:
        gain = gain * sky_at(_into_air(v, n, cos_i, n_water))
    return gain[:, None] * np.asarray(sky)[None, :] + (1.0 - t_out)[:, None] * water


def _into_air(v, n, cos_i, n_water: float) -> np.ndarray:
    """Rays ``v`` (R, 3) going up refracted into the air through facets
    ``n`` (R, 3) at cosines ``cos_i`` (R,); beyond the critical angle (no
    ray leaves) the direction where the refracted ray grazes the facet."""
    sin2_t = n_water ** 2 * (1.0 - cos_i ** 2)
    cos_t = np.sqrt(np.clip(1.0 - sin2_t, 0.0, 1.0))
    t = n_water * v + (cos_t - n_water * cos_i)[:, None] * n
    return t / np.linalg.norm(t, axis=1, keepdims=True)


def _rays_to_surface(camera, open_up, facets, a, b):
    """What both terms need: ``c`` (n,), a zero image (H, W, n), the mask of
    ``open_up`` rays going up, those rays (R, 3) (None where there are
    none), their distance ``S`` to the mean plane and the facets' normals
    there (up for ``facets`` None)."""
    v = camera.ray_directions()
    c = np.asarray(a, dtype=float) + np.asarray(b, dtype=float)
    out = np.zeros(v.shape[:2] + (c.size,))
    mask = np.asarray(open_up, dtype=bool) & (v[..., 1] > 0)
    if not mask.any():
        return c, out, mask, None, None, None
    vv = v[mask]
    o = np.asarray(camera.position, dtype=float)
    s = -o[1] / vv[:, 1]
    normals = (np.broadcast_to(FLAT_NORMAL, vv.shape) if facets is None
               else facets.normals(o[0] + s * vv[:, 0], o[2] + s * vv[:, 2]))
    return c, out, mask, vv, s, normals


def window_correction(camera, open_up, tables, facets, *, a, b, e0,
                      n_water: float = N_WATER, sky_at=None) -> np.ndarray:
    """``Delta`` (H, W, n) for ``camera`` under the sea (module docstring):
    zero but where ``open_up`` (H, W) (rays going up that reach the surface,
    no surface before it). ``tables``: the flat surface's light field;
    ``facets``: :class:`aquaspec.light.wave_facets.SurfaceFacets` or None
    (the flat surface); ``sky_at``: the sky's distribution in air
    (:func:`aquaspec.shading.above_water.sky_shape`), against the uniform
    sky the light field's top boundary shows."""
    c, out, mask, vv, s, normals = _rays_to_surface(camera, open_up, facets, a, b)
    if vv is None:
        return out
    sky = sky_radiance_above(tables, e0)
    if facets is None:
        # The flat surface: the mirrored water is the same on both sides and cancels.
        nodes, table = np.array([-1.0, -WAVE_T_TOP]), np.zeros((2, sky.size))
    else:
        nodes, table = water_below_table(tables, a=a, b=b, e0=e0, n_water=n_water,
                                         t_top=WAVE_T_TOP)
    wavy = surface_from_below(vv, normals, sky, nodes, table, n_water, sky_at)
    flat = surface_from_below(vv, np.broadcast_to(FLAT_NORMAL, vv.shape), sky, nodes, table,
                              n_water)
    out[mask] = np.exp(-c[None, :] * s[:, None]) * (wavy - flat)
    return out


def sun_radius_below(camera, to_sun_air, n_water: float = N_WATER) -> float:
    """The angular radius (radians, in air) the sun's disc is drawn with
    seen from below in ``camera``'s image: the sun's, or three quarters of a
    pixel magnified into the air, where that is larger (module docstring).
    A ray's angle in the water maps onto ``n`` times it in the air
    sideways and ``n cos(theta_w) / cos(theta_a)`` times it towards the
    horizon; the larger is taken, so the disc always covers a pixel centre."""
    pixel = 1.0 / max(float(camera.fx), float(camera.fy))
    cos_a = max(float(np.asarray(to_sun_air, dtype=float)[1]), 0.05)
    cos_w = np.sqrt(1.0 - (1.0 - cos_a ** 2) / n_water ** 2)
    magnification = n_water * max(1.0, cos_w / cos_a)
    return max(float(np.radians(SUN_RADIUS_DEG)), 0.75 * magnification * pixel)


def sun_through_surface(v, normals, to_sun_air, sun_irradiance_air, radius_rad: float,
                        n_water: float = N_WATER) -> np.ndarray:
    """The sun's disc seen along rays ``v`` (R, 3) going up through facets of
    unit ``normals`` (R, 3), at the surface (not yet attenuated): ``T_out n^2
    E_sun / Omega`` where the ray refracted into the air is within
    ``radius_rad`` of ``to_sun_air``, else 0 (and 0 beyond the critical
    angle); (R, n) for the sun's normal irradiance in air (n,)."""
    v = np.asarray(v, dtype=float)
    n = np.asarray(normals, dtype=float)
    cos_i = np.sum(v * n, axis=1)
    n = np.where((cos_i > 0)[:, None], n, FLAT_NORMAL)
    cos_i = np.where(cos_i > 0, cos_i, v[:, 1])
    sin2_t = n_water ** 2 * (1.0 - cos_i ** 2)
    t = _into_air(v, n, cos_i, n_water)
    cos_r = np.cos(radius_rad)
    inside = (sin2_t < 1.0) & ((t @ np.asarray(to_sun_air, dtype=float)) >= cos_r)
    omega = 2.0 * np.pi * (1.0 - cos_r)
    gain = np.where(inside, fresnel_transmittance_out(cos_i, n_water) * n_water ** 2 / omega, 0.0)
    return gain[:, None] * np.asarray(sun_irradiance_air, dtype=float)[None, :]


def glitter_below(v, normals, to_sun_air, sun_irradiance_air, s2: float,
                  n_water: float = N_WATER) -> np.ndarray:
    """The sun's transmitted glitter (module docstring) along rays ``v`` (R,
    3) going up, meeting the tile's facets of unit ``normals`` (R, 3), at the
    surface (not yet attenuated): (R, n) for the sun's normal irradiance
    ``sun_irradiance_air`` (n,) in air towards ``to_sun_air``. Zero where the
    refracting facet would face away from the ray, the sun or the tile's
    facet (then no small facet refracts the sun into the ray); a tile facet
    facing away from the ray is taken upright, as :func:`sun_through_surface`
    takes it."""
    v = np.asarray(v, dtype=float)
    nr = np.asarray(normals, dtype=float)
    nr = np.where((np.sum(v * nr, axis=1) > 0)[:, None], nr, FLAT_NORMAL)
    t = np.asarray(to_sun_air, dtype=float)
    hv = n_water * v - t[None, :]
    length2 = np.sum(hv * hv, axis=1)
    h = hv / np.sqrt(length2)[:, None]
    cos_v = np.sum(v * h, axis=1)                   # the ray's incidence on h (water side)
    cos_t = h @ t                                   # the sun's (air side)
    cos_b = np.sum(h * nr, axis=1)                  # h's tilt from the tile's facet
    mu_v = np.sum(v * nr, axis=1)
    ok = (cos_v > 0) & (cos_t > 0) & (cos_b > 0) & (mu_v > 0)
    cb = np.where(ok, cos_b, 1.0)
    p = np.exp(-(1.0 - cb * cb) / (cb * cb) / s2) / (np.pi * s2)
    tr = fresnel_transmittance_out(np.where(ok, cos_v, 1.0), n_water)
    g = np.where(ok, tr * n_water ** 2 * cos_t * cos_v * p
                 / (np.where(ok, mu_v, 1.0) * length2 * cb ** 4), 0.0)
    return g[:, None] * np.asarray(sun_irradiance_air, dtype=float)[None, :]


def glitter_variance_below(camera, s2: float, n_water: float = N_WATER) -> float:
    """The slope variance the glitter is drawn with seen from below in
    ``camera``'s image: ``s2``, or what spreads it over about 1.5 pixels where
    that is larger (a facet tilt ``delta`` moves the ray that sees the sun by
    about ``delta (n - 1) / n``, so a narrow glitter would fall between pixel
    centres; the law stays normalised, so its energy is kept)."""
    pixel = 1.0 / min(float(camera.fx), float(camera.fy))
    spread = 1.5 * pixel * n_water / (n_water - 1.0)
    return max(float(s2), 2.0 * spread ** 2)


def sun_disc_below(camera, open_up, facets, to_sun_air, sun_irradiance_air, *, a, b,
                   n_water: float = N_WATER) -> np.ndarray:
    """The sun's disc through the surface (H, W, n) for ``camera`` under the
    sea, attenuated by ``exp(-c S)``; zero but where ``open_up``. ``facets``:
    the wave tile's (:class:`aquaspec.light.wave_facets.SurfaceFacets`) or
    None for the flat surface; with unresolved slopes (``facets.s2 > 0``)
    the sun's glitter (:func:`glitter_below`) in place of the disc."""
    c, out, mask, vv, s, normals = _rays_to_surface(camera, open_up, facets, a, b)
    if vv is None:
        return out
    if facets is not None and facets.s2 > 0:
        disc = glitter_below(vv, normals, to_sun_air, sun_irradiance_air,
                             glitter_variance_below(camera, facets.s2, n_water), n_water)
    else:
        disc = sun_through_surface(vv, normals, to_sun_air, sun_irradiance_air,
                                   sun_radius_below(camera, to_sun_air, n_water), n_water)
    out[mask] = np.exp(-c[None, :] * s[:, None]) * disc
    return out
