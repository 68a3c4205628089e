"""The wind sea seen from below on the GPU (below_waves.wgsl) against NumPy."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import Reflectance
from aquaspec.colour.sensors import get_sensor, radiance_to_rgb
from aquaspec.light.sky import surface_light
from aquaspec.light.wave_facets import surface_facets
from aquaspec.light.waves import Waves
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.shading.below_waves import window_correction

pytestmark = pytest.mark.gpu


@pytest.mark.parametrize("n_bands", [5, 8])
def test_below_waves_pass_matches_numpy(device, n_bands):
    from aquaspec.gpu.gbuffer import GBufferTextures
    from aquaspec.gpu.passes.below_waves import BelowWavesPass
    setup = SpectralSetup(load_water("IB"), get_sensor("nikon-5100-npl"),
                          surface_light("overcast"), Bands(n_bands), surface="flat")
    med, tables = setup.medium([]), setup.lightfield_tables()
    facets = surface_facets(Waves(5.0, grid=64))
    p = np.array([0.3, -3.0, 1.0])
    cam = Camera.look_at(p, p + [0.2, 0.9, -0.4], width=72, height=40, fov_y_deg=100.0)
    h, w = cam.height, cam.width
    distance = np.full((h, w), np.inf, np.float32)
    distance[:, :12] = 1.5                        # a wall in front on the left
    distance[:6, 30:40] = 50.0                    # something beyond the surface
    gb = GBuffer(cam, distance, np.tile(np.float32([0, 0, 1]), (h, w, 1)),
                 np.zeros((h, w), np.uint32), np.zeros((h, w, 3), np.float32),
                 materials=[Reflectance.constant(0.3)])
    tex = GBufferTextures(device, w, h)
    tex.upload(gb)
    gpu_pass = BelowWavesPass(device, w, h)
    gpu_pass.set_medium(tables, facets, a=med["a"], b=med["b"], e0=med["e0"],
                        response_weights=med["response_weights"])
    gpu = gpu_pass.render(cam, tex.textures["surface"])
    v = cam.ray_directions()
    s_top = 3.0 / np.where(v[..., 1] > 0, v[..., 1], 1.0)
    open_up = ~np.isfinite(distance) | (distance > s_top)
    ref = radiance_to_rgb(window_correction(cam, open_up, tables, facets, a=med["a"], b=med["b"],
                                            e0=med["e0"]), med["response_weights"])
    assert np.abs(ref).max() > 0
    np.testing.assert_allclose(gpu, ref, rtol=2e-3, atol=2e-4 * np.abs(ref).max())


@pytest.mark.parametrize("waves", [None, 5.0])
def test_the_sun_through_the_surface_matches_numpy(device, waves):
    """The sun's disc seen from below through the flat surface and through
    the waves' facets, on the GPU against NumPy (away from the disc's rim,
    where a float32 ray may fall either side)."""
    from aquaspec.gpu.passes.below_waves import BelowWavesPass
    from aquaspec.shading.above_water import sky_shape, sun_in_air
    from aquaspec.shading.below_waves import sun_disc_below
    light = surface_light("sun-sky", sun_elevation_deg=70.0, sun_azimuth_deg=0.0)
    setup = SpectralSetup(load_water("IB"), get_sensor("nikon-5100-npl"), light, Bands(6),
                          surface="flat")
    med, tables, sun = setup.medium([]), setup.lightfield_tables(), setup.sun_inputs()
    facets = None if waves is None else surface_facets(Waves(waves, grid=64))
    p = np.array([0.0, -2.0, 0.0])
    cam = Camera.look_at(p, p + sun.to_sun, width=96, height=64, fov_y_deg=30.0)
    h, w = cam.height, cam.width
    tex = _open_water_textures(device, cam)
    gpu_pass = BelowWavesPass(device, w, h)
    gpu_pass.set_medium(tables, facets, a=med["a"], b=med["b"], e0=med["e0"],
                        response_weights=med["response_weights"], sun=sun)
    gpu = gpu_pass.render(cam, tex.textures["surface"])
    to_air, e_air = sun_in_air(sun)
    open_up = np.ones((h, w), bool)
    bands = sun_disc_below(cam, open_up, facets, to_air, e_air, a=med["a"], b=med["b"])
    # The sky through the surface is the clear sky about the sun, flat or not.
    bands = bands + window_correction(cam, open_up, tables, facets, a=med["a"], b=med["b"],
                                      e0=med["e0"], sky_at=sky_shape(sun))
    ref = radiance_to_rgb(bands, med["response_weights"])
    lit = sun_disc_below(cam, open_up, facets, to_air, e_air, a=med["a"], b=med["b"])[..., 0] > 0
    assert lit.any()
    rim = np.zeros_like(lit)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            rim |= np.roll(np.roll(lit, dy, 0), dx, 1) != lit
    keep = ~rim
    np.testing.assert_allclose(gpu[keep], ref[keep], rtol=3e-3, atol=2e-4 * np.abs(ref).max())


def test_set_slopes_moves_the_sea_without_new_tables(device):
    """set_slopes with the same sea at another instant gives the frame that a
    fresh set_medium at that instant gives; a tile of another size is refused."""
    from aquaspec.errors import AquaspecError
    from aquaspec.gpu.passes.below_waves import BelowWavesPass
    setup = SpectralSetup(load_water("IB"), get_sensor("human"), surface_light("overcast"),
                          Bands(4), surface="flat")
    med, tables = setup.medium([]), setup.lightfield_tables()
    p = np.array([0.0, -3.0, 0.0])
    cam = Camera.look_at(p, p + [0.0, 1.0, -0.6], width=48, height=32, fov_y_deg=70.0)
    h, w = cam.height, cam.width
    tex = _open_water_textures(device, cam)
    kw = dict(a=med["a"], b=med["b"], e0=med["e0"], response_weights=med["response_weights"])
    early, late = (surface_facets(Waves(6.0, grid=32, time_s=t)) for t in (0.0, 1.1))
    moved = BelowWavesPass(device, w, h)
    moved.set_medium(tables, early, **kw)
    first = moved.render(cam, tex.textures["surface"])
    moved.set_slopes(late)
    fresh = BelowWavesPass(device, w, h)
    fresh.set_medium(tables, late, **kw)
    want = fresh.render(cam, tex.textures["surface"])
    np.testing.assert_array_equal(moved.render(cam, tex.textures["surface"]), want)
    assert np.abs(first - want).max() > 0
    with pytest.raises(AquaspecError, match="this pass has the sea of a"):
        moved.set_slopes(surface_facets(Waves(6.0, grid=64)))


def _open_water_textures(device, cam):
    """The frame's G-buffer textures of a camera that sees only open water."""
    from aquaspec.gpu.gbuffer import GBufferTextures
    h, w = cam.height, cam.width
    gb = GBuffer(cam, np.full((h, w), np.inf, np.float32),
                 np.tile(np.float32([0, 0, 1]), (h, w, 1)), np.zeros((h, w), np.uint32),
                 np.zeros((h, w, 3), np.float32), materials=[Reflectance.constant(0.3)])
    tex = GBufferTextures(device, w, h)
    tex.upload(gb)
    return tex
