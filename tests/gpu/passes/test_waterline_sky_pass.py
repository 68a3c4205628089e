"""The half-and-half frame's sky on the GPU (aquaspec.gpu.passes.waterline_sky)
against its NumPy twin (aquaspec.rendering.above.waterline_sky)."""

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.gpu.buffers import create_storage_buffer, read_buffer
from aquaspec.gpu.passes.waterline_sky import WaterlineSkyPass
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import load_water
from aquaspec.rendering.above import waterline_sky
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera
from aquaspec.shading.above_water import sky_radiance_above, sun_in_air

pytestmark = pytest.mark.gpu


@pytest.mark.parametrize("pitch_deg,light", [(-8.0, "overcast"), (20.0, "overcast"),
                                             (20.0, "sun-sky")])
def test_sky_over_the_rays_going_up(device, pitch_deg, light):
    """The rays going up get the sky's camera RGB, the others keep the frame
    (w too), as waterline_sky does it in NumPy; a turned camera (roll) too;
    with a sun the sky is the CIE clear sky about it (not uniform)."""
    w, h = 37, 21
    setup = SpectralSetup(load_water("IB"), get_sensor("human"),
                          surface_light(light, sun_elevation_deg=40.0, sun_azimuth_deg=0.0),
                          Bands(5), ms_model="lightfield", surface="flat")
    a = np.radians(pitch_deg)
    cam = Camera.look_at([0.3, 0.0, 0.0], [0.3 + np.sin(0.4), np.sin(a), -np.cos(a)],
                         up=[0.2, 1.0, 0.0], width=w, height=h, fov_y_deg=60.0)
    rng = np.random.default_rng(0)
    frame = rng.uniform(0.0, 5.0, size=(h, w, 4)).astype(np.float32)
    buf = create_storage_buffer(device, frame)
    med = setup.medium([])
    sky = sky_radiance_above(setup.lightfield_tables(), med["e0"]) @ med["response_weights"]
    p = WaterlineSkyPass(device, w, h)
    enc = device.create_command_encoder()
    sun = setup.sun_inputs(caustics=False)
    p.encode(enc, cam, sky, buf, sun_air=None if sun is None else sun_in_air(sun)[0])
    device.queue.submit([enc.finish()])
    got = read_buffer(device, buf, np.float32, (h, w, 4))
    want, _ = waterline_sky(setup, cam, frame[..., :3].astype(np.float64))
    np.testing.assert_allclose(got[..., :3], want, rtol=1e-4)     # the shape in float32
    np.testing.assert_array_equal(got[..., 3], frame[..., 3])
    up = cam.ray_directions()[..., 1] > 0
    assert 0 < up.sum() < up.size                   # both halves in view
    spread = want[up].sum(axis=-1).max() / want[up].sum(axis=-1).min()
    assert (spread > 1.1) == (light == "sun-sky")
