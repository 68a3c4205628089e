"""The GPU's snow field (aquaspec.gpu.passes.snow_field) against its NumPy twin:
frame_splats (SnowField.at, ParticleLight.rgb, splats) and splat_image."""

import numpy as np
import pytest

pytestmark = pytest.mark.gpu

W, H = 150, 90


def _setup(light="overcast"):
    from aquaspec.colour.bands import Bands
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.light.sky import surface_light
    from aquaspec.medium.water import get_water
    from aquaspec.rendering.setup import SpectralSetup
    return SpectralSetup(get_water("IB"), get_sensor("human"), surface_light(light), Bands(8))


def _surface(device, camera, dist):
    from aquaspec.gpu.gbuffer import GBufferTextures
    from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer
    gb = GBufferTextures(device, W, H)
    gb.upload(GBuffer(camera, dist, np.tile([0.0, 0.0, 1.0], (H, W, 1)),
                      np.full((H, W), PER_PIXEL, np.uint32), np.zeros((H, W, 3))))
    return gb.textures["surface"]


@pytest.mark.parametrize("time_s", [0.0, 37.3])
def test_the_field_on_the_gpu_matches_numpy(device, time_s):
    from aquaspec.gpu.passes.particles import ParticlePass
    from aquaspec.gpu.passes.snow_field import SnowFieldPass
    from aquaspec.rendering.marine_snow import frame_splats, particle_light, snow_field
    from aquaspec.scene.builtin import builtin_scene
    from aquaspec.scene.particles import parse_marine_snow
    from aquaspec.shading.particles import splat_image
    _, camera = builtin_scene(5.0, width=W, height=H)
    snow = parse_marine_snow("3000,4,albedo=1,range=2,current=0.3:0.01:-0.2")
    light = particle_light(_setup(), camera, snow)
    dist = np.full((H, W), np.inf, np.float32)
    dist[:, :60] = 1.2                     # a wall 1.2 m away over the left part
    part = ParticlePass(device, W, H)
    gpu = SnowFieldPass(part)
    gpu.set_field(snow_field(snow))
    gpu.set_light(light)
    enc = device.create_command_encoder()
    gpu.encode(enc, _surface(device, camera, dist), camera, time_s)
    device.queue.submit([enc.finish()])
    got = part.read_accumulated()
    records = frame_splats(snow, light, camera, time_s)
    want = splat_image(records, dist)
    assert len(records) > 300 and gpu.read_drawn() == len(records)
    assert (want[..., 3] > 0).mean() > 0.2 and np.all(want[:, :60, 3][dist[:, :60] < 1.0] == 0)
    peak = np.abs(want).max(axis=(0, 1))
    err = np.abs(got - want) / peak
    # Float32 positions and light against float64, and a fixed-point step
    # chosen from bounds: within 1e-3 of each channel's maximum.
    assert err.max() < 1e-3, err.max()
    assert err.mean() < 1e-5


def test_the_sun_stays_on_the_host(device):
    from aquaspec.errors import AquaspecError
    from aquaspec.gpu.passes.particles import ParticlePass
    from aquaspec.gpu.passes.snow_field import SnowFieldPass
    from aquaspec.rendering.marine_snow import particle_light
    from aquaspec.scene.builtin import builtin_scene
    from aquaspec.scene.particles import parse_marine_snow
    _, camera = builtin_scene(5.0, width=W, height=H)
    light = particle_light(_setup("sun-sky"), camera, parse_marine_snow("100"))
    with pytest.raises(AquaspecError, match="accepted"):
        SnowFieldPass(ParticlePass(device, W, H)).set_light(light)
