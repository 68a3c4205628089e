"""aquaspec bench --motion (aquaspec.apps.motion)."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.apps import motion
from aquaspec.errors import AquaspecError
from aquaspec.scene.builtin import builtin_scene


class TestCameraPath:
    def test_moves_by_metres_within_the_step(self):
        _, cam = builtin_scene(5.0, width=64, height=36)
        path = motion.camera_path(cam, 40)
        depths = np.array([c.depth_m for c in path])
        steps = np.abs(np.diff(depths))
        assert path[0].depth_m == pytest.approx(5.0)
        assert steps.max() <= motion.MAX_DEPTH_STEP_M + 1e-12
        assert steps.max() > 0.8                    # changes by up to ~1 m a frame
        assert depths.max() - depths.min() > 3.0    # metres up and down
        assert depths.min() >= motion.MIN_PATH_DEPTH_M
        # It turns too: the view direction changes.
        fwd = np.array([c.forward for c in path])
        assert np.degrees(np.arccos(np.clip(fwd @ fwd[0], -1, 1))).max() > 10

    def test_shallow_start_swings_less(self):
        _, cam = builtin_scene(2.0, width=64, height=36)
        depths = [c.depth_m for c in motion.camera_path(cam, 24)]
        assert min(depths) == pytest.approx(motion.MIN_PATH_DEPTH_M)

    def test_too_shallow_is_refused(self):
        _, cam = builtin_scene(1.0, width=64, height=36)
        with pytest.raises(AquaspecError, match="at least 1.5 m"):
            motion.camera_path(cam, 12)


@pytest.mark.gpu
class TestRun:
    def test_reports_both_frames_each_pass_and_the_switches(self):
        lines = []
        res = motion.run_motion_bench(size=(64, 36), bands=3, frames=12, warmup=1,
                                      light="sun-sky", progress=lines.append)
        for key in ("frame", "per_pass"):
            assert res[key]["still_ms"] > 0 and res[key]["moving_ms"] > 0
            assert res[key]["moving_over_still"] == pytest.approx(
                res[key]["moving_ms"] / res[key]["still_ms"])
        passes = set(res["per_pass"]["passes"])
        # (The light field adds the sun in its shading pass, the display fused.)
        assert {"geometry", "sun shadow", "sun froxels", "shading+display"} <= passes
        assert len(res["path"]["depths_m"]) == 13
        sw = res["switch"]
        assert sw["new_water_s"] > 0 and sw["cached_bands_s"] > 0 and sw["new_sun_s"] > 0
        assert sw["sun_elevation_deg"] == pytest.approx(70.0)
        text = motion.format_motion(res)
        assert "moving / still" in text and "first frame after a change" in text

    def test_too_few_frames(self):
        with pytest.raises(AquaspecError, match="at least 12"):
            motion.run_motion_bench(size=(64, 36), bands=3, frames=5)
