"""The live view's run statistics (aquaspec.apps.view), from frame times alone."""

from __future__ import annotations

import pytest

from aquaspec.apps.view import _slowest_second_fps


class TestSlowestSecond:
    def test_steady_frames(self):
        assert _slowest_second_fps([50.0] * 100) == 20      # 5 s at 20 fps

    def test_a_stall_is_the_slowest_second(self):
        """20 fps with a 600 ms stall after 3 s: a second ending with a frame
        and holding the stall has 9 frames in it (the stalled one and 8 at
        50 ms)."""
        times = [50.0] * 60 + [600.0] + [50.0] * 60
        assert _slowest_second_fps(times) == 9

    def test_the_first_second_is_skipped(self):
        """Pipelines compile in the first frames: not counted."""
        assert _slowest_second_fps([900.0] + [25.0] * 200) == 40

    @pytest.mark.parametrize("times", [[], [100.0] * 15])
    def test_too_short_a_run_has_none(self, times):
        assert _slowest_second_fps(times) is None
