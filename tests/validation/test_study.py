"""Validation against Mitsuba 3: reference sanity, metrics, a small study, bad input."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.validation import metrics
from aquaspec.medium.water import Water, load_water


def mitsuba():
    pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (extra 'validation')")
    from aquaspec.validation.reference import require_mitsuba
    return require_mitsuba()


class TestMetrics:
    def test_identical_images(self):
        img = np.random.default_rng(0).random((20, 30, 3))
        m = metrics.all_metrics(img, img)
        assert m["rmse"] == 0 and m["hsv"] == 0 and m["hue_deg"] == 0
        assert m["ciede2000"] < 1e-9
        assert metrics.ssim(img, img) == pytest.approx(1.0)

    def test_hsv_distance_closed_form(self):
        # Fully saturated red vs fully saturated green: hues 120 degrees apart
        # on the unit circle, distance 2 sin(60 deg) = sqrt(3).
        red = np.array([[1.0, 0.0, 0.0]])
        green = np.array([[0.0, 0.5, 0.0]])     # value differs: ignored
        assert metrics.hsv_distance(red, green) == pytest.approx(np.sqrt(3))
        assert metrics.hue_difference_deg(red, green) == pytest.approx(120.0)
        grey = np.array([[0.3, 0.3, 0.3]])
        assert metrics.hsv_distance(red, grey) == pytest.approx(1.0)

    def test_rmse_and_mask(self):
        a = np.zeros((2, 2, 3))
        b = a.copy()
        b[0, 0] = 2.0
        assert metrics.rmse(a + 1, b + 1)["rmse"] == pytest.approx(1.0)
        mask = np.array([[False, True], [True, True]])
        assert metrics.rmse(a, b, mask)["rmse"] == 0
        with pytest.raises(AquaspecError, match="selects no pixel"):
            metrics.rmse(a, b, np.zeros((2, 2), bool))

    def test_ssim_of_flat_images_closed_form(self):
        # No variance: only the luminance term, (2 mx my + C1) / (mx^2 + my^2 + C1),
        # with C1 = (0.01 L)^2 and L = 1 for a reference without range.
        x, y = np.full((16, 16, 3), 0.25), np.full((16, 16, 3), 0.5)
        c1 = 1e-4
        want = (2 * 0.25 * 0.5 + c1) / (0.25 ** 2 + 0.5 ** 2 + c1)
        assert metrics.ssim(x, y) == pytest.approx(want, rel=1e-9)

    def test_display_lab_and_ciede2000(self):
        # The display transform reads scaled RGB as linear sRGB: white is
        # L* = 100, a* = b* = 0 under D65; mid grey 0.18 is L* = 49.5.
        lab = metrics.display_lab(np.array([[2.0, 2.0, 2.0], [0.36, 0.36, 0.36]]), scale=0.5)
        # (a*, b* within 0.02: sRGB's white point and the D65 chromaticity
        # used for Lab are rounded differently.)
        np.testing.assert_allclose(lab[0], [100.0, 0.0, 0.0], atol=0.02)
        assert lab[1, 0] == pytest.approx(116 * 0.18 ** (1 / 3) - 16, abs=1e-3)
        np.testing.assert_allclose(lab[1, 1:], 0.0, atol=0.02)
        # Two greys differ in lightness only: CIEDE2000 of a pure L* difference
        # is dL / S_L with S_L = 1 + 0.015 (L - 50)^2 / sqrt(20 + (L - 50)^2).
        ref = np.full((1, 2, 3), 0.18)
        test = np.full((1, 2, 3), 0.18 * 1.2)
        scale = 0.9 / 0.18        # the reference's 99th percentile maps to 0.9
        l1 = metrics.display_lab(ref.reshape(-1, 3), scale=scale)[0, 0]
        l2 = metrics.display_lab(test.reshape(-1, 3), scale=scale)[0, 0]
        lm = (l1 + l2) / 2
        s_l = 1 + 0.015 * (lm - 50) ** 2 / np.sqrt(20 + (lm - 50) ** 2)
        # 0.9 * 1.2 > 1 is clipped to white by the display transform.
        assert l2 == pytest.approx(100.0, abs=1e-3)
        assert metrics.ciede2000(ref, test) == pytest.approx(abs(l2 - l1) / s_l, rel=1e-6)

    def test_ssim_drops_with_noise(self):
        rng = np.random.default_rng(1)
        img = np.tile(np.linspace(0, 1, 40), (30, 1))[..., None].repeat(3, -1)
        noisy = img + rng.normal(0, 0.2, img.shape)
        assert metrics.ssim(img, noisy) < 0.7


@pytest.mark.slow
class TestReference:
    def test_pure_absorber_matches_beer_lambert(self):
        """b = 0: a grey board lit by the sky through an absorbing medium.

        The board's radiance is rho E / pi, with E the irradiance of the
        uniform sky (radiance E0 / pi) on the vertical board through the
        absorber (each direction attenuated over its slant path d / mu),
        attenuated by exp(-c S) towards the camera.
        """
        mitsuba()
        from aquaspec.validation.reference import render_reference
        from aquaspec.validation.scenes import board_scene
        wl = np.array([300.0, 800.0])
        water = Water("absorber", "test", wl, a=np.full(2, 0.25), b=np.zeros(2), kd=np.full(2, 0.25))
        scene, cam = board_scene(1.0, width=24, height=18, fov_y_deg=12)
        scene.materials[:] = [type(scene.materials[-1]).constant(0.5)] * len(scene.materials)
        ref = render_reference(scene, cam, water, surface_light("overcast"), spp=256,
                               bands=Bands(3))
        c, d, s = 0.25, 1.0, 3.0
        e0 = 100 / 300
        # Irradiance on a vertical board from a uniform sky seen through the
        # absorber: int over the upper half of the board's hemisphere.
        mu = np.linspace(1e-6, 1, 4001)
        phi = np.linspace(-np.pi / 2, np.pi / 2, 801)
        M, P = np.meshgrid(mu, phi, indexing="ij")
        sin_t = np.sqrt(1 - M ** 2)
        cos_board = sin_t * np.cos(P)            # cosine to the board's normal
        L = e0 / np.pi * np.exp(-c * d / M)
        E = np.trapezoid(np.trapezoid(L * cos_board, phi, axis=1), mu)
        want = 0.5 * E / np.pi * np.exp(-c * s)
        centre = ref["band_radiance"][7:11, 10:14].mean(axis=(0, 1))
        np.testing.assert_allclose(centre, want, rtol=0.05)

    def test_preflight_catches_a_black_scene(self):
        """A scene no light reaches fails on the tiny test image, not after the study."""
        mitsuba()
        from aquaspec.light.sky import SurfaceLight
        from aquaspec.validation.reference import preflight
        from aquaspec.validation.scenes import board_scene
        scene, cam = board_scene(3.0, width=32, height=24)
        water = load_water("IB")
        ok = preflight(scene, cam, water, surface_light("overcast"))
        assert ok["band_radiance"].shape == (6, 8, 30) and ok["band_radiance"].max() > 0
        dark = SurfaceLight("dark", np.array([300.0, 900.0]), np.zeros(2), {})
        with pytest.raises(AquaspecError, match="test render is black"):
            preflight(scene, cam, water, dark)

    def test_irradiance_meter_in_a_pure_absorber(self):
        """b = 0 under a uniform sky of radiance E0 / pi and a non-refracting surface.

        Each direction at zenith cosine mu is attenuated over d / mu, so
        ``E_d(d) = 2 E0 int_0^1 mu exp(-a d / mu) dmu = 2 E0 E_3(a d)`` (E_3:
        exponential integral), a closed form the meters must reproduce.
        """
        mitsuba()
        from scipy.special import expn
        from aquaspec.validation.meters import measure_kd
        a = 0.2
        water = Water("absorber", "test", np.array([300.0, 800.0]), a=np.full(2, a),
                      b=np.zeros(2), kd=np.full(2, a))
        light = surface_light("overcast")
        b = Bands(3)
        res = measure_kd(water, light, depths_m=(1.0, 3.0, 6.0), spp=20000, bands=b)
        want = 2 * expn(3, a * res["depths_m"])[:, None] * light.on_bands(b)[None, :]
        np.testing.assert_allclose(res["e_d"], want, rtol=0.03)
        # The log-linear fit of a non-exponential profile: between the local
        # slopes of 2 E_3(a d) at 1 and 6 m.
        slope = expn(2, a * np.array([1.0, 6.0])) / expn(3, a * np.array([1.0, 6.0])) * a
        assert np.all((res["kd"] > slope[1] - 0.02) & (res["kd"] < slope[0] + 0.02))

    def test_open_water_matches_the_light_field(self):
        """Scattering water: the reference's open-water radiance against an independent
        solution of the same transfer problem (discrete ordinates, aquaspec.transport.lightfield.solve).

        Rays going down or level (the light field's weakest part is near the
        surface), summed over three 100 nm groups of bands to beat the noise.
        """
        mitsuba()
        from aquaspec.scene.raycast import raycast_gbuffer
        from aquaspec.validation.reference import render_reference
        from aquaspec.validation.scenes import board_scene, masks
        from aquaspec.validation.study import _spectral
        light = surface_light("overcast")
        for wname, depth in (("IB", 5.0), ("II", 3.0)):
            water = load_water(wname)
            scene, cam = board_scene(depth, width=32, height=24)
            gb = raycast_gbuffer(scene, cam)
            sel = masks(gb)["background"] & (cam.ray_directions()[..., 1] <= 0)
            ref = render_reference(scene, cam, water, light, spp=128)["band_radiance"][sel]
            lf = _spectral(gb, water, light, 30, "lightfield", "isotropic")[sel]
            r = ref.reshape(-1, 3, 10).sum(axis=2)
            want = lf.reshape(-1, 3, 10).sum(axis=2).mean(axis=0)
            got = r.mean(axis=0)
            stderr = r.std(axis=0) / np.sqrt(len(r))
            assert np.all(np.abs(got - want) < 4 * stderr + 0.05 * want), (wname, got, want)

    @pytest.mark.parametrize("wname, depth, phase", [("IB", 5.0, "ff"), ("II", 3.0, "petzold")])
    def test_open_water_matches_the_light_field_with_ocean_phase(self, wname, depth, phase):
        """As above with Fournier-Forand and Petzold: Mitsuba's tabphase and the light
        field's moments come from one table (a wrong table, sign or scale fails)."""
        mitsuba()
        from aquaspec.scene.raycast import raycast_gbuffer
        from aquaspec.validation.reference import lightfield_phase, render_reference
        from aquaspec.validation.scenes import board_scene, masks
        from aquaspec.validation.study import _spectral
        light = surface_light("overcast")
        water = load_water(wname)
        scene, cam = board_scene(depth, width=32, height=24)
        gb = raycast_gbuffer(scene, cam)
        sel = masks(gb)["background"] & (cam.ray_directions()[..., 1] <= 0)
        ref = render_reference(scene, cam, water, light, spp=256, phase=phase)
        method, params = lightfield_phase(phase)
        lf = _spectral(gb, water, light, 30, "lightfield", method, params)[sel]
        r = ref["band_radiance"][sel].reshape(-1, 3, 10).sum(axis=2)
        want = lf.reshape(-1, 3, 10).sum(axis=2).mean(axis=0)
        got = r.mean(axis=0)
        stderr = r.std(axis=0) / np.sqrt(len(r))
        assert np.all(np.abs(got - want) < 4 * stderr + 0.05 * want), (got, want)

    def test_kd_meters_use_the_phase_function(self):
        """Irradiance meters in grey water (a = 0.1, b = 0.4 1/m at every wavelength)
        against the light field's E_d with the same tabulated phase function.

        Forward-peaked scattering keeps 4.5x more light at 8 m than isotropic
        scattering, so meters in a medium with another phase function fail.
        """
        mitsuba()
        from aquaspec.transport.lightfield.solve import solve_lightfield
        from aquaspec.validation.meters import measure_kd
        from aquaspec.validation.reference import lightfield_phase
        water = Water("grey", "test", np.array([300.0, 800.0]), a=np.full(2, 0.1),
                      b=np.full(2, 0.4), kd=np.full(2, 0.15))
        light = surface_light("overcast")
        b = Bands(3)
        depths = np.array([1.0, 4.0, 8.0])
        iso = solve_lightfield([0.1], [0.4], phase="isotropic")
        e_iso = np.ravel(iso.irradiance(depths[:, None], np.ones((1, 1))))
        for phase in ("ff", "petzold"):
            res = measure_kd(water, light, depths_m=depths, spp=4000, bands=b, phase=phase)
            method, params = lightfield_phase(phase)
            lf = solve_lightfield([0.1], [0.4], phase=method, **dict(params))
            e_lf = np.ravel(lf.irradiance(depths[:, None], np.ones((1, 1))))
            assert e_iso[-1] < 0.5 * e_lf[-1]
            got = res["e_d"] / light.on_bands(b)[None, :]
            np.testing.assert_allclose(got, np.broadcast_to(e_lf[:, None], got.shape),
                                       rtol=0.04, err_msg=phase)

    def test_kd_independent_of_depth_range(self):
        mitsuba()
        from aquaspec.validation.meters import measure_kd
        water = load_water("IB")
        light = surface_light("overcast")
        b = Bands(3)
        shallow = measure_kd(water, light, depths_m=(2.0, 4.0, 6.0), spp=40000, bands=b)
        deep = measure_kd(water, light, depths_m=(6.0, 9.0, 12.0), spp=40000, bands=b, seed=7)
        tol = 4 * np.hypot(shallow["kd_stderr"], deep["kd_stderr"]) + 0.1 * deep["kd"]
        assert np.all(np.abs(shallow["kd"] - deep["kd"]) < tol), (shallow["kd"], deep["kd"])


