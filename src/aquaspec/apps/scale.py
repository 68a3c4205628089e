"""Render scale: fewer pixels rendered, the frame stretched to the window.

The live view renders at a fraction of the window's size (the present pass
stretches the image to the window, nearest pixel) so that a CPU renderer
stays interactive. :class:`RenderScale` picks the fraction from a fixed
ladder (:data:`SCALE_LEVELS`); with a target frame rate it moves along the
ladder from the frame times it is shown: one step down when the frames are
slower than the target (by :data:`SLOWER_BY`), one step up when the next
level's predicted rate (frame time taken proportional to the pixel count)
still beats the target by :data:`FASTER_BY`. It judges only after
:data:`WINDOW_FRAMES` frames at a level (the first frame at a new level
builds its renderer and is not counted), so it does not flicker.
"""

from __future__ import annotations

import numpy as np

from aquaspec.errors import AquaspecError

#: The scales the view may take (fractions of the window's width and height).
SCALE_LEVELS = (1.0, 0.75, 0.5, 0.375, 0.25)
#: Frames judged at a level before it may change, and frames skipped first.
WINDOW_FRAMES, SETTLE_FRAMES = 12, 2
#: Step down below target / SLOWER_BY fps; step up when the next level is
#: predicted above target * FASTER_BY.
SLOWER_BY, FASTER_BY = 1.1, 1.25


def scaled_size(width: int, height: int, scale: float) -> tuple[int, int]:
    """The render size at ``scale`` of a ``width`` x ``height`` window: the
    window's own at 1, else even sides of at least 16 pixels."""
    if scale == 1.0:
        return int(width), int(height)
    return (max(16, 2 * int(round(width * scale / 2))),
            max(16, 2 * int(round(height * scale / 2))))


class RenderScale:
    """The render scale, fixed or following a target frame rate (module docstring).

    Parameters
    ----------
    scale : float
        The start scale, one of :data:`SCALE_LEVELS`.
    target_fps : float or None
        Frames per second to keep; None: the scale stays.
    """

    def __init__(self, scale: float = 1.0, target_fps: float | None = None):
        if scale not in SCALE_LEVELS:
            raise AquaspecError(f"render scale {scale!r}; accepted: "
                                + ", ".join(f"{s:g}" for s in SCALE_LEVELS))
        if target_fps is not None and not (np.isfinite(target_fps) and target_fps > 0):
            raise AquaspecError(f"target frame rate {target_fps!r} fps; accepted: a positive "
                                "number (or none: a fixed scale)")
        self.level = SCALE_LEVELS.index(scale)
        self.target_fps = None if target_fps is None else float(target_fps)
        self._times: list[float] = []
        self._skip = SETTLE_FRAMES

    @property
    def scale(self) -> float:
        return SCALE_LEVELS[self.level]

    def observe(self, frame_ms: float) -> bool:
        """Take one frame's time (ms); True when the scale changed."""
        if self.target_fps is None:
            return False
        if self._skip:
            self._skip -= 1
            return False
        self._times.append(float(frame_ms))
        if len(self._times) < WINDOW_FRAMES:
            return False
        fps = 1e3 / float(np.median(self._times))
        self._times = []
        level = self.level
        if fps < self.target_fps / SLOWER_BY and level + 1 < len(SCALE_LEVELS):
            level += 1
        elif level > 0:
            gain = (SCALE_LEVELS[level] / SCALE_LEVELS[level - 1]) ** 2
            if fps * gain > self.target_fps * FASTER_BY:
                level -= 1
        if level == self.level:
            return False
        self.level = level
        self._skip = SETTLE_FRAMES
        return True
