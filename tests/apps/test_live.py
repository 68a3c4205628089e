"""The live view's frame loop (aquaspec.apps.live) on rendercanvas's offscreen canvas."""

from __future__ import annotations

import gc
import time
import weakref

import numpy as np
import pytest

pytestmark = pytest.mark.gpu

W, H = 64, 36          # the canvas_and_view fixture's size (tests/apps/conftest.py)


def _key(view, key):
    view.handle_event({"event_type": "key_down", "key": key, "modifiers": ()})
    view.handle_event({"event_type": "key_up", "key": key, "modifiers": ()})


def test_the_canvas_keeps_the_view_alive_through_garbage_collection(device):
    """The old matplotlib viewer lost its controls to weak references; here the
    canvas holds the draw function and the event handlers strongly."""
    from rendercanvas.offscreen import RenderCanvas

    from aquaspec.apps.live import LiveView, ViewSettings
    canvas = RenderCanvas(size=(W, H))
    view = LiveView(ViewSettings(width=W, height=H, bands=3))
    view.attach(canvas)
    ref = weakref.ref(view)
    del view
    gc.collect()
    assert ref() is not None
    # Offscreen, no scheduler flushes submitted events: flush them as it would.
    canvas.submit_event({"event_type": "key_down", "key": "w", "modifiers": ()})
    canvas._events.flush()
    assert ref().flight.moving                   # the handler got the key
    canvas.draw()
    time.sleep(0.05)
    canvas.draw()
    assert ref().frame_index == 2
    assert ref().flight.position[2] < 0          # and the frames flew the camera
    ref().close()
    canvas.close()


def test_frames_are_the_renderers_display_image(canvas_and_view):
    canvas, view = canvas_and_view
    image = np.asarray(canvas.draw())
    np.testing.assert_array_equal(image[..., :3], view.renderer.read_display())
    assert view.frame_index == 1 and "fps" in view.status()


def test_held_key_moves_between_frames(canvas_and_view):
    canvas, view = canvas_and_view
    canvas.draw()
    view.handle_event({"event_type": "key_down", "key": "w", "modifiers": ()})
    time.sleep(0.05)
    canvas.draw()
    assert view.flight.position[2] < 0          # forward is -z
    view.handle_event({"event_type": "key_up", "key": "w", "modifiers": ()})


def test_number_key_switches_the_water_off_the_frame_thread(canvas_and_view):
    canvas, view = canvas_and_view
    first = np.asarray(canvas.draw())[..., :3].astype(float)
    _key(view, "7")                              # Jerlov 3C
    assert view.water == "IB" and "loading water 3C" in view.message
    view._pending[1].result(timeout=120)         # the worker's setup
    image = np.asarray(canvas.draw())[..., :3].astype(float)
    assert view.water == "3C" and view.message is None
    # Coastal 3C is greener than oceanic IB, the exposure held.
    assert (image[..., 2].mean() / image[..., 1].mean()
            < first[..., 2].mean() / first[..., 1].mean())


def test_h_toggles_the_text_and_escape_closes(canvas_and_view):
    canvas, view = canvas_and_view
    assert view.overlay is False
    canvas.draw()
    assert view.present.overlay_size == (0, 0)
    _key(view, "h")
    canvas.draw()
    assert view.overlay is True and view.present.overlay_size[0] > 0
    _key(view, "Escape")
    assert canvas.get_closed()


def test_p_saves_the_frame_as_render_does(canvas_and_view, tmp_path):
    import json

    from PIL import Image
    canvas, view = canvas_and_view
    view.save_dir = tmp_path
    view.flight.set_position([0.5, -4.0, -1.0])
    canvas.draw()
    shown = view.renderer.read_display()
    _key(view, "p")
    pngs = list(tmp_path.glob("aquaspec-view-*.png"))
    assert len(pngs) == 1 and view.message == f"saved {pngs[0].name}"
    np.testing.assert_array_equal(np.asarray(Image.open(pngs[0]))[..., :3], shown)
    side = json.loads((tmp_path / (pngs[0].name + ".json")).read_text())
    np.testing.assert_allclose(side["camera"]["position_m"], [0.5, -4.0, -1.0])
    assert side["water"]["name"] == "IB" and side["display"]["tonemap"] == "filmic"
    linear = side["files"]["linear"]
    assert linear.endswith((".exr", ".npy")) and (tmp_path / linear).is_file()
    canvas.draw()                                  # the view goes on after saving
    view.save_dir = tmp_path / "missing"
    _key(view, "p")
    assert view.message.startswith("not saved: save folder")


