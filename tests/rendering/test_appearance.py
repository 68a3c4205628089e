"""`water_colour` and the `aquaspec colour|list|spectra` commands."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

from aquaspec.rendering.appearance import water_colour
from aquaspec.colour.bands import Bands
from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.colour.sensors import get_sensor, load_camspec
from aquaspec.medium.water import JERLOV_TYPES, load_water

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


def _sun_setup(ms_model, elevation, azimuth, n=8, water="IB"):
    from aquaspec.light.sky import surface_light
    from aquaspec.rendering.setup import SpectralSetup
    return SpectralSetup(load_water(water), get_sensor("human"),
                         surface_light("sun-sky", sun_elevation_deg=elevation,
                                       sun_azimuth_deg=azimuth), Bands(n),
                         ms_model=ms_model, cone_spread=False,
                         forward_cone_deg=15.0 if ms_model == "lightfield" else None)


def _view(elevation_deg):
    r = np.radians(elevation_deg)
    return np.array([0.0, np.sin(r), -np.cos(r)])


def _rendered_pixel(setup, depth, view, distance):
    """The NumPy renderer's camera RGB of one ray along ``view`` (a 1x1 camera
    with a narrow pixel) ending on an 18 % grey card facing it, or in open water."""
    from aquaspec.rendering.appearance import GREY_CARD_REFLECTANCE
    from aquaspec.scene.camera import Camera
    from aquaspec.scene.gbuffer import GBuffer
    from aquaspec.shading.shade import shade_gbuffer
    cam = Camera((0.0, -depth, 0.0), view, (0.0, 1.0, 0.0), 1, 1, 1000.0, 1000.0, 0.5, 0.5)
    gb = GBuffer(cam, [[distance]], [[-view]], [[0]], [[(0.0, 0.0, 0.0)]], materials=["grey"])
    medium = {**setup.medium([]),
              "material_bands": np.full((1, setup.bands.n), GREY_CARD_REFLECTANCE)}
    return shade_gbuffer(gb, **medium, lightfield=setup.lightfield_tables(),
                         sun=setup.sun_inputs())["camera_rgb"][0, 0]


class TestSun:
    """With --light sun-sky the colour is what the renderer makes of the sun."""

    @pytest.mark.parametrize("ms_model", ["lightfield", "seeds"])
    @pytest.mark.parametrize("elevation, azimuth, view", [
        (20, 180, 0), (60, 0, 0), (45, 150, -30), (70, 30, 40)])
    def test_the_renderers_pixel(self, ms_model, elevation, azimuth, view):
        from aquaspec.rendering.appearance import colour_of_setup
        setup = _sun_setup(ms_model, elevation, azimuth)
        v = _view(view)
        res = colour_of_setup(setup, depth_m=6.0, distance_m=2.5, view=v)
        for key, dist in (("water_rgb", np.inf), ("grey_card_rgb", 2.5)):
            got = np.array(res[key])
            want = _rendered_pixel(setup, 6.0, v, dist)
            # (The renderer integrates the beam's scattering in froxel
            # slices; here it is closed form: measured within 0.3 %.)
            np.testing.assert_allclose(got, want, atol=3e-3 * np.abs(want).max())
        assert res["sun_part"]["water_rgb"][2] > 0

    def test_sun_parts_in_closed_form(self):
        """Horizontal view, sun behind the camera: the water's share is
        b p(theta) E_b(d) / c, the card's adds rho/pi E_b(d) sin(theta_w) e^{-cS}."""
        from aquaspec.rendering.appearance import GREY_CARD_REFLECTANCE, colour_of_setup
        from aquaspec.colour.sensors import radiance_to_rgb
        from aquaspec.transport.sun_scattering import phase_from_log_table
        setup = _sun_setup("lightfield", 35, 180)
        sun = setup.sun_inputs()
        d, s = 4.0, 2.0
        res = colour_of_setup(setup, depth_m=d, distance_m=s)
        e_b = sun.beam0 * np.exp(-sun.c_sun * d / sun.mu0)
        p = phase_from_log_table(sun.log_phase, -sun.to_sun[2])      # view -z
        scatter = sun.b * p * e_b / sun.c_view
        w = setup.sensor.band_weights(setup.bands)
        np.testing.assert_allclose(res["sun_part"]["water_rgb"], radiance_to_rgb(scatter, w),
                                   rtol=1e-9)
        sin_w = np.sqrt(1.0 - sun.mu0 ** 2)
        assert sun.to_sun[2] == pytest.approx(sin_w)           # towards the card's normal +z
        card = (scatter * -np.expm1(-sun.c_view * s)
                + GREY_CARD_REFLECTANCE / np.pi * e_b * sin_w * np.exp(-sun.c_view * s))
        np.testing.assert_allclose(res["sun_part"]["grey_card_rgb"], radiance_to_rgb(card, w),
                                   rtol=1e-9)

    def test_sun_ahead_lights_the_water_not_the_card(self):
        from aquaspec.rendering.appearance import colour_of_setup
        ahead = colour_of_setup(_sun_setup("lightfield", 50, 0), depth_m=5.0, distance_m=3.0)
        behind = colour_of_setup(_sun_setup("lightfield", 50, 180), depth_m=5.0, distance_m=3.0)
        # Petzold: scattering through 61 degrees (sun ahead) beats 119 (behind) ...
        assert ahead["sun_part"]["water_rgb"][2] > 1.8 * behind["sun_part"]["water_rgb"][2]
        # ... and the card's back is to it: only the water in front scatters.
        assert behind["sun_part"]["grey_card_rgb"][1] > 5 * ahead["sun_part"]["grey_card_rgb"][1]

    def test_without_the_sun_no_beam(self):
        from aquaspec.light.sky import surface_light
        w, s = load_water("IB"), get_sensor("human")
        light = surface_light("sun-sky", sun_elevation_deg=40)
        kw = dict(depth_m=5, distance_m=3, surface="index-matched")
        diffuse = water_colour(w, s, Bands(8), light=light.without_sun(), **kw)
        beam = water_colour(w, s, Bands(8), light=light, **kw)
        assert "sun_part" not in diffuse and "sun_part" in beam
        # The same E0 lights both; a beam from 40 degrees scatters less into a
        # horizontal view than a diffuse sky shining in at every angle does
        # (under the flat surface the sky comes through Snell's window, more
        # steeply than this beam, and the order reverses).
        assert beam["light"]["sun"]["elevation_deg"] == 40
        assert beam["water_rgb"][2] < diffuse["water_rgb"][2]

    def test_cli(self, capsys):
        assert main(["colour", "--water", "IB", "--depth", "5", "--light", "sun-sky",
                     "--sun-azimuth", "180", "--view-elevation", "-30", "--bands", "8"]) == 0
        out = capsys.readouterr().out
        assert "view -30 deg" in out and "of which the sun's beam" in out
        assert main(["colour", "--water", "IB", "--depth", "5", "--view-elevation", "-30",
                     "--json", "--bands", "8"]) == 0
        doc = json.loads(capsys.readouterr().out)
        assert doc["view_elevation_deg"] == pytest.approx(-30)
        assert doc["grey_card_depth_m"] == pytest.approx(5 + 3 * 0.5)

    @pytest.mark.parametrize("argv, match", [
        (["--view-elevation", "95"], "view elevation 95.0 degrees is not accepted; give -90"),
        (["--depth", "1", "--view-elevation", "60"], "would be above the water surface"),
    ])
    def test_cli_errors(self, capsys, argv, match):
        base = ["colour", "--water", "IB", "--bands", "8"]
        assert main(base + (argv if "--depth" in argv else ["--depth", "5", *argv])) == 2
        assert match in capsys.readouterr().err
