"""The floor under a flying camera (aquaspec.apps.floor)."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.apps.floor import FloorMap, _surface_points
from aquaspec.errors import AquaspecError
from aquaspec.scene.builtin import CAMERA_HEIGHT_M, builtin_scene


def test_a_long_thin_triangle_fills_the_cells_it_crosses():
    """A 10 m sliver has corners only at its ends; its middle is a floor too."""
    v = np.array([[0.0, -3.0, 0.0], [10.0, -3.0, 0.0], [10.0, -3.0, 0.05]])
    floor = FloorMap(_surface_points(v, np.array([[0, 1, 2]]), 0.5), 0.5)
    for x in (0.1, 2.5, 5.0, 7.5, 9.9):
        assert floor.floor_y(x, 0.0) == pytest.approx(-3.0)


def test_highest_surface_wins_and_reaches_the_next_cell():
    low = np.array([[x, -5.0, z] for x in np.arange(-3, 3.1, 0.25)
                    for z in np.arange(-3, 3.1, 0.25)])
    top = np.array([[0.1, -2.0, 0.1]])              # one high point
    floor = FloorMap(np.concatenate([low, top]), 0.5)
    assert floor.floor_y(0.1, 0.1) == -2.0
    assert floor.floor_y(0.1 + 0.6, 0.1) == -2.0     # the neighbouring cell
    assert floor.floor_y(2.0, 2.0) == -5.0
    assert floor.floor_y(50.0, 0.0) == -np.inf      # outside the map: no floor


def test_builtin_scene_floor_is_its_sand_under_the_camera():
    scene, cam = builtin_scene(3.0, width=32, height=18)
    floor = FloorMap.from_scene(scene)
    sand = -3.0 - CAMERA_HEIGHT_M
    # The sand under the start camera, within the terrain's relief over a cell or two.
    assert sand - 0.1 <= floor.floor_y(0.0, 0.0) <= sand + 0.5
    assert floor.floor_y(0.0, 0.0) >= -scene.seabed.depth_m


def test_bad_input():
    with pytest.raises(AquaspecError, match="floor cell 0"):
        FloorMap(np.zeros((3, 3)), 0)
    with pytest.raises(AquaspecError, match="finite surface points"):
        FloorMap(np.full((2, 3), np.nan))
