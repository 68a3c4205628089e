"""`aquaspec view`: the headless script mode (offscreen canvas, recorded frames)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from aquaspec.cli import main

DESCENT = {"fps": 1, "keyframes": [
    {"t": 0, "depth_m": 1.5, "yaw_deg": 0, "pitch_deg": 0},
    {"t": 2, "depth_m": 3.0}]}


def _blue_over_red(png, rows=0.2):
    """Mean blue over mean red of the top ``rows`` of the frame: open water
    above the horizon, the background (the camera looks level)."""
    a = np.asarray(Image.open(png)).astype(float)
    top = a[:max(1, int(a.shape[0] * rows))]
    return top[..., 2].mean() / top[..., 0].mean()


@pytest.mark.gpu
class TestScriptMode:
    def test_descent_in_jerlov_ib_turns_the_background_bluer(self, tmp_path, capsys):
        """Three frames, the camera descending from 1.5 to 3 m in Jerlov IB with
        the exposure held: red is absorbed faster than blue, so the background's
        blue-to-red ratio grows frame by frame."""
        script = tmp_path / "descent.json"
        script.write_text(json.dumps(DESCENT))
        out = tmp_path / "run"
        assert main(["view", "--offscreen", "--script", str(script), "--frames", "3",
                     "--record", str(out), "--water", "IB", "--size", "96x54",
                     "--bands", "6", "--surface", "index-matched"]) == 0
        frames = [out / f"frame_{i:05d}.png" for i in range(3)]
        assert all(f.is_file() for f in frames)
        assert not list(out.glob(".*part*"))            # no temporary file left behind
        ratios = [_blue_over_red(f) for f in frames]
        assert ratios[0] < ratios[1] < ratios[2], ratios
        run = json.loads((out / "run.json").read_text())
        assert run["settings"]["water"] == "IB" and run["mode"] == "offscreen"
        assert [f["file"] for f in run["frames"]] == [f.name for f in frames]
        np.testing.assert_allclose([f["depth_m"] for f in run["frames"]], [1.5, 2.25, 3.0])
        assert run["script"] == DESCENT
        assert "3 frames (offscreen)" in capsys.readouterr().out

    def test_water_change_in_the_script(self, tmp_path):
        """A keyframe's water takes effect at its time; the exposure held, the
        greener coastal water 3C looks less blue than IB from the same pose."""
        script = tmp_path / "water.json"
        script.write_text(json.dumps({"fps": 1, "keyframes": [
            {"t": 0, "depth_m": 2, "pitch_deg": 0}, {"t": 1, "water": "3C"}]}))
        out = tmp_path / "run"
        assert main(["view", "--offscreen", "--script", str(script), "--frames", "2",
                     "--record", str(out), "--size", "64x36", "--bands", "6"]) == 0
        run = json.loads((out / "run.json").read_text())
        assert [f["water"] for f in run["frames"]] == ["IB", "3C"]
        a, b = (np.asarray(Image.open(out / f["file"])).astype(float)[:8].mean(axis=(0, 1))
                for f in run["frames"])
        assert b[2] / b[1] < a[2] / a[1]

    def test_mp4_holds_the_frames(self, tmp_path):
        imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="the view extra's "
                                             "imageio-ffmpeg writes the MP4")
        out = tmp_path / "run"
        assert main(["view", "--offscreen", "--frames", "3", "--record", str(out), "--mp4",
                     "--size", "64x36", "--bands", "3"]) == 0
        reader = imageio_ffmpeg.read_frames(str(out / "flight.mp4"))
        meta = next(reader)
        assert tuple(meta["size"]) == (64, 36)
        assert sum(1 for _ in reader) == 3
        assert json.loads((out / "run.json").read_text())["video"] == "flight.mp4"

    def test_a_mesh_in_open_water(self, tmp_path):
        """--mesh: a white cube 3 m ahead in open water; the camera looks at it,
        so the centre of the frame is the cube, lit, and the corners water."""
        import trimesh
        cube = tmp_path / "cube.obj"
        trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(cube)
        out = tmp_path / "run"
        assert main(["view", "--offscreen", "--frames", "2", "--record", str(out), "--mesh",
                     str(cube), "--depth", "4", "--size", "64x36", "--bands", "3"]) == 0
        run = json.loads((out / "run.json").read_text())
        assert run["settings"]["mesh"] == str(cube)
        frame = np.asarray(Image.open(out / run["frames"][-1]["file"])).astype(float)
        centre, corner = frame[16:20, 30:34].mean(axis=(0, 1)), frame[:4, :4].mean(axis=(0, 1))
        assert np.abs(centre - corner).max() > 10

    def test_a_mesh_on_a_seabed_with_an_albedo(self, tmp_path):
        """--seabed 6,0.5 under a cube at 4 m: the plane fills the bottom of the
        frame where open water was, brighter than it (the exposure is set by
        each run's first frame, so the bottom is compared with the top); a red
        --albedo makes the cube redder than the white one."""
        import trimesh
        cube = tmp_path / "cube.obj"
        trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(cube)
        frames = {}
        for name, extra in (("open", []), ("bed", ["--seabed", "6,0.5"]),
                            ("red", ["--seabed", "6,0.5", "--albedo", "0.8,0.2,0.2"])):
            out = tmp_path / name
            assert main(["view", "--offscreen", "--frames", "1", "--record", str(out),
                         "--mesh", str(cube), "--depth", "4", "--size", "64x36", "--bands",
                         "4", *extra]) == 0
            run = json.loads((out / "run.json").read_text())
            frames[name] = np.asarray(Image.open(out / run["frames"][0]["file"])).astype(float)
        assert run["settings"]["seabed"] == [6.0, 0.5]
        assert run["settings"]["albedo"] == [0.8, 0.2, 0.2]

        def bottom_over_top(im):
            return im[-4:].mean() / im[:4].mean()
        assert bottom_over_top(frames["bed"]) > 1.1 * bottom_over_top(frames["open"])
        cube_rgb = {k: frames[k][16:20, 30:34].mean(axis=(0, 1)) for k in ("bed", "red")}
        assert cube_rgb["red"][0] / cube_rgb["red"][2] > cube_rgb["bed"][0] / cube_rgb["bed"][2]

    def test_an_rgbd_photograph_seen_deeper(self, tmp_path):
        """--rgbd: the photograph's own view at its own size; the script takes
        the camera from 2 to 8 m (exposure held): the whole frame darkens and
        the red of the photograph's left half fades faster than its blue
        (Jerlov IB); the sidecar names the photograph."""
        rgb = np.zeros((36, 48, 3), np.uint8)
        rgb[:, :24] = (220, 120, 60)
        rgb[:, 24:] = (60, 120, 220)
        Image.fromarray(rgb).save(tmp_path / "rgb.png")
        np.save(tmp_path / "depth.npy", np.full((36, 48), 2.5))
        script = tmp_path / "down.json"
        script.write_text(json.dumps({"fps": 1, "keyframes": [{"t": 0, "depth_m": 2},
                                                              {"t": 1, "depth_m": 8}]}))
        out = tmp_path / "run"
        assert main(["view", "--offscreen", "--frames", "2", "--record", str(out), "--rgbd",
                     str(tmp_path / "rgb.png"), str(tmp_path / "depth.npy"), "--intrinsics",
                     "50,50,24,18", "--bands", "6", "--script", str(script)]) == 0
        run = json.loads((out / "run.json").read_text())
        assert run["settings"]["rgbd"]["intrinsics"] == [50.0, 50.0, 24.0, 18.0]
        assert [f["depth_m"] for f in run["frames"]] == [2.0, 8.0]
        near, deep = (np.asarray(Image.open(out / f["file"])).astype(float)
                      for f in run["frames"])
        assert near.shape == (36, 48, 3)
        assert deep.mean() < near.mean() - 5
        left = [im[:, :20].mean(axis=(0, 1)) for im in (near, deep)]
        assert left[1][0] / left[1][2] < left[0][0] / left[0][2]

    def test_an_rgbd_script_that_turns_is_refused(self, tmp_path, capsys):
        Image.fromarray(np.full((18, 32, 3), 128, np.uint8)).save(tmp_path / "rgb.png")
        np.save(tmp_path / "depth.npy", np.full((18, 32), 2.0))
        script = tmp_path / "turn.json"
        script.write_text(json.dumps({"keyframes": [{"t": 0, "yaw_deg": 30}]}))
        assert main(["view", "--offscreen", "--frames", "1", "--rgbd",
                     str(tmp_path / "rgb.png"), str(tmp_path / "depth.npy"), "--intrinsics",
                     "30,30,16,9", "--bands", "3", "--script", str(script)]) == 2
        assert "keeps its direction" in capsys.readouterr().err


class TestOptions:
    @pytest.mark.parametrize("args, message", [
        (["--offscreen"], "--offscreen needs --frames N"),
        (["--offscreen", "--frames", "0"], "--frames 0; accepted: a whole number >= 1"),
        (["--offscreen", "--frames", "2", "--mp4"], "--mp4 needs --record OUTDIR"),
        (["--wind", "3"], "needs a sun elevation of at least 1"),
        (["--intrinsics", "1,1,1,1"], "--intrinsics is only used with --rgbd"),
        (["--rgbd", "a.png", "d.npy"], "--rgbd needs --intrinsics"),
        (["--rgbd", "a.png", "d.npy", "--intrinsics", "1,1,1,1", "--mesh", "m.obj"],
         "a view shows one of them"),
        (["--rgbd", "missing.png", "d.npy", "--intrinsics", "1,1,1,1"],
         "could not read image file 'missing.png'"),
        (["--seabed", "12"], "a seabed goes with a mesh or an RGB-D photograph"),
        (["--albedo", "0.5,0.5,0.5"], "albedo replaces a mesh's colours"),
        (["--mesh", "m.obj", "--albedo", "0.5,2,0.5"], "three numbers in [0, 1]"),
        (["--mesh", "m.obj", "--seabed", "3", "--depth", "5"], "not below the camera at 5 m"),
        (["--mesh", "m.obj", "--seabed", "-3"], "--seabed '-3'; accepted: DEPTH[,ALBEDO]"),
    ])
    def test_bad_combinations_are_refused_before_rendering(self, args, message, capsys):
        assert main(["view", *args]) == 2
        assert message in capsys.readouterr().err

    def test_no_display_is_a_clear_error_not_a_crash(self, monkeypatch, capsys):
        """glfw aborts the process when a window is made without a display; the
        command checks first and says what to do."""
        pytest.importorskip("glfw", reason="the view extra's glfw opens windows")
        for var in ("DISPLAY", "WAYLAND_DISPLAY", "RENDERCANVAS_FORCE_OFFSCREEN"):
            monkeypatch.delenv(var, raising=False)
        assert main(["view", "--size", "32x18", "--bands", "3"]) == 2
        err = capsys.readouterr().err
        assert "no window can open here" in err and "--offscreen" in err

    @pytest.mark.gpu
    def test_a_bad_script_names_the_file(self, tmp_path, capsys):
        bad = tmp_path / "bad.json"
        bad.write_text(json.dumps({"keyframes": [{"t": 0, "zoom": 3}]}))
        assert main(["view", "--offscreen", "--frames", "1", "--script", str(bad),
                     "--size", "32x18", "--bands", "3"]) == 2
        err = capsys.readouterr().err
        assert "bad.json" in err and "unknown key(s) ['zoom']" in err
