"""`water_colour` and the `aquaspec colour|list|spectra` commands."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from aquaspec.appearance import water_colour
from aquaspec.bands import Bands
from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.sensors import get_sensor, load_camspec
from aquaspec.water import JERLOV_TYPES, load_water

CONVERGENCE_N = (3, 8, 16, 32)


def colour_of(water, sensor, n, depth=5.0, ms_model="seeds"):
    # The seeds' model unless asked: the convergence study below takes 300
    # bands for every type and camera (the light field's tables at 300 bands
    # would take minutes).
    return np.array(water_colour(water, sensor, Bands(n), depth_m=depth,
                                 distance_m=3.0, ms_model=ms_model)["water_rgb"])


class TestConvergence:
    """water_rgb at 5 m converges to the 1 nm result for every type and camera."""

    def test_every_type_and_camera(self, camspec_path):
        cams = load_camspec(camspec_path)
        worst = dict.fromkeys(CONVERGENCE_N, 0.0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            waters = [load_water(t) for t in JERLOV_TYPES]
        for w in waters:
            for s in cams.values():
                ref = colour_of(w, s, 300)
                errs = [np.linalg.norm(colour_of(w, s, n) - ref) / np.linalg.norm(ref)
                        for n in CONVERGENCE_N]
                for n, e in zip(CONVERGENCE_N, errs):
                    worst[n] = max(worst[n], e)
                # Midpoint rule: the error falls as the band count grows (3
                # bands can be lucky, so compare with 8).
                assert errs[3] < errs[2] < errs[1]
        print("worst relative error of water_rgb vs 1 nm:", worst)
        assert worst[32] < 0.005 and worst[16] < 0.02 and worst[8] < 0.06


class TestWaterColour:
    def test_deeper_is_darker_and_bluer(self):
        w, s = load_water("IB"), get_sensor("human")
        shallow, deep = colour_of(w, s, 16, 2.0), colour_of(w, s, 16, 15.0)
        assert deep.sum() < shallow.sum()
        assert deep[2] / deep[1] > shallow[2] / shallow[1]

    def test_grey_card_between_water_and_unveiled(self):
        w, s = load_water("3C"), get_sensor("human")
        near = water_colour(w, s, Bands(16), depth_m=5, distance_m=0.2)
        far = water_colour(w, s, Bands(16), depth_m=5, distance_m=30)
        # Far away the card disappears into the water colour.
        np.testing.assert_allclose(far["grey_card_rgb"], far["water_rgb"], rtol=0.02)
        assert not np.allclose(near["grey_card_rgb"], near["water_rgb"], rtol=0.1)

    @pytest.mark.parametrize("depth", [-1.0, float("nan"), "deep"])
    def test_bad_depth(self, depth):
        with pytest.raises(AquaspecError, match="depth"):
            water_colour(load_water("IB"), get_sensor("human"), Bands(8), depth_m=depth,
                         distance_m=3)


class TestCli:
    def test_colour_json(self, capsys):
        assert main(["colour", "--water", "IB", "--depth", "5", "--distance", "3",
                     "--sensor", "human", "--bands", "16", "--json"]) == 0
        out = json.loads(capsys.readouterr().out)
        assert len(out["water_rgb"]) == 3 and len(out["grey_card_rgb"]) == 3
        assert out["water"]["name"] == "IB" and out["depth_m"] == 5 and out["bands"]["n"] == 16
        assert out["ms_model"] == "lightfield" and out["phase"] == "petzold"   # the default

    def test_colour_text_names_the_model(self, capsys):
        for argv, name in [([], "light field (petzold phase function)"),
                           (["--ms-model", "seeds"], "seeds' model")]:
            assert main(["colour", "--water", "IB", "--depth", "5", "--bands", "4", *argv]) == 0
            assert capsys.readouterr().out.splitlines()[0].endswith(name)

    def test_colour_camspec(self, capsys, camspec_path):
        assert main(["colour", "--water", "3C", "--depth", "9", "--sensor", "Nikon D90",
                     "--camspec", str(camspec_path), "--json"]) == 0
        assert json.loads(capsys.readouterr().out)["sensor"]["name"] == "Nikon D90"

    @pytest.mark.parametrize("argv,match", [
        (["--water", "XI", "--depth", "5"], "unknown water type 'XI'"),
        (["--water", "IB", "--depth", "-2"], "depth -2.0 m is not accepted; give metres below"),
        (["--water", "IB", "--depth", "5", "--distance", "-1"],
         "distance -1.0 m is not accepted; give metres from the camera"),
        (["--water", "IB", "--depth", "5", "--bands", "0"], "n=0 is out of range"),
        (["--water", "IB", "--depth", "5", "--sensor", "leica"], "unknown sensor 'leica'"),
        (["--water", "IB", "--depth", "5", "--range", "350-700"], "sensor 'human' covers 360-830"),
        (["--water", "IB", "--depth", "5", "--range", "400-800"], "covers 300-700 nm"),
    ])
    def test_errors(self, capsys, argv, match):
        assert main(["colour", *argv]) == 2
        err = capsys.readouterr().err
        assert "error:" in err
        import re
        assert re.search(match, err), err

    def test_list(self, capsys):
        assert main(["list", "waters"]) == 0
        out = capsys.readouterr().out
        assert "9C" in out and "williamson2022" in out
        assert main(["list", "sensors"]) == 0
        assert "nikon-5100-npl" in capsys.readouterr().out

    def test_help(self, capsys):
        with pytest.raises(SystemExit):
            main(["--help"])
        assert "aquaspec colour" in capsys.readouterr().out


class TestSpectraCommand:
    def test_table_and_plot(self, tmp_path, capsys):
        out = tmp_path / "sp.png"
        assert main(["spectra", "--water", "IB", "--sensor", "nikon-5100-npl", "--bands", "8",
                     "--plot", str(out)]) == 0
        text = capsys.readouterr().out
        assert "Kd" in text and "400.0- 437.5" in text and "nikon-5100-npl" in text
        assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"

    def test_unwritable_plot_fails_before_work(self, tmp_path, capsys):
        assert main(["spectra", "--water", "IB", "--plot", str(tmp_path / "no" / "x.png")]) == 2
        captured = capsys.readouterr()
        assert "does not exist" in captured.err and "band_nm" not in captured.out


class TestMsModels:
    def test_lightfield_isotropic_brighter_than_seeds(self):
        # The seeds' formula drives in-scattering by E_d; an isotropic medium
        # is driven by the scalar irradiance, which is larger (SPEC: the
        # seeds' L_MS is 35-67 % too dark in isotropic media).
        w, s = load_water("IB"), get_sensor("human")
        seeds = water_colour(w, s, Bands(16), depth_m=5, distance_m=3)
        lf = water_colour(w, s, Bands(16), depth_m=5, distance_m=3, ms_model="lightfield",
                          phase="isotropic")
        assert lf["water_rgb"][2] > 1.3 * seeds["water_rgb"][2]
        assert lf["ms_model"] == "lightfield" and lf["phase"] == "isotropic"

    def test_unknown_model(self, capsys):
        with pytest.raises(SystemExit):
            main(["colour", "--water", "IB", "--depth", "5", "--ms-model", "magic"])
        assert "invalid choice: 'magic'" in capsys.readouterr().err
        with pytest.raises(AquaspecError, match="unknown multiple-scattering model 'magic'"):
            water_colour(load_water("IB"), get_sensor("human"), Bands(8), depth_m=5,
                         distance_m=3, ms_model="magic")
