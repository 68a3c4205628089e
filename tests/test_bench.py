"""`aquaspec bench`: the cost study's structure, ratios and errors (not its speed)."""

import json

import numpy as np
import pytest

from aquaspec.bench import format_table, run_bench
from aquaspec.cli import main

pytestmark = pytest.mark.gpu

SIZE = [(64, 36)]


@pytest.fixture(scope="module")
def seeds_result():
    return run_bench(sizes=SIZE, bands=[3, 8], frames=2, warmup=1, ms_model="seeds")


def test_rows_fits_and_ratios(seeds_result):
    res = seeds_result
    assert [(x["width"], x["bands"]) for x in res["rows"]] == [(64, 3), (64, 8)]
    for x in res["rows"]:
        for k in ("geometry_ms", "deferred_ms", "display_ms", "copy_ms", "shade_display_ms",
                  "frame_ms", "frame_wall_ms"):
            assert np.isfinite(x[k]) and x[k] > 0, k
        assert x["frame_ms"] == pytest.approx(x["geometry_ms"] + x["shade_display_ms"])
        assert x["fps"] == pytest.approx(1e3 / x["frame_ms"])
    fit = res["fits"][0]
    rows = res["rows"]
    # Two points: the line goes through both.
    for x in rows:
        assert fit["t0_ms"] + fit["t1_ms_per_band"] * x["bands"] == pytest.approx(x["frame_ms"])
    r = res["ratios"][0]
    assert r["n8_over_n3"] == pytest.approx(rows[1]["frame_ms"] / rows[0]["frame_ms"])
    assert r["deferred_over_copy_n8"] == pytest.approx(rows[1]["deferred_ms"] / rows[1]["copy_ms"])
    npy = res["numpy_reference"][0]
    assert npy["numpy_over_gpu"] == pytest.approx(npy["numpy_ms"] / rows[1]["frame_ms"])
    assert r["numpy_over_gpu_n8"] == npy["numpy_over_gpu"]
    text = format_table(res)
    assert "fit 64x36: t(n) =" in text and "n8_over_n3" in text


def test_lightfield_against_seeds_in_the_same_run():
    res = run_bench(sizes=SIZE, bands=[8], frames=2, warmup=1, numpy_reference=False,
                    ms_model="lightfield", compare_seeds=True)
    x = res["rows"][0]
    assert x["seeds_frame_ms"] > 0
    assert x["over_seeds"] == pytest.approx(x["frame_ms"] / x["seeds_frame_ms"])
    assert res["ratios"][0]["lightfield_over_seeds_n8"] == x["over_seeds"]
    assert "seeds" in format_table(res).splitlines()[2]


def test_lightfield_with_the_cone_spread():
    """The spread runs in the timed shading; the result records it."""
    plain = run_bench(sizes=SIZE, bands=[8], frames=2, warmup=1, numpy_reference=False,
                      ms_model="lightfield", cone_spread=False)
    res = run_bench(sizes=SIZE, bands=[8], frames=2, warmup=1, numpy_reference=False)
    # (No model given: the default, the light field with the spread.)
    assert res["ms_model"] == "lightfield"
    assert res["cone_spread"] is True and plain["cone_spread"] is False
    assert res["rows"][0]["frame_ms"] > 0


def test_cli_json_and_plot(tmp_path, capsys):
    out, png = tmp_path / "b.json", tmp_path / "b.png"
    assert main(["bench", "--sizes", "64x36", "--bands", "3,8", "--frames", "2", "--warmup", "0",
                 "--no-numpy", "--json", str(out), "--plot", str(png)]) == 0
    doc = json.loads(out.read_text())
    assert len(doc["rows"]) == 2 and doc["ms_model"] == "lightfield" and doc["cone_spread"]
    assert png.stat().st_size > 1000
    assert "ratios 64x36" in capsys.readouterr().out


@pytest.mark.parametrize("argv,match", [
    (["--bands", "3,x"], r"--bands '3,x' must be comma-separated integers"),
    (["--ms-model", "seeds", "--compare-seeds"], r"needs ms_model='lightfield'"),
    (["--ms-model", "seeds", "--cone-spread"], r"cone_spread is part of the light-field model"),
    (["--json", "out.txt"], r"\.txt"),
])
def test_bad_input(argv, match, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["bench", "--sizes", "64x36", "--frames", "1", *argv]) == 2
    err = capsys.readouterr().err
    assert __import__("re").search(match, err), err
