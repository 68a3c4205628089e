"""aquaspec synth end to end on the local pool: outputs, holes, failures,
resuming, retrying; and the errors found before any work."""

from __future__ import annotations

import csv
import json
import os
import socket
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from aquaspec.apps.synth import synth
from aquaspec.apps.synth.files import folder_lock
from aquaspec.errors import AquaspecError
from aquaspec.io.layers_file import read_layers
from aquaspec.io.linear import read_linear
from support.synth_data import depth_mm, make_folder, write_config

HOLES = 30


def manifest(out):
    with open(out / "manifest.csv", newline="") as f:
        return list(csv.DictReader(f))


@pytest.mark.gpu
def test_run_holes_failures_resume_and_retry(tmp_path):
    # Four pairs: img001 has depth holes, img002's depth is a pixel narrower.
    make_folder(tmp_path / "data", 4, holes={1: HOLES}, mismatched=(2,))
    cfg = write_config(tmp_path / "synth.toml", extra="layers = true\n")
    out = tmp_path / "out"

    first = synth(cfg, workers=1, progress=False)
    assert (first["planned"], first["done"], first["failed"], first["pending"]) == (8, 6, 2, 0)
    rows = manifest(out)
    assert len(rows) == 8 and len({r["sample_id"] for r in rows}) == 8
    assert [r["input"] for r in rows] == sorted(r["input"] for r in rows)     # plan order
    bad = [r for r in rows if r["input"] == "img002"]
    assert all(r["status"] == "failed" and "64x48" in r["error"] and "63x48" in r["error"]
               for r in bad)
    for r in rows:
        if r["status"] != "done":
            continue
        png = np.asarray(Image.open(out / r["png"]))
        assert png.shape == (48, 64, 3) and png.dtype == np.uint8
        assert read_linear(out / r["linear"]).shape == (48, 64, 3)
        layers, _ = read_layers(out / r["layers"])
        side = json.loads((out / r["sidecar"]).read_text())
        assert side["synth"]["sample_id"] == r["sample_id"] and side["timestamp"] is None
        assert side["water"]["name"] == r["water"] and side["depth_m"] == float(r["depth_m"])
        if r["input"] == "img001":
            # Holes: counted, masked in every output, and a validity mask written.
            assert int(r["depth_holes"]) == HOLES
            valid = np.asarray(Image.open(out / r["mask"])) == 255
            assert (~valid).sum() == HOLES
            assert np.all(png[~valid] == 0)
            assert np.all(read_linear(out / r["linear"])[~valid] == 0)
            assert all(np.all(v[~valid] == 0) for v in layers.values())
        else:
            assert int(r["depth_holes"]) == 0 and r["mask"] == ""
    manifest_bytes = (out / "manifest.csv").read_bytes()

    again = synth(cfg, workers=1, progress=False)
    assert (again["rendered"], again["skipped_done"], again["skipped_failed"]) == (0, 6, 2)
    assert (out / "manifest.csv").read_bytes() == manifest_bytes

    # The bad pair mended, --retry-failed renders its samples; their failures go.
    Image.fromarray(depth_mm(2)).save(tmp_path / "data" / "depth" / "img002.png")
    fixed = synth(cfg, workers=1, progress=False, retry_failed=True)
    assert (fixed["rendered"], fixed["done"], fixed["failed"]) == (2, 8, 0)
    assert not list((out / "failures").glob("*.json"))
    assert {r["status"] for r in manifest(out)} == {"done"}


def test_zero_sample_plan_fails_before_writing(tmp_path):
    make_folder(tmp_path / "data", 1)
    cfg = write_config(tmp_path / "synth.toml", plan="samples_per_input = 0\n")
    with pytest.raises(AquaspecError, match="zero samples"):
        synth(cfg, progress=False)
    assert not (tmp_path / "out").exists()


def test_unwritable_output_folder(tmp_path):
    make_folder(tmp_path / "data", 1)
    (tmp_path / "afile").write_text("not a folder")
    cfg = write_config(tmp_path / "synth.toml", output="afile/out")
    with pytest.raises(AquaspecError, match="output folder .*afile/out' cannot be made"):
        synth(cfg, progress=False)


@pytest.mark.gpu
def test_mesh_inputs(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    (tmp_path / "models").mkdir()
    trimesh.creation.box().export(tmp_path / "models" / "box.ply")
    cfg = tmp_path / "synth.toml"
    cfg.write_text('[inputs]\nmeshes = "models"\nmesh_size = [32, 24]\n'
                   '[plan]\nmode = "grid"\nbands = 4\ndepth_m = [4, 8]\n'
                   '[output]\nfolder = "out"\nmanifest = "csv"\n')
    summary = synth(cfg, progress=False)
    assert (summary["planned"], summary["done"]) == (2, 2)
    rows = manifest(tmp_path / "out")
    assert {(r["kind"], r["mesh"], r["width"], r["height"]) for r in rows} == {
        ("mesh", "box.ply", "32", "24")}
    png = np.asarray(Image.open(tmp_path / "out" / rows[0]["png"]))
    assert png.shape == (24, 32, 3) and png.std() > 0       # the box stands out of the water


class TestFolderLock:
    def test_a_second_run_on_the_folder_is_refused(self, tmp_path):
        make_folder(tmp_path / "data", 1)
        cfg = write_config(tmp_path / "synth.toml")
        (tmp_path / "out").mkdir()
        (tmp_path / "out" / "synth.lock").write_text(
            json.dumps({"pid": os.getpid(), "host": socket.gethostname()}))
        with pytest.raises(AquaspecError, match="in use by another aquaspec synth run "
                                                f"\\(process {os.getpid()}"):
            synth(cfg, progress=False)

    def test_a_killed_run_s_lock_is_taken_over(self, tmp_path):
        done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                              capture_output=True, text=True)
        (tmp_path / "synth.lock").write_text(
            json.dumps({"pid": int(done.stdout), "host": socket.gethostname()}))
        with folder_lock(tmp_path):
            held = json.loads((tmp_path / "synth.lock").read_text())
            assert held["pid"] == os.getpid()
        assert not (tmp_path / "synth.lock").exists()


@pytest.mark.gpu
def test_render_with_a_kept_renderer(tmp_path):
    """render(renderer=): the same image as a fresh renderer's, and a renderer
    of another size or band count refused, naming both."""
    from aquaspec.rendering.api import render
    from aquaspec.rendering.renderer import Renderer
    from support.synth_data import INTRINSICS, rgb_image
    rgbd = (rgb_image(0), depth_mm(0) * 1e-3, INTRINSICS)
    kept = Renderer(64, 48, 4)
    render(water="3C", depth_m=8.0, bands=4, rgbd=rgbd, renderer=kept)
    again = render(water="IB", depth_m=4.0, bands=4, rgbd=rgbd, layers=True, renderer=kept)
    fresh = render(water="IB", depth_m=4.0, bands=4, rgbd=rgbd, layers=True)
    np.testing.assert_array_equal(again.linear_rgb, fresh.linear_rgb)
    np.testing.assert_array_equal(again.layers["backscatter"], fresh.layers["backscatter"])
    with pytest.raises(AquaspecError, match="renderer=64x48, 4 bands cannot shade this 64x48 "
                                            "image of 8 bands"):
        render(bands=8, rgbd=rgbd, renderer=kept)
