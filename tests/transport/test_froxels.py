"""The froxels (aquaspec.transport.froxels) against each pixel's own march."""

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.scene.shadowmap import numpy_shadow_map
from aquaspec.shading.sun import sun_radiance


def _sun_scene(width, height):
    """The built-in scene at 4 m under a sun at 50 degrees (azimuth 30), six
    bands of Jerlov IB, ray-cast: ``(camera, G-buffer, sun inputs, keywords of
    sun_radiance for black surfaces with a 512-texel NumPy shadow map)``."""
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import get_water
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.scene.builtin import builtin_scene
    from aquaspec.scene.raycast import raycast_gbuffer
    scene, cam = builtin_scene(4.0, width=width, height=height)
    light = surface_light("sun-sky", sun_elevation_deg=50.0, sun_azimuth_deg=30.0)
    setup = SpectralSetup(get_water("IB"), get_sensor("human"), light, Bands(6),
                          ms_model="seeds")
    sun = setup.sun_inputs()
    hmap, spec = numpy_shadow_map(scene, cam, sun.to_sun, size=512)
    black = dict(rho_of_hits=lambda m: np.zeros((m.sum(), 6)), height_map=hmap, spec=spec)
    return cam, raycast_gbuffer(scene, cam), sun, black


def test_froxels_against_each_pixels_own_march():
    """The renderer's froxels (columns of 8x8 pixels, 64 slices) against each
    pixel's own ray marched in 48 steps, single scattering only, built-in
    scene with the sun ahead (shadows of the board and rocks in the veil)."""
    cam, gb, sun, black = _sun_scene(160, 90)
    frox = sun_radiance(gb, sun, **black)
    march = sun_radiance(gb, sun, method="march", **black)
    rel = np.abs(frox / march - 1.0)
    assert np.median(rel) < 0.005
    assert np.percentile(rel, 99) < 0.06
    assert abs(frox.sum() / march.sum() - 1.0) < 0.01
    with pytest.raises(AquaspecError, match="froxel"):
        sun_radiance(gb, sun, method="exact", **black)


def test_froxel_columns_keep_their_angle_as_the_image_grows():
    """Columns are 8 pixels per 640 of width (16 at 1280x720); 16-pixel columns
    at 320x180, twice as wide in angle as 1280x720's, still meet the 160x90
    test's bounds against each pixel's own march (measured: median 0.28 %,
    99th percentile 5.6 %, as 8-pixel columns at 160x90)."""
    from aquaspec.transport.froxels import froxel_grid, froxel_lookup, froxel_tile, pixel_lengths
    from aquaspec.transport.sun_scattering import band_mean_phase_at
    from aquaspec.scene.shadowmap import map_visibility
    assert [froxel_tile(w) for w in (64, 640, 641, 1280, 1920)] == [8, 8, 16, 16, 24]
    cam, gb, sun, black = _sun_scene(320, 180)
    hmap, spec = black["height_map"], black["spec"]
    march = sun_radiance(gb, sun, method="march", **black)
    grid = froxel_grid(cam, sun, lambda p: map_visibility(hmap, spec, p), tile=16)
    from aquaspec.transport.monzon2022 import hit_before_surface
    d = gb.distance.astype(float)
    s = np.where(hit_before_surface(d, cam.ray_directions()[..., 1], -cam.position[1]), d,
                 np.inf)
    frox = froxel_lookup(grid, cam, s, pixel_lengths(cam, sun), tile=16) * band_mean_phase_at(
        sun.log_phase, cam.ray_directions() @ sun.to_sun)[..., None]
    rel = np.abs(frox / march - 1.0)
    assert np.median(rel) < 0.005
    assert np.percentile(rel, 99) < 0.06
    assert abs(frox.sum() / march.sum() - 1.0) < 0.01
