"""The add pass (aquaspec.gpu.passes.add_rgb) against NumPy's sum."""

import numpy as np
import pytest

from aquaspec.gpu.buffers import create_storage_buffer, read_buffer
from aquaspec.gpu.passes.add_rgb import AddRgbPass

pytestmark = pytest.mark.gpu


def test_adds_the_change_in_place_and_keeps_w(device):
    """Odd sizes (partial workgroups): every pixel's RGB gains the change, w is
    kept, the pass adds again on a second run and follows new buffers."""
    w, h = 13, 7
    rng = np.random.default_rng(3)
    rgb = rng.normal(size=(h, w, 4)).astype(np.float32)
    change = rng.normal(size=(h, w, 4)).astype(np.float32)
    a, b = create_storage_buffer(device, rgb), create_storage_buffer(device, change)
    p = AddRgbPass(device, w, h)
    for _ in range(2):
        enc = device.create_command_encoder()
        p.encode(enc, b, a)
        device.queue.submit([enc.finish()])
    got = read_buffer(device, a, np.float32, (h, w, 4))
    np.testing.assert_allclose(got[..., :3], rgb[..., :3] + 2 * change[..., :3], rtol=1e-6,
                               atol=1e-6)
    np.testing.assert_array_equal(got[..., 3], rgb[..., 3])
    other = create_storage_buffer(device, np.zeros_like(rgb))
    enc = device.create_command_encoder()
    p.encode(enc, b, other)
    device.queue.submit([enc.finish()])
    np.testing.assert_array_equal(read_buffer(device, other, np.float32, (h, w, 4))[..., :3],
                                  change[..., :3])
