"""The rendering API (aquaspec.rendering.api) and `aquaspec render`: pictures, the
white card, files, bad input."""

from __future__ import annotations

import json
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

    @pytest.mark.parametrize("ms_model, surface, name", [
        ("seeds", None, "reference_IB_5m.png"),
        ("lightfield", "index-matched", "reference_IB_5m_lightfield.png"),
        ("lightfield", None, "reference_IB_5m_flat.png")])
    def test_reference_image(self, tmp_path, ms_model, surface, name):
        """Regression against tests/data/reference_IB_5m*.png of the classic built-in
        scene (the seeds' model, the
        light field with the cone spread under the index-matched surface, and the
        default: the same under the flat surface); writes a diff image on failure."""
        ref_path = DATA / name
        res = render(water="IB", depth_m=5.0, size=(160, 90), bands=8, exposure=-1.5,
                     ms_model=ms_model, surface=surface, builtin="classic")
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
        """Blue water's card has a negative linear-sRGB red (under the
        index-matched surface, whose sky shines in at every angle; under the
        flat one this card's red is just above 0): the eye's von Kries
        adaptation still balances it (a camera's per-channel gains could not)."""
        from aquaspec.rendering.api import render
        res = render(water="IB", depth_m=5.0, size=(32, 18), bands=8,
                     white_balance="white-patch", backend="numpy", surface="index-matched")
        ref = np.array(res.params["white_card"]["camera_rgb"])
        assert ref[0] < 0
        disp = res.params["display"]
        assert disp["white_balance_space"].startswith("cones")
        np.testing.assert_allclose(disp["white_balance_gains"], 1.0)
        m = np.array(disp["matrix"])
        np.testing.assert_allclose(m @ ref, ref.mean(), rtol=1e-9)
