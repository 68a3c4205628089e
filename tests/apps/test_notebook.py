"""The live view in a notebook widget (aquaspec.apps.notebook), without a kernel.

jupyter_rfb's widget is made outside a notebook; what the browser would do is
done by hand: a resize event gives the widget its size, ``get_frame`` is the
browser asking for a frame. The canvas reads the presented texture back
through a promise that needs a running asyncio loop (a kernel has one), so
the tests run inside ``asyncio.run``.
"""

from __future__ import annotations

import asyncio
import time

import numpy as np
import pytest

from aquaspec.errors import AquaspecError

pytestmark = pytest.mark.gpu
pytest.importorskip("jupyter_rfb")

W, H = 64, 36


def _resize(canvas):
    canvas.handle_event({"event_type": "resize", "width": W, "height": H, "pixel_ratio": 1.0})


async def _frame(canvas) -> np.ndarray:
    """The frame the widget sends to the browser for one ``get_frame``."""
    canvas._last_image = None
    canvas.get_frame()
    for _ in range(1000):
        if canvas._last_image is not None:
            return np.asarray(canvas._last_image)
        await asyncio.sleep(0.01)
    raise AssertionError("the widget sent no frame in 10 s")


def test_the_widget_shows_the_renderers_display_image_and_keys_fly(device):
    from aquaspec.apps.notebook import notebook_view

    async def run():
        canvas = notebook_view(width=W, height=H, bands=3, panel=False)
        view = canvas.live_view
        try:
            _resize(canvas)
            image = await _frame(canvas)
            assert image.shape == (H, W, 4)
            np.testing.assert_array_equal(image[..., :3], view.renderer.read_display())
            # A key from the browser goes through the canvas's events to the flight.
            canvas.handle_event({"event_type": "key_down", "key": "w", "modifiers": (),
                                 "time_stamp": time.perf_counter()})
            canvas._events.flush()
            assert view.flight.moving
            await asyncio.sleep(0.05)
            await _frame(canvas)
            assert view.flight.position[2] < 0            # forward is -z
            assert view.frame_index == 2
        finally:
            view.close()
            canvas.close()

    asyncio.run(run())


def test_closing_the_widget_closes_the_view(device):
    from aquaspec.apps.notebook import notebook_view
    canvas = notebook_view(width=W, height=H, bands=3, panel=False)
    view = canvas.live_view
    closed = []
    view.close = lambda: closed.append(True)     # the handler looks it up when called
    canvas.handle_event({"event_type": "close"})
    canvas._events.flush()
    assert closed and canvas.get_closed()          # the browser closed the widget
    canvas.close()
    canvas = notebook_view(width=W, height=H, bands=3, panel=False)
    closed.clear()
    canvas.live_view.close = lambda: closed.append(True)
    canvas.close()                                 # a cell closed it
    assert closed


def test_the_panel_is_drawn_into_the_widgets_frame(device):
    pytest.importorskip("imgui_bundle")
    from aquaspec.apps.notebook import notebook_view
    w, h = 960, 120                               # 960 px and wider: the panel starts open

    async def run():
        canvas = notebook_view(width=w, height=h, bands=3)
        view = canvas.live_view
        try:
            canvas.handle_event({"event_type": "resize", "width": w, "height": h,
                                 "pixel_ratio": 1.0})
            image = (await _frame(canvas))[..., :3]
            shown = view.renderer.read_display()
            assert view.gui is not None
            np.testing.assert_array_equal(image[:, :500], shown[:, :500])   # the scene
            assert np.abs(image[:, -200:].astype(int) - shown[:, -200:]).mean() > 10  # panel
        finally:
            view.close()
            canvas.close()

    asyncio.run(run())


@pytest.mark.parametrize("kwargs, words", [
    ({"colour": "red"}, ["colour", "accepted", "water"]),
    ({"settings": "IB"}, ["'IB'", "ViewSettings"]),
    ({"max_fps": 0}, ["max_fps=0", "> 0"]),
    ({"scale": 0.3}, ["0.3", "0.75"]),
])
def test_bad_options_are_named(kwargs, words):
    from aquaspec.apps.notebook import notebook_view
    with pytest.raises(AquaspecError) as info:
        notebook_view(**kwargs)
    for w in words:
        assert w in str(info.value)
