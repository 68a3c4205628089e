"""`aquaspec render`: files, sidecars, options and bad input."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from PIL import Image

from aquaspec.cli import main


@pytest.mark.gpu
class TestRenderCommand:
    def test_writes_png_and_sidecar(self, tmp_path, capsys):
        out = tmp_path / "x.png"
        assert main(["render", "--water", "IB", "--depth", "5", "--size", "320x180",
                     "--bands", "8", "-o", str(out)]) == 0
        assert Image.open(out).size == (320, 180)
        side = json.loads((tmp_path / "x.png.json").read_text())
        assert side["water"]["name"] == "IB" and side["bands"]["n"] == 8
        assert side["depth_m"] == 5.0 and side["camera"]["height"] == 180

    @pytest.mark.parametrize("how", ["single", "multiple"])
    def test_light_field_with_the_cone_spread(self, tmp_path, how):
        """GPU render with --cone-spread: the parameters reach the sidecar (cone
        40 degrees by default) and the image is the NumPy backend's, within the
        compiled model's interpolation (the GPU's water table; measured 1.2e-3 of
        the image's largest value), with the cone's light scattered once or
        (--spread-scattering multiple) a Poisson number of times."""
        out, lin = tmp_path / "s.png", tmp_path / "s.npy"
        args = ["render", "--water", "II", "--size", "64x36", "--bands", "4", "--ms-model",
                "lightfield", "--phase", "ff", "--cone-spread", "--exposure", "0",
                "--spread-scattering", how]
        assert main([*args, "-o", str(out), "--linear", str(lin)]) == 0
        side = json.loads((tmp_path / "s.png.json").read_text())
        assert side["cone_spread"] is True and side["forward_cone_deg"] == 40.0
        assert side["spread_scattering"] == how
        ref = tmp_path / "r.npy"
        assert main([*args, "--backend", "numpy", "-o", str(tmp_path / "r.png"),
                     "--linear", str(ref)]) == 0
        np.testing.assert_allclose(np.load(lin), np.load(ref), rtol=2e-3,
                                   atol=2e-3 * np.abs(np.load(ref)).max())

    def test_ambient_shadow_on_the_gpu(self, tmp_path, capsys):
        """--ambient-shadow with the GPU backend: recorded in the sidecar, and
        it darkens the pixels where targets block the water's light (by 5.8 %
        at the 99th percentile here, 0.8 % brighter at the 1st: a surface
        brighter than the water it hides gives light back)."""
        args = ["render", "--water", "II", "--size", "48x27", "--bands", "4",
                "--spread-scattering", "multiple", "--exposure", "0"]
        lin, lin0 = tmp_path / "a.npy", tmp_path / "b.npy"
        assert main([*args, "--ambient-shadow", "-o", str(tmp_path / "a.png"),
                     "--linear", str(lin)]) == 0
        assert json.loads((tmp_path / "a.png.json").read_text())["ambient_shadow"] is True
        # (Its progress: a line per grid of receivers.)
        assert "the scene's shadow: " in capsys.readouterr().err
        assert main([*args, "-o", str(tmp_path / "b.png"), "--linear", str(lin0)]) == 0
        with_shadow, without = np.load(lin), np.load(lin0)
        assert np.all(np.isfinite(with_shadow))
        assert np.percentile((without - with_shadow) / without, 99) > 0.02

    def test_linear_exr(self, tmp_path):
        from aquaspec.io.linear import read_linear
        out, lin = tmp_path / "x.png", tmp_path / "x.exr"
        assert main(["render", "--water", "IB", "--size", "64x36", "--bands", "4", "-o", str(out),
                     "--linear", str(lin)]) == 0
        arr = read_linear(lin)
        assert arr.shape[:2] == (36, 64) and np.all(np.isfinite(arr))

    def test_mesh(self, tmp_path):
        import trimesh
        mesh = tmp_path / "box.ply"
        trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(mesh)
        out = tmp_path / "m.png"
        assert main(["render", "--mesh", str(mesh), "--albedo", "0.6,0.3,0.1", "--size", "64x36",
                     "--bands", "4", "-o", str(out)]) == 0
        assert json.loads((tmp_path / "m.png.json").read_text())["scene"]["kind"] == "mesh"

    def test_rgbd(self, tmp_path):
        rgb = np.full((36, 64, 3), 128, np.uint8)
        Image.fromarray(rgb).save(tmp_path / "im.png")
        np.save(tmp_path / "d.npy", np.full((36, 64), 2.0))
        out = tmp_path / "r.png"
        assert main(["render", "--rgbd", str(tmp_path / "im.png"), str(tmp_path / "d.npy"),
                     "--intrinsics", "50,50,32,18", "--bands", "4", "-o", str(out)]) == 0
        assert Image.open(out).size == (64, 36)

    def bad(self, tmp_path, capsys, argv, match):
        out = tmp_path / "bad.png"
        try:
            code = main(["render", "--size", "64x36", "--bands", "4", *argv, "-o", str(out)]
                        if "-o" not in argv else ["render", *argv])
        except SystemExit as exc:      # refused by the parser
            code = exc.code
        err = capsys.readouterr().err
        assert code == 2 and re.search(match, err), err
        assert not out.exists() and not list(tmp_path.glob(".*.part"))

    def test_missing_mesh(self, tmp_path, capsys):
        self.bad(tmp_path, capsys, ["--mesh", str(tmp_path / "none.obj")], "none.obj")

    def test_corrupt_mesh(self, tmp_path, capsys):
        p = tmp_path / "broken.glb"
        p.write_bytes(b"glTF\x02\x00\x00\x00garbage")
        self.bad(tmp_path, capsys, ["--mesh", str(p)], "broken.glb")

    def rgbd_files(self, tmp_path, depth, size=(36, 64)):
        Image.fromarray(np.zeros(size + (3,), np.uint8)).save(tmp_path / "im.png")
        np.save(tmp_path / "d.npy", depth)
        return ["--rgbd", str(tmp_path / "im.png"), str(tmp_path / "d.npy"),
                "--intrinsics", "50,50,32,18"]

    def test_rgbd_sizes_differ(self, tmp_path, capsys):
        self.bad(tmp_path, capsys, self.rgbd_files(tmp_path, np.ones((30, 64))), "same size")

    @pytest.mark.parametrize("value", [np.nan, 0.0, -1.0])
    def test_rgbd_bad_depth(self, tmp_path, capsys, value):
        d = np.ones((36, 64))
        d[5, 7] = value
        self.bad(tmp_path, capsys, self.rgbd_files(tmp_path, d), r"1 pixel.*row 5.*column 7|"
                 r"row 5, column 7")

    @pytest.mark.parametrize("size", ["0x10", "9000x100", "axb"])
    def test_bad_size(self, tmp_path, capsys, size):
        self.bad(tmp_path, capsys, ["--size", size], "8192|WIDTHxHEIGHT")

    def test_unwritable_output(self, tmp_path, capsys):
        code = main(["render", "--size", "64x36", "-o", str(tmp_path / "nodir" / "x.png")])
        assert code == 2 and "does not exist" in capsys.readouterr().err

    def test_bad_exposure(self, tmp_path, capsys):
        self.bad(tmp_path, capsys, ["--exposure", "bright"], "exposure 'bright'")

    def test_bad_spread_scattering(self, tmp_path, capsys):
        # (argparse's own usage error: exit status 2 naming the choices.)
        with pytest.raises(SystemExit) as exc:
            main(["render", "--spread-scattering", "double", "-o", str(tmp_path / "x.png")])
        err = capsys.readouterr().err
        assert exc.value.code == 2 and "invalid choice: 'double'" in err and "multiple" in err
        assert not list(tmp_path.iterdir())

    def test_cone_spread_needs_the_light_field(self, tmp_path, capsys):
        self.bad(tmp_path, capsys, ["--ms-model", "seeds", "--cone-spread"],
                 "cone_spread is part of the light-field model.*'seeds'")
