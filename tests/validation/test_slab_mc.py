"""The Monte Carlo reference of the sea seen from above (validation.slab_mc)
against closed forms and, where Mitsuba can render the same, Mitsuba."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.medium.interface import N_WATER, fresnel_transmittance
from aquaspec.medium.phase import get_phase
from aquaspec.transport.sun_scattering import single_scattering_open
from aquaspec.medium.interface import fresnel_transmittance_out
from aquaspec.validation.slab_mc import PhaseSampler, sea_radiance_mc

DOWN = np.array([[0.0, -1.0, 0.0]])
ISO = get_phase("isotropic")


def _sun(elevation_deg=50.0):
    e = np.radians(elevation_deg)
    return np.array([np.cos(e), np.sin(e), 0.0])


def _beam_below(to_air, e_air):
    """The refracted beam's normal irradiance and way under the flat surface."""
    cos_z = to_air[1]
    sin_w = np.sqrt(1 - cos_z ** 2) / N_WATER
    mu0 = np.sqrt(1 - sin_w ** 2)
    return e_air * cos_z * fresnel_transmittance(cos_z) / mu0, mu0, np.array([-sin_w, -mu0, 0.0])


def test_clear_water_over_a_seabed_is_the_closed_form():
    """Water that neither absorbs nor scatters over a Lambertian seabed: the
    seabed's radiance is rho/pi mu0 F0 / (1 - rho r_i), r_i the surface's
    internal reflectance of diffuse light (the bounces between seabed and
    surface), and the camera sees T/n^2 of it."""
    rho, e_air = 0.3, 2.0
    to_air = _sun()
    f0, mu0, _ = _beam_below(to_air, e_air)
    mu = np.linspace(0.0, 1.0, 200001)
    r_i = 1.0 - np.trapezoid(2.0 * mu * fresnel_transmittance_out(mu, N_WATER), mu)
    expect_bed = rho / np.pi * mu0 * f0 / (1.0 - rho * r_i)
    r = sea_radiance_mc(DOWN, a=[1e-9], b=[0.0], phase=ISO, sky_radiance=[0.0], sun_to_air=to_air,
                        sun_beam_air=[e_air], seabed_depth_m=2.0, seabed_albedo=rho,
                        paths=40_000, seed=1)
    t = fresnel_transmittance(1.0)
    assert 0.45 < r_i < 0.5
    assert abs(r["mean"][0] - t / N_WATER ** 2 * expect_bed) < 4 * r["standard_error"][0] + 1e-9


def test_weakly_scattering_water_is_single_scattering():
    """Albedo 1 %: the sun scattered once (closed form,
    transport.sun_scattering.single_scattering_open with c both ways), within
    the next orders' share (about the albedo) and the noise."""
    a, b, e_air = 1.0, 0.01, 1.0
    to_air = _sun(60.0)
    f0, mu0, way = _beam_below(to_air, e_air)
    r = sea_radiance_mc(DOWN, a=[a], b=[b], phase=ISO, sky_radiance=[0.0], sun_to_air=to_air,
                        sun_beam_air=[e_air], paths=20_000, seed=2)
    ss = single_scattering_open(b=b, phase_value=1 / (4 * np.pi), beam0=f0, c_sun=a + b,
                                c_view=a + b, depth_o=np.zeros(1), v_y=np.array([-1.0]),
                                s=np.array([np.inf]), mu0=mu0)[0, 0]
    expect = fresnel_transmittance(1.0) / N_WATER ** 2 * ss
    assert abs(r["mean"][0] / expect - 1.0) < 0.02 + 4 * r["standard_error"][0] / expect


def test_the_sky_alone_over_black_water_is_its_reflection():
    r = sea_radiance_mc(DOWN * [[0.6, 1.0, 0.0]] / np.hypot(0.6, 1.0), a=[50.0], b=[1e-9],
                        phase=ISO, sky_radiance=[3.0], paths=2000)
    mu = 1.0 / np.hypot(0.6, 1.0)
    assert r["mean"][0] == pytest.approx((1 - fresnel_transmittance(mu)) * 3.0, rel=1e-6)


def test_the_phase_sampler_draws_the_phase_function():
    """Petzold's table: sampled cosines' histogram against p; the truncated
    sampler leaves the cone empty and keeps the rest's shape."""
    p = get_phase("tabulated", of="petzold")
    rng = np.random.default_rng(0)
    for cut in (0.0, 3.0):
        s = PhaseSampler(p, cut)
        mu = s.sample(rng, 400_000)
        edges = np.array([-1.0, -0.5, 0.0, 0.5, 0.9, 0.99])
        counts = np.histogram(mu, edges)[0] / mu.size
        grid = np.linspace(-1, 0.99, 400001)
        pv = s.value(grid) * 2 * np.pi
        expect = [np.trapezoid(pv[(grid >= lo) & (grid <= hi)], grid[(grid >= lo) & (grid <= hi)])
                  for lo, hi in zip(edges[:-1], edges[1:])]
        np.testing.assert_allclose(counts, expect, rtol=0.05, atol=2e-4)
        if cut:
            assert mu.max() <= np.cos(np.radians(cut)) + 1e-12
            assert 0.3 < s.forward_fraction < 0.9


@pytest.mark.slow
def test_against_mitsuba_with_the_sun_through_an_index_matched_surface():
    """Where Mitsuba can render the sun (no refraction: n = 1), the same
    scene: Jerlov 3C, a grey seabed at 3 m, isotropic scattering, the sun at
    30 degrees and the sky. (Measured at 16 px, 2048 spp, 30 bands: 0.999.)"""
    mitsuba = pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (extra 'validation')")
    import tempfile

    from aquaspec.colour.bands import Bands
    from aquaspec.light.sky import surface_light
    from aquaspec.medium.water import load_water
    from aquaspec.validation.above_check import SEABED_ALBEDO, _seabed_scene, above_camera
    from aquaspec.validation.reference import phase_function, require_mitsuba, scene_dict
    bands = Bands(15, 400.0, 700.0)     # narrow: the water's a and b are averaged per band
    cam = above_camera(12)
    light = surface_light("sun-sky", sun_elevation_deg=30.0, sun_azimuth_deg=30.0)
    water = load_water("3C")
    mi = require_mitsuba()
    with tempfile.TemporaryDirectory() as tmp:
        d = scene_dict(_seabed_scene(3.0, cam), cam, water, light, spp=512, mesh_dir=tmp,
                       bands=bands, phase="isotropic", surface="index-matched")
        d["sensor"].pop("medium")
        ref = np.array(mi.render(mi.load_dict(d), seed=1), dtype=float).reshape(-1, bands.n)
    bw = water.on_bands(bands)
    r = sea_radiance_mc(cam.ray_directions().reshape(-1, 3), a=bw.a, b=bw.b,
                        phase=phase_function("isotropic"), sky_radiance=light.sky_on(bands) / np.pi,
                        sun_to_air=light.sun.to_sun, sun_beam_air=light.sun.beam_on(bands),
                        seabed_depth_m=3.0, seabed_albedo=SEABED_ALBEDO, n_water=1.0,
                        paths=20_000)
    assert mitsuba is not None
    np.testing.assert_allclose(r["mean"], ref.mean(axis=0), rtol=0.03)
