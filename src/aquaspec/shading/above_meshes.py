"""What a camera above the sea sees under the surface: meshes, and the sun's
caustics on them and on the seabed (NumPy).

The view from above (:func:`aquaspec.shading.above_water.sea_from_above`)
takes, per pixel, the radiance ``L_w(0, t)`` arriving just below the surface
along the refracted ray ``t`` (y up, the surface ``y = 0``, metres). Without
meshes it is the light field's, down to its seabed or into deep water. Here
the refracted rays, leaving from where the camera's rays meet the mean
plane (:func:`rays_into_water`), are cast into the scene
(:func:`aquaspec.scene.raycast.raycast_rays`); where one meets a surface
under the water at distance ``S`` (and above the light field's seabed),
``L_w`` becomes that of a camera at depth 0 looking along ``t`` at a hit
surface (:func:`water_to_hits`):

- the light field's part, ``T(S) rho E(d, n_y) / pi`` plus the water's path
  radiance over ``S``
  (:meth:`~aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance`
  with ``depth_o = 0``), as a camera under water sees a surface;
- with the light field's forward cone (``cone_spread``), the cone's share
  of the light carried from each hit surface is spread over the image as
  under water, its kernel scaled for the view through the surface
  (:func:`_spread_cone`);
- with a sun, its beam on the surface, ``rho / pi E_b(d) max(0, n . s) V
  exp(-c_view S)`` (:func:`aquaspec.light.sun.surface_irradiance`), ``V``
  the sun's shadow map's visibility times, under waves, each band's caustic
  factor (:mod:`aquaspec.light.caustic_sample`) read over the pixel's
  footprint; and the beam scattered once along the ray over ``S``
  (:func:`aquaspec.transport.sun_scattering.single_scattering_open`, not
  shadowed by the scene).

Rays that miss keep the light field's seabed; under waves with a sun its
directly lit share gets the caustics too (:func:`seabed_caustics`). With
the scene's occlusion maps (``render(occlusion=True)``) the hits get the
light of the directions they see, as under water; the water's own shadow
is left out. The parts of meshes above the water are not drawn (their hits
are skipped).
"""

from __future__ import annotations

import numpy as np

from aquaspec.light import caustic_sample
from aquaspec.light.sun import surface_irradiance
from aquaspec.medium.interface import N_WATER, fresnel_transmittance, refract
from aquaspec.scene.gbuffer import hit_reflectance
from aquaspec.scene.raycast import raycast_rays
from aquaspec.scene.shadowmap import NORMAL_OFFSET_TEXELS, map_visibility
from aquaspec.shading.above_water import WAVE_T_TOP, facet_normals
from aquaspec.transport.lightfield.occlusion import occlusion_factor, weights_from_tables
from aquaspec.transport.lightfield.conespread import (node_pyramid_weights, pyramid_weights,
                                                      spread_by_lambda)
from aquaspec.transport.lightfield.conespread import spread as pyramid_spread
from aquaspec.transport.sun_scattering import (phase_from_log_table, scattering_cosine,
                                               single_scattering_open)


def rays_into_water(camera, facets=None, n_water: float = N_WATER):
    """The camera's rays going down, refracted into the sea: ``(down (H, W),
    origins (H, W, 3), t (H, W, 3))``: where each ray meets the mean plane
    ``y = 0`` and its refracted unit direction (the flat surface's, or the
    wave tile's facet's, as :func:`aquaspec.shading.above_water.sea_from_above`
    refracts them). Rays not going down keep the camera's position and
    their own direction."""
    v = camera.ray_directions().astype(np.float64)
    shape = v.shape
    v = v.reshape(-1, 3)
    down = v[:, 1] < 0
    origins = np.broadcast_to(np.asarray(camera.position, dtype=float), v.shape).copy()
    t = v.copy()
    if np.any(down):
        vd = v[down]
        s = float(camera.position[1]) / -vd[:, 1]
        origins[down] = camera.position + s[:, None] * vd
        origins[down, 1] = 0.0
        td, _ = refract(vd, facet_normals(camera, vd, facets), n_water)
        td[:, 1] = np.minimum(td[:, 1], -WAVE_T_TOP if facets is not None else -1e-12)
        t[down] = td / np.linalg.norm(td, axis=1, keepdims=True)
    return down.reshape(shape[:2]), origins.reshape(shape), t.reshape(shape)


