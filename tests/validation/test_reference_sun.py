"""The path-traced reference with a refracted directional sun (sun-sky light).

What is checked against closed forms, in Mitsuba's own water:

- the scene: a ``directional`` emitter with the refracted direction of
  travel and ``beam_normal`` as irradiance, and the rest of E0 as the sky;
- horizontal Lambertian plates in nearly clear water: radiance
  ``rho / pi (E_sky(d) + mu0 E_b(d))`` with the sky through the absorber
  ``2 E_3(c d) E_sky`` and the beam ``beam_normal exp(-c d / mu0)``
  (wrong units, direction or path length of the beam fail);
- the Kd meters (which never see a delta emitter unscattered) plus the
  closed-form beam against the plates;
- the sun's single scattering alone (the sun as the only light, volpathmis
  ``max_depth = 2``) against :func:`aquaspec.transport.sun_scattering.single_scattering_open`,
  looking towards, across and away from the sun, isotropic and HG;
- the study and the CLI hand the light with its sun to both sides, and the
  cache keys hold the sun.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.special import expn

from aquaspec.colour.bands import Bands
from aquaspec.cli import main
from aquaspec.light.sky import SurfaceLight, surface_light
from aquaspec.medium.water import Water, load_water


def mitsuba():
    pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (extra 'validation')")
    from aquaspec.validation.reference import require_mitsuba
    return require_mitsuba()


def sun_sky(elevation=40.0, azimuth=30.0):
    return surface_light("sun-sky", sun_elevation_deg=elevation, sun_azimuth_deg=azimuth)


def _numbers(text):
    return np.array([float(x) for x in text.split(",")])


def test_scene_has_a_directional_sun_and_the_rest_as_sky():
    mitsuba()
    from aquaspec.validation.reference import base_scene, sky_irradiance
    light = sun_sky()
    sun = light.sun
    water = load_water("IB")
    d = base_scene(water, light, "isotropic", 0.0)
    em = d["sun"]
    assert em["type"] == "directional"
    # Mitsuba's "direction" is the way the light travels: down, refracted.
    np.testing.assert_allclose(em["direction"], sun.direction, atol=1e-12)
    assert em["direction"][1] == pytest.approx(-sun.mu0) and sun.mu0 > 0.66
    np.testing.assert_allclose(_numbers(em["irradiance"]["wavelengths"]), sun.wavelength_nm,
                               rtol=1e-6)
    np.testing.assert_allclose(_numbers(em["irradiance"]["values"]), sun.beam_normal,
                               rtol=1e-8)
    # Sky radiance: (E0 - mu0 beam) / pi on the light's grid; sky + sun = E0.
    sky = _numbers(d["sky"]["radiance"]["values"])
    np.testing.assert_allclose(sky * np.pi + sun.mu0 * sun.beam_normal, light.values, rtol=1e-7)
    np.testing.assert_allclose(sky * np.pi, sky_irradiance(light), rtol=1e-8)
    assert np.all(sky >= 0) and sky.sum() * np.pi < 0.5 * light.values.sum()
    # The same split as the light's own per band.
    b = Bands(6)
    np.testing.assert_allclose(b.average(light.wavelength_nm, sky_irradiance(light)),
                               light.sky_on(b), rtol=1e-9)
    # No sun: no emitter and the whole E0 as sky (as before).
    over = surface_light("overcast")
    d0 = base_scene(water, over, "isotropic", 0.0)
    assert "sun" not in d0
    np.testing.assert_allclose(_numbers(d0["sky"]["radiance"]["values"]) * np.pi, over.values)


def test_cache_keys_hold_the_sun():
    from aquaspec.validation.reference import cache_key, light_key
    assert light_key(surface_light("overcast")) == {}
    keys = {cache_key(kind="render", **light_key(sun_sky(e, az)))
            for e, az in ((40, 30), (41, 30), (40, 31), (40, 30))}
    assert len(keys) == 3
    assert cache_key(kind="render") not in keys


class _Recorder:
    def __init__(self):
        self.lights, self.keys = [], []


def _fake_study(monkeypatch):
    """run_study with the path tracer and the shading replaced by recorders."""
    import aquaspec.validation.study as study
    rec = _Recorder()
    real_key = study.cache_key

    def key(**params):
        rec.keys.append(params)
        return real_key(**params)

    def kd(water, light, **kw):
        rec.lights.append(("kd", light))
        n = 30
        return {"kd": np.full(n, 0.1), "kd_stderr": np.zeros(n), "e_d": np.ones((6, n))}

    def ref(scene, cam, water, light, **kw):
        rec.lights.append(("reference", light))
        return {"band_radiance": np.full((cam.height, cam.width, 30), 0.01), "seconds": 0.0}

    def spectral(gb, water, light, n, *args, **kw):
        rec.lights.append(("spectral", light))
        return np.full(gb.distance.shape + (n,), 0.01)

    monkeypatch.setattr(study, "cache_key", key)
    monkeypatch.setattr(study, "preflight", lambda *a, **kw: rec.lights.append(("preflight",
                                                                              a[3])))
    monkeypatch.setattr(study, "measure_kd", kd)
    monkeypatch.setattr(study, "render_reference", ref)
    monkeypatch.setattr(study, "_spectral", spectral)
    return study, rec


def test_study_hands_the_sun_to_both_sides(monkeypatch):
    study, rec = _fake_study(monkeypatch)
    from aquaspec.colour.sensors import get_sensor
    res = study.run_study(waters=("IB",), depths=(3.0,), sensors={"human": get_sensor("human")},
                          size=(16, 12), band_counts=(8,), kd_modes=("database",),
                          light="sun-sky", sun_elevation_deg=35.0, sun_azimuth_deg=200.0)
    kinds = {k for k, _ in rec.lights}
    assert kinds == {"preflight", "kd", "reference", "spectral"}
    for _, light in rec.lights:
        assert light.name == "sun-sky" and light.sun is not None
        assert light.sun.elevation_deg == 35.0 and light.sun.azimuth_deg == 200.0
    assert res["params"]["light"]["sun"]["elevation_deg"] == 35.0
    sun_keys = [k["sun"] for k in rec.keys if k.get("kind") in ("kd", "render")]
    assert len(sun_keys) == 2 and all(s["elevation_deg"] == 35.0 for s in sun_keys)

    # Overcast (the default): no sun anywhere and no "sun" in the keys.
    study, rec = _fake_study(monkeypatch)
    study.run_study(waters=("IB",), depths=(3.0,), sensors={"human": get_sensor("human")},
                    size=(16, 12), band_counts=(8,), kd_modes=("database",))
    assert all(light.sun is None and light.name == "overcast" for _, light in rec.lights)
    assert not any("sun" in k for k in rec.keys)


def test_cli_passes_the_sun(monkeypatch, tmp_path):
    import aquaspec.validation.reference as reference
    import aquaspec.validation.study as study
    from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG
    seen = {}

    class Stop(Exception):
        pass

    def fake(**kw):
        seen.update(kw)
        raise Stop
    monkeypatch.setattr(reference, "require_mitsuba", lambda: None)
    monkeypatch.setattr(study, "run_study", fake)
    with pytest.raises(Stop):
        main(["validate", "--light", "sun-sky", "--sun-elevation", "35", "-o", str(tmp_path)])
    assert (seen["light"], seen["sun_elevation_deg"], seen["sun_azimuth_deg"]) == \
        ("sun-sky", 35.0, DEFAULT_SUN_AZIMUTH_DEG)
    seen.clear()
    with pytest.raises(Stop):
        main(["validate", "-o", str(tmp_path)])
    assert seen["light"] == "overcast"


@pytest.mark.parametrize("argv, match", [
    (["--sun-elevation", "30"], "--sun-elevation places the sun: it needs --light sun-sky"),
    (["--sun-azimuth", "30"], "--sun-azimuth places the sun: it needs --light sun-sky"),
    (["--light", "sun-sky", "--sun-elevation", "0"], "sun elevation 0.0 deg; accepted: 1 to 90"),
    # (Refused by the parser: a number that is not finite is no angle.)
    (["--light", "sun-sky", "--sun-azimuth", "nan"], "--sun-azimuth: 'nan' is not accepted"),
])
def test_cli_bad_sun(argv, match, monkeypatch, capsys, tmp_path):
    import aquaspec.validation.study as study
    monkeypatch.setattr(study, "run_study", lambda **kw: pytest.fail("study ran"))
    try:
        code = main(["validate", *argv, "-o", str(tmp_path)])
    except SystemExit as exc:       # argparse's own refusals
        code = exc.code
    assert code == 2
    assert match in capsys.readouterr().err


# ---- the emitter measured in Mitsuba's water ---------------------------------

#: Nearly clear water: absorption linear from 0.05 (300 nm) to 0.5 1/m
#: (900 nm), b = 1e-4 1/m (the beam and the sky are attenuated, hardly scattered).
CLEAR = Water("clear", "test", np.array([300.0, 900.0]), a=np.array([0.05, 0.5]),
              b=np.full(2, 1e-4), kd=np.array([0.05, 0.5]))
FINE = np.arange(400.0, 700.001, 0.05)


def _closed_forms(water, light, depths, bands):
    """(sky, direct) downwelling irradiance per band (n_depths, n) in a
    non-scattering water of the reference's c, and the plates' factor
    exp(-c 0.01 m) per band."""
    from aquaspec.validation.reference import medium_spectra, sky_irradiance
    wl, c, _ = medium_spectra(water)
    cf = np.interp(FINE, wl, c)
    sky = np.interp(FINE, light.wavelength_nm, sky_irradiance(light))
    beam = np.interp(FINE, light.sun.wavelength_nm, light.sun.beam_normal)
    d = np.asarray(depths)[:, None]
    mu0 = light.sun.mu0
    e_sky = 2 * expn(3, cf * d) * sky
    e_dir = mu0 * beam * np.exp(-cf * d / mu0)
    up = np.exp(-cf * 0.01)
    return (bands.average(FINE, e_sky * up), bands.average(FINE, e_dir * up),
            bands.average(FINE, e_sky), bands.average(FINE, e_dir), cf, sky, beam)


def test_plates_see_the_sky_and_the_refracted_sun():
    """A horizontal Lambertian plate (rho = 0.5) in nearly clear water has radiance
    ``rho / pi (E_sky(d) + mu0 E_b(d))``: checks the directional emitter's
    irradiance (normal to the beam), its direction (down, refracted) and the
    beam's path ``d / mu0``; the alternatives are outside the tolerance."""
    mitsuba()
    from aquaspec.validation.meters import measure_plate
    light = sun_sky()
    b = Bands(3)
    depths = np.array([1.0, 4.0])
    rho = 0.5
    got = measure_plate(CLEAR, light, depths_m=depths, albedo=rho, spp=80000, bands=b)
    sky_up, dir_up, *_, cf, sky, beam = _closed_forms(CLEAR, light, depths, b)
    want = rho / np.pi * (sky_up + dir_up)
    np.testing.assert_allclose(got, want, rtol=0.03)
    # What a wrong emitter would give (each fails the same tolerance):
    mu0 = light.sun.mu0
    d = depths[:, None]
    up = np.exp(-cf * 0.01)
    wrong = {
        "irradiance taken as horizontal": sky_up + mu0 * dir_up,
        "beam path d instead of d / mu0": sky_up + b.average(
            FINE, mu0 * beam * np.exp(-cf * d) * up),
        "sun pointing up (no sun on the plate)": sky_up,
        "whole E0 as sky and no sun": b.average(FINE, 2 * expn(3, cf * d) * np.interp(
            FINE, light.wavelength_nm, light.values) * up),
    }
    for name, alt in wrong.items():
        assert np.max(np.abs(got / (rho / np.pi * alt) - 1)) > 0.05, name


