"""Flat horizontal plates for sun and caustics tests."""

import numpy as np

from aquaspec.colour.reflectance import Reflectance
from aquaspec.scene.mesh import Mesh, Scene


def plate(y, x0, x1, z0, z1, material=0) -> Mesh:
    """A horizontal rectangle at height ``y`` over ``[x0, x1] x [z0, z1]``, facing up."""
    v = np.array([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], float)
    return Mesh.flat(v, np.array([[0, 1, 2], [0, 2, 3]]), material=material, name="plate")


#: The small plate of :func:`plate_scene`: ``(y, x0, x1, z0, z1)``.
SMALL_PLATE = (-1.0, -3.0, 0.0, -20.0, 2.0)


def plate_scene() -> Scene:
    """A small grey plate under 1 m of water (x < 0) over a seabed at 6 m."""
    scene = Scene()
    scene.add_material(Reflectance.constant(0.5))
    scene.add(plate(*SMALL_PLATE))                      # x < 0 under 1 m of water
    scene.add(plate(-6.0, -30.0, 30.0, -40.0, 10.0))    # the seabed at 6 m
    return scene


def exact_visibility(points, to_sun, plate=SMALL_PLATE):
    """Lit unless the line towards the sun crosses the small plate (the seabed
    is below every point asked about)."""
    y0, x0, x1, z0, z1 = plate
    p = np.asarray(points, float)
    t = (y0 - p[..., 1]) / to_sun[1]
    q = p + t[..., None] * to_sun
    under = (t > 0) & (q[..., 0] > x0) & (q[..., 0] < x1) & (q[..., 2] > z0) & (q[..., 2] < z1)
    return (~under).astype(float)
