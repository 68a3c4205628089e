"""The pinhole camera as uniform fields, shared by every pass that casts the pixels' rays.

:data:`CAMERA_FIELDS` opens the uniform layout (:class:`aquaspec.gpu.layout.UniformLayout`)
of the deferred, light-field, sun and shadow passes; :func:`camera_fields`
gives their values for a :class:`aquaspec.scene.camera.Camera`. Each pass's
WGSL rebuilds a pixel's ray from them as
:meth:`aquaspec.scene.camera.Camera.ray_directions` does.
"""

from __future__ import annotations

#: The camera's world position and axes, and its intrinsics in pixels.
CAMERA_FIELDS = [
    ("position", "vec3<f32>"), ("fx", "f32"),
    ("right", "vec3<f32>"), ("fy", "f32"),
    ("up", "vec3<f32>"), ("cx", "f32"),
    ("forward", "vec3<f32>"), ("cy", "f32"),
]


def camera_fields(camera) -> dict:
    """Values of :data:`CAMERA_FIELDS` for ``camera``."""
    return dict(position=camera.position, fx=camera.fx, right=camera.right, fy=camera.fy,
                up=camera.true_up, cx=camera.cx, forward=camera.forward, cy=camera.cy)