@pytest.mark.slow
def test_small_study(tmp_path, camspec_path, capsys):
    mitsuba()
    code = main(["validate", "--waters", "IB,3C", "--depths", "3,9", "--camspec",
                 str(camspec_path), "--sensors", "Canon 5DMarkII,Nikon D90,SONY NEX-5N",
                 "--size", "48x36", "--spp", "32", "--kd-spp", "4000", "--no-cache",
                 "--gpu-timing", "-o", str(tmp_path)])
    assert code == 0
    out = capsys.readouterr().out
    assert "time per image at equal pixel count" in out
    assert "mean over scenes whose reference converged" in out
    assert "diffuse attenuation (1/m)" in out
    import json
    doc = json.loads((tmp_path / "validation.json").read_text())
    rows = doc["rows"]
    # At 32 spp and 48x36 the references are noisy: every scene reports its
    # standard error, and the 3C 9 m one (the darkest) is flagged.
    # The light-field model's Kd beside the database's and the path tracer's:
    # isotropic scattering in the reference and the model, so the model's Kd
    # over the meters' depths must agree with the measured one (the meters'
    # noise at 4000 samples aside), and the database's (made for real,
    # forward-peaked water) must not.
    for wname, att in doc["waters"].items():
        lf, meas, db = (np.array(att[k]) for k in ("kd_lightfield", "kd_measured",
                                                   "kd_database"))
        assert lf.shape == meas.shape == db.shape == (30,)
        assert np.median(np.abs(lf / meas - 1)) < 0.1, wname
        assert np.median(np.abs(lf / db - 1)) > 0.2, wname
    for sc in doc["scenes"]:
        assert set(sc["reference_stderr"]) == {"grey", "background"}
        assert sc["converged"] == (max(sc["reference_stderr"].values()) <= 0.05)
    assert not next(sc for sc in doc["scenes"]
                    if (sc["water"], sc["depth_m"]) == ("3C", 9.0))["converged"]
    assert {r["region"] for r in rows} == {"image", "patches", "grey", "background",
                                           "background_down", "patch_means"}
    for sc in doc["scenes"]:
        assert sc["reference_seconds"] > 0 and sc["numpy_shading_seconds"]["seeds-n16"] > 0
        assert sc["gpu_frame_seconds"] is None or sc["gpu_frame_seconds"] > 0
        # Kd measured in the path-traced water: positive in every band.
        assert len(sc["kd_measured"]) == 30 and min(sc["kd_measured"]) > 0
    assert {r["camera"] for r in rows} == {"Canon 5DMarkII", "Nikon D90", "SONY NEX-5N"}
    assert {(r["water"], r["depth_m"]) for r in rows} == {("IB", 3.0), ("IB", 9.0),
                                                          ("3C", 3.0), ("3C", 9.0)}
    assert {"seeds-n8", "seeds-n16", "rgb-seeds-n3", "unreal", "ifm"} <= {r["method"]
                                                                         for r in rows}
    assert all(np.isfinite(r["hsv"]) for r in rows)
    assert {(r["method"], r["kd"]) for r in rows if r["method"] in ("ifm", "unreal")} == {
        ("ifm", "database"), ("ifm", "measured"), ("unreal", "database")}
    for name in ("validation.csv", "error_per_scene.png", "error_per_scene_measured_kd.png",
                 "panels.png"):
        assert (tmp_path / name).stat().st_size > 0
    # The CSV holds the JSON's rows: one column per key (SSIM once, empty
    # where a region has none), the same values.
    import csv
    with open(tmp_path / "validation.csv", newline="") as f:
        header = next(csv.reader(f))
        f.seek(0)
        table = list(csv.DictReader(f))
    assert len(header) == len(set(header)) and "ssim" in header
    assert len(table) == len(rows)
    for got, want in zip(table, rows):
        assert got["method"] == want["method"] and got["region"] == want["region"]
        assert float(got["rmse_rel"]) == pytest.approx(want["rmse_rel"], rel=1e-12)
        assert (got["ssim"] == "") == ("ssim" not in want)


