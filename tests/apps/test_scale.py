"""Render scale (aquaspec.apps.scale): the ladder and the automatic control, no GPU."""

from __future__ import annotations

import pytest

from aquaspec.apps import scale as sc
from aquaspec.apps.scale import SCALE_LEVELS, RenderScale, scaled_size
from aquaspec.errors import AquaspecError


def _feed(rs, frame_ms, frames):
    changed = [rs.observe(frame_ms) for _ in range(frames)]
    return sum(changed)


def test_scaled_sizes_are_even_and_not_tiny():
    assert scaled_size(1280, 720, 0.5) == (640, 360)
    assert scaled_size(1280, 720, 0.375) == (480, 270)
    assert scaled_size(101, 57, 1.0) == (101, 57)          # the window's own
    assert scaled_size(101, 57, 0.5) == (50, 28)
    assert scaled_size(40, 30, 0.25) == (16, 16)


def test_fixed_scale_never_moves():
    rs = RenderScale(0.5)
    assert _feed(rs, 1000.0, 100) == 0 and rs.scale == 0.5


def test_slow_frames_step_down_one_level_per_window():
    rs = RenderScale(1.0, target_fps=12)
    per_window = sc.SETTLE_FRAMES + sc.WINDOW_FRAMES
    assert _feed(rs, 200.0, per_window - 1) == 0          # not judged yet
    assert _feed(rs, 200.0, 1) == 1 and rs.scale == SCALE_LEVELS[1]
    _feed(rs, 200.0, 10 * per_window)
    assert rs.scale == SCALE_LEVELS[-1]                    # the bottom of the ladder


def test_fast_frames_step_up_only_when_the_next_level_would_still_be_fast():
    rs = RenderScale(0.5, target_fps=10)
    # 60 ms (16.7 fps) at 0.5: 0.75 would take ~135 ms (7.4 fps): stay.
    assert _feed(rs, 60.0, 100) == 0
    # 20 ms (50 fps): 0.75 predicted at 22 fps > 12.5: step up, then again.
    _feed(rs, 20.0, 2 * (sc.SETTLE_FRAMES + sc.WINDOW_FRAMES))
    assert rs.scale == 1.0


def test_on_target_it_stays():
    rs = RenderScale(0.75, target_fps=10)
    assert _feed(rs, 100.0, 200) == 0


@pytest.mark.parametrize("kw, match", [
    ({"scale": 0.6}, "render scale 0.6; accepted: 1, 0.75"),
    ({"target_fps": 0}, "target frame rate 0 fps"),
    ({"target_fps": float("nan")}, "target frame rate nan"),
])
def test_bad_values(kw, match):
    with pytest.raises(AquaspecError, match=match):
        RenderScale(**kw)
