"""The water surface as a camera under (or at) the sea sees it: step 3's last
touch in :func:`aquaspec.rendering.api.render`.

- At the waterline, rays going up see the sky in air
  (:func:`aquaspec.rendering.above.waterline_sky`).
- Under a wind sea (``waves=``, ``--wind``) with the flat surface's light
  field, the rays going up through open water meet the wave tile's facets:
  Snell's window breaks up and moves with the waves
  (:mod:`aquaspec.shading.below_waves`; on the GPU
  :class:`aquaspec.gpu.passes.below_waves.BelowWavesPass`, reading the
  frame's G-buffer). The change is added to the image (and the band
  radiance) and kept in ``shaded.surface_change``: the image-formation
  layers' backscatter (the image with every surface black) gets it too, the
  sky and water seen through the waves being the water's light, not a
  surface's.
- With a sun, its disc seen through the surface (flat, or the waves'
  facets; :func:`aquaspec.shading.below_waves.sun_disc_below`), in the same
  step and pass.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.light.wave_facets import surface_facets
from aquaspec.rendering.above import at_waterline, waterline_sky
from aquaspec.shading.above_water import sun_in_air
from aquaspec.shading.below_waves import sun_disc_below, window_correction


def surface_seen_from_water(setup, view, shaded, backend: str):
    """``shaded`` with the waterline's sky, or the waves' change to the surface
    seen from below and the sun's disc through it (module docstring); as it
    was otherwise."""
    if at_waterline(view.camera):
        linear, radiance = waterline_sky(setup, view.camera, shaded.linear, shaded.radiance)
        return dataclasses.replace(shaded, linear=linear, radiance=radiance)
    sun = setup.sun_inputs() if setup.light.sun is not None else None
    if (setup.waves is None and sun is None) or setup.surface != "flat" \
            or setup.ms_model != "lightfield":
        return shaded
    med = setup.medium([])
    tables, cam = setup.lightfield_tables(), view.camera
    facets = None if setup.waves is None else surface_facets(setup.waves)
    radiance = shaded.radiance
    if backend == "gpu" and radiance is None:
        r = shaded.renderer
        gpu = _below_pass(r.deferred.device, cam.width, cam.height)
        gpu.set_medium(tables, facets, a=med["a"], b=med["b"], e0=med["e0"],
                       response_weights=med["response_weights"], sun=sun)
        change = gpu.render(cam, r.deferred.gbuffer.textures["surface"]).astype(np.float64)
    else:
        v = cam.ray_directions()
        s_top = -float(cam.position[1]) / np.where(v[..., 1] > 0, v[..., 1], 1.0)
        dist = shaded.gbuffer.distance
        open_up = (v[..., 1] > 0) & (~np.isfinite(dist) | (dist > s_top))
        bands = 0.0
        if facets is not None:
            bands = window_correction(cam, open_up, tables, facets, a=med["a"], b=med["b"],
                                      e0=med["e0"])
        if sun is not None:
            to_air, e_air = sun_in_air(sun)
            bands = bands + sun_disc_below(cam, open_up, facets, to_air, e_air, a=med["a"],
                                           b=med["b"])
        change = radiance_to_rgb(bands, med["response_weights"])
        if radiance is not None:
            radiance = radiance + bands
    return dataclasses.replace(shaded, linear=shaded.linear + change, radiance=radiance,
                               surface_change=change)


@functools.lru_cache(maxsize=2)
def _below_pass(device, width: int, height: int):
    """The waves-from-below pass at one size, compiled once per device."""
    from aquaspec.gpu.passes.below_waves import BelowWavesPass   # deferred: wgpu on the GPU path
    return BelowWavesPass(device, width, height)