def test_kd_meters_add_the_unscattered_sun():
    """The irradiance meters see the sky (a delta emitter reaches them only
    scattered); measure_kd adds the beam in closed form. The sum matches the
    plates (cosine collectors that do see the sun) and the closed form."""
    mitsuba()
    from aquaspec.validation.meters import measure_kd, measure_plate
    light = sun_sky()
    b = Bands(3)
    depths = np.array([1.0, 4.0])
    res = measure_kd(CLEAR, light, depths_m=depths, spp=80000, bands=b)
    sky_up, dir_up, e_sky, e_dir, cf, *_ = _closed_forms(CLEAR, light, depths, b)
    np.testing.assert_allclose(res["e_d_direct"], e_dir, rtol=1e-3)
    np.testing.assert_allclose(res["e_d"] - res["e_d_direct"], e_sky, rtol=0.03)
    np.testing.assert_allclose(res["e_d"], e_sky + e_dir, rtol=0.03)
    plate = measure_plate(CLEAR, light, depths_m=depths, spp=80000, bands=b, seed=3)
    up = b.average(FINE, np.exp(-cf * 0.01))
    np.testing.assert_allclose(np.pi * plate / up, res["e_d"], rtol=0.04)
    # Overcast: nothing added.
    res0 = measure_kd(CLEAR, surface_light("overcast"), depths_m=depths, spp=2000, bands=b)
    assert np.all(res0["e_d_direct"] == 0)


