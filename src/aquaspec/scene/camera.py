"""Pinhole camera in world space.

World units are metres, y is up, the water surface is y = 0 and a point's
depth is ``-p.y``. Pixel (i, j) is row i (top to bottom), column j (left to
right); its ray goes through the pixel centre (j + 0.5, i + 0.5) in pixel
coordinates. Intrinsics follow the usual computer-vision convention (``fx,
fy, cx, cy`` in pixels, image y pointing down).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np

from aquaspec.errors import AquaspecError

#: Largest accepted image side, in pixels.
MAX_SIDE = 8192


def check_size(width, height):
    """Validate an image size; returns ``(width, height)`` as ints."""
    for name, v in (("width", width), ("height", height)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 1 <= v <= MAX_SIDE:
            raise AquaspecError(f"image {name} {v!r} is not accepted; use an integer "
                                f"from 1 to {MAX_SIDE}")
    return int(width), int(height)


def parse_size(text) -> tuple[int, int]:
    """``"WxH"`` (or a ``(W, H)`` pair) -> (W, H), validated by :func:`check_size`."""
    if isinstance(text, (tuple, list)) and len(text) == 2:
        return check_size(*text)
    try:
        w, h = (int(x) for x in str(text).lower().split("x"))
    except ValueError:
        raise AquaspecError(f"image size {text!r} is not WIDTHxHEIGHT, e.g. 1280x720") from None
    return check_size(w, h)


def _normalise(v, name):
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v)
    if v.shape != (3,) or not np.isfinite(n) or n == 0:
        raise AquaspecError(f"{name} {v!r} must be a finite, non-zero 3-vector")
    return v / n


@dataclass(frozen=True)
class Camera:
    """A pinhole camera.

    Parameters
    ----------
    position : (3,) array
        Centre of projection in world metres.
    forward : (3,) array
        Viewing direction (normalised here).
    up : (3,) array
        Approximate up vector; the image's up is its part orthogonal to
        ``forward``.
    width, height : int
        Image size in pixels (1 to 8192).
    fx, fy, cx, cy : float
        Pinhole intrinsics in pixels.
    """

    position: np.ndarray
    forward: np.ndarray
    up: np.ndarray
    width: int
    height: int
    fx: float
    fy: float
    cx: float
    cy: float
    near: float = 0.05
    far: float = 1000.0
    right: np.ndarray = field(init=False, repr=False)
    true_up: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        check_size(self.width, self.height)
        object.__setattr__(self, "position", np.asarray(self.position, dtype=float).reshape(3))
        if not np.all(np.isfinite(self.position)):
            raise AquaspecError(f"camera position {self.position!r} must be finite")
        fwd = _normalise(self.forward, "camera forward")
        right = np.cross(fwd, _normalise(self.up, "camera up"))
        if np.linalg.norm(right) < 1e-9:
            raise AquaspecError("camera up is parallel to forward; give another up vector")
        right /= np.linalg.norm(right)
        object.__setattr__(self, "forward", fwd)
        object.__setattr__(self, "right", right)
        object.__setattr__(self, "true_up", np.cross(right, fwd))
        for name in ("fx", "fy"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise AquaspecError(f"focal length {name}={v!r} must be a positive number of pixels")

    @classmethod
    def look_at(cls, position, target, *, width, height, fov_y_deg=60.0, up=(0.0, 1.0, 0.0)):
        """Camera at ``position`` looking at ``target`` with vertical field of view."""
        width, height = check_size(width, height)
        if not 1.0 <= fov_y_deg <= 170.0:
            raise AquaspecError(f"vertical field of view {fov_y_deg!r} deg; accepted: 1 to 170")
        f = 0.5 * height / np.tan(np.radians(fov_y_deg) / 2)
        fwd = np.asarray(target, dtype=float) - np.asarray(position, dtype=float)
        return cls(position, fwd, up, width, height, f, f, width / 2, height / 2)

    @property
    def depth_m(self) -> float:
        """Depth of the camera below the surface (``-position.y``)."""
        return float(-self.position[1])

    def rotation(self) -> np.ndarray:
        """World-from-camera rotation; columns are right, down, forward (CV axes)."""
        return np.stack([self.right, -self.true_up, self.forward], axis=1)

    def ray_directions(self) -> np.ndarray:
        """Unit world-space ray directions through pixel centres, shape (H, W, 3)."""
        j = np.arange(self.width) + 0.5
        i = np.arange(self.height) + 0.5
        x = (j[None, :] - self.cx) / self.fx
        y = (i[:, None] - self.cy) / self.fy
        d = (self.right[None, None, :] * x[..., None]
             - self.true_up[None, None, :] * y[..., None]
             + self.forward[None, None, :])
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def view_matrix(self) -> np.ndarray:
        """4x4 world-to-view matrix (OpenGL-style view space: x right, y up, -z forward)."""
        r = np.stack([self.right, self.true_up, -self.forward])
        m = np.eye(4)
        m[:3, :3] = r
        m[:3, 3] = -r @ self.position
        return m

    def projection_matrix(self) -> np.ndarray:
        """4x4 view-to-clip matrix for WebGPU (clip z in [0, 1], y up in NDC).

        Built from the pinhole intrinsics so that a point projects to the
        pixel the CV convention assigns it.
        """
        w, h, n, f = self.width, self.height, self.near, self.far
        p = np.zeros((4, 4))
        p[0, 0] = 2 * self.fx / w
        p[0, 2] = 1 - 2 * self.cx / w          # multiplies z_view (negative ahead)
        p[1, 1] = 2 * self.fy / h
        p[1, 2] = 2 * self.cy / h - 1
        p[2, 2] = f / (n - f)
        p[2, 3] = n * f / (n - f)
        p[3, 2] = -1.0
        return p

    def resized(self, width: int, height: int) -> "Camera":
        """The same view on an image of ``width`` x ``height`` pixels: the
        intrinsics scaled with the image (the field of view kept)."""
        width, height = check_size(width, height)
        if (width, height) == (self.width, self.height):
            return self
        sx, sy = width / self.width, height / self.height
        return dataclasses.replace(self, width=width, height=height, fx=self.fx * sx,
                                   fy=self.fy * sy, cx=self.cx * sx, cy=self.cy * sy)

    def describe(self) -> dict:
        return {"position_m": self.position.tolist(), "forward": self.forward.tolist(),
                "up": self.true_up.tolist(), "width": self.width, "height": self.height,
                "fx": self.fx, "fy": self.fy, "cx": self.cx, "cy": self.cy,
                "depth_m": self.depth_m}


def camera_depth(camera) -> float:
    """Camera depth ``-position.y`` in m; raises if the camera is above the water."""
    d_o = float(-camera.position[1])
    if d_o < 0:
        raise AquaspecError(f"camera is {-d_o:g} m above the water surface (position y = "
                            f"{camera.position[1]:g}); the shading needs y <= 0")
    return d_o


#: How far below the horizon a camera above the sea looks by default (degrees).
DEFAULT_LOOK_DOWN_DEG = 30.0


def camera_above(height_m: float, look_down_deg: float = DEFAULT_LOOK_DOWN_DEG, *,
                 width: int, height: int, fov_y_deg: float = 60.0):
    """A camera ``height_m`` above the sea at the origin, looking towards -z
    and ``look_down_deg`` below the horizon (0 ... 90: level to straight down);
    ``height_m`` 0 puts its centre on the surface (the half-and-half view)."""
    h, d = float(height_m), float(look_down_deg)
    if not (np.isfinite(h) and 0.0 <= h <= 10_000.0):
        raise AquaspecError(f"camera height {height_m!r} m; accepted: 0 (at the waterline) to "
                            "10000 m above the sea")
    if not (np.isfinite(d) and 0.0 <= d <= 90.0):
        raise AquaspecError(f"look-down angle {look_down_deg!r} degrees; accepted: 0 (level) "
                            "to 90 (straight down)")
    pitch = np.radians(min(d, 89.9))            # (straight down: an up vector must exist)
    p = np.array([0.0, h, 0.0])
    forward = np.array([0.0, -np.sin(pitch), -np.cos(pitch)])
    return Camera.look_at(p, p + forward, width=width, height=height, fov_y_deg=fov_y_deg)
