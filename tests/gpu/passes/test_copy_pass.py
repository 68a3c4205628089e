"""The copy pass (aquaspec.gpu.passes.copy): the G-buffer it read, back on the host."""

import numpy as np
import pytest

from support.analytic_gbuffers import H, W, deferred_pass, scene_seabed

pytestmark = pytest.mark.gpu


class TestCopyPass:
    def test_returns_what_it_read(self, device):
        from aquaspec.gpu.passes.copy import CopyPass
        gb = scene_seabed()
        p = deferred_pass(device, 3)
        p.gbuffer.upload(gb)
        c = CopyPass(p)
        c.run()
        out = c.read()
        assert out.shape == (H, W, 4)
        dist = np.where(gb.hit, gb.distance, -1.0)
        np.testing.assert_array_equal(out[..., 0], dist.astype(np.float32))
        np.testing.assert_array_equal(out[..., 1], gb.normal[..., 1])
        np.testing.assert_array_equal(out[..., 2], gb.sigmoid[..., 2])
        np.testing.assert_array_equal(out[..., 3], gb.material.astype(np.float32))