@pytest.mark.parametrize("phase, g", [("isotropic", 0.0), ("hg", 0.5)])
def test_single_scattering_of_the_sun(phase, g):
    """The sun as the only light, paths of at most one scattering event
    (volpathmis ``max_depth = 2``: camera - medium - emitter), against
    :func:`aquaspec.transport.sun_scattering.single_scattering_open` with the same c, b and phase
    function, per pixel of a 3-degree view towards, across and away from the
    sun (Jerlov IB at 4 m). Both sides are the same quantity, so only Monte
    Carlo noise separates them: tolerance 4 standard errors of the pixels'
    mean plus 1.5 %. With HG the sun's forward peak (looking at the sun is
    25x looking away) checks the scattering angle's convention."""
    mitsuba()
    from aquaspec.transport import sun_scattering as S
    from aquaspec.scene.camera import Camera
    from aquaspec.scene.mesh import Scene
    from aquaspec.validation.reference import medium_spectra, phase_function, render_reference
    light = sun_sky(50.0, 30.0)
    sun = light.sun
    only_sun = SurfaceLight("sun only", sun.wavelength_nm, sun.mu0 * sun.beam_normal, {}, sun)
    water = load_water("IB")
    b = Bands(6)
    depth = 4.0
    o = np.array([0.0, -depth, 0.0])
    across = np.cross(sun.to_sun, [0.0, 1.0, 0.0])
    across /= np.linalg.norm(across)
    views = {"towards": sun.to_sun, "away": sun.direction, "across": across}
    fine = np.arange(400.0, 700.001, 0.5)
    wl, c, albedo = medium_spectra(water)
    cf = np.interp(fine, wl, c)
    bf = cf * np.interp(fine, wl, albedo)
    beam = np.interp(fine, sun.wavelength_nm, sun.beam_normal)
    ph = phase_function(phase, g)
    means = {}
    for name, v in views.items():
        cam = Camera.look_at(o, o + v, width=6, height=6, fov_y_deg=3.0)
        img = render_reference(Scene(camera=cam), cam, water, only_sun, spp=1024, bands=b,
                               phase=phase, g=g, max_depth=2)["band_radiance"]
        dirs = cam.ray_directions().reshape(-1, 3)
        pv = ph.value(S.scattering_cosine(sun.direction, dirs))[:, None] * np.ones(fine.size)
        want = b.average(fine, S.single_scattering_open(
            b=bf, phase_value=pv, beam0=beam, c_sun=cf, c_view=cf,
            depth_o=np.full(len(dirs), depth), v_y=dirs[:, 1], s=np.full(len(dirs), np.inf),
            mu0=sun.mu0)).mean(axis=0)
        px = img.reshape(-1, b.n)
        got = px.mean(axis=0)
        se = px.std(axis=0, ddof=1) / np.sqrt(len(px))
        assert np.all(np.abs(got - want) < 4 * se + 0.015 * want), (name, got / want, se / got)
        means[name] = (got, want)
    ratio_got = means["towards"][0] / means["away"][0]
    ratio_want = means["towards"][1] / means["away"][1]
    np.testing.assert_allclose(ratio_got, ratio_want, rtol=0.08)
    if phase == "hg":
        assert np.all(ratio_want > 10)