@pytest.mark.slow
def test_reference_cache(tmp_path):
    """A second identical study takes the reference and Kd from the cache; another spp does not."""
    mitsuba()
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.validation.study import run_study
    kw = dict(waters=("IB",), depths=(4.0,), sensors={"human": get_sensor("human")},
              size=(24, 18), kd_spp=2000, band_counts=(8,), cache_dir=tmp_path)
    logs = [[], [], []]
    first = run_study(spp=8, progress=logs[0].append, **kw)
    second = run_study(spp=8, progress=logs[1].append, **kw)
    run_study(spp=16, progress=logs[2].append, **kw)
    assert not any("cache" in m for m in logs[0])
    assert any("reference from cache" in m for m in logs[1])
    assert any("Kd measured in the reference (cache)" in m for m in logs[1])
    assert not any("reference from cache" in m for m in logs[2])
    a = first["images"][("board", "IB", 4.0, "reference", "-")]
    np.testing.assert_array_equal(a, second["images"][("board", "IB", 4.0, "reference", "-")])
    assert len(list(tmp_path.glob("*.npz"))) == 3     # Kd, render at 8 spp, render at 16 spp


@pytest.mark.slow
def test_small_study_with_fournier_forand(tmp_path):
    """--phase ff end to end: the light-field rows exist and the study records the table."""
    mitsuba()
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.validation.study import run_study
    res = run_study(waters=("IB",), depths=(4.0,), sensors={"human": get_sensor("human")},
                    size=(24, 18), spp=8, kd_spp=2000, band_counts=(8,), phase="ff",
                    backscatter=0.03, ms_models=("lightfield",), cache_dir=tmp_path,
                    cone_spread=False)
    pf = res["params"]["phase_function"]
    assert pf["name"] == "tabulated" and pf["of"]["name"] == "ff"
    assert pf["backscatter_fraction"] == pytest.approx(0.03, rel=1e-4)
    assert res["params"]["backscatter"] == 0.03
    rows = [r for r in res["rows"] if r["method"] == "lightfield-n8"]
    assert rows and all(np.isfinite(r["rmse_rel"]) for r in rows)
    assert res["params"]["cone_spread"] is False
    # The cone spread over the image: same (cached) reference, other numbers.
    spread = run_study(waters=("IB",), depths=(4.0,), sensors={"human": get_sensor("human")},
                       size=(24, 18), spp=8, kd_spp=2000, band_counts=(8,), phase="ff",
                       backscatter=0.03, ms_models=("lightfield",), cache_dir=tmp_path,
                       forward_cone_deg=30.0)
    # (cone_spread not given: on, as the light field's default.)
    assert spread["params"]["cone_spread"] is True
    srows = [r for r in spread["rows"] if r["method"] == "lightfield-n8"]
    assert len(srows) == len(rows) and all(np.isfinite(r["rmse_rel"]) for r in srows)
    assert any(a["mean_ratio"] != b["mean_ratio"] for a, b in zip(rows, srows))
    # With the multiple spread and the scene's shadow (aquaspec.transport.lightfield.shadow): recorded, other numbers.
    shade = run_study(waters=("IB",), depths=(4.0,), sensors={"human": get_sensor("human")},
                      size=(24, 18), spp=8, kd_spp=2000, band_counts=(8,), phase="ff",
                      backscatter=0.03, ms_models=("lightfield",), cache_dir=tmp_path,
                      forward_cone_deg=30.0, spread_scattering="multiple", ambient_shadow=True)
    assert shade["params"]["ambient_shadow"] is True
    hrows = [r for r in shade["rows"] if r["method"] == "lightfield-n8"]
    assert len(hrows) == len(rows) and all(np.isfinite(r["rmse_rel"]) for r in hrows)
    assert any(a["mean_ratio"] != b["mean_ratio"] for a, b in zip(srows, hrows))
    with pytest.raises(AquaspecError, match="ambient_shadow is part of the light-field model"):
        run_study(waters=("IB",), depths=(4.0,), sensors={"human": get_sensor("human")},
                  ms_models=("seeds",), ambient_shadow=True, cache_dir=tmp_path)
    with pytest.raises(AquaspecError, match="cone_spread is part of the light-field model"):
        run_study(waters=("IB",), depths=(4.0,), sensors={"human": get_sensor("human")},
                  ms_models=("seeds",), cone_spread=True, cache_dir=tmp_path)