def test_half_scale_renders_half_and_stretches_to_the_canvas(canvas_and_view):
    canvas, view = canvas_and_view
    view.use_scale(0.5)
    image = np.asarray(canvas.draw())[..., :3]
    assert (view.renderer.width, view.renderer.height) == (W // 2, H // 2)
    assert image.shape == (H, W, 3)
    small = view.renderer.read_display()
    np.testing.assert_array_equal(image, small.repeat(2, axis=0).repeat(2, axis=1))
    # The same view, not a narrower one: intrinsics scale with the size.
    cam, full = view.camera(), view.flight.camera()
    assert cam.fx == pytest.approx(full.fx / 2) and cam.cx == pytest.approx(full.cx / 2)
    _key(view, "]")                                # back up the ladder, auto off
    # Frames on screen: the new size's renderer is made off the frame thread,
    # the frames going on at the old size meanwhile.
    assert view._scale_pending[0] == (48, 28) and "48x28 being made" in view.status()
    view._scale_pending[1].result(timeout=120)
    canvas.draw()
    assert (view.renderer.width, view.renderer.height) == (48, 28)
    assert view._scale_pending is None
    assert view.render_scale.target_fps is None


def test_exposure_steps_from_the_automatic_one(canvas_and_view):
    canvas, view = canvas_and_view
    auto_ev = view.display_settings["exposure_ev"]
    dim = np.asarray(canvas.draw())[..., :3].astype(float).mean()
    _key(view, ".")
    _key(view, ".")
    assert view.ev_offset == 1.0
    assert view.display_settings["exposure_ev"] == pytest.approx(auto_ev + 1.0)
    assert view.display_settings["exposure_scale"] == pytest.approx(2.0 ** (auto_ev + 1.0))
    bright = np.asarray(canvas.draw())[..., :3].astype(float).mean()
    assert bright > dim
    _key(view, ",")
    assert "EV +0.5 from auto" in view.status()


def test_an_rgbd_view_saves_renders_at_scale_and_moves_only_in_depth(device, tmp_path):
    """An RGB-D photograph as the view's scene: Q moves the camera down (W does
    nothing), P saves a sidecar naming the photograph and the linear image of
    the frame shown, and at half scale the photograph is shown at half size;
    a size of another aspect ratio is refused."""
    import json

    from PIL import Image
    from rendercanvas.offscreen import RenderCanvas

    from aquaspec.apps.live import LiveView, ViewSettings
    from aquaspec.errors import AquaspecError
    rgb = np.zeros((H, W, 3), np.uint8)
    rgb[:, : W // 2] = (200, 90, 40)
    Image.fromarray(rgb).save(tmp_path / "rgb.png")
    np.save(tmp_path / "depth.npy", np.full((H, W), 3.0))
    photo = (str(tmp_path / "rgb.png"), str(tmp_path / "depth.npy"), (40.0, 40.0, W / 2, H / 2))
    with pytest.raises(AquaspecError, match="would stretch it"):
        LiveView(ViewSettings(width=W, height=W, bands=3, rgbd=photo))
    canvas = RenderCanvas(size=(W, H))
    view = LiveView(ViewSettings(width=W, height=H, bands=3, depth_m=4.0, rgbd=photo))
    view.attach(canvas)
    try:
        canvas.draw()
        for key in ("w", "q"):
            view.handle_event({"event_type": "key_down", "key": key, "modifiers": ()})
            time.sleep(0.05)
            canvas.draw()
            view.handle_event({"event_type": "key_up", "key": key, "modifiers": ()})
        x, y, z = view.flight.position
        assert x == 0 and z == 0 and y < -4.0
        view.save_dir = tmp_path
        view.save_frame()
        side = json.loads(next(tmp_path.glob("aquaspec-view-*.png.json")).read_text())
        assert side["scene"]["kind"] == "rgbd" and side["scene"]["rgbd_image"] == photo[0]
        assert side["camera"]["position_m"][1] == pytest.approx(y)
        view.use_scale(0.5)
        view._scale_pending[1].result(timeout=120)
        image = np.asarray(canvas.draw())[..., :3]
        assert (view.renderer.width, view.renderer.height) == (W // 2, H // 2)
        # The photograph's warm left half and blue right half survive the scaling.
        assert image[:, : W // 2 - 2, 0].mean() > image[:, W // 2 + 2:, 0].mean() + 5
    finally:
        view.close()
        canvas.close()
