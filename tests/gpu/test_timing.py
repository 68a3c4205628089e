"""Timing GPU passes (aquaspec.gpu.timing.time_passes) on the deferred and copy passes."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError

from support.analytic_gbuffers import deferred_pass, medium, run_gpu, scene_box

pytestmark = pytest.mark.gpu


class TestTimePasses:
    @pytest.mark.parametrize("method", ["auto", "wall-clock"])
    def test_times_are_positive(self, device, method):
        from aquaspec.gpu.timing import time_passes, timestamps_supported
        from aquaspec.gpu.passes.copy import CopyPass
        p = run_gpu(device, scene_box(), medium("IB", 8), 8)
        t = time_passes({"deferred": p, "copy": CopyPass(p)}, frames=3, warmup=1,
                        method=method, device=device)
        assert set(t.ms) == {"deferred", "copy"}
        assert all(v > 0 and np.isfinite(v) for v in t.ms.values())
        assert all(len(v) == 3 for v in t.samples_ms.values())
        expected = ("timestamp-query" if method == "auto" and timestamps_supported(device)
                    else "wall-clock")
        assert t.method == expected

    def test_bad_arguments(self, device):
        from aquaspec.gpu.timing import time_passes
        p = deferred_pass(device, 3)
        with pytest.raises(AquaspecError, match="frames"):
            time_passes({"d": p}, frames=0, device=device)
        with pytest.raises(AquaspecError, match="timing method"):
            time_passes({"d": p}, method="stopwatch", device=device)
        with pytest.raises(AquaspecError, match="at least one pass"):
            time_passes({}, device=device)