def panel_strips(path, columns):
    """Share of non-white pixels in each of ``columns`` vertical strips of a PNG."""
    import matplotlib.image
    img = matplotlib.image.imread(path)[..., :3]
    ink = (img < 0.9).any(axis=-1)
    return [float(strip.mean()) for strip in np.array_split(ink, columns, axis=1)]


#: A panel showing an image is mostly ink; a blank one holds only its title.
PANEL_INK = 0.25


class TestPanels:
    """panels.png shows the models that were run, titled with what was run."""

    def images(self, methods, scenes=(("board", "I", 3.0), ("ledge", "IB", 5.0))):
        rng = np.random.default_rng(0)
        out = {}
        for name, w, d in scenes:
            out[(name, w, d, "reference", "-")] = rng.random((6, 8, 3))
            for m in methods:
                out[(name, w, d, m, "database")] = rng.random((6, 8, 3))
        return out

    def test_the_default_models(self):
        from aquaspec.validation.report import panel_columns
        images = self.images(["seeds-n8", "seeds-n16", "rgb-seeds-n3", "lightfield-n8",
                              "lightfield-n16", "rgb-lightfield-n3", "unreal", "ifm"])
        cols = panel_columns(images, {"ms_models": ["seeds", "lightfield"],
                                      "band_counts": [8, 16]})
        # The renderer's default model is the one compared in RGB and in
        # the difference; the thesis's is titled with its canonical name.
        assert [c.title for c in cols] == [
            "reference", "seeds-n16 (monzon2022)", "lightfield-n16", "rgb-lightfield-n3",
            "|lightfield-n16 - ref| x4"]
        assert cols[-1].difference and cols[-1].method == "lightfield-n16"

    @pytest.mark.parametrize("models, methods, titles", [
        (["lightfield"], ["lightfield-n8", "rgb-lightfield-n3"],
         ["reference", "lightfield-n8", "rgb-lightfield-n3", "|lightfield-n8 - ref| x4"]),
        (["lightfield"], ["lightfield-n8", "lightfield-deep-n8", "rgb-lightfield-n3"],
         ["reference", "lightfield-n8", "lightfield-deep-n8 (no seabed)", "rgb-lightfield-n3",
          "|lightfield-n8 - ref| x4"]),
        (["monzon2022"], ["monzon2022-n8", "rgb-monzon2022-n3"],
         ["reference", "monzon2022-n8", "rgb-monzon2022-n3", "|monzon2022-n8 - ref| x4"]),
    ])
    def test_every_panel_shows_an_image(self, models, methods, titles, tmp_path):
        """(Before: the seeds' model only, blank panels when it was not run.)"""
        from aquaspec.validation.report import panel_columns, plot_panels
        images = self.images(methods)
        params = {"ms_models": models, "band_counts": [8]}
        assert [c.title for c in panel_columns(images, params)] == titles
        plot_panels(images, tmp_path / "panels.png", params)
        ink = panel_strips(tmp_path / "panels.png", len(titles))
        assert min(ink) > PANEL_INK, ink


