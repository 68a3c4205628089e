"""The lamps' terms of a G-buffer, per pixel (NumPy reference of the GPU's lamp pass).

Each pixel gets, for every lamp, the lit surface's light carried to the
camera, ``rho / pi E exp(-c_view S)`` with ``E`` the lamp's irradiance
(:func:`aquaspec.transport.lamp_scattering.lamp_irradiance`) and its glow's
(:func:`aquaspec.transport.lamp_halo.halo_on_surfaces`, unshadowed), plus the
lamp's light scattered once, and its glow scattered towards the camera, along the pixel's ray up to the surface it meets, or
the water surface for an open-water ray going up: read from the lamp's
columns (``veil="froxels"``, :mod:`aquaspec.transport.lamp_froxels`, as the
GPU does) or marched per pixel (``veil="march"``,
:func:`aquaspec.transport.lamp_scattering.single_scattering`, the reference
the columns are measured against). Shadows come
from the lamp's depth maps (:mod:`aquaspec.scene.lamp_shadow`) when they are
given. Conventions: metres, y up, the water surface at y = 0; radiance in
W m^-2 sr^-1 nm^-1 per band. The GPU twin is :mod:`aquaspec.gpu.passes.lamps`.

**The forward cone's share** (``split_cone=True``, with the light field's cone
spread): a lit surface's light reaches the camera with ``T' = exp(-(c - f b) S)``
(``c_view``): the water's scattering within the forward cone is counted as
kept in the beam. That share, ``(T' - T)`` with ``T = exp(-c S)``, is really
spread over the pixels around; as for the daylight
(:meth:`aquaspec.transport.lightfield.tables.LightfieldTables.pixel_radiance`)
it is the share of the surface's contrast against the background it hides,
``(1 - exp(-f b S)) L_s - (1 - exp(-<f b> S)) (V(inf) - V(S))``: ``L_s`` the
lit surface's light at the camera, ``V(S)`` the lamps' veil (single
scattering and glow) up to ``S``, so ``V(inf) - V(S)`` the veil behind the
surface that it blocks, taken with the bands' mean ``<f b>`` (the GPU holds
the veil in camera RGB only).
:func:`aquaspec.shading.shade.shade_gbuffer` takes it off the pixel and
spreads it with the daylight's kernel.
"""

from __future__ import annotations

import numpy as np

from aquaspec.scene.camera import camera_depth
from aquaspec.scene.lamp_shadow import lamp_visibility
from aquaspec.errors import AquaspecError
from aquaspec.transport import monzon2022 as model
from aquaspec.transport.lamp_froxels import LAMP_SLICES, lamp_froxel_grid, lamp_froxel_lookup
from aquaspec.transport.lamp_halo import halo_on_surfaces, halo_tables, halo_veil
from aquaspec.transport.lamp_scattering import (DEFAULT_SAMPLES, LampInputs, lamp_irradiance,
                                                single_scattering)


