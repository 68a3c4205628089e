"""Camera flight (aquaspec.apps.flight), without a window."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.apps import flight
from aquaspec.apps.flight import FlightController
from aquaspec.errors import AquaspecError
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.camera import Camera


def _level_camera(depth_m=5.0):
    """Looking level along -z (yaw 0, pitch 0) at ``depth_m``."""
    p = np.array([0.0, -depth_m, 0.0])
    return Camera.look_at(p, p + [0.0, 0.0, -1.0], width=64, height=36)


def _press(ctl, key, seconds):
    ctl.handle_event({"event_type": "key_down", "key": key, "modifiers": ()})
    ctl.advance(seconds)
    ctl.handle_event({"event_type": "key_up", "key": key, "modifiers": ()})


class TestMoves:
    @pytest.mark.parametrize("key, direction", [
        ("w", (0, 0, -1)), ("s", (0, 0, 1)), ("d", (1, 0, 0)), ("a", (-1, 0, 0)),
        ("e", (0, 1, 0)), ("q", (0, -1, 0))])
    def test_each_key_moves_speed_times_time_its_way(self, key, direction):
        ctl = FlightController(_level_camera(), speed_m_s=2.0)
        start = ctl.position.copy()
        _press(ctl, key, 0.25)
        np.testing.assert_allclose(ctl.position - start, 0.5 * np.array(direction), atol=1e-12)

    def test_shift_letters_move_too(self):
        ctl = FlightController(_level_camera())
        _press(ctl, "W", 0.1)
        assert ctl.position[2] < 0

    def test_forward_follows_the_view(self):
        ctl = FlightController(_level_camera(), speed_m_s=2.0)
        ctl.set_view(90.0, 0.0)                  # yaw 90: looking along +x
        _press(ctl, "w", 0.5)
        np.testing.assert_allclose(ctl.position, [1.0, -5.0, 0.0], atol=1e-12)
        np.testing.assert_allclose(ctl.camera().forward, [1.0, 0.0, 0.0], atol=1e-12)

    def test_two_keys_move_at_the_same_speed(self):
        ctl = FlightController(_level_camera(), speed_m_s=2.0)
        ctl.key_down("w")
        ctl.key_down("d")
        ctl.advance(0.5)
        assert np.linalg.norm(ctl.position - [0.0, -5.0, 0.0]) == pytest.approx(1.0)

    def test_nothing_held_nothing_moves(self):
        ctl = FlightController(_level_camera())
        ctl.advance(1.0)
        np.testing.assert_array_equal(ctl.position, [0.0, -5.0, 0.0])

    def test_a_stalled_frame_moves_at_most_the_step_limit(self):
        ctl = FlightController(_level_camera(), speed_m_s=1.0)
        _press(ctl, "w", 30.0)
        assert -ctl.position[2] == pytest.approx(flight.MAX_STEP_S)


class TestLook:
    def test_drag_turns_yaw_and_pitch(self):
        ctl = FlightController(_level_camera())
        ctl.handle_event({"event_type": "pointer_down", "x": 100, "y": 100, "buttons": (1,)})
        ctl.handle_event({"event_type": "pointer_move", "x": 150, "y": 75, "buttons": (1,)})
        assert ctl.yaw_deg == pytest.approx(50 * flight.MOUSE_DEG_PER_PX)
        assert ctl.pitch_deg == pytest.approx(25 * flight.MOUSE_DEG_PER_PX)   # mouse up: look up
        fwd = ctl.camera().forward
        assert fwd[0] > 0 and fwd[1] > 0

    def test_moving_without_a_button_does_not_turn(self):
        ctl = FlightController(_level_camera())
        ctl.handle_event({"event_type": "pointer_move", "x": 150, "y": 75, "buttons": ()})
        assert (ctl.yaw_deg, ctl.pitch_deg) == (0.0, 0.0)

    def test_pitch_is_bounded(self):
        ctl = FlightController(_level_camera())
        ctl.turn(0.0, -1e6)
        assert ctl.pitch_deg == flight.MAX_PITCH_DEG
        ctl.camera()                        # still a valid camera

    def test_yaw_pitch_round_trip(self):
        for yaw, pitch in [(0, 0), (30, -20), (-150, 60), (179, 10)]:
            got = flight.yaw_pitch_deg(flight.forward_of(yaw, pitch))
            np.testing.assert_allclose(got, (yaw, pitch), atol=1e-9)


class TestBounds:
    def test_stays_below_the_surface(self):
        ctl = FlightController(_level_camera(1.0), speed_m_s=5.0)
        _press(ctl, "e", 0.5)
        assert ctl.depth_m == pytest.approx(flight.SURFACE_MARGIN_M)

    def test_stays_above_the_seabed(self):
        ctl = FlightController(_level_camera(5.0), seabed_depth_m=6.0, speed_m_s=5.0)
        _press(ctl, "q", 0.5)
        assert ctl.depth_m == pytest.approx(6.0 - flight.SEABED_MARGIN_M)

    def test_stays_above_the_floor_and_climbs_over_it(self):
        class Step:
            """Sand at y = -8; a 2 m high block for z < -1."""
            def floor_y(self, x, z):
                return -6.0 if z < -1.0 else -8.0

        ctl = FlightController(_level_camera(7.5), speed_m_s=1.0, floor=Step())
        assert ctl.depth_m == pytest.approx(7.5)
        _press(ctl, "q", 0.5)
        assert ctl.depth_m == pytest.approx(8.0 - flight.SEABED_MARGIN_M)
        for _ in range(4):                       # forward, over the block
            _press(ctl, "w", 0.5)
        assert ctl.position[2] < -1.0
        assert ctl.depth_m == pytest.approx(6.0 - flight.SEABED_MARGIN_M)

    def test_the_surface_wins_over_a_floor_above_it(self):
        class High:
            def floor_y(self, x, z):
                return 1.0

        ctl = FlightController(_level_camera(3.0), floor=High())
        assert ctl.depth_m == pytest.approx(flight.SURFACE_MARGIN_M)

    def test_no_seabed_no_floor(self):
        ctl = FlightController(_level_camera(5.0), speed_m_s=20.0)
        for _ in range(4):
            _press(ctl, "q", 0.5)
        assert ctl.depth_m == pytest.approx(45.0)

    def test_start_pose_is_clamped_into_the_water(self):
        ctl = FlightController(_level_camera(0.0))
        assert ctl.depth_m == flight.SURFACE_MARGIN_M

    def test_builtin_scene_bound(self):
        scene, cam = builtin_scene(5.0, width=64, height=36)
        ctl = FlightController(cam, seabed_depth_m=scene.seabed.depth_m, speed_m_s=20.0)
        _press(ctl, "q", 0.5)
        assert ctl.depth_m <= scene.seabed.depth_m - flight.SEABED_MARGIN_M + 1e-12

    def test_shallow_seabed_is_refused(self):
        with pytest.raises(AquaspecError, match="leaves no water"):
            FlightController(_level_camera(0.4), seabed_depth_m=0.5)

    def test_bad_time_step(self):
        with pytest.raises(AquaspecError, match="time step"):
            FlightController(_level_camera()).advance(float("nan"))


class TestSpeedAndReset:
    def test_plus_minus_scale_speed_within_limits(self):
        ctl = FlightController(_level_camera(), speed_m_s=1.0)
        ctl.key_down("+")
        assert ctl.speed_m_s == pytest.approx(flight.SPEED_STEP)
        ctl.key_down("-")
        ctl.key_down("-")
        assert ctl.speed_m_s == pytest.approx(1.0 / flight.SPEED_STEP)
        for _ in range(50):
            ctl.key_down("=")
        assert ctl.speed_m_s == flight.MAX_SPEED_M_S
        for _ in range(50):
            ctl.key_down("-")
        assert ctl.speed_m_s == flight.MIN_SPEED_M_S

    def test_reset_restores_pose_and_speed(self):
        start = _level_camera()
        ctl = FlightController(start, speed_m_s=1.0)
        ctl.key_down("+")
        _press(ctl, "w", 0.3)
        ctl.turn(40, 10)
        ctl.key_down("r")
        np.testing.assert_array_equal(ctl.position, start.position)
        np.testing.assert_allclose(ctl.camera().forward, start.forward, atol=1e-12)
        assert ctl.speed_m_s == 1.0

    def test_camera_keeps_intrinsics(self):
        start = _level_camera()
        cam = FlightController(start).camera()
        assert (cam.width, cam.height, cam.fx, cam.fy, cam.cx, cam.cy) == \
            (start.width, start.height, start.fx, start.fy, start.cx, start.cy)


class TestFixedView:
    """An RGB-D photograph's view: only up and down."""

    def test_only_q_and_e_move(self):
        ctl = FlightController(_level_camera(), fixed_view=True)
        for key in "wasd":
            _press(ctl, key, 0.5)
        np.testing.assert_allclose(ctl.position, [0.0, -5.0, 0.0])
        _press(ctl, "q", 0.5)
        np.testing.assert_allclose(ctl.position, [0.0, -5.5, 0.0])
        _press(ctl, "e", 0.25)
        np.testing.assert_allclose(ctl.position, [0.0, -5.25, 0.0])

    def test_the_mouse_does_not_turn_and_the_camera_keeps_its_view(self):
        start = _level_camera()
        ctl = FlightController(start, fixed_view=True)
        ctl.handle_event({"event_type": "pointer_down", "x": 0, "y": 0})
        ctl.handle_event({"event_type": "pointer_move", "x": 50, "y": 20, "buttons": (1,)})
        cam = ctl.camera()
        np.testing.assert_array_equal(cam.forward, start.forward)
        assert (cam.fx, cam.cx, cam.width) == (start.fx, start.cx, start.width)

    def test_a_turn_is_refused_and_the_same_view_accepted(self):
        ctl = FlightController(_level_camera(), fixed_view=True)
        ctl.set_view(0.0, 0.0)
        with pytest.raises(AquaspecError, match="keeps its direction"):
            ctl.set_view(10.0, 0.0)

