"""The scene's occlusion maps (aquaspec.scene.occlusion): directions, visibility, distances."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.occlusion import occlusion_maps, sphere_directions
from aquaspec.scene.seabed import Seabed
from aquaspec.scene.camera import Camera


def quad(y, half, name="roof", up=False):
    """A horizontal square at height ``y`` (one open mesh), facing down (or up)."""
    v = np.array([[-half, y, -half], [half, y, -half], [half, y, half], [-half, y, half]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]]) if up is False else np.array([[0, 2, 1], [0, 3, 2]])
    n = np.tile([0.0, 1.0 if up else -1.0, 0.0], (4, 1))
    return Mesh(v, f, n, 0, name=name)


def slab(lo, hi):
    """A closed box (outward normals, counter-clockwise from outside)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                  for z in (lo[2], hi[2])])
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    centre = c.mean(axis=0)
    tri = c[faces]
    out = np.einsum("ij,ij->i", np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                    tri.mean(axis=1) - centre)
    faces = np.where(out[:, None] < 0, faces[:, ::-1], faces)
    return Mesh.flat(c, faces, material=0, name="slab")


def scene_of(*meshes, seabed_m=None):
    s = Scene(materials=[type("M", (), {"name": "grey"})()])
    for m in meshes:
        s.add(m)
    if seabed_m is not None:
        s.seabed = Seabed(seabed_m, 0.2)
    return s


CAMERA = Camera.look_at(np.array([0.0, -5.0, 3.0]), np.array([0.0, -5.0, 0.0]), width=8,
                        height=8, fov_y_deg=40.0)


def test_sphere_directions():
    d, om = sphere_directions(64)
    np.testing.assert_allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(om.sum(), 4 * np.pi)
    np.testing.assert_allclose(d.mean(axis=0), 0.0, atol=0.03)
    assert np.all(d[:, 1] != 0)
    for bad in (3, 2.5, True, 5000):
        with pytest.raises(AquaspecError, match="accepted"):
            sphere_directions(bad)


def offset_tol(maps, k):
    """How far off ``s`` may be along direction ``k``: the point is looked up
    ``normal_offset_texels`` above itself (the line from there meets a
    horizontal occluder up to that over ``w_y`` nearer), plus a texel."""
    spec = maps.specs[k]
    return (maps.normal_offset_texels / maps.directions[k, 1] + 1.0) * spec.texel


def test_roof_visibility_and_distance():
    """Under a large roof h above the point: every up direction that meets
    the roof is hidden at s = h / w_y; every down direction is seen."""
    h = 0.5
    maps = occlusion_maps(scene_of(quad(-5.0 + h, 8.0)), CAMERA, directions=64, size=1024,
                          radius_m=8.0, margin_m=0.5)
    p = np.array([[0.0, -5.0, 0.0]])
    vis, dist = maps.visibility(p, np.array([[0.0, 1.0, 0.0]]))
    w_y = maps.directions[:, 1]
    meets = np.flatnonzero(w_y > h / 7.0)
    np.testing.assert_allclose(vis[0, meets], 0.0, atol=1e-12)
    for k in meets:
        assert abs(dist[0, k] - h / w_y[k]) <= offset_tol(maps, k)
    assert np.all(vis[0, w_y < 0] == 1.0) and np.all(np.isinf(dist[0, w_y < 0]))


def test_closed_occluder_distance_is_its_near_side():
    """A closed 0.2 m slab 0.3 m above the point: s is the distance to its
    underside (not to its top, 0.2 m further)."""
    maps = occlusion_maps(scene_of(slab([-6, -4.7, -6], [6, -4.5, 6])), CAMERA,
                          directions=64, size=1024, radius_m=6.0, margin_m=0.5)
    vis, dist = maps.visibility(np.array([[0.0, -5.0, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    up = np.flatnonzero(maps.directions[:, 1] > 0.3)
    np.testing.assert_allclose(vis[0, up], 0.0, atol=1e-12)
    for k in up:
        assert abs(dist[0, k] - 0.3 / maps.directions[k, 1]) <= offset_tol(maps, k)


def test_nothing_occludes_open_water_and_surfaces_not_themselves():
    """No occluder: V = 1 exactly. A flat board and a closed box do not shadow
    their own surface points, whatever the direction."""
    empty = occlusion_maps(scene_of(quad(-9.0, 50.0, name="seabed", up=True), seabed_m=9.0),
                           CAMERA)
    assert empty.empty
    v, s = empty.visibility(np.zeros((5, 3)) - [0, 5, 0], np.tile([1.0, 0, 0], (5, 1)))
    assert np.all(v == 1.0) and np.all(np.isinf(s))
    board = Mesh(np.array([[-1, -6, -2], [1, -6, -2], [1, -4, -2], [-1, -4, -2]], float),
                 np.array([[0, 1, 2], [0, 2, 3]]), np.tile([0.0, 0.0, 1.0], (4, 1)), 0,
                 name="board")
    box = slab([5.0, -6.0, -3.0], [6.0, -5.0, -2.0])
    maps = occlusion_maps(scene_of(board, box), CAMERA, directions=64, size=512)
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(-0.95, 0.95, 200), rng.uniform(-5.95, -4.05, 200),
                           np.full(200, -2.0)])
    v, _ = maps.visibility(pts, np.tile([0.0, 0.0, 1.0], (200, 1)))
    assert np.all(v == 1.0)
    top = np.column_stack([rng.uniform(5.05, 5.95, 100), np.full(100, -5.0),
                           rng.uniform(-2.95, -2.05, 100)])
    v, _ = maps.visibility(top, np.tile([0.0, 1.0, 0.0], (100, 1)))
    assert np.all(v == 1.0)


def test_the_seabed_does_not_occlude():
    """The seabed mesh (by name) and any triangle lying on the seabed's plane
    are not occluders: a point just above them sees every direction."""
    bed = quad(-9.0, 50.0, name="seabed", up=True)
    tile = quad(-9.0, 3.0, name="tile", up=True)
    maps = occlusion_maps(scene_of(bed, tile, seabed_m=9.0), CAMERA, directions=64, size=256)
    assert maps.empty
    v, _ = maps.visibility(np.array([[0.0, -8.9, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    assert np.all(v == 1.0)
    # Without the seabed the tile does occlude (the test can fail).
    maps = occlusion_maps(scene_of(tile), CAMERA, directions=64, size=256)
    v, _ = maps.visibility(np.array([[0.0, -9.5, 0.0]]), np.array([[0.0, 1.0, 0.0]]))
    assert np.any(v < 1.0)


def test_an_occluder_behind_the_surface_is_not_seen():
    """A roof above a surface facing down: every direction it hides is behind
    the surface (n . w <= 0), so all count as visible."""
    maps = occlusion_maps(scene_of(quad(-4.5, 30.0)), CAMERA, directions=64, size=256)
    p = np.array([[0.0, -5.0, 0.0]])
    v_down, _ = maps.visibility(p, np.array([[0.0, -1.0, 0.0]]))
    v_up, _ = maps.visibility(p, np.array([[0.0, 1.0, 0.0]]))
    assert np.all(v_down == 1.0) and np.any(v_up == 0.0)


def test_bad_receivers_are_refused():
    maps = occlusion_maps(scene_of(quad(-4.5, 3.0)), CAMERA, directions=16, size=64)
    with pytest.raises(AquaspecError, match="same shape"):
        maps.visibility(np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(AquaspecError, match="finite"):
        maps.visibility(np.full((1, 3), np.inf), np.ones((1, 3)))
