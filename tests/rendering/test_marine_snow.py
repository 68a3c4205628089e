"""render(marine_snow=...) and live frames with marine snow (aquaspec.rendering.marine_snow)."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.rendering.api import render

SMALL = dict(size=(128, 72), bands=8)
TINY = dict(size=(32, 18), bands=4)


class TestErrors:
    def test_bad_spec_fails_before_rendering(self):
        with pytest.raises(AquaspecError, match="density_per_m3=-1.0"):
            render(marine_snow=-1.0, backend="numpy", **TINY)

    def test_needs_the_light_field(self):
        with pytest.raises(AquaspecError, match="ms_model='lightfield'"):
            render(marine_snow=50, ms_model="seeds", backend="numpy", **TINY)

    def test_not_from_above(self):
        from aquaspec.scene.camera import camera_above
        with pytest.raises(AquaspecError, match="above"):
            render(marine_snow=50, camera=camera_above(2.0, width=32, height=18),
                   backend="numpy", **TINY)


@pytest.mark.gpu
@pytest.mark.slow
class TestRender:
    def test_gpu_and_numpy_draw_the_same_snow(self, device):
        """The particles' light (with snow minus without) agrees between backends,
        and the default has none."""
        spec = "1500,3,albedo=1"
        gpu = {s: render(marine_snow=s, **SMALL) for s in (None, spec)}
        cpu = {s: render(marine_snow=s, backend="numpy", **SMALL) for s in (None, spec)}
        assert "marine_snow" not in gpu[None].params
        snow = gpu[spec].params["marine_snow"]
        assert snow["seed"] == 3 and snow["particles_drawn"] > 1000
        d_gpu = gpu[spec].linear_rgb - gpu[None].linear_rgb
        d_cpu = cpu[spec].linear_rgb - cpu[None].linear_rgb
        assert np.abs(d_cpu).max() > 0.05 * cpu[None].linear_rgb.max()
        # The snow's light agrees to the half-float target's precision, but on
        # silhouette pixels where the rasteriser's and the ray caster's G-buffers
        # differ (the depth test then differs).
        off = np.abs(d_gpu - d_cpu).max(axis=-1) > 0.01 * np.abs(d_cpu).max()
        assert off.mean() < 1e-3
        assert np.abs(d_gpu - d_cpu).mean() < 1e-3 * np.abs(d_cpu).max()

    # sun-sky: the particles' light on the host; overcast: all of it on the GPU
    # (aquaspec.gpu.passes.snow_field).
    @pytest.mark.parametrize("light, sun_elevation", [("sun-sky", 60.0), ("overcast", None)])
    def test_live_frame_matches_numpy(self, device, light, sun_elevation):
        from aquaspec.gpu.passes.display import DisplayPass
        from aquaspec.rendering.api import _spectral_setup
        from aquaspec.rendering.marine_snow import frame_splats, particle_light
        from aquaspec.rendering.renderer import Renderer
        from aquaspec.scene.builtin import builtin_scene
        from aquaspec.scene.particles import parse_marine_snow
        from aquaspec.shading.particles import composite, splat_image
        w, h = 160, 90
        scene, cam = builtin_scene(5.0, width=w, height=h)
        setup, _ = _spectral_setup(
            water="IB", source="solonenko2015", sensor="human", camspec=None,
            bands=8, wavelength_range=(400.0, 700.0), light=light, irradiance_w_m2=None,
            sun_elevation_deg=sun_elevation, sun_azimuth_deg=None, sun_shadow_map=None, waves=None,
            ambient="cosine", outside="error", ms_model="lightfield", phase="petzold",
            forward_cone_deg=None, cone_spread=None, spread_scattering="single",
            ambient_shadow=False, say=lambda m: None, surface="flat")
        r = Renderer(w, h, 8)
        plain = r.render_scene(scene, cam, setup).astype(float)
        r.auto_display(scene, cam, setup)
        snow = parse_marine_snow("400,5")
        r.set_marine_snow(snow, 2.0)
        r.draw_frame(scene, cam, setup)
        got = r.read_display().astype(int)
        gbuffer = r.raster.read_gbuffer(scene, cam, r.deferred.gbuffer.textures)
        records = frame_splats(snow, particle_light(setup, cam, snow), cam, 2.0)
        assert r.snow.drawn == len(records)
        want = composite(plain, splat_image(records, gbuffer.distance))
        assert np.abs(want - plain).max() > 0.02 * plain.max()
        # The composed frame's display against the display pass of NumPy's composition:
        # 8-bit codes within one (rounding), but where half floats tip a code over.
        shown = DisplayPass(w, h, device=device)
        shown.set_settings(**r._display.settings)
        shown.upload(want)
        shown.run()
        diff = np.abs(got - shown.read().astype(int))
        assert diff.max() <= 2 and (diff > 1).mean() < 1e-3
        # The drift moves the particles: another instant, another image.
        r.set_marine_snow(snow, 7.0)
        r.draw_frame(scene, cam, setup)
        assert np.abs(r.read_display().astype(int) - got).max() > 10
