"""A lamp's shadows: perspective depth maps seen from the lamp (NumPy twin of the GPU's).

Conventions: metres, y up, the surface at y = 0. A lamp's map is one or
more *faces*, each a square pinhole view from the lamp's position
(:class:`LampShadowFace`, a :class:`aquaspec.scene.camera.Camera` of
``size`` texels a side): a spot lamp whose cone is at most
:data:`SINGLE_FACE_MAX_DEG` has one face along its axis covering the cone;
a wider lamp (up to a point light) has the six faces of a cube, each a
little wider than 90 degrees so that they overlap.

A texel holds the view depth ``z`` (along the face's forward axis) of the
first surface on the ray through its centre: what the GPU's raster writes
(as a perspective depth, :meth:`LampShadowFace.clip_matrix`; WebGPU's depth
``z_ndc = far (z - near) / ((far - near) z)``), and what
:func:`face_depth_map` finds by ray casting
(:func:`aquaspec.scene.raycast.raycast_gbuffer` with the face as the
camera). A point at ``p`` is read in the face its direction from the lamp
points at most along (:func:`lamp_visibility`): it is lit where its own
depth, less a bias of :data:`BIAS_TEXELS` texels at its depth, is at most
the texel's; the four texels around it are compared and the results
weighted bilinearly (percentage-closer filtering), as the sun's map is
read (:mod:`aquaspec.scene.shadowmap`). Outside every face, or beyond the
lamp's side of a single face, a point is lit (it gets no light from the
lamp's profile there anyway).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from aquaspec.scene.camera import Camera
from aquaspec.scene.raycast import raycast_gbuffer

#: Texels a side of each face.
DEFAULT_LAMP_MAP_SIZE = 1024
#: Widest cone (cut-off half-angle, degrees) drawn in one face.
SINGLE_FACE_MAX_DEG = 60.0
#: A face reaches this far beyond its cone or its cube side, degrees.
FACE_MARGIN_DEG = 1.0
#: Near and far planes of the faces, m.
NEAR_M, FAR_M = 0.02, 500.0
#: Depth bias, in texels at the point's depth.
BIAS_TEXELS = 1.5
#: Surface points are looked up this far along their normal, texels at their depth.
NORMAL_OFFSET_TEXELS = 1.5
#: The cube's forward axes and an up for each.
_CUBE = [((1, 0, 0), (0, 1, 0)), ((-1, 0, 0), (0, 1, 0)), ((0, 1, 0), (0, 0, 1)),
         ((0, -1, 0), (0, 0, 1)), ((0, 0, 1), (0, 1, 0)), ((0, 0, -1), (0, 1, 0))]


@dataclass(frozen=True, eq=False)
class LampShadowFace:
    """One face of a lamp's shadow map: a square pinhole ``camera`` at the lamp."""

    camera: Camera

    @property
    def size(self) -> int:
        return self.camera.width

    @property
    def texel_angle(self) -> float:
        """The angle of one texel at the face's centre, rad (``1 / f``)."""
        return 1.0 / self.camera.fx

    def clip_matrix(self) -> np.ndarray:
        """World -> clip (WebGPU, depth 0 at :data:`NEAR_M`, 1 at :data:`FAR_M`)."""
        return self.camera.projection_matrix() @ self.camera.view_matrix()

    def key(self) -> tuple:
        """The face's geometry as a hashable value (equal keys draw equal maps)."""
        c = self.camera
        return ("lamp-face", tuple(c.position), tuple(c.forward), tuple(c.true_up), c.fx,
                c.width)


def _face(position, forward, up, half_angle_deg, size) -> LampShadowFace:
    f = 0.5 * size / np.tan(np.radians(half_angle_deg))
    cam = Camera(position, forward, up, size, size, f, f, 0.5 * size, 0.5 * size,
                 near=NEAR_M, far=FAR_M)
    return LampShadowFace(cam)


def lamp_shadow_faces(lamp, size: int = DEFAULT_LAMP_MAP_SIZE) -> list[LampShadowFace]:
    """The faces of a lamp placed in the world (:meth:`aquaspec.light.lamp.Lamp.placed`)."""
    if lamp.cone_deg <= SINGLE_FACE_MAX_DEG:
        d = lamp.direction
        up = (0.0, 1.0, 0.0) if abs(d[1]) < 0.9 else (1.0, 0.0, 0.0)
        # The square face's half-width covers the cone's half-angle.
        return [_face(lamp.position, d, up, lamp.cone_deg + FACE_MARGIN_DEG, size)]
    return [_face(lamp.position, fwd, up, 45.0 + FACE_MARGIN_DEG, size) for fwd, up in _CUBE]


def face_depth_map(scene, face: LampShadowFace) -> np.ndarray:
    """The face's view depths (size, size), m (``inf`` where no surface), by ray casting."""
    cam = face.camera
    g = raycast_gbuffer(scene, cam)
    depth = g.distance * (cam.ray_directions() @ cam.forward)
    return np.where(np.isfinite(g.distance) & (depth <= FAR_M), depth, np.inf)


def lamp_depth_maps(scene, faces) -> list[np.ndarray]:
    """:func:`face_depth_map` of every face."""
    return [face_depth_map(scene, f) for f in faces]


def face_of(faces, to_point) -> np.ndarray:
    """Which face each direction ``to_point`` (..., 3) from the lamp is read in:
    the one whose forward axis it points at most along."""
    fwd = np.stack([f.camera.forward for f in faces])                  # (F, 3)
    return np.argmax(np.asarray(to_point, dtype=float) @ fwd.T, axis=-1)


def lamp_visibility(faces, maps, points, *, normals=None) -> np.ndarray:
    """``V`` in [0, 1] of the lamp at ``points`` (..., 3); with ``normals``
    (surfaces) the points are first moved off the surface by
    :data:`NORMAL_OFFSET_TEXELS` texels along them."""
    p = np.asarray(points, dtype=float)
    q = faces[0].camera.position
    to_p = p - q
    k = face_of(faces, to_p)
    vis = np.ones(p.shape[:-1])
    for i, (face, depth) in enumerate(zip(faces, maps)):
        sel = k == i
        if not np.any(sel):
            continue
        cam = face.camera
        pts = p[sel]
        z = (pts - q) @ cam.forward
        if normals is not None:
            pts = pts + np.asarray(normals, dtype=float)[sel] * (
                NORMAL_OFFSET_TEXELS * np.maximum(z, 0.0) / cam.fx)[:, None]
            z = (pts - q) @ cam.forward
        zs = np.maximum(z, 1e-9)
        x = cam.fx * ((pts - q) @ cam.right) / zs + cam.cx - 0.5
        y = -cam.fy * ((pts - q) @ cam.true_up) / zs + cam.cy - 0.5
        zb = z - BIAS_TEXELS * z / cam.fx
        j0, i0 = np.floor(x), np.floor(y)
        fx, fy = x - j0, y - i0
        j0, i0 = j0.astype(np.int64), i0.astype(np.int64)
        n = face.size
        v = np.zeros(pts.shape[0])
        for di, wy in ((0, 1.0 - fy), (1, fy)):
            for dj, wx in ((0, 1.0 - fx), (1, fx)):
                ii, jj = i0 + di, j0 + dj
                inside = (ii >= 0) & (ii < n) & (jj >= 0) & (jj < n)
                zm = np.where(inside, depth[np.clip(ii, 0, n - 1), np.clip(jj, 0, n - 1)],
                              np.inf)
                v = v + wx * wy * (zb <= zm)
        vis[sel] = np.where(z > 0, v, 1.0)
    return vis
