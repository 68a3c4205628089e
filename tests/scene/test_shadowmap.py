"""The NumPy shadow map (aquaspec.scene.shadowmap): heights and visibility."""

import numpy as np

from aquaspec.light.sun import refracted_to_sun
from aquaspec.scene.shadowmap import (DEFAULT_MAP_MARGIN_M, map_visibility, shadow_map_numpy,
                                      shadow_map_spec)
from support.plates import exact_visibility, plate_scene


def test_shadow_map_heights_and_visibility():
    scene = plate_scene()
    to_sun = refracted_to_sun(50.0, 120.0)
    spec = shadow_map_spec(scene.bounds(), np.array([0.0, -3.0, 0.0]), to_sun, size=256,
                             radius_m=25.0)
    hmap = shadow_map_numpy(scene, spec)
    # The square map over the tilted projection of the scene's box: most
    # texels see a plate, its corners see nothing.
    assert 0.5 < np.isfinite(hmap).mean() < 1.0
    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.uniform(-8, 8, 4000), rng.uniform(-5.5, -1.2, 4000),
                           rng.uniform(-15, 5, 4000)])
    vis = map_visibility(hmap, spec, pts)
    exact = exact_visibility(pts, to_sun)
    # Away from the shadow's edges (two texels) the map is exact.
    x, y, _ = spec.texel_coords(pts)
    near = np.zeros(len(pts), bool)
    for dx in (-2.5, 0, 2.5):
        for dy in (-2.5, 0, 2.5):
            shifted = pts + (dx * spec.e1 + dy * spec.e2) * spec.texel
            near |= exact_visibility(shifted, to_sun) != exact
    assert (~near).sum() > 3000
    assert np.allclose(vis[~near], exact[~near], atol=1e-9)
    assert 0.2 < exact.mean() < 0.95        # both cases occur


def test_the_map_is_the_same_for_every_camera_of_its_cell():
    """The map's centre snaps to a grid of pitch 2 margin across the beam: it
    holds everything within the radius of the camera (at any height along
    the beam), and nearby cameras of the same cell get the same map."""
    to_sun = refracted_to_sun(50.0, 120.0)
    big = np.array([[-200.0, -30.0, -200.0], [200.0, 0.0, 200.0]])
    radius, margin = 10.0, 3.0
    rng = np.random.default_rng(3)
    same = 0
    for _ in range(30):
        cam = rng.uniform([-20, -10, -20], [20, -1, 20])
        spec = shadow_map_spec(big, cam, to_sun, size=256, radius_m=radius, margin_m=margin)
        assert np.isclose(spec.size * spec.texel, 2 * (radius + margin), rtol=1e-5)
        pts = (cam + rng.uniform(-radius, radius, (50, 1)) * spec.e1
               + rng.uniform(-radius, radius, (50, 1)) * spec.e2)
        x, y, _ = spec.texel_coords(pts)
        assert np.all((x >= -0.5) & (x <= spec.size - 0.5) & (y >= -0.5) & (y <= spec.size - 0.5))
        other = cam + rng.uniform(-0.5, 0.5) * spec.e1 + rng.uniform(-20, 20) * to_sun
        o = shadow_map_spec(big, other, to_sun, size=256, radius_m=radius, margin_m=margin)
        if np.round((cam @ spec.e1) / (2 * margin)) == np.round((other @ spec.e1) / (2 * margin)) \
                and np.round((cam @ spec.e2) / (2 * margin)) == np.round((other @ spec.e2) / (2 * margin)):
            assert (o.u0, o.v0, o.texel) == (spec.u0, spec.v0, spec.texel)
            same += 1
    assert same > 10
    assert DEFAULT_MAP_MARGIN_M > 0
