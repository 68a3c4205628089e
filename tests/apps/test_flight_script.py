"""Flight scripts (aquaspec.apps.flight_script): parsing and interpolation."""

from __future__ import annotations

import json

import numpy as np
import pytest

from aquaspec.apps.flight_script import FlightScript, Pose
from aquaspec.errors import AquaspecError

START = Pose((0.0, -5.0, 0.0), 10.0, -10.0)


def _script(*keys, **top):
    return FlightScript({"keyframes": list(keys), **top}, START)


class TestPoses:
    def test_first_keyframe_keeps_what_it_leaves_out(self):
        s = _script({"t": 0, "depth_m": 2})
        assert s.pose_at(0.0) == Pose((0.0, -2.0, 0.0), 10.0, -10.0)

    def test_linear_between_keyframes_and_held_after(self):
        s = _script({"t": 0, "position": [0, -2, 0], "yaw_deg": 0, "pitch_deg": 0},
                    {"t": 2, "position": [4, -6, -2], "pitch_deg": 20})
        mid = s.pose_at(1.0)
        np.testing.assert_allclose(mid.position, [2, -4, -1])
        assert (mid.yaw_deg, mid.pitch_deg) == (0.0, 10.0)
        assert s.pose_at(5.0) == s.keyframes[-1].pose
        assert s.pose_at(-1.0) == s.keyframes[0].pose

    def test_yaw_turns_the_short_way(self):
        s = _script({"t": 0, "yaw_deg": 170}, {"t": 1, "yaw_deg": -170})
        assert s.pose_at(0.5).yaw_deg == pytest.approx(180.0)

    def test_depth_overrides_the_position_height(self):
        s = _script({"t": 0, "position": [1, -2, 3], "depth_m": 7})
        assert s.keyframes[0].pose.position == (1.0, -7.0, 3.0)

    def test_frames_at_the_script_rate(self):
        s = _script({"t": 0}, fps=4)
        assert s.time_of(6) == 1.5


class TestChanges:
    def test_changes_fire_once_in_their_interval(self):
        s = _script({"t": 0, "water": "IB"}, {"t": 1, "water": "II", "auto_exposure": True})
        assert [k.water for k in s.changes_between(None, 0.0)] == ["IB"]
        assert s.changes_between(0.0, 0.5) == []
        fired = s.changes_between(0.5, 1.0)
        assert [(k.water, k.auto_exposure) for k in fired] == [("II", True)]


class TestErrors:
    @pytest.mark.parametrize("doc, match", [
        ({}, "non-empty list 'keyframes'"),
        ({"keyframes": []}, "non-empty list 'keyframes'"),
        ({"keyframes": [{"t": 0}], "speed": 2}, r"unknown key\(s\) \['speed'\]"),
        ({"keyframes": [{"t": 0, "zoom": 2}]}, r"unknown key\(s\) \['zoom'\]; accepted: t, "),
        ({"keyframes": [{"t": 0}, {"t": 0}]}, "not after the one before"),
        ({"keyframes": [{"t": 0}, {"depth_m": 3}]}, "keyframe 1 t is None"),
        ({"keyframes": [{"t": 0, "depth_m": -1}]}, "depth_m is -1; accepted: >= 0"),
        ({"keyframes": [{"t": 0, "position": [0, 1]}]}, r"accepted: \[x, y, z\]"),
        ({"keyframes": [{"t": 0, "yaw_deg": "north"}]}, "yaw_deg is 'north'"),
        ({"keyframes": [{"t": 0, "water": 3}]}, "water is 3"),
        ({"keyframes": [{"t": 0}], "fps": 0}, "fps is 0"),
    ])
    def test_bad_scripts_name_the_value(self, doc, match):
        with pytest.raises(AquaspecError, match=match):
            FlightScript(doc, START)

    def test_load_reads_json_and_names_bad_files(self, tmp_path):
        good = tmp_path / "f.json"
        good.write_text(json.dumps({"keyframes": [{"t": 0, "depth_m": 3}]}))
        assert FlightScript.load(good, START).pose_at(0).position[1] == -3.0
        bad = tmp_path / "bad.json"
        bad.write_text("{keyframes: ")
        with pytest.raises(AquaspecError, match="bad.json' is not valid JSON"):
            FlightScript.load(bad, START)
        with pytest.raises(AquaspecError, match="does not exist"):
            FlightScript.load(tmp_path / "missing.json", START)
