"""The NumPy shadow map (aquaspec.scene.shadowmap): heights and visibility."""

import numpy as np

from aquaspec.light.sun import refracted_to_sun
from aquaspec.scene.shadowmap import map_visibility, shadow_map_numpy, shadow_map_spec
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
