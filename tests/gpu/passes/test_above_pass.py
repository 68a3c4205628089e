"""The view from above on the GPU (above.wgsl) against its NumPy reference."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor, radiance_to_rgb
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import camera_above
from aquaspec.scene.seabed import Seabed
from aquaspec.shading.above_water import sea_from_above

pytestmark = pytest.mark.gpu


@pytest.mark.parametrize("water,bed,look_down,n", [
    ("IB", None, 30.0, 8),            # the horizon in view: sky above it
    ("3C", Seabed(4.0, 0.3), 70.0, 5),
])
def test_above_pass_matches_numpy(device, water, bed, look_down, n):
    from aquaspec.gpu.passes.above import AbovePass
    setup = SpectralSetup(load_water(water), get_sensor("nikon-5100-npl"),
                          surface_light("overcast"), Bands(n), surface="flat", seabed=bed)
    med = setup.medium([])
    tables = setup.lightfield_tables()
    cam = camera_above(3.0, look_down, width=61, height=37, fov_y_deg=70.0)
    p = AbovePass(device, cam.width, cam.height)
    p.set_medium(tables, a=med["a"], b=med["b"], e0=med["e0"],
                 response_weights=med["response_weights"])
    gpu = p.render(cam)
    ref = radiance_to_rgb(sea_from_above(cam, tables, a=med["a"], b=med["b"], e0=med["e0"]),
                          med["response_weights"])
    np.testing.assert_allclose(gpu, ref, rtol=2e-4, atol=1e-6 * np.abs(ref).max())
    if look_down == 30.0:
        assert (cam.ray_directions()[..., 1] > 0).any()
    # The camera moves: the same medium, a new view, no new upload.
    cam2 = camera_above(8.0, 50.0, width=61, height=37)
    ref2 = radiance_to_rgb(sea_from_above(cam2, tables, a=med["a"], b=med["b"], e0=med["e0"]),
                           med["response_weights"])
    np.testing.assert_allclose(p.render(cam2), ref2, rtol=2e-4, atol=1e-6 * np.abs(ref2).max())
