"""The controls panel's changes (aquaspec.apps.controls), through the functions its
widgets call, on rendercanvas's offscreen canvas; and the panel drawn by imgui."""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.gpu

W, H = 64, 36          # the canvas_and_view fixture's size (tests/apps/conftest.py)


@pytest.fixture()
def live(canvas_and_view):
    from aquaspec.apps.controls import ViewControls
    canvas, view = canvas_and_view
    return canvas, view, ViewControls(view)


def _frame(canvas) -> np.ndarray:
    return np.asarray(canvas.draw())[..., :3].astype(float)


def _settle(canvas, view) -> np.ndarray:
    """The frame once the worker's change is taken (the frame before still shows
    the last setup)."""
    assert view.pending is not None
    before = view.setup
    view._pending[1].result(timeout=300)
    image = _frame(canvas)
    assert view.pending is None and view.setup is not before
    return image


def test_a_new_water_is_made_off_the_frame_thread_and_is_greener(live):
    canvas, view, controls = live
    ib = _frame(canvas)
    assert controls.set_water("3C")
    assert view.water == "IB" and controls.busy()[0].startswith("loading water 3C")
    still = _frame(canvas)                       # the last good frame goes on meanwhile
    if view.pending is not None:
        np.testing.assert_allclose(still, ib, atol=2)
    c3 = _settle(canvas, view)
    assert view.water == "3C" and controls.busy() is None
    # Coastal 3C is greener than oceanic IB, the exposure held.
    assert c3[..., 2].mean() / c3[..., 1].mean() < ib[..., 2].mean() / ib[..., 1].mean()
    # Its published table has gaps, filled: the panel shows it.
    assert any("3C" in w and "missing" in w for w in controls.warnings())


def test_the_sun_on_brightens_the_frame(live):
    canvas, view, controls = live
    overcast = _frame(canvas)
    assert controls.set_sun(True, elevation_deg=60.0)
    # A first sun: the worker made a renderer with the sun's passes compiled.
    _, prepared = view._pending[1].result(timeout=300)
    sunny = _settle(canvas, view)
    assert view.renderer is prepared and view.renderer.sun is not None
    assert view.settings.has_sun and view.settings.sun_elevation_deg == 60.0
    assert sunny.mean() > 1.05 * overcast.mean()
    assert controls.set_sun(False)
    back = _settle(canvas, view) if view.pending is not None else _frame(canvas)
    np.testing.assert_allclose(back.mean(), overcast.mean(), rtol=0.02)


def test_exposure_plus_one_ev_brightens_and_tone_maps_switch(live):
    canvas, view, controls = live
    base = _frame(canvas)
    assert controls.set_ev_offset(1.0)
    brighter = _frame(canvas)
    assert brighter.mean() > 1.2 * base.mean()
    assert view.display_settings["exposure_offset_ev"] == 1.0
    assert controls.set_tonemap("none")
    clipped = _frame(canvas)
    assert view.display_settings["tonemap"] == "none" and not np.array_equal(clipped, brighter)
    assert controls.set_ev_offset(0.0) and view.tonemap == "none"   # the tone map stays


def test_bands_make_new_renderers_and_the_colour_holds(live):
    canvas, view, controls = live
    _frame(canvas)
    assert controls.set_bands(12)
    # The worker made (and compiled, by one frame) the renderer of the new count.
    _, prepared = view._pending[1].result(timeout=300)
    twelve = _settle(canvas, view)
    assert view.renderer is prepared
    assert view.renderer.deferred.n_bands == 12 and view.setup.bands.n == 12
    assert controls.set_bands(24)
    many = _settle(canvas, view)
    assert view.renderer.deferred.n_bands == 24
    # Past a dozen bands more refine the same colour; they do not change it.
    # (Three wide bands do: red through one band is not red through ten.)
    np.testing.assert_allclose(many.mean(axis=(0, 1)), twelve.mean(axis=(0, 1)), rtol=0.1,
                               atol=2)


def test_model_phase_and_sensor_change_the_setup(live):
    canvas, view, controls = live
    _frame(canvas)
    assert controls.set_ms_model("monzon2022")
    _settle(canvas, view)
    assert view.setup.ms_model == "monzon2022"
    assert controls.set_phase("hg")
    _settle(canvas, view)
    assert view.setup.phase == "hg" and dict(view.setup.phase_params)["g"] == 0.92
    other = next(s for s in controls.sensors() if s != "human")
    assert controls.set_sensor(other)
    _settle(canvas, view)
    assert view.settings.sensor == other


