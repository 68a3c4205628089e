"""What the live view does at the surface: it flies under it, and says so."""

from __future__ import annotations

import pytest

from aquaspec.apps.flight import SURFACE_MARGIN_M
from aquaspec.apps.settings import ViewSettings
from aquaspec.errors import AquaspecError


@pytest.mark.parametrize("depth", [0.0, 0.2, -1.0, float("nan")])
def test_a_start_at_or_above_the_surface_is_refused(depth):
    with pytest.raises(AquaspecError, match=f"flies at least {SURFACE_MARGIN_M:g} m under"):
        ViewSettings(depth_m=depth)
    assert ViewSettings(depth_m=SURFACE_MARGIN_M).depth_m == SURFACE_MARGIN_M


@pytest.mark.gpu
def test_a_script_above_the_water_is_flown_under_it_and_said(canvas_and_view):
    from aquaspec.apps.flight_script import FlightScript, Pose
    canvas, view = canvas_and_view
    start = Pose(tuple(view.flight.position), view.flight.yaw_deg, view.flight.pitch_deg)
    view.script = FlightScript({"keyframes": [{"t": 0, "depth_m": 2}, {"t": 0.1, "depth_m": 0}],
                                "fps": 10}, start)
    canvas.draw()
    assert view.message is None
    canvas.draw()
    assert view.flight.depth_m == pytest.approx(SURFACE_MARGIN_M)
    assert "flown 0.3 m under the surface" in view.message


@pytest.mark.gpu
def test_the_panel_turns_the_surface_from_below_off_and_on(canvas_and_view):
    """The control reaches the renderer of the next frame (where a frame looking
    up under the sun would draw the sun's disc: bench --surface times both)."""
    from aquaspec.apps.controls import ViewControls
    canvas, view = canvas_and_view
    c = ViewControls(view)
    c.set_surface_from_below(False)
    canvas.draw()
    assert view.renderer.surface_from_below is False
    c.set_surface_from_below(True)
    canvas.draw()
    assert view.renderer.surface_from_below is True
