"""The seabed: the light field's lower boundary, and a plane to see it by.

:class:`Seabed` is a flat Lambertian floor at a depth: the light field's lower
boundary (:mod:`aquaspec.transport.lightfield.bake`). A scene that has no
floor of its own (a mesh placed in the water) can be given one that the
camera sees as well, :func:`with_seabed_plane`, so the geometry and the
light field's boundary agree.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from aquaspec.colour.reflectance import Reflectance
from aquaspec.errors import AquaspecError
from aquaspec.scene.mesh import Mesh, Scene

#: A seabed plane reaches as far as the water lets this share of the light
#: through along a ray in its clearest band, counting absorption alone (the
#: least any model attenuates): farther out, seabed and open water look the
#: same in an image.
PLANE_TRANSMISSION = 1e-3
#: Sides of the plane's polygon (a disc around the point below the camera).
PLANE_SIDES = 32


@dataclass(frozen=True)
class Seabed:
    """A flat Lambertian seabed as the light field's lower boundary.

    ``depth_m`` (> 0, m below the surface) and ``reflectance``: an object
    with ``on_bands(bands)`` (:class:`aquaspec.colour.reflectance.Reflectance`, e.g.
    the built-in scene's sand) or a number in [0, 1] (grey). The light field
    (``lightfield_tables(seabed_depth_m=, seabed_albedo=)``,
    :mod:`aquaspec.transport.lightfield.bake`) then carries the light the seabed
    reflects up (SPEC: leaving it out made targets 9-15 % too dark in Jerlov
    I); the seabed *mesh* a scene draws is separate geometry.
    """

    depth_m: float
    reflectance: object = 0.2

    def __post_init__(self):
        d = self.depth_m
        if isinstance(d, bool) or not isinstance(d, (int, float, np.number)) \
                or not np.isfinite(d) or d <= 0:
            raise AquaspecError(f"seabed depth_m={d!r}; accepted: a finite depth > 0 m")
        r = self.reflectance
        if not hasattr(r, "on_bands"):
            if isinstance(r, bool) or not isinstance(r, (int, float, np.number)) \
                    or not 0.0 <= float(r) <= 1.0:
                raise AquaspecError(f"seabed reflectance={r!r}; accepted: a Reflectance or "
                                    "a number in [0, 1]")

    def albedo_on(self, bands) -> np.ndarray:
        """Band albedo (n,) on ``bands``."""
        r = self.reflectance
        if hasattr(r, "on_bands"):
            return np.asarray(r.on_bands(bands), dtype=float)
        return np.full(bands.n, float(r))

    def describe(self) -> dict:
        r = self.reflectance
        return {"depth_m": float(self.depth_m),
                "reflectance": getattr(r, "name", None) if hasattr(r, "on_bands") else float(r)}


def plane_radius_m(absorption_per_m, *, below_camera_m: float, far_m: float,
                   reach_m: float = 0.0) -> float:
    """Radius of a seabed plane around the point below the camera, metres.

    The distance at which the water's clearest band keeps
    :data:`PLANE_TRANSMISSION` of the light, ``ln(1 / T) / min(a)``, at least
    ``reach_m`` (the scene's own horizontal extent, which the plane must lie
    under) and short enough that every point of the plane stays within 0.9
    of the camera's far plane ``far_m`` (``below_camera_m`` under it), so a
    rasteriser and a ray caster see the same plane.
    """
    a_min = float(np.min(absorption_per_m))
    visibility = np.log(1.0 / PLANE_TRANSMISSION) / a_min if a_min > 0 else np.inf
    longest = np.sqrt(max((0.9 * far_m) ** 2 - below_camera_m ** 2, 0.0))
    return float(min(max(visibility, reach_m), longest))


def with_seabed_plane(scene: Scene, seabed: Seabed, camera, radius_m: float) -> Scene:
    """A copy of ``scene`` standing on ``seabed``: a flat Lambertian plane at
    ``y = -seabed.depth_m`` facing up, of the seabed's reflectance (a grey
    :meth:`Reflectance.constant` for a number), ``radius_m`` around the point
    below ``camera``, also set as the scene's ``seabed`` (the light field's
    lower boundary)."""
    if not radius_m > 0:
        raise AquaspecError(f"seabed plane radius_m={radius_m!r}; accepted: a distance > 0 m")
    r = seabed.reflectance
    material = r if hasattr(r, "on_bands") else Reflectance.constant(float(r), name="seabed")
    out = dataclasses.replace(scene, meshes=list(scene.meshes), materials=list(scene.materials),
                              seabed=seabed)
    index = out.add_material(material)
    x0, z0 = float(camera.position[0]), float(camera.position[2])
    t = np.linspace(0.0, 2.0 * np.pi, PLANE_SIDES, endpoint=False)
    ring = np.stack([x0 + radius_m * np.cos(t), np.full_like(t, -float(seabed.depth_m)),
                     z0 - radius_m * np.sin(t)], axis=1)
    vertices = np.concatenate([[[x0, -float(seabed.depth_m), z0]], ring])
    i = np.arange(PLANE_SIDES)
    # Counter-clockwise seen from above: the faces' normals point up (+y).
    faces = np.stack([np.zeros(PLANE_SIDES, int), 1 + i, 1 + (i + 1) % PLANE_SIDES], axis=1)
    out.add(Mesh(vertices, faces, np.tile([0.0, 1.0, 0.0], (len(vertices), 1)), index,
                 name="seabed"))
    return out
