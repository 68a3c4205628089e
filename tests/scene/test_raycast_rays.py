"""raycast_rays: the first surfaces met by rays of any origin (the grid walk)."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.scene.builtin import scene_for_render
from aquaspec.scene.raycast import raycast_gbuffer, raycast_rays


@pytest.fixture(scope="module")
def builtin():
    return scene_for_render(None, 5.0, 96, 54, None, None)


def test_pinhole_rays_match_the_cameras_brute_force(builtin):
    """The camera's own rays give the G-buffer of every ray against every
    triangle (the G-buffer stores float32 distances and normals)."""
    scene, cam = builtin
    g = raycast_gbuffer(scene, cam, tile=None)
    d = cam.ray_directions()
    r = raycast_rays(scene, np.broadcast_to(cam.position, d.shape), d, near=cam.near)
    np.testing.assert_array_equal(r.hit, g.hit)
    np.testing.assert_allclose(r.distance[g.hit], g.distance[g.hit], rtol=1e-6)
    np.testing.assert_allclose(r.normal, g.normal, atol=1e-6)
    np.testing.assert_array_equal(r.material, g.material)
    np.testing.assert_allclose(r.sigmoid, g.sigmoid, atol=1e-5)


def _brute(tri, o, d):
    """Nearest hit distance of one ray against all triangles (plain loop-free
    Moller-Trumbore over the triangles, written apart from the module's)."""
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    h = np.cross(d, e2)
    a = (e1 * h).sum(1)
    f = 1.0 / np.where(np.abs(a) > 1e-12, a, np.nan)
    s = o - tri[:, 0]
    u = f * (s * h).sum(1)
    q = np.cross(s, e1)
    v = f * (q @ d)
    t = f * (e2 * q).sum(1)
    ok = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
    return float(np.min(t[ok])) if np.any(ok) else np.inf


def test_rays_from_the_surface_match_the_brute_force(builtin):
    """Rays leaving the plane y = 0 downwards in random directions (as the
    refracted rays of a camera above the sea) meet what every triangle
    tested one by one says they meet."""
    scene, _ = builtin
    rng = np.random.default_rng(3)
    h, w = 12, 16
    o = np.stack([rng.uniform(-8, 8, (h, w)), np.zeros((h, w)), rng.uniform(-18, 2, (h, w))], -1)
    d = np.stack([rng.normal(0, 0.5, (h, w)), -np.ones((h, w)), rng.normal(0, 0.5, (h, w))], -1)
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    r = raycast_rays(scene, o, d)
    tri = np.concatenate([m.vertices[m.faces] for m in scene.meshes])
    expect = np.array([_brute(tri, o[i, j], d[i, j]) for i in range(h) for j in range(w)])
    assert np.isfinite(expect).sum() > 50
    np.testing.assert_array_equal(r.hit.reshape(-1), np.isfinite(expect))
    np.testing.assert_allclose(r.distance.reshape(-1)[np.isfinite(expect)],
                               expect[np.isfinite(expect)], rtol=1e-9)


def test_bad_rays_are_refused(builtin):
    scene, _ = builtin
    with pytest.raises(AquaspecError, match="expected both"):
        raycast_rays(scene, np.zeros((4, 3)), np.ones((4, 3)))
    with pytest.raises(AquaspecError, match="finite"):
        o = np.zeros((2, 2, 3))
        raycast_rays(scene, o, np.full((2, 2, 3), np.nan))
