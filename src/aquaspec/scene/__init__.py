"""Scenes: triangle meshes with materials, the built-in seabed scene, mesh loading.

World units are metres, y is up, the water surface is y = 0.
"""

from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.load import MESH_FORMATS, load_mesh, place_in_front
from aquaspec.scene.mesh import Mesh, Scene, image_to_linear_rgb

__all__ = ["Mesh", "Scene", "builtin_scene", "load_mesh", "place_in_front", "MESH_FORMATS",
           "image_to_linear_rgb"]
