"""The rendering API (aquaspec.rendering.api) and `aquaspec render`: pictures, the
white card, files, bad input."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from aquaspec.scene.camera import Camera
from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.colour.reflectance import colorchecker
from aquaspec.rendering.api import render

DATA = Path(__file__).parents[1] / "data"
GREYS = range(18, 24)          # white 9.5 ... black 2, the chart's bottom row
RED, BLUE = 14, 12             # "red" and "blue" patches of the chart


def patch_means(result, scene, camera):
    """Mean linear RGB of each ColorChecker patch (eroded masks), shape (24, 3)."""
    from aquaspec.gpu.passes.raster import RasterPass
    from scipy.ndimage import binary_erosion
    gb = RasterPass().render(scene, camera)
    out = []
    for patch in colorchecker():
        idx = [i for i, m in enumerate(scene.materials) if m is patch]
        mask = binary_erosion(np.isin(gb.material, idx) & gb.hit, iterations=1)
        assert mask.sum() >= 4, f"patch {patch.name} not visible"
        out.append(result.linear_rgb[mask].mean(axis=0))
    return np.array(out)


def scene_at(depth, width, height, back_m=0.0):
    from aquaspec.scene.builtin import builtin_scene
    scene, cam = builtin_scene(depth, width=width, height=height)
    if back_m:
        back = -cam.forward * np.array([1.0, 0.0, 1.0])
        back = back / np.linalg.norm(back) * back_m
        cam = Camera(cam.position + back, cam.forward, [0, 1, 0], cam.width, cam.height,
                     cam.fx, cam.fy, cam.cx, cam.cy)
    return scene, cam


@pytest.mark.gpu
class TestPictures:
    @pytest.mark.parametrize("water,depth", [("IB", 5.0), ("3C", 9.0)])
    def test_finite_and_grey_order(self, water, depth):
        scene, cam = scene_at(depth, 320, 180)
        res = render(water=water, depth_m=depth, scene=scene, camera=cam, bands=16)
        assert np.all(np.isfinite(res.linear_rgb))
        assert res.display.dtype == np.uint8 and res.display.shape == (180, 320, 3)
        means = patch_means(res, scene, cam)
        grey = means[list(GREYS)].sum(axis=1)
        assert np.all(np.diff(grey) < 0), grey

    def test_red_loses_contrast_faster_than_blue_in_IB(self):
        contrast = {}
        for back in (0.0, 5.0):
            scene, cam = scene_at(5.0, 640, 360, back)
            res = render(water="IB", depth_m=5.0, scene=scene, camera=cam, bands=16,
                         sensor="nikon-5100-npl")
            m = patch_means(res, scene, cam)
            black = m[23]
            # Against the black patch, the veil in front of both cancels.
            contrast[back] = (m[RED, 0] - black[0], m[BLUE, 2] - black[2])
        red_keep = contrast[5.0][0] / contrast[0.0][0]
        blue_keep = contrast[5.0][1] / contrast[0.0][1]
        assert 0 < red_keep < blue_keep < 1, (red_keep, blue_keep)

    @pytest.mark.parametrize("ms_model, name", [("seeds", "reference_IB_5m.png"),
                                                ("lightfield", "reference_IB_5m_lightfield.png")])
    def test_reference_image(self, tmp_path, ms_model, name):
        """Regression against tests/data/reference_IB_5m*.png (the seeds' model, and
        the default light field with the cone spread); writes a diff image on failure."""
        ref_path = DATA / name
        res = render(water="IB", depth_m=5.0, size=(160, 90), bands=8, exposure=-1.5,
                     ms_model=ms_model)
        got = res.display.astype(float)
        ref = np.asarray(Image.open(ref_path).convert("RGB"), dtype=float)
        diff = np.abs(got - ref)
        ok = diff.mean() < 1.0 and np.percentile(diff, 99) < 6.0
        if not ok:
            out = tmp_path / "reference_IB_5m_diff.png"
            Image.fromarray(np.clip(diff * 8, 0, 255).astype(np.uint8)).save(out)
            Image.fromarray(res.display).save(tmp_path / "reference_IB_5m_got.png")
            pytest.fail(f"render differs from {ref_path}: mean {diff.mean():.2f}, 99th pct "
                        f"{np.percentile(diff, 99):.1f} (of 255); diff image: {out}")

    def test_radiance_and_params(self):
        # Per-band radiance from the GPU: the seeds' model only (the light field
        # says so and names the NumPy backend).
        with pytest.raises(AquaspecError, match="backend='numpy'"):
            render(water="3C", depth_m=9.0, size=(64, 36), bands=8, return_radiance=True)
        res = render(water="3C", depth_m=9.0, size=(64, 36), bands=8, return_radiance=True,
                     ms_model="seeds")
        assert res.radiance.shape == (36, 64, 8) and np.all(res.radiance >= 0)
        p = res.params
        assert p["water"]["name"] == "3C" and p["depth_m"] == 9.0 and p["bands"]["n"] == 8
        assert p["camera"]["width"] == 64 and p["sensor"]["name"] == "human"


@pytest.mark.gpu
class TestSeabed:
    """The light field's lower boundary: the built-in scene's sand by default."""

    def test_scene_seabed_brightens_clear_water(self):
        from aquaspec.scene.seabed import Seabed
        kw = dict(water="I", depth_m=5.0, size=(64, 36), bands=4, exposure=0.0)
        with_bed = render(**kw)
        deep = render(**kw, seabed=None)
        bed = with_bed.params["seabed"]
        assert bed["reflectance"] == "sand" and 5.0 < bed["depth_m"] < 9.0
        assert deep.params["seabed"] is None
        # Upwelling from the sand lights the scene (measured +1.5-2 % at 160x90).
        assert with_bed.linear_rgb.mean() > 1.005 * deep.linear_rgb.mean()
        grey = render(**kw, seabed=Seabed(9.0, 0.4))
        assert grey.params["seabed"] == {"depth_m": 9.0, "reflectance": 0.4}
        # The seeds' model has no light field: no seabed recorded.
        assert "seabed" not in render(**kw, ms_model="seeds").params

    @pytest.mark.parametrize("seabed, match", [
        ("sand", r"seabed='sand'; accepted: 'scene', None or an aquaspec.scene.seabed.Seabed"),
        (4.0, r"seabed=4.0; accepted"),
    ])
    def test_bad_seabed(self, seabed, match):
        with pytest.raises(AquaspecError, match=match):
            render(water="I", depth_m=5.0, size=(16, 9), bands=3, seabed=seabed)

    def test_seabed_above_the_camera(self):
        from aquaspec.scene.seabed import Seabed
        with pytest.raises(AquaspecError, match="the seabed at 3 m is not below the camera "
                                                "at 5 m"):
            render(water="I", depth_m=5.0, size=(16, 9), bands=3, seabed=Seabed(3.0))

    def test_seabed_type_checks(self):
        from aquaspec.scene.seabed import Seabed
        with pytest.raises(AquaspecError, match="seabed depth_m=-1"):
            Seabed(-1.0)
        with pytest.raises(AquaspecError, match="seabed reflectance=1.5"):
            Seabed(5.0, 1.5)
        from aquaspec.colour.bands import Bands
        np.testing.assert_array_equal(Seabed(5.0, 0.25).albedo_on(Bands(3)), [0.25] * 3)

    def test_cli(self, tmp_path, capsys):
        out = tmp_path / "s.png"
        base = ["render", "--water", "I", "--size", "32x18", "--bands", "3", "-o", str(out)]
        assert main([*base, "--seabed", "9,0.3"]) == 0
        side = json.loads((tmp_path / "s.png.json").read_text())
        assert side["seabed"] == {"depth_m": 9.0, "reflectance": 0.3}
        assert main([*base, "--seabed", "none"]) == 0
        assert json.loads((tmp_path / "s.png.json").read_text())["seabed"] is None
        assert main([*base, "--seabed", "deep"]) == 2
        assert "--seabed 'deep'; accepted: scene, none, or DEPTH[,ALBEDO]" in \
            capsys.readouterr().err


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
        code = main(["render", "--size", "64x36", "--bands", "4", *argv, "-o", str(out)]
                    if "-o" not in argv else ["render", *argv])
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


class TestWhiteCard:
    def test_along_the_view_or_level_near_the_surface(self):
        from aquaspec.scene.camera import Camera
        from aquaspec.rendering.api import WHITE_CARD_DISTANCE_M, white_card
        down = Camera((0, -5, 0), (0, -1, -1), (0, 1, 0), 8, 8, 8.0, 8.0, 4.0, 4.0)
        card = white_card(down)
        assert card["depth_m"] == 5 and card["distance_m"] == WHITE_CARD_DISTANCE_M
        np.testing.assert_allclose(card["view"], np.array([0, -1, -1]) / np.sqrt(2))
        up = Camera((0, -0.5, 0), (1, 2, 0), (0, 0, 1), 8, 8, 8.0, 8.0, 4.0, 4.0)
        np.testing.assert_allclose(white_card(up)["view"], [1, 0, 0])

    def test_unbalanceable_card_fails_before_shading(self, monkeypatch):
        import aquaspec.rendering.api
        from aquaspec.rendering.api import render
        from aquaspec.colour.sensors import Sensor
        wl = np.linspace(380.0, 720.0, 35)
        # A CSV-like sensor whose red lobe is negative everywhere.
        odd = Sensor("odd", wl, np.stack([-np.ones_like(wl), np.ones_like(wl),
                                          np.ones_like(wl)]))
        monkeypatch.setattr(aquaspec.rendering.api, "shade_gbuffer",
                            lambda *a, **k: pytest.fail("shaded before the check"))
        with pytest.raises(AquaspecError, match=r"grey card 1 m ahead has camera RGB -.*"
                                                r"sensor 'odd'.*'grey-world'"):
            render(water="IB", depth_m=5.0, size=(32, 18), bands=8, sensor=odd,
                   white_balance="white-patch", backend="numpy")

    def test_human_white_patch_adapts_the_cones(self):
        """Blue water's card has a negative linear-sRGB red: the eye's von Kries
        adaptation still balances it (a camera's per-channel gains could not)."""
        from aquaspec.rendering.api import render
        res = render(water="IB", depth_m=5.0, size=(32, 18), bands=8,
                     white_balance="white-patch", backend="numpy")
        ref = np.array(res.params["white_card"]["camera_rgb"])
        assert ref[0] < 0
        disp = res.params["display"]
        assert disp["white_balance_space"].startswith("cones")
        np.testing.assert_allclose(disp["white_balance_gains"], 1.0)
        m = np.array(disp["matrix"])
        np.testing.assert_allclose(m @ ref, ref.mean(), rtol=1e-9)