def test_study_with_a_seabed(tmp_path, capsys, monkeypatch):
    """--seabed-below: a grey seabed in the reference and in the light field,
    which also runs without it (lightfield-deep-n*); the reference is another
    render (its geometry is in the cache key). The panels show the light
    field with and without the seabed, every one an image."""
    mitsuba()
    import aquaspec.validation.report as report
    from aquaspec.validation.scenes import board_scene
    shown = []
    columns = report.panel_columns
    monkeypatch.setattr(report, "panel_columns",
                        lambda *a: shown.append(columns(*a)) or shown[-1])
    code = main(["validate", "--waters", "I", "--depths", "4", "--size", "24x18", "--spp", "8",
                 "--kd-spp", "2000", "--ms-models", "lightfield", "--no-cone-spread",
                 "--seabed-below", "1.5,0.3", "--cache", str(tmp_path / "cache"),
                 "-o", str(tmp_path / "out")])
    assert code == 0
    import json
    doc = json.loads((tmp_path / "out" / "validation.json").read_text())
    assert doc["params"]["seabed"] == {"below_camera_m": 1.5, "albedo": 0.3}
    methods = {r["method"] for r in doc["rows"]}
    assert {"lightfield-n8", "lightfield-deep-n8", "lightfield-n16"} <= methods
    ratio = {r["method"]: r["mean_ratio"] for r in doc["rows"]
             if r["region"] == "image" and r["camera"] == "human"}
    # The seabed's light makes the light field brighter than over deep water.
    assert ratio["lightfield-n16"] > ratio["lightfield-deep-n16"]
    (cols,) = shown
    assert [c.title for c in cols] == ["reference", "lightfield-n16",
                                       "lightfield-deep-n16 (no seabed)", "rgb-lightfield-n3",
                                       "|lightfield-n16 - ref| x4"]
    assert min(panel_strips(tmp_path / "out" / "panels.png", len(cols))) > PANEL_INK
    scene, _ = board_scene(4.0, seabed_below_m=1.5, seabed_albedo=0.3)
    assert scene.seabed.depth_m == 5.5 and scene.meshes[-1].name == "seabed"
    assert main(["validate", "--seabed-below", "0", "--no-cache"]) == 2
    assert "--seabed-below '0'; accepted: M[,ALBEDO]" in capsys.readouterr().err