def test_another_data_source_and_its_warning(live):
    canvas, view, controls = live
    _frame(canvas)
    assert "IB" in controls.waters("williamson2022") and "I" not in controls.waters(
        "williamson2022")
    assert controls.set_water("IB", "williamson2022")
    _settle(canvas, view)
    assert view.setup.water.source == "williamson2022"
    assert any("Kd is derived" in w for w in controls.warnings())


def test_a_newer_request_supersedes_a_pending_one(live):
    canvas, view, controls = live
    _frame(canvas)
    controls.set_water("3C")
    controls.set_water("II")
    assert view.pending[0] == "II"
    _settle(canvas, view)
    assert view.water == "II"


def test_refused_values_leave_the_view_and_say_why(live):
    canvas, view, controls = live
    _frame(canvas)
    settings = view.settings
    assert not controls.set_bands(0)
    assert "0 bands" in view.message and "accepted" in view.message
    assert not controls.set_wind(5.0)                    # overcast: no caustics
    assert "sun elevation" in view.message
    assert not controls.set_tonemap("sepia") and "sepia" in view.message
    assert not controls.set_sun(True, elevation_deg=120.0) and "120" in view.message
    assert view.pending is None and view.settings is settings
    assert view.message in controls.warnings()


def test_waves_pause_and_play_at_their_speed(live):
    canvas, view, controls = live
    _frame(canvas)
    controls.set_waves_playing(False)
    t = view.time_s
    _frame(canvas)
    assert view.time_s == t
    assert controls.set_wave_speed(2.0) and view.wave_speed == 0.0    # still paused
    controls.set_waves_playing(True)
    assert view.wave_speed == 2.0
    assert not controls.set_wave_speed(0.0)


def test_the_depth_control_moves_the_camera_within_the_water(live):
    """The built-in scene's camera goes straight down (the background bluer,
    the exposure held) but not through the rock under it: the control's range ends at the
    seabed, and a value beyond it is clamped as flying is."""
    canvas, view, controls = live
    first = _frame(canvas)
    x, _, z = view.flight.position
    lo, hi = controls.depth_range()
    assert lo == pytest.approx(0.3) and view.flight.depth_m < hi < 20
    # (the bound is the floor under the camera: here a rock above the seabed)
    assert controls.set_depth(hi)
    deeper = _frame(canvas)
    assert view.flight.depth_m == pytest.approx(hi, abs=0.05)
    assert (view.flight.position[0], view.flight.position[2]) == (x, z)
    # The open water above the horizon loses red faster than blue as it goes down.
    top = [im[:4].mean(axis=(0, 1)) for im in (first, deeper)]
    assert top[1][0] / top[1][2] < top[0][0] / top[0][2]
    controls.set_depth(hi + 50)
    assert view.flight.depth_m <= hi + 1e-9
    assert not controls.set_depth(float("nan")) and "nan" in view.message


def test_the_flat_surface_from_the_panel(live):
    """Looking up (pitch 60), the flat surface shows Snell's window with the
    water mirrored around it: the frame's bottom (outside the window) darkens
    against the index-matched surface's sky all round, the exposure held."""
    canvas, view, controls = live
    view.flight.set_view(0.0, 60.0)
    assert view.setup.surface == "flat"                  # the default
    assert controls.set_surface("index-matched")
    matched = _settle(canvas, view)
    assert view.setup.surface == "index-matched"
    assert controls.set_surface("flat")
    # (The flat surface's setup may still be the view's: then it is taken at once.)
    flat = _settle(canvas, view) if view.pending is not None else _frame(canvas)
    assert view.setup.surface == "flat"
    # The bottom rows look up at about 35 degrees: outside the window (48.8).
    assert flat[-4:].mean() < 0.8 * matched[-4:].mean()
    assert not controls.set_surface("wavy") and "wavy" in view.message


