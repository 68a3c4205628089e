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
  step and pass; under waves its glitter over the unresolved slopes.
- With a scene (meshes), the scene mirrored in the surface (total internal
  reflection outside Snell's window, Fresnel inside it) in place of the open
  water's mirror where a mirrored ray meets it
  (:mod:`aquaspec.shading.below_mirror`: a G-buffer from the camera
  mirrored in ``y = 0``, ray cast in NumPy, rasterised on the GPU by the
  frame's raster pass into its own targets, shaded by
  :class:`aquaspec.gpu.passes.below_mirror.BelowMirrorPass`); under waves
  each ray is mirrored by the tile's facet and looked up in the mirrored
  camera's image along its mirrored direction.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.light.wave_facets import surface_facets
from aquaspec.rendering.above import above_water, at_waterline, waterline_sky
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.shading.above_water import sky_shape, sun_in_air
from aquaspec.shading.below_mirror import mirrored_camera, scene_in_mirror
from aquaspec.shading.below_waves import sun_disc_below, window_correction


def surface_seen_from_water(setup, view, shaded, backend: str):
    """``shaded`` with the waterline's sky, or the surface seen from below:
    the waves' change, the sun's disc or glitter through it and the scene
    mirrored in it (module docstring); as it was otherwise."""
    if at_waterline(view.camera):
        linear, radiance = waterline_sky(setup, view.camera, shaded.linear, shaded.radiance)
        return dataclasses.replace(shaded, linear=linear, radiance=radiance)
    if setup.surface != "flat" or setup.ms_model != "lightfield" or above_water(view.camera):
        return shaded
    sun = setup.sun_inputs() if setup.light.sun is not None else None
    cam = view.camera
    v = cam.ray_directions()
    s_top = -float(cam.position[1]) / np.where(v[..., 1] > 0, v[..., 1], 1.0)
    # (The GPU's frame keeps its G-buffer on the device: its pass finds the open water.)
    mirror = view.scene is not None and bool(np.any(
        v[..., 1] > 0 if shaded.gbuffer is None else _open_up(v, s_top, shaded.gbuffer.distance)))
    if setup.waves is None and sun is None and not mirror:
        return shaded
    med = setup.medium(view.scene.materials if mirror else [])
    tables = setup.lightfield_tables()
    facets = None if setup.waves is None else surface_facets(setup.waves)
    radiance = shaded.radiance
    if backend == "gpu" and radiance is None:
        r = shaded.renderer
        surface = r.deferred.gbuffer.textures["surface"]
        change = 0.0
        if setup.waves is not None or sun is not None:
            gpu = _below_pass(r.deferred.device, cam.width, cam.height)
            gpu.set_medium(tables, facets, a=med["a"], b=med["b"], e0=med["e0"],
                           response_weights=med["response_weights"], sun=sun)
            change = gpu.render(cam, surface).astype(np.float64)
        if mirror:
            change = change + _mirror_on_gpu(r, view, med, tables, sun, facets, surface)
    else:
        open_up = _open_up(v, s_top, shaded.gbuffer.distance)
        bands = 0.0
        if facets is not None or sun is not None:
            bands = window_correction(cam, open_up, tables, facets, a=med["a"], b=med["b"],
                                      e0=med["e0"], sky_at=None if sun is None else sky_shape(sun))
        if sun is not None:
            to_air, e_air = sun_in_air(sun)
            bands = bands + sun_disc_below(cam, open_up, facets, to_air, e_air, a=med["a"],
                                           b=med["b"])
        if mirror:
            bands = bands + scene_in_mirror(
                cam, open_up, raycast_gbuffer(view.scene, mirrored_camera(cam)), tables,
                **{k: med[k] for k in MIRROR_KEYS}, sun=sun, facets=facets)
        change = radiance_to_rgb(bands, med["response_weights"])
        if radiance is not None:
            radiance = radiance + bands
    return dataclasses.replace(shaded, linear=shaded.linear + change, radiance=radiance,
                               surface_change=change)


#: The medium's arguments :func:`aquaspec.shading.below_mirror.scene_in_mirror` takes.
MIRROR_KEYS = ("a", "b", "e0", "material_bands", "sigmoid_centers_t")


def _open_up(v, s_top, distance):
    """Rays going up that reach the surface: no hit, or a hit beyond it."""
    return (v[..., 1] > 0) & (~np.isfinite(distance) | (distance > s_top))


def _mirror_on_gpu(r, view, med, tables, sun, facets, surface):
    """The scene mirrored in the surface on the GPU (camera RGB, float64):
    the mirrored camera's G-buffer drawn by the frame's raster pass into its
    own targets, then :class:`~aquaspec.gpu.passes.below_mirror.BelowMirrorPass`."""
    cam = view.camera
    gpu = _mirror_pass(r.deferred.device, cam.width, cam.height)
    gpu.set_medium(tables, **{k: med[k] for k in MIRROR_KEYS if k not in ("a", "b", "e0")},
                   a=med["a"], b=med["b"], e0=med["e0"],
                   response_weights=med["response_weights"], sun=sun, facets=facets)
    encoder = r.deferred.device.create_command_encoder()
    targets = gpu.mirror_gbuffer(encoder, r.raster, view.scene, cam)
    r.deferred.device.queue.submit([encoder.finish()])
    return gpu.render(cam, surface, targets).astype(np.float64)


@functools.lru_cache(maxsize=2)
def _mirror_pass(device, width: int, height: int):
    """The mirrored-scene pass at one size, compiled once per device."""
    from aquaspec.gpu.passes.below_mirror import BelowMirrorPass   # deferred: wgpu on the GPU path
    return BelowMirrorPass(device, width, height)


@functools.lru_cache(maxsize=2)
def _below_pass(device, width: int, height: int):
    """The waves-from-below pass at one size, compiled once per device."""
    from aquaspec.gpu.passes.below_waves import BelowWavesPass   # deferred: wgpu on the GPU path
    return BelowWavesPass(device, width, height)
