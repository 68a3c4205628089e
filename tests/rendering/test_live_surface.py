"""The surface seen from below in live frames (aquaspec.rendering.live_surface):
the waves' window and the sun's disc, against the still render's GPU path."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.light import caustics as cst
from aquaspec.light.sky import surface_light
from aquaspec.light.wave_facets import surface_facets
from aquaspec.light.waves import Waves, looping
from aquaspec.medium.water import load_water
from aquaspec.rendering.api import _Shaded, _View
from aquaspec.rendering.live_surface import facets_at, surface_drawn
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.rendering.surface_view import surface_seen_from_water
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.camera import Camera

SEA = Waves(4.0, grid=32, tile_m=2.0, seed=1, period_s=1.0)
SUN = (55.0, 20.0)
FRAMES = 8
W, H, N = 96, 54, 6


def _setup(sea=SEA, sun=True, **kw):
    light = (surface_light("sun-sky", sun_elevation_deg=SUN[0], sun_azimuth_deg=SUN[1])
             if sun else surface_light("overcast"))
    kw = {"ms_model": "lightfield", "surface": "flat", **kw}
    return SpectralSetup(load_water("IB"), get_sensor("human"), light, Bands(N), waves=sea, **kw)


def _looking_up(camera: Camera, degrees: float = 55.0) -> Camera:
    """``camera`` turned ``degrees`` up (the window and the sun in view)."""
    a = np.radians(degrees)
    f = np.asarray(camera.forward) * np.cos(a) + np.asarray(camera.true_up) * np.sin(a)
    p = np.asarray(camera.position, dtype=float)
    return Camera.look_at(p, p + f, width=camera.width, height=camera.height, fov_y_deg=70.0)


@pytest.mark.parametrize("t", [0.0, 0.31, 2.7])
def test_facets_at_a_time_are_the_looping_sea_s(t):
    """Exactly the facets the still render takes for the looping sea at ``t``
    (the tile's slopes to float32 rounding)."""
    sea = Waves(6.0, wind_azimuth_deg=30.0, grid=64)
    got = facets_at(sea, t)
    want = surface_facets(dataclasses.replace(looping(sea), time_s=t))
    np.testing.assert_allclose(got.slopes, want.slopes, atol=1e-6)
    assert (got.tile_m, got.s2) == (want.tile_m, want.s2)
    assert np.abs(facets_at(sea, t + 0.2).slopes - got.slopes).max() > 0.05     # they move


def test_where_the_surface_is_drawn():
    cam = builtin_scene(2.0, width=W, height=H)[1]
    above = dataclasses.replace(cam, position=np.array([0.0, 2.0, 0.0]))
    waterline = dataclasses.replace(cam, position=np.array([0.0, 0.0, 0.0]))
    assert surface_drawn(_setup(), cam)
    assert surface_drawn(_setup(sea=None), cam)                  # the sun's disc alone
    assert not surface_drawn(_setup(sea=None, sun=False), cam)   # nothing to add (waves need a sun)
    assert not surface_drawn(_setup(), above)
    down = Camera.look_at([0.0, -2.0, 0.0], [0.0, -3.0, -0.2], width=W, height=H, fov_y_deg=60.0)
    assert not surface_drawn(_setup(), down)                     # no ray goes up
    rolled = Camera.look_at([0.0, -2.0, 0.0], [0.0, -2.6, -1.0], up=[1.0, 0.2, 0.0], width=W,
                            height=H, fov_y_deg=60.0)
    assert (rolled.ray_directions()[..., 1] > 0).any() == surface_drawn(_setup(), rolled)
    assert (down.ray_directions()[..., 1] > 0).sum() == 0
    assert surface_drawn(_setup(sea=None, sun=False), waterline)     # the sky's half
    assert not surface_drawn(_setup(surface="index-matched"), cam)
    assert not surface_drawn(_setup(sea=None, ms_model="seeds", surface="index-matched"), cam)


def _displayed(renderer, rgb, settings):
    from aquaspec.gpu.passes.display import DisplayPass
    disp = DisplayPass(W, H, device=renderer.deferred.device)
    disp.set_settings(exposure_ev=settings["exposure_ev"],
                      white_balance_gains=settings["white_balance_gains"],
                      matrix=settings["matrix"], tonemap=settings["tonemap"])
    disp.upload(rgb.astype(np.float32))
    disp.run()
    return disp.read()


@pytest.mark.gpu
@pytest.mark.parametrize("t", [None, 0.25, 0.625])
def test_live_frame_is_the_still_render_with_the_window_and_the_sun(t):
    """A live frame under the sun shows the still render's GPU image, the
    surface seen from below included, within one 8-bit step: over a flat
    sea (``t`` None) with the sun's disc in view, and under a moving sea at
    ``t`` (a loop frame's time: its caustics are that instant's) against the
    same sea at the same time, the window moving with the time."""
    from aquaspec.rendering.renderer import Renderer
    scene, start = builtin_scene(2.0, width=W, height=H)
    cam = _looking_up(start)
    setup = _setup(sea=None if t is None else SEA)
    live = Renderer(W, H, N)
    live.sun_map_size = 256
    if t is not None:
        live.set_wave_time(t, frames=FRAMES)
    settings = live.auto_display(scene, cam, setup)
    live.draw_frame(scene, cam, setup)
    shown = live.read_display()
    linear = live.lightfield.read_rgb()             # (the surface added before the display)

    still_setup = setup
    if t is not None:
        loop = cst.caustic_loop(SEA, *SUN, frames=FRAMES, n_water=1.33,
                                scatter=setup.sun_inputs().caustics.scatter)
        still_setup = _setup(sea=dataclasses.replace(SEA, time_s=t))
        still_setup.cache.sun_inputs = dataclasses.replace(still_setup.sun_inputs(),
                                                          caustics=loop.map_at(t))
    still = Renderer(W, H, N)
    still.sun_map_size = 256
    flat = still.render_scene(scene, cam, still_setup)
    # (No scene in the view: the scene mirrored in the surface is not drawn live.)
    shaded = surface_seen_from_water(still_setup, _View(None, cam, None, False, {}),
                                     _Shaded(flat, None, None, still), "gpu")
    scale = np.abs(flat).max()
    np.testing.assert_allclose(linear, shaded.linear, rtol=1e-5, atol=1e-6 * scale)
    want = _displayed(still, shaded.linear, settings)
    assert np.abs(shown.astype(int) - want.astype(int)).max() <= 1
    if t is None:
        # The disc: a few pixels tens of times the brightest of the rest.
        lit = np.abs(shaded.surface_change).max(axis=-1) > 10 * scale
        assert 1 <= lit.sum() <= 12
        return
    plain = _displayed(still, flat, settings)
    assert np.abs(plain.astype(int) - want.astype(int)).max() > 20   # what the waves change
    # The next loop frame: the slopes alone uploaded, as a renderer starting there has them.
    live.set_wave_time(t + 0.125, frames=FRAMES)
    live.draw_frame(scene, cam, setup)
    assert np.abs(live.read_display().astype(int) - shown.astype(int)).max() > 10
    fresh = Renderer(W, H, N)
    fresh.sun_map_size = 256
    fresh.set_wave_time(t + 0.125, frames=FRAMES)
    fresh.set_spectral(setup, scene.materials)
    fresh.set_display(settings)
    fresh.draw_frame(scene, cam, setup)
    np.testing.assert_allclose(live.lightfield.read_rgb(), fresh.lightfield.read_rgb(),
                               rtol=1e-6, atol=1e-7 * scale)
