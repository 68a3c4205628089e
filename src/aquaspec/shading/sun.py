"""The sun's terms of a G-buffer, per pixel (NumPy reference).

Each pixel gets the lit surface's light carried to the camera,
``rho / pi E_b(d) max(0, n . to_sun) V exp(-c_view S)``
(:func:`aquaspec.light.sun.surface_irradiance`), plus the beam scattered once
along its ray (:mod:`aquaspec.transport.sun_scattering`, read from the froxels
of :mod:`aquaspec.transport.froxels`). ``V`` is the shadow map's visibility
(:mod:`aquaspec.scene.shadowmap`) times the caustic factor under waves
(:mod:`aquaspec.light.caustics`), read over the pixel's footprint, each
band's (:func:`aquaspec.light.caustics.band_factor`). The GPU
twin is :mod:`aquaspec.gpu.passes.sun`.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.light import caustics
from aquaspec.light.caustic_sample import band_factor
from aquaspec.light.sun import surface_irradiance
from aquaspec.scene.camera import camera_depth
from aquaspec.scene.shadowmap import NORMAL_OFFSET_TEXELS, ShadowMapSpec, map_visibility
from aquaspec.transport.froxels import froxel_grid, froxel_lookup, pixel_lengths
from aquaspec.transport.monzon2022 import hit_before_surface
from aquaspec.transport.sun_scattering import (TAIL, SunInputs, band_mean_phase_at,
                                               phase_from_log_table, single_scattering_marched)

#: How :func:`sun_radiance` integrates the single scattering.
SS_METHODS = ("froxel", "march")


def sun_radiance(gbuffer, sun: SunInputs, *, rho_of_hits, height_map=None,
                 spec: ShadowMapSpec | None = None, tail: float = TAIL,
                 method: str = "froxel") -> np.ndarray:
    """The sun's band radiance per pixel, (H, W, n): the lit surfaces' light
    carried to the camera plus the beam's single scattering along the ray.

    ``rho_of_hits(mask)`` returns the band reflectance (P, n) of the pixels in
    ``mask`` (H, W). Without a map (``height_map`` None) nothing is shadowed.
    ``method="froxel"`` (the renderer's; twin of the froxel and sun passes of
    :mod:`aquaspec.gpu.passes.sun`) reads the single scattering from
    :func:`aquaspec.transport.froxels.froxel_grid`; ``"march"`` integrates
    each pixel's own ray in ``sun.n_steps`` steps
    (:func:`aquaspec.transport.sun_scattering.single_scattering_marched`), the
    reference the froxels are measured against.
    """
    if method not in SS_METHODS:
        raise AquaspecError(f"single-scattering method {method!r}; accepted: "
                            f"{', '.join(SS_METHODS)}")
    cam = gbuffer.camera
    d_o = camera_depth(cam)
    dirs = cam.ray_directions().astype(float)
    v_y = dirs[..., 1]
    s = gbuffer.distance.astype(float)
    hit = hit_before_surface(s, v_y, d_o)
    s = np.where(hit, s, np.inf)
    mu0 = sun.mu0
    n = sun.b.size
    shadowed = height_map is not None and spec is not None

    def vis_points(points):
        return map_visibility(height_map, spec, points) if shadowed \
            else np.ones(np.shape(points)[:-1])

    def march_light(points, t):
        # The march's reference reads the caustics at each step's own pixel
        # footprint, each band's (a band axis when the map scales them).
        out = vis_points(points)
        if sun.caustics is not None:
            c = caustics.band_factor(sun.caustics, caustics.sample(
                sun.caustics, points, np.abs(t) / cam.fx), -points[..., 1])
            out = out[..., None] * c if c.shape[-1] > 1 else out * c[..., 0]
        return out

    if method == "froxel":
        grid = froxel_grid(cam, sun, vis_points, tail=tail)
        out = (froxel_lookup(grid, cam, s, pixel_lengths(cam, sun, tail=tail))
               * band_mean_phase_at(sun.log_phase, dirs @ sun.to_sun)[..., None])
    else:
        out = np.zeros(s.shape + (n,))
        phase = phase_from_log_table(sun.log_phase, dirs @ sun.to_sun)      # (H, W, n)
        rows = max(1, 200_000 // max(1, cam.width * sun.n_steps))
        for r0 in range(0, cam.height, rows):
            sel = np.zeros(s.shape, bool)
            sel[r0:r0 + rows] = True
            out[sel] = single_scattering_marched(
                b=sun.b, phase_value=phase[sel], beam0=sun.beam0, c_sun=sun.c_sun,
                c_view=sun.c_view, depth_o=np.full(sel.sum(), d_o), v_y=v_y[sel], s=s[sel],
                mu0=mu0, n_steps=sun.n_steps, tail=tail,
                visibility=lambda t, sel=sel: march_light(
                    cam.position + dirs[sel][:, None, :] * t[..., None], t))
    if np.any(hit):
        pos = cam.position + dirs[hit] * s[hit, None]
        normal = gbuffer.normal[hit].astype(float)
        vis = 1.0
        if shadowed:
            vis = map_visibility(height_map, spec,
                                 pos + normal * (NORMAL_OFFSET_TEXELS * spec.texel))
        e = surface_irradiance(sun.beam0, sun.c_sun, -pos[:, 1], normal, sun.to_sun, vis)
        if sun.caustics is not None:        # each band's factor (P, n or 1)
            e = e * caustics.band_factor(sun.caustics, surface_caustics(
                sun.caustics, cam, pos, s[hit]), -pos[:, 1])
        out[hit] += rho_of_hits(hit) / np.pi * e * np.exp(-sun.c_view * s[hit, None])
    return out


def surface_caustics(cmap: caustics.CausticMap | None, camera, pos, s):
    """The caustic factor at surface points ``pos`` (P, 3) seen at distances
    ``s`` (P,), each averaged over its pixel's footprint ``s / fx`` (1 without caustics)."""
    if cmap is None:
        return 1.0
    return caustics.sample(cmap, pos, np.asarray(s, dtype=float) / camera.fx)


def surface_visibility(gbuffer, height_map=None, spec: ShadowMapSpec | None = None,
                       caustics: caustics.CausticMap | None = None):
    """The share of the beam each visible surface gets, (H, W): the shadow
    map's visibility (1 without a map; looked up as :func:`sun_radiance` does,
    off the surface along its normal) times the caustic factor; (H, W, n),
    each band's, when the map scales the bands (:func:`aquaspec.light.caustics.band_factor`)."""
    out = np.ones(gbuffer.distance.shape)
    hit = gbuffer.hit
    if (height_map is None or spec is None) and caustics is None:
        return out
    pos = gbuffer.positions()[hit]
    if height_map is not None and spec is not None:
        out[hit] = map_visibility(height_map, spec, pos + gbuffer.normal[hit].astype(float)
                                  * (NORMAL_OFFSET_TEXELS * spec.texel))
    if caustics is None:
        return out
    c = band_factor(caustics, surface_caustics(caustics, gbuffer.camera, pos,
                                               gbuffer.distance[hit]), -pos[:, 1])
    per_band = np.ones(out.shape + (c.shape[-1],))
    per_band[hit] = out[hit][:, None] * c
    return per_band if c.shape[-1] > 1 else per_band[..., 0]
