"""`aquaspec render --lamp SPEC --light none`: lamps in the sidecar, the GPU image
against the NumPy backend, and bad lamps refused before any rendering."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from aquaspec.cli import main

#: GPU (float32, 1024-texel rasterised shadow maps, profile tables) against the
#: NumPy backend (float64, ray-cast maps) on the whole image, relative to its
#: largest value (measured 8.6e-5; median per pixel 1.1e-4 of its own value).
IMAGE_ATOL_OF_MAX = 1e-3


def bad(tmp_path, capsys, argv, match):
    out = tmp_path / "bad.png"
    try:
        code = main(["render", "--size", "32x18", "--bands", "4", *argv, "-o", str(out)])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and re.search(match, err), err
    assert not out.exists()


@pytest.mark.parametrize("spec, match", [
    ("pos=0,0,0;power=0", r"lamp power 0.0 W; accepted: a number > 0"),
    ("pos=0,0,0;power=1;cone=200", r"lamp cone 200.0 degrees"),
    ("pos=0,3,0;power=1;frame=world", r"y = 3 m is not under water"),
    ("pos=0,0,0;power=1;spectrum=nope.csv", r"lamp spectrum file 'nope.csv' does not exist"),
    ("floodlight", r"a preset \(rov-pair, torch\)")])
def test_bad_lamps(tmp_path, capsys, spec, match):
    bad(tmp_path, capsys, ["--light", "none", "--lamp", spec], match)


def test_negative_spectrum_csv(tmp_path, capsys):
    csv = tmp_path / "lamp.csv"
    csv.write_text("wavelength_nm,power\n380,1\n550,-0.5\n720,1\n")
    bad(tmp_path, capsys, ["--lamp", f"pos=0,0,0;power=1;spectrum={csv}"], r"-0.5 at 550 nm")


@pytest.mark.gpu
def test_lamps_on_the_gpu_and_in_numpy(tmp_path):
    args = ["render", "--water", "II", "--depth", "40", "--size", "64x36", "--bands", "4",
            "--light", "none", "--lamp", "rov-pair", "--exposure", "0"]
    lin_gpu, lin_np = tmp_path / "g.npy", tmp_path / "n.npy"
    assert main([*args, "-o", str(tmp_path / "g.png"), "--linear", str(lin_gpu)]) == 0
    side = json.loads((tmp_path / "g.png.json").read_text())
    assert [lamp["name"] for lamp in side["lamps"]] == ["rov-left", "rov-right"]
    assert side["light"]["name"] == "none"
    assert side["lamp_rendering"]["shadow_map_texels"] == 1024
    assert main([*args, "--backend", "numpy", "-o", str(tmp_path / "n.png"),
                 "--linear", str(lin_np)]) == 0
    gpu, ref = np.load(lin_gpu), np.load(lin_np)
    assert np.all(np.isfinite(gpu)) and ref.max() > 0
    np.testing.assert_allclose(gpu, ref, atol=IMAGE_ATOL_OF_MAX * ref.max())


@pytest.mark.gpu
def test_lamps_in_the_layers():
    """With lamps the backscatter layer (every surface black) holds their veil and
    not their lit surfaces: it is the NumPy backend's, and the direct signal
    (image - backscatter) is not negative (a camera's RGB; the human observer's
    linear sRGB has negative reds for cyan surfaces)."""
    from aquaspec.rendering.api import render
    kw = dict(water="II", depth_m=40, size=(48, 27), bands=4, light="none",
              lamps=["rov-pair"], exposure=0, layers=True, sensor="nikon-5100-npl")
    gpu, ref = render(**kw), render(**kw, backend="numpy")
    back, back_ref = gpu.layers["backscatter"], ref.layers["backscatter"]
    np.testing.assert_allclose(back, back_ref, atol=IMAGE_ATOL_OF_MAX * back_ref.max())
    assert gpu.layers["direct"].min() > -IMAGE_ATOL_OF_MAX * gpu.linear_rgb.max()
    hit = gpu.layers["range_m"] > 0
    # Surfaces the lamps reach are brighter than their veil (those outside the
    # cones or in shadows are not).
    lit = back[hit].sum(-1) < 0.9 * gpu.linear_rgb[hit].sum(-1)
    assert lit.mean() > 0.3


@pytest.mark.gpu
def test_lamps_on_an_rgbd_photograph():
    """An RGB-D photograph lit by lamps: no shadow maps (nothing is known behind
    what it shows), the GPU image the NumPy backend's."""
    from aquaspec.rendering.api import render
    img = np.full((36, 64, 3), 150, np.uint8)
    img[:, 32:] = (200, 60, 40)
    depth = np.full((36, 64), 3.0)
    depth[:18] = 6.0
    kw = dict(rgbd=(img, depth, (50.0, 50.0, 32.0, 18.0)), water="II", depth_m=30, bands=4,
              light="none", lamps=["rov-pair"], exposure=0)
    gpu, ref = render(**kw), render(**kw, backend="numpy")
    assert gpu.params["lamp_rendering"]["shadow_map_texels"] is None
    np.testing.assert_allclose(gpu.linear_rgb, ref.linear_rgb,
                               atol=IMAGE_ATOL_OF_MAX * ref.linear_rgb.max())


@pytest.mark.gpu
def test_many_bands_read_the_phase_table_from_storage():
    """Past 32 bands the lamp pass's phase table no longer fits a uniform buffer
    and is read from storage: the same image as the NumPy backend's."""
    from aquaspec.rendering.api import render
    kw = dict(water="IB", depth_m=20, size=(32, 18), bands=40, light="none",
              lamps=["torch"], exposure=0)
    gpu, ref = render(**kw), render(**kw, backend="numpy")
    np.testing.assert_allclose(gpu.linear_rgb, ref.linear_rgb,
                               atol=IMAGE_ATOL_OF_MAX * ref.linear_rgb.max())
