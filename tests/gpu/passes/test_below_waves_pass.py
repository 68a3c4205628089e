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
