"""`aquaspec bench --surface`: the sea surface's frames timed in one run."""

from __future__ import annotations

import json

import numpy as np
import pytest

from aquaspec.cli import main

pytestmark = pytest.mark.gpu


@pytest.mark.slow      # (four live frames with the sun, each renderer compiled: ~25 s)
def test_surface_bench_times_every_frame(tmp_path, capsys):
    out = tmp_path / "surface.json"
    assert main(["bench", "--surface", "--sizes", "64x36", "--bands", "4", "--frames", "2",
                 "--warmup", "1", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    res = json.loads(out.read_text())
    assert res["size"] == [64, 36] and res["bands"] == 4
    for name in ("below", "below_flat", "looking_up_flat", "waterline", "above", "above_sun_waves",
                 "below_sun", "below_sun_plain", "below_sun_waves", "below_sun_waves_plain"):
        assert name in text
        assert np.isfinite(res["frame_wall_ms"][name]) and res["frame_wall_ms"][name] > 0
    assert res["ratio_to_below"]["below"] == 1.0
    ms = res["frame_wall_ms"]
    assert res["surface_from_below_ratio"] == {
        "sun": ms["below_sun"] / ms["below_sun_plain"],
        "sun_waves": ms["below_sun_waves"] / ms["below_sun_waves_plain"]}


def test_surface_bench_refuses_what_it_does_not_time(capsys):
    assert main(["bench", "--surface", "--light", "sun-sky"]) == 2
    assert "--surface times the surface's frames alone" in capsys.readouterr().err