def lamp_radiance(gbuffer, lamps, *, rho_of_hits, shadows=None,
                  n_samples: int = DEFAULT_SAMPLES, veil: str = "froxels",
                  split_cone: bool = False):
    """The lamps' band radiance per pixel, (H, W, n).

    ``lamps``: :class:`aquaspec.transport.lamp_scattering.LampInputs`, one
    per lamp (placed in the world); ``rho_of_hits(mask)`` returns the band
    reflectance (P, n) of the pixels in ``mask`` (H, W); ``shadows``: per
    lamp ``(faces, maps)`` of :mod:`aquaspec.scene.lamp_shadow` or None (no
    shadow), or None for no shadows at all; ``veil``: ``"froxels"`` (the
    columns of :data:`aquaspec.transport.lamp_froxels.LAMP_SLICES` slices) or
    ``"march"`` (``n_samples`` per pixel). ``split_cone``: return
    ``(radiance, cone)``, ``cone`` (H, W, n) the forward cone's share of the
    lit surfaces' light against the veil they hide (module docstring; zero for
    open water and where ``f b = 0``), part of ``radiance``.
    """
    if veil not in ("froxels", "march"):
        raise AquaspecError(f"veil {veil!r}; accepted: 'froxels', 'march'")
    cam = gbuffer.camera
    d_o = camera_depth(cam)
    dirs = cam.ray_directions().astype(float)
    v_y = dirs[..., 1]
    s = gbuffer.distance.astype(float)
    hit = model.hit_before_surface(s, v_y, d_o)
    s = np.where(hit, s, np.inf)
    # Open water going up ends at the water surface.
    s_ray = model.ray_length(s, np.full(s.shape, d_o), v_y)
    lamps = list(lamps)
    n = np.asarray(lamps[0].b).size if lamps else 0
    out = np.zeros(s.shape + (n,))
    cone = np.zeros(s.shape + (n,)) if split_cone else None
    if not lamps:
        return (out, cone) if split_cone else out
    rho = rho_of_hits(hit) if np.any(hit) else None
    pos = cam.position + dirs[hit] * s[hit, None]
    normal = gbuffer.normal[hit].astype(float)
    for k, inp in enumerate(lamps):
        if not isinstance(inp, LampInputs):
            raise TypeError(f"lamps[{k}] is {type(inp).__name__}; expected LampInputs")
        shadow = None if shadows is None else shadows[k]
        vis_fn = None if shadow is None else (lambda x, sh=shadow: lamp_visibility(*sh, x))
        tables = halo_tables(inp) if inp.halo else None
        if veil == "froxels":
            grid = lamp_froxel_grid(inp, cam, visibility=vis_fn, slices=LAMP_SLICES,
                                    halo_tables=tables)
            v_s = lamp_froxel_lookup(grid, cam, s)
        else:
            v_s = _marched_veil(inp, cam, dirs, s_ray, n_samples, vis_fn, tables)
        out += v_s
        if rho is not None:
            vis = 1.0 if shadow is None else lamp_visibility(*shadow, pos, normals=normal)
            e = lamp_irradiance(inp, pos, normal, vis)
            if inp.halo:
                e = e + halo_on_surfaces(inp, pos, normal, tables)
            l_s = rho / np.pi * e * np.exp(-np.asarray(inp.c_view) * s[hit, None])
            out[hit] += l_s
            fb = inp.forward_share * np.asarray(inp.b, dtype=float)
            if split_cone and np.any(fb > 0):
                # The veil behind the surface, V(inf) - V(S), which it hides.
                v_inf = (lamp_froxel_lookup(grid, cam, np.full(s.shape, np.inf))
                         if veil == "froxels" else
                         _marched_veil(inp, cam, dirs, model.ray_length(
                             np.full(s.shape, np.inf), np.full(s.shape, d_o), v_y),
                             n_samples, vis_fn, tables))
                # (The veil's share with the bands' mean f b: the GPU's veil is
                # in camera RGB.)
                cone[hit] += (-np.expm1(-fb * s[hit, None]) * l_s
                              + np.expm1(-fb.mean() * s[hit, None]) * (v_inf - v_s)[hit])
    return (out, cone) if split_cone else out


def _marched_veil(inp, cam, dirs, s_ray, n_samples, vis_fn, tables) -> np.ndarray:
    """The lamp's veil (single scattering and glow) along each pixel's ray up
    to ``s_ray`` (H, W), marched per pixel: (H, W, n)."""
    shape = s_ray.shape + (np.asarray(inp.b).size,)
    out = single_scattering(inp, cam.position, dirs.reshape(-1, 3), s_ray.reshape(-1),
                            n_samples=n_samples, visibility=vis_fn).reshape(shape)
    if inp.halo:
        out += halo_veil(inp, cam.position, dirs.reshape(-1, 3), s_ray.reshape(-1),
                         tables=tables).reshape(shape)
    return out
