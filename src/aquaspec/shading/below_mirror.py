"""The scene mirrored in the sea surface seen from below (NumPy reference).

Conventions: metres, y up, the mean surface the plane ``y = 0``, depth ``d =
-y``; a camera at depth ``d_o`` under the sea, unit view directions ``v``
from it. A ray going up through open water meets the flat surface at ``S =
d_o / v_y`` and is mirrored there into ``r = (v_x, -v_y, v_z)`` with the
surface's reflectance ``R(v_y) = 1 - T_out(v_y)`` (1 outside Snell's window:
total internal reflection; :func:`aquaspec.medium.interface.fresnel_transmittance_out`).
The flat surface's light field (its ``mirrored_top`` table) puts there the
*open water* seen along ``r``; where ``r`` meets the scene (rocks, the seabed
mesh, a chart) at ``S2`` beyond the surface, the light field's radiance
along ``r`` from depth 0
(:meth:`aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance`
with ``depth_o = 0``, ``v_y = r_y``, ``s = S2``, the hit's reflectance, depth
and normal) replaces the open water's, so the image gains

    Delta = T'(S) R(v_y) (L(0, r; S2, hit) - L(0, r; open water))
          = T'(S) R(v_y) T'(S2) (L_hit - L_bg(d_2, r))

with ``T'(x) = exp(-(c - f b) x)`` the beam's transmittance (the forward
cone counted as unscattered, as the light field carries a target's light
against the background it hides: the mirror's change is such a target, seen
at ``S``); the second line is the light field's two-point form, with
``L_hit`` the hit's Lambertian radiance and ``L_bg(d_2, r)`` the open
water's radiance at the hit's depth ``d_2`` looking along ``r``
(:func:`mirror_background_table` tabulates it for the GPU). With a sun, ``L_hit`` gains the refracted beam on the hit,
``rho E_b(d_2) max(0, n . to_sun) / pi``, unshadowed and without caustics.

The mirrored rays are those of the *mirrored camera*
(:func:`mirrored_camera`: the camera reflected in ``y = 0``, its image flipped
left to right), so the hits are one G-buffer of the scene seen from it
(:func:`aquaspec.scene.raycast.raycast_gbuffer` here, the raster pass on
the GPU), its distance ``S + S2``. A first hit closer than ``S`` is above the
water (a rock sticking out): the scene below it is not seen there and the
open water's mirror stays. Under a wind sea the ray is mirrored by the
wave tile's facet where it meets the mean plane, ``r = v - 2 (v . n) n``,
with ``R(v . n)``, and the hit is the mirrored camera's along ``r`` (its
pixel whose ray is along ``r``): the scene in the surface wobbles with the
waves as the open water's mirror does (:mod:`aquaspec.shading.below_waves`,
whose change this one adds to). The approximation: the mirrored camera's
ray along ``r`` leaves the surface where the flat mirror's would, not at the
point the camera's ray meets it (off by ``S`` times the facet's tilt
sideways, small against the distances to the scene for gentle slopes);
``S2`` is the length along ``r`` from the surface down to the hit's depth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.light.sun import surface_irradiance
from aquaspec.medium.interface import FLAT_NORMAL, N_WATER, fresnel_transmittance_out
from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import hit_reflectance

#: Nodes of :func:`mirror_background_table` over depth (on ``sqrt(d / D)``) and
#: over the mirrored ray's ``r_y`` (on its angle, as the light field's tables).
BACKGROUND_DEPTH_NODES = 96
BACKGROUND_COS_NODES = 48

_MIRROR = np.array([1.0, -1.0, 1.0])


def mirrored_camera(camera: Camera) -> Camera:
    """``camera`` reflected in the surface ``y = 0``: its pixel ``(i, W - 1 -
    j)`` looks along the mirror image of ``camera``'s pixel ``(i, j)`` ray (a
    mirror turns a right-handed camera left-handed; the image's columns are
    flipped and ``cx`` with them to stay right-handed)."""
    return Camera(camera.position * _MIRROR, camera.forward * _MIRROR,
                  camera.true_up * _MIRROR, camera.width, camera.height, camera.fx,
                  camera.fy, camera.width - camera.cx, camera.cy, camera.near, camera.far)


@dataclass(frozen=True)
class MirrorHits:
    """The pixels whose mirrored ray meets the scene below the surface:
    ``mask`` (H, W), and per such pixel (P,) ``v_y``, the distance ``s_top``
    to the surface, the ray's cosine ``cos_i`` to the facet it is mirrored
    by, the mirrored ray's ``r_y``, ``s2`` beyond the surface to the hit, the
    hit's depth ``depth`` and unit normal ``normal`` (P, 3), its
    ``material`` and ``sigmoid`` (P, 3)."""

    mask: np.ndarray
    v_y: np.ndarray
    s_top: np.ndarray
    cos_i: np.ndarray
    r_y: np.ndarray
    s2: np.ndarray
    depth: np.ndarray
    normal: np.ndarray
    material: np.ndarray
    sigmoid: np.ndarray


def mirror_hits(camera: Camera, open_up, mirror_gbuffer, facets=None) -> MirrorHits:
    """The hits of ``mirror_gbuffer`` (a G-buffer of the scene from
    :func:`mirrored_camera` of ``camera``) that the rays of ``camera`` going
    up through open water (``open_up`` (H, W)) see in the surface.

    Each ray is mirrored at the mean plane by the facet there (``facets``:
    :class:`aquaspec.light.wave_facets.SurfaceFacets`, or None for the flat
    surface; a facet facing away from the ray is taken upright, as
    :mod:`aquaspec.shading.below_waves` takes it); the mirrored ray ``r`` is
    looked up in the mirrored camera's pixel whose ray is along ``r`` (its
    own pixel for the flat surface), and the hit is that pixel's, so under
    waves the scene seen in a tilted facet is the one the mirrored camera
    sees along ``r`` (exact for the flat surface; under waves the point the
    ray leaves the surface from moves by the facet's tilt, which is left
    out). No hit where ``r`` leaves the image, goes up, or its hit is above
    the water."""
    v = camera.ray_directions()
    h, w = v.shape[:2]
    o = np.asarray(camera.position, dtype=float)
    up = v[..., 1] > 0
    cand = np.asarray(open_up, dtype=bool) & up
    vv = v[cand]
    s_top = -o[1] / vv[:, 1]
    p = o + vv * s_top[:, None]
    n = (np.broadcast_to(FLAT_NORMAL, vv.shape) if facets is None
         else facets.normals(p[:, 0], p[:, 2]))
    cos_i = np.sum(vv * n, axis=1)
    n = np.where((cos_i > 0)[:, None], n, FLAT_NORMAL)
    cos_i = np.where(cos_i > 0, cos_i, vv[:, 1])
    r = vv - 2.0 * cos_i[:, None] * n
    m = r * _MIRROR
    fwd = m @ camera.forward
    safe = np.where(fwd > 0, fwd, 1.0)
    j = np.floor(camera.cx + camera.fx * (m @ camera.right) / safe).astype(np.int64)
    i = np.floor(camera.cy - camera.fy * (m @ camera.true_up) / safe).astype(np.int64)
    ok = (r[:, 1] < 0) & (fwd > 0) & (j >= 0) & (j < w) & (i >= 0) & (i < h)
    j, i = np.where(ok, j, 0), np.where(ok, i, 0)
    col = w - 1 - j
    dist = mirror_gbuffer.distance[i, col].astype(float)
    hit = (o * _MIRROR) + np.where(np.isfinite(dist), dist, 0.0)[:, None] \
        * (v[i, j] * _MIRROR)
    ok &= np.isfinite(dist) & (hit[:, 1] < 0)
    mask = np.zeros((h, w), bool)
    mask[cand] = ok
    i, col, hit = i[ok], col[ok], hit[ok]
    # S2 along r from the surface to the hit's depth: the light field depends on
    # the path's depths and length only (horizontally uniform water), and so the
    # path and its end agree under waves too (for the flat surface it is |hit - p|).
    return MirrorHits(mask, vv[ok, 1], s_top[ok], cos_i[ok], r[ok, 1],
                      -hit[:, 1] / -r[ok, 1], -hit[:, 1],
                      mirror_gbuffer.normal[i, col].astype(float),
                      mirror_gbuffer.material[i, col],
                      mirror_gbuffer.sigmoid[i, col].astype(float))


def scene_in_mirror(camera: Camera, open_up, mirror_gbuffer, tables, *, a, b, e0,
                    material_bands, sigmoid_centers_t, sun=None, facets=None,
                    n_water: float = N_WATER) -> np.ndarray:
    """``Delta`` (H, W, n) of the module docstring for ``camera`` under the
    sea: zero but where a ray going up through open water (``open_up``) is
    mirrored into the scene. ``mirror_gbuffer``: the scene from
    :func:`mirrored_camera`; ``tables``: the flat surface's light field;
    ``material_bands`` (M, n) and ``sigmoid_centers_t`` (n,): the
    reflectances as :func:`aquaspec.shading.shade.shade_gbuffer` takes them;
    ``sun``: :class:`~aquaspec.transport.sun_scattering.SunInputs` or None;
    ``facets``: the wave tile's (:func:`mirror_hits`), or None."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    hits = mirror_hits(camera, open_up, mirror_gbuffer, facets)
    out = np.zeros(hits.mask.shape + (a.size,))
    if not hits.mask.any():
        return out
    rho = hit_reflectance(hits.material, hits.sigmoid, np.asarray(material_bands, dtype=float),
                          np.asarray(sigmoid_centers_t, dtype=float))
    col = (lambda x: np.asarray(x, dtype=float)[:, None])
    kw = dict(a=a, b=b, e0=np.asarray(e0, dtype=float), depth_o=col(np.zeros_like(hits.s2)),
              v_y=col(hits.r_y))
    seen = tables.pixel_radiance(**kw, s=col(hits.s2), rho=rho, surface_depth=col(hits.depth),
                                 n_y=col(hits.normal[:, 1]))
    open_water = tables.pixel_radiance(**kw, s=col(np.full_like(hits.s2, np.inf)))
    if sun is not None:
        lit = rho / np.pi * surface_irradiance(sun.beam0, sun.c_sun, hits.depth, hits.normal,
                                               sun.to_sun)
        seen = seen + np.exp(-tables.ray_extinction(a, b) * col(hits.s2)) * lit
    reflectance = 1.0 - fresnel_transmittance_out(hits.cos_i, n_water)
    out[hits.mask] = (np.exp(-tables.ray_extinction(a, b) * col(hits.s_top)) * col(reflectance)
                      * (seen - open_water))
    return out