def test_reference_medium_follows_the_models_a_and_b():
    """The medium handed to Mitsuba: c and b / c on a 1-nm grid, so that
    Mitsuba's linear interpolation between grid points follows the
    piecewise-linear a and b that aquaspec's band means integrate. Given at
    the data's 25 nm spacing (as before), b / c between two points was off by
    several per cent where a rises steeply (Jerlov IB, 575-600 nm)."""
    from aquaspec.validation.reference import medium_spectra, water_medium

    def parse(spec):
        return (np.array([float(x) for x in spec["wavelengths"].split(",")]),
                np.array([float(x) for x in spec["values"].split(",")]))
    water = load_water("IB")
    med = water_medium(water, "isotropic", 0.0)
    wl_c, c = parse(med["sigma_t"])
    wl_s, albedo = parse(med["albedo"])
    assert np.all(np.diff(wl_c) <= 1.0 + 1e-9) and set(water.wavelength_nm) <= set(wl_c)
    x = np.linspace(576.0, 599.0, 47)              # between the data's 575 and 600 nm
    a = np.interp(x, water.wavelength_nm, water.a)
    b = np.interp(x, water.wavelength_nm, water.b)
    np.testing.assert_allclose(np.interp(x, wl_c, c), a + b, rtol=1e-6)
    np.testing.assert_allclose(np.interp(x, wl_s, albedo), b / (a + b), rtol=2e-3)
    # What the data's own spacing would have given: b several per cent off.
    wl = water.wavelength_nm
    coarse = np.interp(x, wl, water.b / (water.a + water.b)) * (a + b)
    assert np.abs(coarse / b - 1).max() > 0.05
    assert medium_spectra(water)[0][0] == wl[0] and medium_spectra(water)[0][-1] == wl[-1]


def test_cache_keys_hold_the_phase_function():
    from aquaspec.validation.reference import phase_key
    # Isotropic and HG keys are what they were (existing caches stay valid).
    assert phase_key("isotropic") == {"phase": "isotropic", "g": 0.0}
    assert phase_key("hg", g=0.92) == {"phase": "hg", "g": 0.92}
    ff = phase_key("ff", backscatter=0.0183)
    assert ff["backscatter"] == 0.0183 and ff["table_nodes"] > 10_000
    keys = [ff, phase_key("ff", backscatter=0.02), phase_key("petzold"), phase_key("hg", g=0.9)]
    assert len({tuple(sorted(k.items())) for k in keys}) == len(keys)
    assert phase_key("ff", g=0.5) == ff           # g does not belong to FF


