"""aquaspec bench --detail (aquaspec.apps.detail_bench): the frames it times and its refusals."""

from __future__ import annotations

import pytest

from aquaspec.cli import main


@pytest.mark.gpu
def test_times_plain_particles_and_a_detailed_scene(device):
    from aquaspec.apps.detail_bench import format_detail, run_detail_bench
    from aquaspec.scene.builtin import builtin_scene
    row = run_detail_bench(width=160, height=90, n_bands=3, frames=2, warmup=1,
                           marine_snow="300,1,range=2",
                           detailed_scene=lambda d, w, h: builtin_scene(d, seed=1, width=w,
                                                                        height=h))
    for key in ("plain_ms", "particles_ms", "detailed_ms", "detailed_particles_ms"):
        assert row[key] > 0
    assert row["particles_ratio"] == pytest.approx(row["particles_ms"] / row["plain_ms"])
    assert row["particles_drawn"] > 10 and row["marine_snow"]["density_per_m3"] == 300
    # The splat before the shading, which composes it in its fused display.
    assert {"particles", "shading+display"} <= set(row["passes_ms"]["particles"])
    assert "shading+display" in row["passes_ms"]["plain"]
    assert "plain frame" in format_detail(row)


@pytest.mark.parametrize("extra, named", [
    (["--marine-snow", "-5"], "density_per_m3=-5.0"),
    (["--light", "sun-sky"], "--detail times the detail alone"),
])
def test_refused_before_any_gpu_work(extra, named, capsys):
    assert main(["bench", "--detail", *extra]) == 2
    err = capsys.readouterr().err
    assert named in err and "accepted" in err
