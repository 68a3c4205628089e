"""Live frames of a camera above the sea and at the waterline
(aquaspec.rendering.live_above, the waterline's sky in live_surface) against
the still render's paths."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.gpu.buffers import read_buffer
from aquaspec.light.sky import surface_light
from aquaspec.light.waves import Waves
from aquaspec.medium.water import load_water
from aquaspec.rendering.above import shade_above, waterline_sky
from aquaspec.rendering.api import _View
from aquaspec.rendering.live_above import check_live_above
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.camera import Camera, camera_above

pytestmark = pytest.mark.gpu

SEA = Waves(5.0, grid=32, tile_m=2.0, seed=2, period_s=1.0)
W, H, N = 80, 45, 5


def _setup(sea=None, light="sun-sky", **kw):
    kw = {"ms_model": "lightfield", "surface": "flat", **kw}
    return SpectralSetup(load_water("IB"), get_sensor("human"),
                         surface_light(light, sun_elevation_deg=40.0, sun_azimuth_deg=10.0)
                         if light == "sun-sky" else surface_light(light), Bands(N), waves=sea,
                         **kw)


def _displayed(device, rgb, settings):
    from aquaspec.gpu.passes.display import DisplayPass
    disp = DisplayPass(W, H, device=device)
    disp.set_settings(exposure_ev=settings["exposure_ev"],
                      white_balance_gains=settings["white_balance_gains"],
                      matrix=settings["matrix"], tonemap=settings["tonemap"])
    disp.upload(np.asarray(rgb, dtype=np.float32))
    disp.run()
    return disp.read()


def _linear_above(renderer):
    return read_buffer(renderer.deferred.device, renderer._above.rgb_buffer, np.float32,
                       (H, W, 4))[..., :3]


def test_the_sea_from_above_moving_with_the_waves():
    """A live frame 4 m above a sea moving in time is the still render's GPU
    frame from above of the same sea at the same time (linear within 1e-5,
    8-bit within one step); the next time's frame (its slopes alone
    uploaded) is a renderer's starting there."""
    from aquaspec.rendering.renderer import Renderer
    scene, _ = builtin_scene(3.0, width=W, height=H)
    cam = camera_above(4.0, 35.0, width=W, height=H)
    setup = _setup(SEA)
    live = Renderer(W, H, N)
    live.set_wave_time(0.3)
    settings = live.auto_display(scene, cam, setup)
    live.draw_frame(scene, cam, setup)
    shown, linear = live.read_display(), _linear_above(live)
    still_setup = _setup(dataclasses.replace(SEA, time_s=0.3))
    still, _ = shade_above(still_setup, _View(None, cam, None, False, {"kind": "builtin"}),
                           "gpu", False, lambda m: None)
    scale = np.abs(still).max()
    np.testing.assert_allclose(linear, still, rtol=1e-5, atol=1e-6 * scale)
    want = _displayed(live.deferred.device, still, settings)
    assert np.abs(shown.astype(int) - want.astype(int)).max() <= 1
    assert shown.std() > 5                           # a picture, not a flat fill
    live.set_wave_time(0.45)
    live.draw_frame(scene, cam, setup)
    moved = _linear_above(live)
    assert np.abs(moved - linear).max() > 1e-3 * scale
    fresh = Renderer(W, H, N)
    fresh.set_wave_time(0.45)
    fresh.set_display(settings)
    fresh.draw_frame(scene, cam, setup)
    np.testing.assert_allclose(moved, _linear_above(fresh), rtol=1e-6, atol=1e-7 * scale)


def test_the_half_and_half_frame():
    """A live frame of a camera on the surface is the still render's: the
    water's half rendered from depth 0, the sky over the rays going up."""
    from aquaspec.rendering.renderer import Renderer
    scene, _ = builtin_scene(3.0, width=W, height=H)
    cam = camera_above(0.0, 8.0, width=W, height=H)
    setup = _setup(light="overcast", seabed=scene.seabed)
    live = Renderer(W, H, N)
    settings = live.auto_display(scene, cam, setup)
    live.draw_frame(scene, cam, setup)
    shown, linear = live.read_display(), live.lightfield.read_rgb()
    flat = Renderer(W, H, N).render_scene(scene, cam, setup)
    want_linear, _ = waterline_sky(setup, cam, flat)
    scale = np.abs(want_linear).max()
    np.testing.assert_allclose(linear, want_linear, rtol=1e-5, atol=1e-6 * scale)
    want = _displayed(live.deferred.device, want_linear, settings)
    assert np.abs(shown.astype(int) - want.astype(int)).max() <= 1
    up = cam.ray_directions()[..., 1] > 0
    assert np.abs(flat[up] - want_linear[up]).max() > 0.1 * scale   # the sky replaced them
    sky_only = Camera.look_at([0.0, 0.0, 0.0], [0.0, 0.5, -0.866], width=W, height=H,
                              fov_y_deg=20.0)
    with pytest.raises(AquaspecError, match="sees no water"):
        live.draw_frame(scene, sky_only, setup)


def test_what_a_live_frame_from_above_refuses():
    from aquaspec.rendering.renderer import Renderer
    scene, _ = builtin_scene(3.0, width=W, height=H)
    setup = _setup()
    with pytest.raises(AquaspecError, match="light-field model"):
        check_live_above(_setup(ms_model="seeds", surface="index-matched"), scene)
    with pytest.raises(AquaspecError, match="real surface"):
        check_live_above(_setup(surface="index-matched"), scene)
    with pytest.raises(AquaspecError, match="camera model"):
        check_live_above(setup, scene, camera_model="gopro")
    with pytest.raises(AquaspecError, match="marine snow"):
        check_live_above(setup, scene, marine_snow=object())
    from aquaspec.scene.gbuffer import GBuffer
    photo = GBuffer(scene.camera, np.full((H, W), 2.0, np.float32),
                    np.zeros((H, W, 3), np.float32), np.zeros((H, W), np.uint32),
                    np.zeros((H, W, 3), np.float32), materials=scene.materials)
    with pytest.raises(AquaspecError, match="RGB-D"):
        check_live_above(setup, photo)
    r = Renderer(W, H, N)
    cam = camera_above(2.0, 30.0, width=W, height=H)
    with pytest.raises(AquaspecError, match="no display settings"):
        r.encode_frame(r.deferred.device.create_command_encoder(), scene, cam, setup)
