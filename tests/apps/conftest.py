"""Fixtures shared by the live view's tests."""

from __future__ import annotations

import pytest

#: The size of the small offscreen views the tests draw.
VIEW_W, VIEW_H = 64, 36


@pytest.fixture()
def canvas_and_view(device):
    """A live view of the built-in scene (3 bands) attached to rendercanvas's
    offscreen canvas: ``(canvas, view)``; both closed after the test."""
    from rendercanvas.offscreen import RenderCanvas

    from aquaspec.apps.live import LiveView
    from aquaspec.apps.settings import ViewSettings
    canvas = RenderCanvas(size=(VIEW_W, VIEW_H))
    view = LiveView(ViewSettings(width=VIEW_W, height=VIEW_H, bands=3))
    view.attach(canvas)
    yield canvas, view
    view.close()
    canvas.close()