def test_reference_and_light_field_share_the_table():
    """The values Mitsuba's tabphase is given are the light field's table (9 digits)."""
    from aquaspec.validation.reference import (lightfield_phase, phase_function,
                                               reference_phase)
    for phase, kw in (("ff", {"backscatter": 0.01}), ("petzold", {})):
        d = reference_phase(phase, **kw)
        assert d["type"] == "tabphase"
        values = np.array([float(v) for v in d["values"].split(",")])
        tab = phase_function(phase, **kw)
        np.testing.assert_allclose(values, tab.values, rtol=1e-8)
        method, params = lightfield_phase(phase, **kw)
        assert method == "tabulated" and dict(params)["of"] == phase
    assert reference_phase("hg", g=0.8) == {"type": "hg", "g": 0.8}
    assert lightfield_phase("hg", g=0.8) == ("hg", (("g", 0.8),))
    with pytest.raises(AquaspecError, match="'rayleigh'; accepted: isotropic, hg, ff, petzold"):
        reference_phase("rayleigh")


class TestBadInput:
    @pytest.mark.parametrize("argv, match", [
        (["--phase", "ff", "--backscatter", "0.9"], "B=0.9 is not accepted"),
        (["--phase", "ff", "--backscatter", "nan"], "--backscatter: 'nan' is not accepted"),
        (["--phase", "ff", "--backscatter", "-0.01"], "B=-0.01 is not accepted"),
        (["--phase", "petzold", "--backscatter", "0.02"], "--backscatter .* needs --phase ff"),
        (["--phase", "hg", "--g", "1.5"], "g=1.5 is not accepted"),
        (["--g", "0.5"], "--g .* needs --phase hg, not --phase isotropic"),
    ])
    def test_bad_phase_parameters(self, argv, match, capsys, tmp_path, monkeypatch):
        # Refused before Mitsuba is even imported, and before anything is rendered.
        import aquaspec.validation.study as study
        monkeypatch.setattr(study, "run_study", lambda **kw: pytest.fail("study ran"))
        try:
            code = main(["validate", *argv, "-o", str(tmp_path)])
        except SystemExit as exc:       # argparse's own refusals (not finite)
            code = exc.code
        assert code == 2
        err = capsys.readouterr().err
        assert "error:" in err
        import re
        assert re.search(match, err), err

    @pytest.mark.parametrize("tyler", [False, True])
    def test_unusable_output_directory_before_any_work(self, tyler, capsys, tmp_path,
                                                       monkeypatch):
        import aquaspec.validation.study as study
        import aquaspec.validation.tyler as tyler_mod
        monkeypatch.setattr(study, "run_study", lambda **kw: pytest.fail("study ran"))
        monkeypatch.setattr(tyler_mod, "tyler_check", lambda: pytest.fail("check ran"))
        blocker = tmp_path / "a_file"
        blocker.write_text("")
        argv = ["validate", "-o", str(blocker / "out")] + (["--tyler"] if tyler else [])
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "cannot create the output directory" in err and "a_file" in err

    def test_unknown_phase(self, capsys, tmp_path):
        with pytest.raises(SystemExit) as exc:
            main(["validate", "--phase", "rayleigh", "-o", str(tmp_path)])
        assert exc.value.code == 2
        assert "invalid choice: 'rayleigh'" in capsys.readouterr().err


    def test_unknown_camera(self, camspec_path, capsys, tmp_path):
        mitsuba()
        assert main(["validate", "--camspec", str(camspec_path), "--sensors", "Leica M9",
                     "-o", str(tmp_path)]) == 2
        assert "unknown sensor 'Leica M9'" in capsys.readouterr().err

    def test_camspec_wrong_format(self, tmp_path, capsys):
        mitsuba()
        bad = tmp_path / "cams.txt"
        bad.write_text("not a camera database\n")
        assert main(["validate", "--camspec", str(bad), "-o", str(tmp_path)]) == 2
        assert "no cameras found" in capsys.readouterr().err

    def test_mitsuba_missing(self, monkeypatch, capsys, tmp_path):
        import builtins
        real_import = builtins.__import__

        def fake(name, *args, **kwargs):
            if name == "mitsuba" or name.startswith("mitsuba."):
                raise ImportError("No module named 'mitsuba'")
            return real_import(name, *args, **kwargs)
        monkeypatch.setattr(builtins, "__import__", fake)
        assert main(["validate", "-o", str(tmp_path)]) == 2
        assert "pip install 'aquaspec[validation]'" in capsys.readouterr().err


def test_reference_stderr_of_known_noise():
    """Standard error of a region mean: sigma / sqrt(N) / mean per third of the spectrum."""
    from aquaspec.validation.study import reference_stderr
    rng = np.random.default_rng(0)
    n = 40000
    img = np.empty((200, 200, 30))
    img[..., :10] = 2.0 + 0.4 * rng.standard_normal((200, 200, 10)) / np.sqrt(10)
    img[..., 10:20] = 1.0
    img[..., 20:] = 1.0 + 0.1 * rng.standard_normal((200, 200, 10)) / np.sqrt(10)
    mask = np.ones((200, 200), bool)
    # Blue third: the sum of its 10 bands has mean 20 and sigma 0.4 (relative
    # error of the mean 0.02 / sqrt(N)); red: mean 10, sigma 0.1 (0.01 /
    # sqrt(N)); green: no noise. The largest is reported.
    got = reference_stderr(img, mask)
    assert got == pytest.approx(0.4 / np.sqrt(n) / 20.0, rel=0.05)
    img[..., 20:] = 0.0
    assert reference_stderr(img, mask) == float("inf")       # no light in the red third
    assert reference_stderr(img, np.zeros((200, 200), bool)) == float("inf")


