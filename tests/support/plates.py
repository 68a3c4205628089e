"""Flat horizontal plates for sun and caustics tests."""

import numpy as np

from aquaspec.scene.mesh import Mesh


def plate(y, x0, x1, z0, z1, material=0) -> Mesh:
    """A horizontal rectangle at height ``y`` over ``[x0, x1] x [z0, z1]``, facing up."""
    v = np.array([[x0, y, z0], [x1, y, z0], [x1, y, z1], [x0, y, z1]], float)
    return Mesh.flat(v, np.array([[0, 1, 2], [0, 2, 3]]), material=material, name="plate")
