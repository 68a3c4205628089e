"""The lamps' veil columns against the per-pixel march, by the columns' width.

The scene of ``tests/transport/test_lamp_froxels.py`` (160x96, fov 45 degrees:
a wall 4 m ahead over the lower half, open water above, a spot lamp 0.5 m
beside the camera, with and without a half-space shadow in the beam): the
single scattering read from columns of 3, 4 and 6 pixels (1.5, 2 and 3 degrees;
the default at this size is 3) against 128 samples per pixel. Error per pixel
relative to its veil or to 1 % of the brightest's.

Usage::

    python tools/lamp_column_width.py
"""
import importlib.util
from pathlib import Path

import numpy as np

spec = importlib.util.spec_from_file_location(
    "lamp_froxel_tests", Path(__file__).parents[1] / "tests/transport/test_lamp_froxels.py")
t = importlib.util.module_from_spec(spec)
spec.loader.exec_module(t)
g, lamp = t.scene()
inp = t.inputs(lamp)
dirs = g.camera.ray_directions().reshape(-1, 3)
for label, vis in (("no shadow", None), ("shadow", lambda x: (x[..., 0] > 0.25).astype(float))):
    ref = t.ls.single_scattering(inp, g.camera.position, dirs,
                                 np.minimum(g.distance, 1e9).reshape(-1), n_samples=128,
                                 visibility=vis).reshape(g.distance.shape + (2,))
    for tile in (3, 4, 6):
        got = t.lf.lamp_froxel_lookup(t.lf.lamp_froxel_grid(inp, g.camera, visibility=vis,
                                                            tile=tile), g.camera, g.distance)
        rel = np.abs(got - ref).sum(-1) / np.maximum(ref.sum(-1), 0.01 * ref.sum(-1).max())
        print(f"{label:9s} columns of {tile} px: mean {100 * rel.mean():.2f} %, 99th percentile "
              f"{100 * np.quantile(rel, 0.99):.1f} %, worst {100 * rel.max():.1f} %, total "
              f"{100 * (got.sum() / ref.sum() - 1):+.2f} %")
