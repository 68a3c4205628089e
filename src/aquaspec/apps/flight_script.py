"""Scripted flights: a camera path and parameter changes from a JSON file.

``aquaspec view --offscreen --script FLIGHT.json --frames N`` renders frame
``i`` at the time ``t = i / fps``. The file::

    {
      "fps": 30,
      "keyframes": [
        {"t": 0, "position": [0, -3, 0], "yaw_deg": 0, "pitch_deg": 0, "water": "IB"},
        {"t": 2, "depth_m": 12},
        {"t": 4, "yaw_deg": 45, "water": "II", "auto_exposure": true}
      ]
    }

``fps`` (default :data:`DEFAULT_FPS`) is the frames' rate in the script's
time. Keyframes, in increasing ``t`` (seconds), give any of ``position``
(world metres, y up, the surface at y = 0), ``depth_m`` (the position's
depth: ``y = -depth_m``), ``yaw_deg`` and ``pitch_deg`` (as in
:mod:`aquaspec.apps.flight`); what a keyframe leaves out it keeps from the one
before (the first from the view's start pose). Between keyframes the pose is
interpolated linearly (yaw the short way round); after the last it holds.
Parameter changes take effect from their keyframe's time on: ``water`` (a
Jerlov type or CSV path) and ``auto_exposure`` (true: set exposure and white
balance again from that frame; otherwise they hold from the first frame, so
frames compare).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.io.limits import read_text

#: Frames per second of the script's time when the file does not say.
DEFAULT_FPS = 30.0
#: Keys a keyframe may hold.
KEYFRAME_KEYS = ("t", "position", "depth_m", "yaw_deg", "pitch_deg", "water", "auto_exposure")


@dataclasses.dataclass(frozen=True)
class Pose:
    """A camera pose: position (world metres), yaw and pitch (degrees)."""

    position: tuple
    yaw_deg: float
    pitch_deg: float


@dataclasses.dataclass(frozen=True)
class Keyframe:
    """One resolved keyframe: its time, full pose and parameter changes."""

    t: float
    pose: Pose
    water: str | None = None
    auto_exposure: bool = False


def _number(value, what):
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
        raise AquaspecError(f"flight script: {what} is {value!r}; accepted: a finite number")
    return float(value)


class FlightScript:
    """A parsed flight script (module docstring).

    Parameters
    ----------
    doc : dict
        The JSON document.
    start : Pose
        The pose keyframes start from (what the first one leaves out).
    source : str
        Where it came from, for error messages.
    """

    def __init__(self, doc, start: Pose, source: str = "flight script"):
        if not isinstance(doc, dict) or not isinstance(doc.get("keyframes"), list) \
                or not doc["keyframes"]:
            raise AquaspecError(f"{source}: accepted: a JSON object with a non-empty list "
                                "'keyframes'")
        unknown = set(doc) - {"fps", "keyframes"}
        if unknown:
            raise AquaspecError(f"{source}: unknown key(s) {sorted(unknown)}; accepted: fps, "
                                "keyframes")
        self.source = source
        self.fps = _number(doc.get("fps", DEFAULT_FPS), "fps")
        if self.fps <= 0:
            raise AquaspecError(f"{source}: fps is {self.fps:g}; accepted: > 0")
        self.doc = doc
        self.keyframes = []
        pose = start
        for i, raw in enumerate(doc["keyframes"]):
            key = self._resolve(i, raw, pose)
            if self.keyframes and key.t <= self.keyframes[-1].t:
                raise AquaspecError(f"{source}: keyframe {i} has t={key.t:g} s, not after "
                                    f"the one before ({self.keyframes[-1].t:g} s); accepted: "
                                    "increasing times")
            self.keyframes.append(key)
            pose = key.pose

    @classmethod
    def load(cls, path, start: Pose) -> "FlightScript":
        """Read a flight script from a JSON file."""
        p = Path(path)
        try:
            doc = json.loads(read_text(p, "script", "flight script"))
        except json.JSONDecodeError as exc:
            raise AquaspecError(f"flight script {str(p)!r} is not valid JSON: {exc}") from None
        return cls(doc, start, f"flight script {str(p)!r}")

    def _resolve(self, i, raw, before: Pose) -> Keyframe:
        where = f"{self.source}: keyframe {i}"
        if not isinstance(raw, dict):
            raise AquaspecError(f"{where} is {raw!r}; accepted: a JSON object")
        unknown = set(raw) - set(KEYFRAME_KEYS)
        if unknown:
            raise AquaspecError(f"{where}: unknown key(s) {sorted(unknown)}; accepted: "
                                + ", ".join(KEYFRAME_KEYS))
        t = _number(raw.get("t", 0.0 if i == 0 else None), f"keyframe {i} t")
        position = np.array(before.position, dtype=float)
        if "position" in raw:
            p = raw["position"]
            if not isinstance(p, list) or len(p) != 3:
                raise AquaspecError(f"{where}: position is {p!r}; accepted: [x, y, z] in "
                                    "metres")
            position = np.array([_number(v, f"keyframe {i} position") for v in p])
        if "depth_m" in raw:
            depth = _number(raw["depth_m"], f"keyframe {i} depth_m")
            if depth < 0:
                raise AquaspecError(f"{where}: depth_m is {depth:g}; accepted: >= 0 (below "
                                    "the surface)")
            position[1] = -depth
        yaw = _number(raw.get("yaw_deg", before.yaw_deg), f"keyframe {i} yaw_deg")
        pitch = _number(raw.get("pitch_deg", before.pitch_deg), f"keyframe {i} pitch_deg")
        water = raw.get("water")
        if water is not None and not isinstance(water, str):
            raise AquaspecError(f"{where}: water is {water!r}; accepted: a Jerlov type name "
                                "or a CSV path")
        auto = raw.get("auto_exposure", False)
        if not isinstance(auto, bool):
            raise AquaspecError(f"{where}: auto_exposure is {auto!r}; accepted: true or false")
        return Keyframe(t, Pose(tuple(float(v) for v in position), yaw, pitch), water, auto)

    def time_of(self, frame: int) -> float:
        """The script time of frame ``frame``, s."""
        return frame / self.fps

    def pose_at(self, t: float) -> Pose:
        """The interpolated pose at time ``t`` (module docstring)."""
        keys = self.keyframes
        if t <= keys[0].t:
            return keys[0].pose
        for a, b in zip(keys, keys[1:]):
            if t < b.t:
                s = (t - a.t) / (b.t - a.t)
                pa, pb = np.array(a.pose.position), np.array(b.pose.position)
                turn = (b.pose.yaw_deg - a.pose.yaw_deg + 180.0) % 360.0 - 180.0
                return Pose(tuple(float(v) for v in pa + s * (pb - pa)),
                            a.pose.yaw_deg + s * turn,
                            a.pose.pitch_deg + s * (b.pose.pitch_deg - a.pose.pitch_deg))
        return keys[-1].pose

    def changes_between(self, t0: float | None, t1: float) -> list[Keyframe]:
        """The keyframes whose time lies in ``(t0, t1]`` (``t0`` None: up to ``t1``)."""
        return [k for k in self.keyframes if (t0 is None or k.t > t0) and k.t <= t1]
