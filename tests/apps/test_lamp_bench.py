"""`aquaspec bench --lamps N`: the frame with shadowed lamps against the frame
without them (its structure and its ratio's arithmetic, not its speed)."""

import json

import pytest

from aquaspec.apps.lamp_bench import bench_lamps, run_lamp_bench
from aquaspec.cli import main
from aquaspec.errors import AquaspecError


def test_bench_lamps():
    assert [lamp.name for lamp in bench_lamps(2)] == ["rov-left", "rov-right"]
    three = bench_lamps(3)
    assert [lamp.position[0] for lamp in three] == [-0.5, 0.0, 0.5]
    assert all(lamp.frame == "camera" for lamp in three)
    for bad in (0, 17, 2.5, True):
        with pytest.raises(AquaspecError, match="--lamps"):
            bench_lamps(bad)


@pytest.mark.gpu
def test_run_lamp_bench():
    row = run_lamp_bench(width=64, height=36, n_bands=4, n_lamps=2, frames=1, warmup=0,
                         water="II", depth_m=40.0, light="none")
    for k in ("geometry_ms", "shading_ms", "shade_display_ms", "lamp_veil_ms",
              "lamp_pixels_ms", "display_ms", "lamp_shadow_maps_ms", "frame_wall_ms",
              "lamp_frame_wall_ms", "lamp_cone_ms", "kept_frame_wall_ms"):
        assert row[k] > 0, k
    assert row["ratio"] == pytest.approx(row["lamp_frame_wall_ms"] / row["frame_wall_ms"])
    assert row["cone_ratio"] == pytest.approx(row["lamp_frame_wall_ms"]
                                              / row["kept_frame_wall_ms"])
    assert row["lamp_frame_ms"] == pytest.approx(
        row["geometry_ms"] + row["shading_ms"] + row["lamp_veil_ms"] + row["lamp_cone_ms"]
        + row["lamp_pixels_ms"])
    assert row["lamps"] == 2


@pytest.mark.gpu
def test_bench_cli_lamps(tmp_path, capsys):
    out = tmp_path / "lamps.json"
    assert main(["bench", "--lamps", "1", "--sizes", "48x27", "--bands", "3", "--frames", "1",
                 "--warmup", "0", "--light", "none", "--json", str(out)]) == 0
    assert "frame with them / without = " in capsys.readouterr().out
    assert json.loads(out.read_text())["lamps"] == 1
    assert main(["bench", "--lamps", "0"]) != 0
    assert "--lamps 0; accepted: an integer 1 ... 16" in capsys.readouterr().err