def water_to_hits(scene, camera, tables, *, a, b, e0, material_bands, sigmoid_centers_t,
                  sun=None, sun_shadow=None, facets=None, occlusion=None,
                  n_water: float = N_WATER, rays=None):
    """``(hit (H, W), L_w (P, n), spread (H, W, n) or None)``: the pixels of
    ``camera`` (above the sea) whose refracted rays meet a surface of
    ``scene`` under the water before the tables' seabed, the radiance
    arriving just below the surface along those rays (module docstring),
    and, with the light field's forward cone, that cone's light spread over
    the image (to add below the surface at every pixel; :func:`_spread_cone`). ``material_bands``,
    ``sigmoid_centers_t``: the scene's materials on the bands
    (:meth:`aquaspec.rendering.setup.SpectralSetup.medium`); ``sun``: the
    sun's :class:`~aquaspec.transport.sun_scattering.SunInputs` (with its
    caustic map under waves) or None; ``sun_shadow``: the scene's
    ``(height_map, spec)`` (:func:`aquaspec.scene.shadowmap.numpy_shadow_map`)
    or None; ``occlusion``: the scene's
    :class:`~aquaspec.scene.occlusion.OcclusionMaps` (``render(occlusion=True)``):
    each hit gets the light field's light of the directions it sees
    (:func:`aquaspec.transport.lightfield.occlusion.occlusion_factor`), as
    under water, or None. ``rays``: :func:`rays_into_water`'s result, when
    the caller has it."""
    down, origins, t = rays_into_water(camera, facets, n_water) if rays is None else rays
    hits = raycast_rays(scene, origins, t)
    s = hits.distance
    depth = -(origins[..., 1] + s * t[..., 1])
    hit = down & np.isfinite(s) & (depth > 0) & (depth < tables.seabed_depth_m)
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    e0 = np.asarray(e0, dtype=float)
    if not np.any(hit):
        return hit, np.zeros((0, a.size)), None
    s_h, t_h, d_h = s[hit], t[hit], depth[hit]
    normal = hits.normal[hit].astype(float)
    rho = hit_reflectance(hits.material[hit], hits.sigmoid[hit],
                          np.asarray(material_bands, dtype=float),
                          np.asarray(sigmoid_centers_t, dtype=float))
    occluded = {}
    if occlusion is not None and not occlusion.empty:
        weights = weights_from_tables(tables, occlusion.directions, occlusion.solid_angle,
                                      a=a, b=b)
        unit = normal / np.linalg.norm(normal, axis=1, keepdims=True)
        points = origins[hit] + t_h * s_h[:, None]
        occluded["surface_scale"] = occlusion_factor(weights, d_h, unit,
                                                     *occlusion.visibility(points, unit))
    out = tables.pixel_radiance(a=a, b=b, e0=e0, depth_o=np.zeros((s_h.size, 1)),
                                v_y=t_h[:, 1:2], s=s_h[:, None], rho=rho,
                                surface_depth=d_h[:, None], n_y=normal[:, 1:2],
                                split_cone=tables.cone is not None, **occluded)
    spread = None
    if tables.cone is not None:
        out, cone = out
        air = np.linalg.norm(origins[hit] - camera.position, axis=1)
        spread = _spread_cone(camera, tables, hit, cone, s_h,
                              float(np.median(s_h / (air + s_h / n_water))))
    out = np.asarray(out, dtype=float)
    if sun is not None:
        pos = origins[hit] + t_h * s_h[:, None]
        vis = 1.0
        if sun_shadow is not None:
            hmap, spec = sun_shadow
            vis = map_visibility(hmap, spec, pos + normal * (NORMAL_OFFSET_TEXELS * spec.texel))
        e = surface_irradiance(sun.beam0, sun.c_sun, d_h, normal, sun.to_sun, vis)
        if sun.caustics is not None:
            e = e * _caustic_factor(sun.caustics, camera, origins[hit], pos, s_h)
        out += rho / np.pi * e * np.exp(-sun.c_view * s_h[:, None])
        out += single_scattering_open(
            b=sun.b, phase_value=phase_from_log_table(
                sun.log_phase, scattering_cosine(-np.asarray(sun.to_sun, float), t_h)),
            beam0=sun.beam0, c_sun=sun.c_sun, c_view=sun.c_view, depth_o=np.zeros(s_h.size),
            v_y=t_h[:, 1], s=s_h, mu0=sun.mu0)
    return hit, out, spread


