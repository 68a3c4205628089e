"""`aquaspec bench`: the cost study's structure, ratios and errors (not its speed)."""

import json

import numpy as np
import pytest

from aquaspec.apps.bench import format_table, run_bench
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


def test_overcast_output_unchanged(seeds_result):
    """Without a light the header is bench's as before; the JSON records the light."""
    assert seeds_result["light"]["name"] == "overcast" and "sun_rendering" not in seeds_result
    assert all("sun_ms" not in x for x in seeds_result["rows"])
    lines = format_table(seeds_result).splitlines()
    assert lines[1].startswith("frame = geometry + shade+display")
    assert not any(x.startswith("light:") or "sun" in x for x in lines)


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
    (["--wind", "3"], r"--wind focuses the sun into caustics: it needs --light sun-sky, not "
                      r"'overcast'"),
    (["--light", "d65", "--wind", "3"], r"needs --light sun-sky, not 'd65'"),
    (["--light", "sun-sky", "--sun-elevation", "95"], r"sun elevation 95\.0 deg; accepted: 1 "
                                                      r"to 90"),
    (["--light", "sun-sky", "--sun-azimuth", "nan"], r"--sun-azimuth: 'nan' is not accepted"),
    (["--light", "sun-sky", "--wind", "-2"], r"wind speed -2\.0 m/s; accepted"),
    (["--light", "sun-sky", "--sun-shadow-map", "8"], r"--sun-shadow-map 8; accepted: an "
                                                      r"integer 16 to 8192"),
])
def test_bad_input(argv, match, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    try:
        code = main(["bench", "--sizes", "64x36", "--frames", "1", *argv])
    except SystemExit as exc:       # argparse's own refusals (numbers that are not finite)
        code = exc.code
    assert code == 2
    err = capsys.readouterr().err
    assert sum("error:" in line for line in err.splitlines()) == 1 and "Traceback" not in err, err
    assert __import__("re").search(match, err), err


SUN_ROW_PASSES = ("sun_shadow_map_ms", "sun_froxels_ms", "sun_pixels_ms")
#: The light field's sun frame: shadow map (kept), froxels, shading with the sun (fused).
FUSED_SUN_PASSES = ("sun_shadow_map_ms", "sun_froxels_ms", "sun_shade_display_ms")


def _small_sun_bench(tmp_path, *argv):
    """A 64x36, 3-band sun bench through the CLI; its JSON."""
    out = tmp_path / "sun.json"
    assert main(["bench", "--light", "sun-sky", *argv, "--sizes", "64x36", "--bands", "3",
                 "--frames", "2", "--warmup", "1", "--no-numpy", "--json", str(out)]) == 0
    return json.loads(out.read_text())


def test_cli_sun_passes_and_ratio(tmp_path, capsys):
    doc = _small_sun_bench(tmp_path, "--sun-elevation", "45", "--sun-azimuth", "30")
    assert doc["light"]["name"] == "sun-sky"
    assert doc["light"]["sun"]["elevation_deg"] == 45 and doc["light"]["sun"]["azimuth_deg"] == 30
    assert doc["sun_rendering"]["shadow_map_texels"] == 2048
    assert doc["sun_rendering"]["caustics"] is None
    x = doc["rows"][0]
    for k in FUSED_SUN_PASSES + ("geometry_ms", "deferred_ms", "display_ms", "shade_display_ms",
                                 "no_sun_frame_ms", "frame_wall_ms", "no_sun_frame_wall_ms",
                                 "sun_shadow_map_redraw_ms"):
        assert np.isfinite(x[k]) and x[k] > 0, k
    assert "flat_sun_ms" not in x and "caustics_over_flat_sun" not in x
    # The light field's sun frame: shadow map (kept while nothing moves), froxels,
    # then the shading pass with the sun in its band loop and the display fused.
    assert x["sun_fused"] is True
    assert x["frame_ms"] == pytest.approx(x["geometry_ms"] + sum(x[k] for k in FUSED_SUN_PASSES))
    assert x["sun_pixels_ms"] == pytest.approx(x["sun_shade_display_ms"] - x["shade_display_ms"])
    assert x["sun_ms"] == pytest.approx(x["frame_ms"] - x["no_sun_frame_ms"])
    assert x["no_sun_frame_ms"] == pytest.approx(x["geometry_ms"] + x["shade_display_ms"])
    assert x["sun_over_no_sun"] == pytest.approx(x["frame_ms"] / x["no_sun_frame_ms"])
    text = capsys.readouterr().out
    assert "light: sun-sky, sun at 45 deg elevation, azimuth 30 deg; shadow map 2048" in text
    assert "sun/px" in text and "no sun" in text and "caustics" not in text


def test_cli_wind_adds_the_caustics_ratio(tmp_path, capsys):
    doc = _small_sun_bench(tmp_path, "--wind", "3", "--sun-shadow-map", "512")
    assert doc["sun_rendering"]["shadow_map_texels"] == 512
    assert doc["sun_rendering"]["caustics"]["wind_speed_m_s"] == 3
    x = doc["rows"][0]
    flat = ("flat_sun_shadow_map_ms", "flat_sun_froxels_ms", "flat_sun_shade_display_ms")
    for k in FUSED_SUN_PASSES + flat:
        assert np.isfinite(x[k]) and x[k] > 0, k
    assert x["flat_sun_frame_ms"] == pytest.approx(x["geometry_ms"] + sum(x[k] for k in flat))
    assert x["flat_sun_ms"] == pytest.approx(x["flat_sun_frame_ms"] - x["no_sun_frame_ms"])
    assert x["caustics_over_flat_sun"] == pytest.approx(x["frame_ms"] / x["flat_sun_frame_ms"])
    assert x["sun_over_no_sun"] == pytest.approx(x["frame_ms"] / x["no_sun_frame_ms"])
    text = capsys.readouterr().out
    assert "caustics of a 3 m/s sea" in text and "flat sun" in text


def test_numpy_reference_shades_the_sun():
    """With a sun the NumPy reference is compared with the sun's frame, and says so."""
    res = run_bench(sizes=SIZE, bands=[8], frames=2, warmup=1, ms_model="seeds",
                    light="sun-sky", sun_shadow_map=256)
    npy, x = res["numpy_reference"][0], res["rows"][0]
    assert npy["with_sun"] is True and npy["gpu_frame_ms"] == x["frame_ms"]
    assert res["ratios"][0]["numpy_over_gpu_n8"] == pytest.approx(npy["numpy_ms"] / x["frame_ms"])
    assert res["ratios"][0]["sun_over_no_sun_n8"] == x["sun_over_no_sun"]
    assert "the NumPy reference shades the sun too" in format_table(res)
    # The seeds' sun frame: its passes between the (unfused) shading and the display.
    assert x["sun_fused"] is False
    assert x["frame_ms"] == pytest.approx(x["geometry_ms"] + x["deferred_ms"] + x["display_ms"]
                                          + sum(x[k] for k in SUN_ROW_PASSES))


def test_compare_seeds_with_a_sun_compares_the_frames_without_it():
    res = run_bench(sizes=SIZE, bands=[3], frames=1, warmup=0, numpy_reference=False,
                    ms_model="lightfield", compare_seeds=True, light="sun-sky",
                    sun_shadow_map=64)
    x = res["rows"][0]
    assert x["over_seeds"] == pytest.approx(x["no_sun_frame_ms"] / x["seeds_frame_ms"])
    assert "seeds: the seeds' frame without the sun" in format_table(res)


def test_d65_has_no_sun():
    res = run_bench(sizes=SIZE, bands=[3], frames=1, warmup=0, ms_model="seeds",
                    numpy_reference=False, light="d65")
    assert res["light"]["name"] == "d65" and "sun_rendering" not in res
    assert "sun_ms" not in res["rows"][0]
    lines = format_table(res).splitlines()
    assert lines[1] == "light: d65" and lines[2].startswith("frame = geometry + shade+display")


def test_sun_parts_record_their_own_pass_with_timestamps():
    """Each sun part records exactly its own pass, and timestamp queries bracket it
    (the path bench takes on hardware GPUs; lavapipe is timed by the wall clock)."""
    from aquaspec.colour.bands import Bands
    from aquaspec.apps.sun_passes import SunFrame
    from aquaspec.gpu.dispatch import submit_pass
    from aquaspec.gpu.timing import time_passes, timestamps_supported
    from aquaspec.light.sky import surface_light
    from aquaspec.rendering.renderer import Renderer
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.scene.builtin import builtin_scene
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import get_water
    scene, camera = builtin_scene(5.0, width=64, height=36)
    setup = SpectralSetup(get_water("IB"), get_sensor("human"), surface_light("sun-sky"),
                          Bands(3), ms_model="seeds")
    r = Renderer(64, 36, 3)
    r.sun_map_size = 256
    r.render_scene(scene, camera, setup)
    sun = SunFrame(r, r.sun, scene, camera, r.deferred)
    parts = sun.parts()
    assert set(parts) == {"shadow_map", "shadow_map_redraw", "froxels", "pixels"}
    # Each part records its own pass: only the per-pixel one adds the sun to the image
    # (the shadow map, kept from the frame before, records an empty pass).
    dev = r.deferred.device
    r.deferred.run()
    base = r.deferred.read_rgb()
    draws = r.sun.shadow_map.draw_count
    for k in ("shadow_map", "shadow_map_redraw", "froxels"):
        submit_pass(dev, parts[k])
        assert np.array_equal(r.deferred.read_rgb(), base), k
    assert r.sun.shadow_map.draw_count == draws + 1      # the redraw alone
    submit_pass(dev, parts["pixels"])
    assert (r.deferred.read_rgb() - base).sum() > 0
    if not timestamps_supported(r.deferred.device):
        pytest.skip("the device has no timestamp queries")
    times = time_passes(parts, method="timestamp-query", frames=1, warmup=0,
                        device=r.deferred.device)
    assert times.method == "timestamp-query" and set(times.ms) == set(parts)


def test_sun_part_missing_pass_is_an_error():
    from aquaspec.apps.sun_passes import SunPart
    from aquaspec.errors import AquaspecError

    class Encoder:
        def begin_compute_pass(self, **kwargs):
            raise AssertionError("not reached")

    with pytest.raises(AquaspecError, match=r"recorded 1 pass\(es\) where bench times its "
                                            r"pixels as pass 2"):
        SunPart(lambda enc: enc.begin_compute_pass(), 1, "pixels").encode(Encoder())


def test_unknown_light_is_refused(capsys):
    with pytest.raises(SystemExit) as e:
        main(["bench", "--light", "moon"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "invalid choice: 'moon' (choose from 'overcast', 'd65', 'sun-sky'" in err


def test_waves_need_the_sun():
    with pytest.raises(__import__("aquaspec.errors").errors.AquaspecError,
                       match=r"need light='sun-sky', not 'd65'"):
        run_bench(sizes=SIZE, bands=[3], light="d65", waves=3.0)


def test_occlusion_rows():
    """--occlusion: the occluded frame and the factors' pass in the same run."""
    res = run_bench(sizes=SIZE, bands=[8], frames=1, warmup=0, numpy_reference=False,
                    occlusion=True)
    row = res["rows"][0]
    assert row["occlusion_ms"] > 0 and row["shade_display_occluded_ms"] > 0
    assert row["occluded_over_plain"] == pytest.approx(row["occluded_frame_ms"]
                                                       / row["frame_ms"])
    assert row["moving_occluded_frame_ms"] > row["occluded_frame_ms"]