def test_converged_means_leave_out_noisy_scenes():
    from aquaspec.validation.report import converged_means, format_converged
    rows = [{"water": w, "depth_m": d, "camera": "c", "method": "m", "kd": "database",
             "region": "grey", "rmse_rel": e, "hsv": 0.0, "hue_deg": 1.0, "ciede2000": 0.0,
             "mean_ratio": 1.0 + e} for w, d, e in (("I", 3.0, 0.1), ("7C", 12.0, 50.0))]
    scenes = [{"water": "I", "depth_m": 3.0, "converged": True},
              {"water": "7C", "depth_m": 12.0, "converged": False}]
    (r,) = converged_means(rows, scenes, region="grey")
    assert r["scenes"] == 1 and r["rmse_rel"] == pytest.approx(0.1)
    assert "left out: 7C 12 m" in format_converged(rows, scenes, regions=("grey",))


def test_board_views():
    """view="down": the board lies flat (facing up) 3 m along a view pitched
    45 degrees down, and every patch is seen; the level view is the thesis's
    board facing the camera (the cached references' geometry)."""
    from aquaspec.scene.raycast import raycast_gbuffer
    from aquaspec.validation.scenes import (BOARD_DISTANCE_M, DOWN_PITCH_DEG, GREY_PATCH,
                                            PATCH_PITCH_M, board_scene, masks)
    scene, cam = board_scene(5.0, view="down")
    s = np.sin(np.radians(DOWN_PITCH_DEG))
    np.testing.assert_allclose(cam.forward, [0.0, -s, -np.cos(np.radians(DOWN_PITCH_DEG))])
    for mesh in scene.meshes:
        np.testing.assert_allclose(mesh.normals, np.tile([0.0, 1.0, 0.0], (4, 1)))
        assert np.all(np.abs(-mesh.vertices[:, 1] - (5.0 + BOARD_DISTANCE_M * s)) < 0.003)
    gb = raycast_gbuffer(scene, cam)
    m = masks(gb)
    assert all(p.sum() >= 4 for p in m["patches"]), [int(p.sum()) for p in m["patches"]]
    assert m["grey"].sum() >= 6
    # Around the board the camera sees the open water below it.
    assert m["background"].any()
    assert np.all(cam.ray_directions()[..., 1][m["background"]] < 0)
    # The first row of the chart is the far one, as the level board's is the top one.
    rows = [np.nonzero(m["patches"][k].any(axis=1))[0].mean() for k in (0, 18)]
    assert rows[0] < rows[1]
    level, lcam = board_scene(5.0)
    np.testing.assert_array_equal(lcam.forward, [0.0, 0.0, -1.0])
    v = level.meshes[GREY_PATCH].vertices
    row, col = divmod(GREY_PATCH, 6)
    np.testing.assert_allclose(v.mean(axis=0), [(col - 2.5) * PATCH_PITCH_M,
                                                -5.0 + (1.5 - row) * PATCH_PITCH_M, -2.998])
    with pytest.raises(AquaspecError, match="view='up'; accepted: level, down"):
        board_scene(5.0, view="up")
    # A seabed must lie under the board, which is 2.1 m below a camera looking down.
    with pytest.raises(AquaspecError, match="seabed_below_m=1.5; accepted: a distance > 2.1"):
        board_scene(5.0, view="down", seabed_below_m=1.5)
    assert board_scene(5.0, view="down", seabed_below_m=3.0)[0].seabed.depth_m == 8.0


def test_study_looking_down(tmp_path):
    """--view down end to end: the study records the view and its reference is
    another render than the level view's."""
    mitsuba()
    out = tmp_path / "out"
    base = ["validate", "--waters", "IB", "--depths", "4", "--size", "24x18", "--spp", "8",
            "--kd-spp", "2000", "--ms-models", "lightfield", "--no-cone-spread",
            "--sensors", "human", "--cache", str(tmp_path / "cache")]
    assert main([*base, "--view", "down", "-o", str(out)]) == 0
    import json
    doc = json.loads((out / "validation.json").read_text())
    assert doc["params"]["view"] == "down"
    rows = [r for r in doc["rows"] if r["region"] == "image" and r["method"] == "lightfield-n8"]
    assert rows and all(np.isfinite(r["mean_ratio"]) for r in rows)
    assert len(list((tmp_path / "cache").glob("*.npz"))) == 2       # Kd and the render
    assert main([*base, "-o", str(tmp_path / "level")]) == 0
    assert len(list((tmp_path / "cache").glob("*.npz"))) == 3