def _spread_cone(camera, tables, hit, cone, s, scale: float) -> np.ndarray:
    """The forward cone's light of the hits (``cone`` (P, n), the part the
    cone adds to the light carried from each surface, at distances ``s``
    (P,)) spread over the image (H, W, n) with the light field's kernel, as
    under water (:mod:`aquaspec.transport.lightfield.conespread`), its
    angles times ``scale``. Under water the kernel's angle is the cone's
    lateral offset over the distance to the camera; seen through the
    surface from ``L`` m of air that offset, ``S`` m down the water, appears
    under the angle offset / (L + S / n) (the apparent depth), so the
    caller's ``scale`` is the hits' median ``S / (L + S / n)``: ``n`` for a
    camera at the surface, smaller higher up."""
    h, w = hit.shape
    image = np.zeros((h, w, cone.shape[-1]))
    image[hit] = cone
    fy = float(camera.fy) * scale
    c = tables.cone
    if c.multiple:
        lam = np.zeros_like(image)
        lam[hit] = np.asarray(c.weight, dtype=float) * s[:, None]
        return spread_by_lambda(image, lam, c.lambda_nodes, node_pyramid_weights(c, fy, h, w))
    return pyramid_spread(image, pyramid_weights(c, fy, h, w))


def _caustic_factor(cmap, camera, origins, pos, s):
    """Each band's caustic factor (P, n or 1) at points ``pos`` (P, 3) seen
    from ``camera`` through the surface at ``origins``, over the pixel's
    footprint (the whole path's length over the focal length)."""
    path = np.linalg.norm(origins - camera.position, axis=1) + s
    factor = caustic_sample.sample(cmap, pos, path / float(camera.fx))
    return caustic_sample.band_factor(cmap, factor, -pos[:, 1])


def seabed_caustics(camera, tables, sun, *, facets=None, skip=None,
                    n_water: float = N_WATER, rays=None) -> np.ndarray:
    """The caustics on the light field's flat seabed seen from above, (H, W,
    n): what the focused beam adds to (or takes from) the seabed's evenly
    lit share, ``albedo / pi E_b(H) mu0 (C_i - 1) exp(-c_view S)`` along
    each refracted ray that reaches the seabed at distance ``S`` (zero
    elsewhere, and where ``skip`` (H, W) is set, e.g. the pixels that see a
    mesh), with the tables' seabed albedo; zero without a caustic map in
    ``sun`` (no waves) or a seabed in ``tables``. ``rays``: as
    :func:`water_to_hits`'."""
    down, origins, t = rays_into_water(camera, facets, n_water) if rays is None else rays
    bed = float(tables.seabed_depth_m)
    n = np.asarray(sun.b).size
    out = np.zeros(down.shape + (n,))
    reach = down if skip is None else down & ~skip
    if not np.isfinite(bed) or sun.caustics is None or not np.any(reach):
        return out
    t_r = t[reach]
    s = bed / -t_r[:, 1]
    pos = origins[reach] + t_r * s[:, None]
    up = np.broadcast_to(np.array([0.0, 1.0, 0.0]), pos.shape)
    e = surface_irradiance(sun.beam0, sun.c_sun, np.full(s.size, bed), up, sun.to_sun)
    c = _caustic_factor(sun.caustics, camera, origins[reach], pos, s)
    out[reach] = (np.asarray(tables.seabed_albedo, dtype=float) / np.pi * e * (c - 1.0)
                  * np.exp(-sun.c_view * s[:, None]))
    return out


def surface_reflectance(camera, facets=None, n_water: float = N_WATER) -> np.ndarray:
    """The surface's Fresnel reflectance (H, W) for ``camera``'s rays going
    down (0 elsewhere), at the flat surface or the wave tile's facets: what
    :func:`aquaspec.shading.above_water.sea_from_above` weighs the water's
    light with, ``1 - R``."""
    v = camera.ray_directions().reshape(-1, 3)
    r = np.zeros(v.shape[0])
    down = v[:, 1] < 0
    n = facet_normals(camera, v[down], facets)
    r[down] = 1.0 - fresnel_transmittance(-np.sum(v[down] * n, axis=1), n_water)
    return r.reshape(camera.height, camera.width)
