"""Depth maps along several directions in one texture array (aquaspec.gpu.passes.depth_maps)
against the NumPy map of each direction."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.scene.shadowmap import shadow_map_numpy, shadow_map_spec


def _directions():
    w = np.array([[0.0, 1.0, 0.0], [0.6, 0.8, 0.0], [0.0, 0.3, -0.9], [-0.5, 0.5, 0.7]])
    return w / np.linalg.norm(w, axis=1, keepdims=True)


def test_each_layer_matches_the_numpy_map_and_is_kept(device):
    from aquaspec.gpu.passes.depth_maps import DepthMapArray
    from aquaspec.gpu.passes.raster import RasterPass
    from aquaspec.scene.builtin import builtin_scene
    scene, cam = builtin_scene(4.0, width=64, height=36)
    specs = [shadow_map_spec(scene.bounds(), cam.position, w, size=256, radius_m=15.0)
             for w in _directions()]
    maps = DepthMapArray(device, 256, len(specs))
    draws = RasterPass(device).draws(scene)
    enc = device.create_command_encoder()
    assert maps.encode(enc, draws, specs)
    device.queue.submit([enc.finish()])
    for k, spec in enumerate(specs):
        gpu, ref = maps.read(spec, k), shadow_map_numpy(scene, spec)
        assert np.isfinite(ref).any()
        both = np.isfinite(gpu) & np.isfinite(ref)
        assert np.mean(np.isfinite(gpu) != np.isfinite(ref)) < 2e-3, k
        assert np.mean(np.abs(gpu[both] - ref[both]) < 1e-3) > 0.995, k
    # Nothing changed: the maps are kept; a new direction draws them again.
    enc = device.create_command_encoder()
    assert not maps.encode(enc, draws, specs)
    moved = specs[:-1] + [shadow_map_spec(scene.bounds(), cam.position, _directions()[0],
                                          size=256, radius_m=15.0)]
    assert maps.encode(enc, draws, moved)
    device.queue.submit([enc.finish()])
    assert maps.draw_count == 2
    assert np.allclose(maps.read(moved[-1], 3), maps.read(specs[0], 0), equal_nan=True)


def test_bad_sizes_and_spec_counts_are_refused(device):
    from aquaspec.gpu.passes.depth_maps import DepthMapArray
    with pytest.raises(AquaspecError, match="depth map size 8"):
        DepthMapArray(device, 8, 2)
    with pytest.raises(AquaspecError, match="layers 0"):
        DepthMapArray(device, 64, 0)
    maps = DepthMapArray(device, 64, 2)
    spec = shadow_map_spec(np.array([[-1.0, -3.0, -1.0], [1.0, -1.0, 1.0]]), np.zeros(3),
                           np.array([0.0, 1.0, 0.0]), size=64)
    with pytest.raises(AquaspecError, match="holds 2 maps of 64 texels"):
        maps.encode(device.create_command_encoder(), [], [spec])
