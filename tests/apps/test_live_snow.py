"""Marine snow in the live view (aquaspec.apps.live, aquaspec.apps.controls)."""

from __future__ import annotations

import numpy as np
import pytest

pytestmark = pytest.mark.gpu


def _frame(canvas) -> np.ndarray:
    return np.asarray(canvas.draw())[..., :3].astype(float)


def test_snow_shows_drifts_and_goes(canvas_and_view):
    from aquaspec.apps.controls import ViewControls
    canvas, view = canvas_and_view
    controls = ViewControls(view)
    view.wave_speed = 0.0                      # the view's clock stands: frames comparable
    plain = _frame(canvas)
    assert controls.set_marine_snow("3000,2,albedo=1,range=1.5,current=0.3:0:0")
    snow = _frame(canvas)
    assert view.renderer.snow.drawn > 100
    assert np.abs(snow - plain).max() > 20      # particles over the frame (8-bit)
    np.testing.assert_array_equal(_frame(canvas), snow)     # the same instant, the same frame
    view.time_s += 2.0                         # the current carries them 0.6 m
    assert np.abs(_frame(canvas) - snow).max() > 20
    assert controls.set_marine_snow(None)
    np.testing.assert_allclose(_frame(canvas), plain, atol=1)


def test_bad_snow_leaves_the_view_and_says_why(canvas_and_view):
    from aquaspec.apps.controls import ViewControls
    _, view = canvas_and_view
    assert not ViewControls(view).set_marine_snow("-5")
    assert view.marine_snow is None and "density_per_m3=-5.0" in view.message
