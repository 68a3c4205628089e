"""The GPU renderer (aquaspec.rendering.renderer.Renderer) against the NumPy shading."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.scene.builtin import builtin_scene

pytestmark = pytest.mark.gpu


class TestRenderer:
    def test_matches_the_numpy_shading_on_the_same_gbuffer(self):
        # The deferred pass against its reference, through the public API.
        from aquaspec.colour.bands import Bands
        from aquaspec.light.sky import surface_light
        from aquaspec.rendering.renderer import Renderer
        from aquaspec.rendering.setup import SpectralSetup
        from aquaspec.colour.sensors import get_sensor
        from aquaspec.shading.shade import shade_gbuffer
        from aquaspec.medium.water import load_water
        scene, cam = builtin_scene(5.0, width=160, height=90)
        setup = SpectralSetup(load_water("IB"), get_sensor("human"), surface_light("overcast"),
                              Bands(8), ms_model="seeds")
        r = Renderer(160, 90, 8)
        gpu = r.render_scene(scene, cam, setup)
        from aquaspec.gpu.passes.raster import RasterPass
        gb = RasterPass().render(scene, cam)
        ref = shade_gbuffer(gb, **setup.medium(gb.materials))["camera_rgb"]
        scale = np.abs(ref).max()
        np.testing.assert_allclose(gpu, ref, rtol=1e-4, atol=1e-6 * scale)
