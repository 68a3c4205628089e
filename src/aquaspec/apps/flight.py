"""Camera flight: keys and mouse to a camera pose that stays in the water.

:class:`FlightController` is pure Python (no window, no GPU): it takes
``rendercanvas`` event dicts (:meth:`FlightController.handle_event`) or direct
calls, advances by the time elapsed (:meth:`FlightController.advance`) and
gives the :class:`aquaspec.scene.camera.Camera` of its pose.

Controls: W/S forward and back along the view direction, A/D left and right,
Q/E down and up (world y), the mouse dragged with a button held turns the
view (yaw and pitch), +/- multiply and divide the speed by
:data:`SPEED_STEP`, R goes back to the start pose and speed.

The pose is yaw and pitch in degrees as :mod:`aquaspec.apps.motion` defines
them (forward ``(cos p sin y, sin p, -cos p cos y)``: yaw 0 looks along -z,
positive yaw turns towards +x, positive pitch looks up). World units are
metres, y is up, the water surface is y = 0: the camera stays at least
``surface_margin_m`` below it and, with a seabed, ``seabed_margin_m`` above
the seabed's depth and (with a ``floor``, e.g. a
:class:`aquaspec.apps.floor.FloorMap`) above the highest surface under it;
the surface wins where the two cannot both hold.

With ``fixed_view`` (an RGB-D photograph, seen only along its own rays) the
camera keeps its start direction: Q/E move it up and down, W/A/S/D and the
mouse do nothing, and a script that turns it is refused.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.scene.camera import Camera

#: Pitch limit, degrees (looking straight up or down would leave the up vector undefined).
MAX_PITCH_DEG = 85.0
#: Speed range, m/s, and the factor of one +/- press.
MIN_SPEED_M_S, MAX_SPEED_M_S, SPEED_STEP = 0.05, 20.0, 1.5
#: Closest the camera comes to the surface and to the seabed, m.
SURFACE_MARGIN_M, SEABED_MARGIN_M = 0.3, 0.3
#: Degrees of turn per pixel of mouse drag.
MOUSE_DEG_PER_PX = 0.2
#: Largest time step one advance takes, s (a stalled frame must not fling the camera).
MAX_STEP_S = 0.5

#: Movement keys: (forward, right, up) unit steps.
MOVE_KEYS = {"w": (1, 0, 0), "s": (-1, 0, 0), "d": (0, 1, 0), "a": (0, -1, 0),
             "e": (0, 0, 1), "q": (0, 0, -1)}
FASTER_KEYS, SLOWER_KEYS, RESET_KEYS = ("+", "=", "Add"), ("-", "_", "Subtract"), ("r",)


def yaw_pitch_deg(forward) -> tuple[float, float]:
    """Yaw and pitch (degrees) of a view direction (module docstring)."""
    f = np.asarray(forward, dtype=float)
    f = f / np.linalg.norm(f)
    return (float(np.degrees(np.arctan2(f[0], -f[2]))),
            float(np.degrees(np.arcsin(np.clip(f[1], -1.0, 1.0)))))


def forward_of(yaw_deg: float, pitch_deg: float) -> np.ndarray:
    """Unit view direction of ``yaw_deg``, ``pitch_deg`` (module docstring)."""
    y, p = np.radians(yaw_deg), np.radians(pitch_deg)
    return np.array([np.cos(p) * np.sin(y), np.sin(p), -np.cos(p) * np.cos(y)])


def _positive(name, value) -> float:
    v = float(value)
    if not (np.isfinite(v) and v > 0):
        raise AquaspecError(f"{name}={value!r}; accepted: a positive finite number")
    return v


class FlightController:
    """A flying camera's pose, moved by keys and mouse, bound to the water.

    Parameters
    ----------
    camera : Camera
        The start pose; its image size and intrinsics are kept.
    seabed_depth_m : float, optional
        Depth of the seabed (the camera stays ``seabed_margin_m`` above it);
        None: no lower bound.
    speed_m_s : float
        Start speed, within [:data:`MIN_SPEED_M_S`, :data:`MAX_SPEED_M_S`].
    surface_margin_m, seabed_margin_m : float
        Closest approach to the surface and to the seabed (or floor).
    floor : object, optional
        Has ``floor_y(x, z)``: the height of the highest surface under a
        point (-inf where none), e.g. a :class:`aquaspec.apps.floor.FloorMap`.
    fixed_view : bool
        Keep the start direction; only up and down moves (module docstring).
    """

    def __init__(self, camera: Camera, *, seabed_depth_m: float | None = None,
                 speed_m_s: float = 1.0, surface_margin_m: float = SURFACE_MARGIN_M,
                 seabed_margin_m: float = SEABED_MARGIN_M, floor=None,
                 fixed_view: bool = False):
        self._start_camera = camera
        self.fixed_view = bool(fixed_view)
        self.floor = floor
        self.surface_margin_m = _positive("surface_margin_m", surface_margin_m)
        self.seabed_margin_m = _positive("seabed_margin_m", seabed_margin_m)
        self.seabed_depth_m = None if seabed_depth_m is None else _positive(
            "seabed_depth_m", seabed_depth_m)
        if self.seabed_depth_m is not None and \
                self.seabed_depth_m <= self.surface_margin_m + self.seabed_margin_m:
            raise AquaspecError(f"seabed at {self.seabed_depth_m:g} m leaves no water to fly "
                                f"in; accepted: deeper than {self.surface_margin_m:g} + "
                                f"{self.seabed_margin_m:g} m")
        self._start_speed = float(np.clip(_positive("speed_m_s", speed_m_s),
                                          MIN_SPEED_M_S, MAX_SPEED_M_S))
        self._held: set[str] = set()
        self._drag = None           # last pointer position while a button is held
        self.reset()

    # ----------------------------------------------------------------- pose
    def reset(self) -> None:
        """Back to the start pose and speed (the R key)."""
        c = self._start_camera
        self.yaw_deg, self.pitch_deg = yaw_pitch_deg(c.forward)
        self.pitch_deg = float(np.clip(self.pitch_deg, -MAX_PITCH_DEG, MAX_PITCH_DEG))
        self.speed_m_s = self._start_speed
        self.set_position(c.position)

    def depth_range_m(self, at=None) -> tuple[float, float]:
        """The depths the camera may take, (shallowest, deepest) in metres;
        ``at`` (x, z): there, above the floor too (the surface wins)."""
        deepest = np.inf if self.seabed_depth_m is None else \
            self.seabed_depth_m - self.seabed_margin_m
        if at is not None and self.floor is not None:
            deepest = min(deepest, -(self.floor.floor_y(*at) + self.seabed_margin_m))
        return self.surface_margin_m, max(self.surface_margin_m, deepest)

    def set_position(self, position) -> None:
        """Move to ``position`` (world metres), its depth clamped to
        :meth:`depth_range_m` and kept above the floor."""
        p = np.asarray(position, dtype=float).reshape(3).copy()
        if not np.all(np.isfinite(p)):
            raise AquaspecError(f"camera position {p!r}; accepted: finite metres")
        lo, hi = self.depth_range_m(at=(p[0], p[2]))
        p[1] = -float(np.clip(-p[1], lo, hi))
        self.position = p

    def set_view(self, yaw_deg: float, pitch_deg: float) -> None:
        """Look along ``yaw_deg``, ``pitch_deg`` (pitch clamped to :data:`MAX_PITCH_DEG`)."""
        if not (np.isfinite(yaw_deg) and np.isfinite(pitch_deg)):
            raise AquaspecError(f"view yaw {yaw_deg!r}, pitch {pitch_deg!r} deg; accepted: "
                                "finite angles")
        if self.fixed_view:
            start = yaw_pitch_deg(self._start_camera.forward)
            if not np.allclose(np.radians([yaw_deg, pitch_deg]), np.radians(start), atol=1e-6):
                raise AquaspecError(f"view yaw {yaw_deg:g}, pitch {pitch_deg:g} deg: this view "
                                    f"keeps its direction (yaw {start[0]:g}, pitch "
                                    f"{start[1]:g}); only its depth changes")
        self.yaw_deg = float((yaw_deg + 180.0) % 360.0 - 180.0)
        self.pitch_deg = float(np.clip(pitch_deg, -MAX_PITCH_DEG, MAX_PITCH_DEG))

    @property
    def depth_m(self) -> float:
        """The camera's depth below the surface, m."""
        return float(-self.position[1])

    def camera(self) -> Camera:
        """The camera of the current pose (the start camera's size and intrinsics)."""
        if self.fixed_view:
            return dataclasses.replace(self._start_camera, position=self.position.copy())
        return dataclasses.replace(self._start_camera, position=self.position.copy(),
                                   forward=forward_of(self.yaw_deg, self.pitch_deg),
                                   up=np.array([0.0, 1.0, 0.0]))

    # ------------------------------------------------------------- controls
    def key_down(self, key: str) -> None:
        """A key pressed (rendercanvas key names; letters in either case)."""
        k = key.lower() if len(key) == 1 else key
        if k in MOVE_KEYS:
            if not self.fixed_view or MOVE_KEYS[k][:2] == (0, 0):
                self._held.add(k)
        elif key in FASTER_KEYS:
            self.speed_m_s = min(self.speed_m_s * SPEED_STEP, MAX_SPEED_M_S)
        elif key in SLOWER_KEYS:
            self.speed_m_s = max(self.speed_m_s / SPEED_STEP, MIN_SPEED_M_S)
        elif k in RESET_KEYS:
            self.reset()

    def key_up(self, key: str) -> None:
        """A key released."""
        self._held.discard(key.lower() if len(key) == 1 else key)

    def turn(self, dx_px: float, dy_px: float) -> None:
        """Turn the view by a mouse drag of ``dx_px``, ``dy_px`` pixels (y down)."""
        self.set_view(self.yaw_deg + dx_px * MOUSE_DEG_PER_PX,
                      self.pitch_deg - dy_px * MOUSE_DEG_PER_PX)

    def handle_event(self, event: dict) -> None:
        """Apply a ``rendercanvas`` event (``key_down``, ``key_up``,
        ``pointer_down``, ``pointer_move``, ``pointer_up``); others are ignored."""
        kind = event.get("event_type")
        if kind == "key_down":
            self.key_down(event["key"])
        elif kind == "key_up":
            self.key_up(event["key"])
        elif kind == "pointer_down" and not self.fixed_view:
            self._drag = (event["x"], event["y"])
        elif kind == "pointer_up":
            self._drag = None
        elif kind == "pointer_move" and self._drag is not None and event.get("buttons"):
            x, y = event["x"], event["y"]
            self.turn(x - self._drag[0], y - self._drag[1])
            self._drag = (x, y)

    @property
    def moving(self) -> bool:
        """Whether a movement key is held."""
        return bool(self._held)

    def advance(self, dt_s: float) -> None:
        """Move by the held keys for ``dt_s`` seconds (at most :data:`MAX_STEP_S`)."""
        if not (np.isfinite(dt_s) and dt_s >= 0):
            raise AquaspecError(f"time step {dt_s!r} s; accepted: a finite number >= 0")
        if not self._held:
            return
        f, r, u = np.sum([MOVE_KEYS[k] for k in self._held], axis=0)
        fwd = forward_of(self.yaw_deg, self.pitch_deg)
        right = np.array([np.cos(np.radians(self.yaw_deg)), 0.0,
                          np.sin(np.radians(self.yaw_deg))])
        step = f * fwd + r * right + u * np.array([0.0, 1.0, 0.0])
        n = np.linalg.norm(step)
        if n > 0:
            self.set_position(self.position
                              + step / n * self.speed_m_s * min(dt_s, MAX_STEP_S))