def test_render_scale_from_the_panel(live):
    canvas, view, controls = live
    assert controls.set_render_scale(0.5)
    _frame(canvas)
    assert (view.renderer.width, view.renderer.height) == (W // 2, H // 2)
    assert not controls.set_render_scale(0.3) and "0.3" in view.message


def test_the_panel_draws_over_the_right_of_the_frame_only(device):
    pytest.importorskip("imgui_bundle")
    from rendercanvas.offscreen import RenderCanvas

    from aquaspec.apps.controls import ViewControls
    from aquaspec.apps.live import LiveView
    from aquaspec.apps.settings import ViewSettings
    from aquaspec.apps.panel import PANEL_MARGIN_PX, PANEL_WIDTH_PX, ControlsPanel
    w, h = 960, 540
    canvas = RenderCanvas(size=(w, h))
    view = LiveView(ViewSettings(width=w, height=h, bands=3))
    view.attach(canvas)
    panel = ControlsPanel(ViewControls(view))
    panel.attach(canvas)
    image = np.asarray(canvas.draw())[..., :3]
    frame = view.renderer.read_display()
    view.close()
    canvas.close()
    assert panel.frames == 1
    assert view.pass_ms["panel"] > 0            # timed on the profiled frame
    left = w - PANEL_WIDTH_PX - PANEL_MARGIN_PX
    np.testing.assert_array_equal(image[:, :left], frame[:, :left])
    assert (image[:, left + 10:] != frame[:, left + 10:]).any(axis=-1).mean() > 0.5


def test_the_panel_shows_a_change_in_progress(device):
    """While a setup is being made the panel shows it (an indeterminate bar) and
    the frame under it is the last good one."""
    pytest.importorskip("imgui_bundle")
    from concurrent.futures import Future

    from rendercanvas.offscreen import RenderCanvas

    from aquaspec.apps.controls import ViewControls
    from aquaspec.apps.live import LiveView
    from aquaspec.apps.settings import ViewSettings
    from aquaspec.apps.panel import ControlsPanel
    w, h = 960, 540
    canvas = RenderCanvas(size=(w, h))
    view = LiveView(ViewSettings(width=w, height=h, bands=3))
    view.attach(canvas)
    controls = ViewControls(view)
    ControlsPanel(controls).attach(canvas)
    idle = np.asarray(canvas.draw())[..., :3].copy()
    # A change that never finishes: the worker's future stands in for a slow one.
    view._pending = (("3C", view.settings), Future())
    view._pending_t0 = 0.0
    view.message = "loading water 3C ..."
    busy = np.asarray(canvas.draw())[..., :3].copy()
    frame = view.renderer.read_display()
    status = controls.busy()
    view._pending = None
    view.close()
    canvas.close()
    assert status[0] == "loading water 3C ..." and status[1] > 0
    assert view.water == "IB"
    assert not np.array_equal(busy, idle)                   # the panel shows more
    left = w - 300
    np.testing.assert_array_equal(busy[:, :left], frame[:, :left])


def test_the_sensors_are_the_built_in_cameras_and_the_camspec_ones(device, camspec_path):
    from rendercanvas.offscreen import RenderCanvas

    from aquaspec.apps.controls import ViewControls
    from aquaspec.apps.live import LiveView
    from aquaspec.apps.settings import ViewSettings
    from aquaspec.colour.sensors import builtin_sensors, load_camspec
    canvas = RenderCanvas(size=(W, H))
    view = LiveView(ViewSettings(width=W, height=H, bands=3, camspec=camspec_path))
    view.attach(canvas)
    controls = ViewControls(view)
    try:
        names = controls.sensors()
        cams = list(load_camspec(camspec_path))
        assert set(builtin_sensors()) <= set(names) and set(cams) <= set(names)
        human = _frame(canvas)
        assert controls.set_sensor(cams[0])
        other = _settle(canvas, view)
        assert view.settings.sensor == cams[0]
        assert not np.array_equal(other, human)      # another camera, other colours
    finally:
        view.close()
        canvas.close()


def test_a_narrow_window_starts_with_the_panel_collapsed(device):
    pytest.importorskip("imgui_bundle")
    from rendercanvas.offscreen import RenderCanvas

    from aquaspec.apps.controls import ViewControls
    from aquaspec.apps.live import LiveView
    from aquaspec.apps.panel import OPEN_FROM_WIDTH_PX, ControlsPanel
    from aquaspec.apps.settings import ViewSettings
    w, h = OPEN_FROM_WIDTH_PX // 2, OPEN_FROM_WIDTH_PX // 4
    canvas = RenderCanvas(size=(w, h))
    view = LiveView(ViewSettings(width=w, height=h, bands=3))
    view.attach(canvas)
    ControlsPanel(ViewControls(view)).attach(canvas)
    image = np.asarray(canvas.draw())[..., :3]
    frame = view.renderer.read_display()
    view.close()
    canvas.close()
    covered = (image != frame).any(axis=-1)
    # Only its title bar (one line of text, about 20 pixels) hides the frame.
    rows = np.flatnonzero(covered.any(axis=1))
    assert rows.size and rows.max() < 40
