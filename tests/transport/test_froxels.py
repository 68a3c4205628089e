"""The froxels (aquaspec.transport.froxels) against each pixel's own march."""

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.scene.shadowmap import numpy_shadow_map
from aquaspec.shading.sun import sun_radiance


def test_froxels_against_each_pixels_own_march():
    """The renderer's froxels (columns of 8x8 pixels, 64 slices) against each
    pixel's own ray marched in 48 steps, single scattering only, built-in
    scene with the sun ahead (shadows of the board and rocks in the veil)."""
    from aquaspec.scene.raycast import raycast_gbuffer
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.scene.builtin import builtin_scene
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import get_water
    scene, cam = builtin_scene(4.0, width=160, height=90)
    light = surface_light("sun-sky", sun_elevation_deg=50.0, sun_azimuth_deg=30.0)
    setup = SpectralSetup(get_water("IB"), get_sensor("human"), light, Bands(6),
                          ms_model="seeds")
    gb = raycast_gbuffer(scene, cam)
    sun = setup.sun_inputs()
    hmap, spec = numpy_shadow_map(scene, cam, sun.to_sun, size=512)
    black = dict(rho_of_hits=lambda m: np.zeros((m.sum(), 6)), height_map=hmap, spec=spec)
    frox = sun_radiance(gb, sun, **black)
    march = sun_radiance(gb, sun, method="march", **black)
    rel = np.abs(frox / march - 1.0)
    assert np.median(rel) < 0.005
    assert np.percentile(rel, 99) < 0.06
    assert abs(frox.sum() / march.sum() - 1.0) < 0.01
    with pytest.raises(AquaspecError, match="froxel"):
        sun_radiance(gb, sun, method="exact", **black)