def mirror_background_table(tables, *, a, b, e0, n_depth: int = BACKGROUND_DEPTH_NODES,
                            n_mu: int = BACKGROUND_COS_NODES) -> np.ndarray:
    """``L_bg(d, r_y)`` (n_depth, n_mu, n): the open water's radiance at depth
    ``d`` looking down along ``r_y``, on nodes ``d = D (i / (n_depth - 1))^2``
    (``D`` the tables' ``max_depth_m``) and ``r_y = -cos(pi j / (2 (n_mu - 1)))``
    (``r_y`` from -1 to 0), for the GPU to read bilinearly (in ``sqrt(d / D)``
    and the angle)."""
    d = float(tables.max_depth_m) * (np.arange(n_depth) / (n_depth - 1.0)) ** 2
    r_y = -np.cos(0.5 * np.pi * np.arange(n_mu) / (n_mu - 1.0))
    dd, rr = np.meshgrid(d, np.minimum(r_y, -1e-4), indexing="ij")
    out = tables.pixel_radiance(a=np.asarray(a, float), b=np.asarray(b, float),
                                e0=np.asarray(e0, float), depth_o=dd.reshape(-1, 1),
                                v_y=rr.reshape(-1, 1), s=np.full((dd.size, 1), np.inf))
    return np.asarray(out, dtype=float).reshape(n_depth, n_mu, -1)
