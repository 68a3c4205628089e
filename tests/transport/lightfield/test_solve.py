"""Discrete-ordinates light field: closed forms, conservation, convergence, tables."""

import warnings

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq
from scipy.special import expn

from aquaspec.transport.lightfield.solve import (clamped_cosine_azimuth, lightfield_l_ms,
                                 lightfield_pixel_radiance, lightfield_tables, solve_lightfield)
from aquaspec.errors import AquaspecError

RAY_TOL = 1e-9


def test_absorbing_slab_exact():
    a = np.array([0.2, 0.05])
    lf = solve_lightfield(a, [0.0, 0.0], phase="isotropic", n_streams=16)
    d = np.array([0.0, 1.0, 5.0, 20.0])
    # Uniform L0 = E0/pi looking up: E_d(d) = 2 pi L0 E3(a d) = 2 E3(a d).
    np.testing.assert_allclose(lf.e_d(d), 2 * expn(3, a[:, None] * d), rtol=1e-5)
    v = np.array([0.9, 0.3, 0.05])
    np.testing.assert_allclose(lf.radiance(3.0, v), np.exp(-a[:, None] * 3.0 / v) / np.pi,
                               rtol=1e-12)
    np.testing.assert_allclose(lf.e_u(d), 0.0, atol=1e-15)


@pytest.mark.parametrize("omega", [0.5, 0.9, 0.99])
def test_isotropic_asymptotic_kappa(omega):
    # Case: omega/(2 k) ln((1 + k)/(1 - k)) = 1, k in units of c.
    k_exact = brentq(lambda k: omega / (2 * k) * np.log((1 + k) / (1 - k)) - 1, 1e-9, 1 - 1e-12)
    lf = solve_lightfield([1 - omega], [omega], phase="isotropic", n_streams=32)
    assert lf.k_inf[0] == pytest.approx(k_exact, rel=1e-8)


@pytest.mark.parametrize("phase,kw", [("isotropic", {}), ("hg", {"g": 0.9})])
def test_energy_conservation_without_absorption(phase, kw):
    lf = solve_lightfield([0.0], [0.3], phase=phase, n_streams=16, seabed_depth_m=10.0,
                          seabed_albedo=0.3, **kw)
    d = np.linspace(0, 10, 11)
    net = (lf.e_d(d) - lf.e_u(d))[0]
    np.testing.assert_allclose(net, net[0], rtol=1e-5)
    # At the seabed the net flux is what it absorbs.
    assert net[-1] == pytest.approx(0.7 * lf.e_d(10.0)[0], rel=1e-6)


def test_convergence_with_streams():
    kw = dict(phase="hg", g=0.92, seabed_depth_m=15.0, seabed_albedo=0.2)
    d = np.array([1.0, 5.0, 12.0])
    ref = solve_lightfield([0.05], [0.25], n_streams=48, **kw)
    errs = []
    for n in (8, 16, 32):
        lf = solve_lightfield([0.05], [0.25], n_streams=n, **kw)
        errs.append(np.max(np.abs(lf.e_scalar(d) / ref.e_scalar(d) - 1)))
    assert errs[2] < errs[0]
    assert errs[2] < 2e-3


def test_tilted_irradiance():
    lf = solve_lightfield([0.05, 0.4], [0.2, 0.3], phase="hg", g=0.9, n_streams=32,
                          seabed_depth_m=8.0, seabed_albedo=0.4)
    d = np.array([0.5, 4.0])
    np.testing.assert_allclose(lf.irradiance(d, 1.0), lf.e_d(d), rtol=1e-14)
    np.testing.assert_allclose(lf.irradiance(d, -1.0), lf.e_u(d), rtol=1e-14)
    # Sideways: against a fine quadrature of the source-integrated radiance.
    mu = np.linspace(-1, 1, 4001)
    lrad = lf.radiance(np.full_like(mu, 4.0), mu)
    for ny in (0.0, 0.5, -0.7):
        fine = np.trapezoid(lrad * clamped_cosine_azimuth(mu, ny), mu, axis=-1)
        np.testing.assert_allclose(lf.irradiance(4.0, ny), fine, rtol=0.02)


def test_clamped_cosine_closed_form():
    # Vertical plane (n_y = 0): h = 2 sqrt(1 - mu^2).
    mu = np.linspace(-1, 1, 9)
    np.testing.assert_allclose(clamped_cosine_azimuth(mu, 0.0), 2 * np.sqrt(1 - mu * mu))
    # Integral over the sphere of max(0, n.w) is pi for any n.
    x = np.linspace(-1, 1, 20001)
    for ny in (-0.3, 0.8):
        assert np.trapezoid(clamped_cosine_azimuth(x, ny), x) == pytest.approx(np.pi, rel=1e-6)


@pytest.mark.parametrize("seabed", [None, 15.0])
def test_ray_integral_matches_quadrature(seabed):
    lf = solve_lightfield([0.06, 0.3], [0.2, 0.5], phase="petzold", wavelength_nm=[450, 600],
                          n_streams=24, seabed_depth_m=seabed, seabed_albedo=0.3)
    c = lf.c
    for d_o, v, s in ((5.0, 0.0, 3.0), (5.0, 0.5, np.inf), (2.0, -0.7, 4.0),
                      (8.0, 0.95, 2.0), (1.0, -0.2, np.inf)):
        exact = lf.l_ms(d_o, v, s)
        end = s
        if v > 0:
            end = min(end, d_o / v)
        if seabed and v < 0:
            end = min(end, (seabed - d_o) / -v)
        if not np.isfinite(end):
            end = 500.0
        for k in range(2):
            q = quad(lambda t: np.exp(-c[k] * t) * lf.source(d_o - t * v, v)[k], 0, end,
                     epsabs=0, epsrel=1e-12, limit=400)[0]
            assert exact[k] == pytest.approx(q, rel=RAY_TOL)


@pytest.fixture(scope="module")
def ib_tables():
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import load_water
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bw = load_water("IB").on_bands(Bands(8))
    lf = solve_lightfield(bw.a, bw.b, phase="petzold", wavelength_nm=bw.bands.centers_nm,
                          n_streams=32)
    return bw, lf, lightfield_tables(bw, phase="petzold")


def test_table_error_bound(ib_tables):
    """Measured: mean < 0.3 %, steep rays (|v_y| > 0.5) < 3 %, all S from 0.1 m to inf."""
    bw, lf, tab = ib_tables
    rng = np.random.default_rng(7)
    d = rng.uniform(0.5, 50, 300)
    v = rng.uniform(-1, 1, 300)
    for s in (0.1, 1.0, 10.0, np.inf):
        exact = lf.l_ms(d, v, s).T
        approx = lightfield_l_ms(tab, a=bw.a, b=bw.b, e0=1.0, depth_o=d[:, None],
                                 v_y=v[:, None], s=s)
        err = np.abs(approx / exact - 1)
        assert err.mean() < 3e-3
        assert err[np.abs(v) > 0.5].max() < 3e-2


def test_tables_dtype_and_surfaces(ib_tables):
    bw, lf, tab = ib_tables
    assert tab["ms_log_prefactor"].dtype == np.float32
    assert tab["irradiance_per_e0"].shape == (8, 64, 65)
    ny = np.array([1.0, 0.0, -1.0])
    e0 = np.linspace(1, 2, 8)
    lrad = lightfield_pixel_radiance(tab, a=bw.a, b=bw.b, e0=e0, depth_o=np.full((3, 1), 5.0),
                                     v_y=np.zeros((3, 1)), s=np.full((3, 1), 2.0), rho=0.5,
                                     surface_depth=np.full((3, 1), 5.0), n_y=ny[:, None])
    e_exact = lf.irradiance(5.0, ny).T * e0
    t = np.exp(-(bw.a + bw.b) * 2.0)
    l_ms = lf.l_ms(5.0, 0.0, 2.0) * e0
    np.testing.assert_allclose(lrad, t * 0.5 * e_exact / np.pi + l_ms, rtol=1e-2)
    assert np.all(np.isfinite(lrad))


def test_bad_input():
    with pytest.raises(AquaspecError, match="n_streams"):
        solve_lightfield([0.1], [0.1], phase="isotropic", n_streams=2)
    with pytest.raises(AquaspecError, match="surface"):
        solve_lightfield([0.1], [0.1], phase="isotropic", surface="wavy")
    with pytest.raises(AquaspecError, match="seabed_depth_m"):
        solve_lightfield([0.1], [0.1], phase="isotropic", seabed_depth_m=-1)


def test_forward_cone_zero_limit_and_effect():
    """A vanishing forward cone gives the plain two-point form; a real one
    leaves open water untouched and gives targets more contrast against it
    (less veil from light that the target blocks)."""
    from aquaspec.colour.bands import Bands
    from aquaspec.transport.lightfield.solve import lightfield_pixel_radiance, lightfield_tables
    from aquaspec.medium.water import load_water
    bw = load_water("IB").on_bands(Bands(4))
    t0 = lightfield_tables(bw, phase="hg", g=0.92)
    tiny = dict(t0, forward_fraction=np.full(4, 1e-12, np.float32))
    cone = lightfield_tables(bw, phase="hg", g=0.92, forward_cone_deg=15.0)
    assert np.all(cone["forward_fraction"] > 0.5)
    v = np.array([[-0.5], [0.0], [0.3], [0.9]])
    s = np.array([[2.0], [3.0], [3.0], [1.0]])
    kw = dict(a=bw.a, b=bw.b, e0=np.full(4, 0.3), depth_o=5.0, v_y=v, s=s,
              rho=np.full(4, 0.2), surface_depth=5.0 - s * v, n_y=np.zeros((4, 1)))
    plain = lightfield_pixel_radiance(t0, **kw)
    np.testing.assert_allclose(lightfield_pixel_radiance(tiny, **kw), plain, rtol=1e-10)
    open_kw = dict(kw, s=np.full((4, 1), np.inf))
    for key in ("rho", "surface_depth", "n_y"):
        open_kw.pop(key)
    background = lightfield_pixel_radiance(t0, **open_kw)
    np.testing.assert_allclose(lightfield_pixel_radiance(cone, **open_kw), background,
                               rtol=1e-12)
    contrast_cone = np.abs(lightfield_pixel_radiance(cone, **kw) - background)
    assert np.all(contrast_cone > np.abs(plain - background))


def test_forward_cone_over_a_seabed_hides_the_seabed_too():
    """Down rays over a seabed: the cone's share of a target is measured
    against the background it hides, L_bg(d_S, v), which ends on the seabed
    (the open-water radiance looking the same way from the target's depth).
    So the seabed seen as a surface, or as open water, has no cone term and
    does not depend on the cone: its forward-scattered light is already in
    the 1-D field. (Leaving the seabed out of L_bg made the seabed 27-46 %
    too bright in Jerlov IB with Fournier-Forand water, against Mitsuba.)"""
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import load_water
    n = 4
    bw = load_water("IB").on_bands(Bands(n))
    bed = dict(seabed_depth_m=6.0, seabed_albedo=np.full(n, 0.3))
    plain = lightfield_tables(bw, phase="hg", g=0.92, **bed)
    cone = lightfield_tables(bw, phase="hg", g=0.92, forward_cone_deg=40.0,
                             cone_spread=True, **bed)
    d_o = 4.0
    v = np.array([[-0.1], [-0.4], [-0.9]])
    kw = dict(a=bw.a, b=bw.b, e0=np.full(n, 0.5), depth_o=d_o, v_y=v)
    far = np.full_like(v, np.inf)
    background = lightfield_pixel_radiance(plain, **kw, s=far)
    # Open water going down ends on the seabed: the same with or without the cone.
    base, share = lightfield_pixel_radiance(cone, **kw, s=far, split_cone=True)
    np.testing.assert_allclose(base, background, rtol=1e-12)
    np.testing.assert_allclose(share, 0.0, atol=1e-15)
    np.testing.assert_allclose(lightfield_pixel_radiance(cone, **kw, s=far), background,
                               rtol=1e-12)
    # The seabed as a hit surface (a seabed mesh) is the same radiance, no cone term.
    to_bed = (6.0 - d_o) / -v
    bed_hit = dict(kw, s=to_bed, rho=np.full(n, 0.3), surface_depth=np.full_like(v, 6.0),
                   n_y=np.ones_like(v))
    base, share = lightfield_pixel_radiance(cone, **bed_hit, split_cone=True)
    np.testing.assert_allclose(share, 0.0, atol=1e-7 * background.max())
    np.testing.assert_allclose(base, background, rtol=1e-6)
    # A black target halfway: its cone share is -(T' - T) L_bg(d_S, v).
    s = 0.5 * to_bed
    d_s = d_o - s * v
    black = dict(kw, s=s, rho=np.zeros(n), surface_depth=d_s, n_y=np.zeros_like(v))
    _, share = lightfield_pixel_radiance(cone, **black, split_cone=True)
    hidden = lightfield_pixel_radiance(cone, **dict(kw, depth_o=d_s), s=far)
    c = bw.a + bw.b
    t_beam = np.exp(-(c - cone["forward_fraction"] * bw.b) * s)
    np.testing.assert_allclose(share, -(t_beam - np.exp(-c * s)) * hidden, rtol=1e-9)


def test_cone_spread_kernel_holds_the_offset_distribution():
    """The kernel sums to 1, is symmetric, and its mass within radius r pixels
    is the CDF of the apparent offset at r / fy radians."""
    from aquaspec.transport.lightfield.solve import cone_spread_kernel
    from aquaspec.medium.phase import band_cone_offset_cdf
    offsets = np.radians(20.0) * np.concatenate([[0.0], np.geomspace(1e-5, 1.0, 255)])
    cdf = band_cone_offset_cdf("ff", 20.0, offsets, backscatter=0.0183)[0]
    fy = 60.0
    k = cone_spread_kernel(offsets, cdf, fy, subsamples=16)
    r = k.shape[0] // 2
    assert k.shape == (2 * r + 1, 2 * r + 1) and r == int(np.ceil(np.radians(20.0) * fy))
    assert k.sum() == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(k, k[::-1, ::-1], atol=1e-15)
    np.testing.assert_allclose(k, k.T, atol=1e-15)
    y, x = np.indices(k.shape) - r
    dist = np.hypot(x, y)
    for radius in (3.0, 6.0, 12.0):
        inside = k[dist <= radius].sum()
        want = np.interp(radius / fy, offsets, cdf)
        # Pixel cells straddle the circle: compare within the CDF between
        # radius -+ half a cell diagonal.
        lo = np.interp((radius - 0.71) / fy, offsets, cdf)
        hi = np.interp((radius + 0.71) / fy, offsets, cdf)
        assert lo - 1e-3 <= inside <= hi + 1e-3, (radius, inside, want)
    with pytest.raises(AquaspecError, match="pixels_per_radian"):
        cone_spread_kernel(offsets, cdf, 0.0)


def test_cone_spread_needs_a_cone():
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import load_water
    bw = load_water("IB").on_bands(Bands(3))
    with pytest.raises(AquaspecError, match="cone_spread needs a forward cone"):
        lightfield_tables(bw, phase="ff", backscatter=0.0183, cone_spread=True)
    t = lightfield_tables(bw, phase="ff", backscatter=0.0183, forward_cone_deg=30.0,
                          cone_spread=True)
    assert t["cone_offset_cdf"].shape == (3, t["cone_offset_rad"].size)


def test_forward_cone_defaults():
    """No cone given: 15 degrees, 40 with the spread; a given one is kept."""
    from aquaspec.colour.bands import Bands
    from aquaspec.light.sky import surface_light
    from aquaspec.transport.lightfield.solve import forward_cone
    from aquaspec.rendering.renderer import SpectralSetup
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import load_water
    assert forward_cone(None, False) == 15.0 and forward_cone(None, True) == 40.0
    assert forward_cone(25, True) == 25.0
    base = dict(water=load_water("IB"), sensor=get_sensor("human"),
                light=surface_light("overcast"), bands=Bands(3), ms_model="lightfield")
    assert SpectralSetup(**base, cone_spread=False).describe()["forward_cone_deg"] == 15.0
    spread = SpectralSetup(**base, cone_spread=True)
    assert spread.describe()["forward_cone_deg"] == 40.0 and spread.describe()["cone_spread"]
    assert SpectralSetup(**base, cone_spread=True, forward_cone_deg=30.0).cone_deg == 30.0
    # No cone_spread given: the light field's default is the spread (model.cone_spread_for).
    assert SpectralSetup(**base).describe()["cone_spread"] is True
    assert SpectralSetup(**base).cone_deg == 40.0


def test_default_model_is_the_light_field_with_the_spread():
    """The default multiple-scattering model is the one the validation chose;
    the seeds' model has no cone and refuses one."""
    from aquaspec.transport import monzon2022 as model
    from aquaspec.colour.bands import Bands
    from aquaspec.light.sky import surface_light
    from aquaspec.rendering.renderer import SpectralSetup
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import load_water
    assert model.DEFAULT_MS_MODEL == "lightfield"
    assert model.cone_spread_for("lightfield", None) is True
    assert model.cone_spread_for("lightfield", False) is False
    assert model.cone_spread_for("seeds", None) is False
    with pytest.raises(AquaspecError, match="cone_spread is part of the light-field model"):
        model.cone_spread_for("seeds", True)
    base = dict(water=load_water("IB"), sensor=get_sensor("human"),
                light=surface_light("overcast"), bands=Bands(3))
    d = SpectralSetup(**base).describe()
    assert d["ms_model"] == "lightfield" and d["cone_spread"] and d["phase"] == "petzold"
    assert "cone_spread" not in SpectralSetup(**base, ms_model="seeds").describe()
    with pytest.raises(AquaspecError, match="cone_spread"):
        SpectralSetup(**base, ms_model="seeds", cone_spread=True)


def test_multiple_scattering_spread_moves_light_off_bright_targets():
    """spread_scattering="multiple" in Jerlov II (about one to three scatterings
    inside the cone over the board's 3 m): the white patch keeps less of its
    light and the black board around the patches gets more, the light moved,
    not made (the image's total within 1 %); the setup says which it used."""
    from aquaspec.colour.bands import Bands
    from aquaspec.gpu.passes.raster import raycast_gbuffer
    from aquaspec.light.sky import surface_light
    from aquaspec.rendering.renderer import SpectralSetup
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.shading.shade import shade_gbuffer
    from aquaspec.validation.scenes import board_scene, masks
    from aquaspec.medium.water import load_water
    scene, cam = board_scene(3.0, width=96, height=72)
    gb = raycast_gbuffer(scene, cam)
    m = masks(gb)
    board = gb.hit & (gb.material == 24)
    out = {}
    for how in ("single", "multiple"):
        setup = SpectralSetup(load_water("II"), get_sensor("human"), surface_light("overcast"),
                              Bands(8), ms_model="lightfield", phase="petzold",
                              cone_spread=True, spread_scattering=how)
        assert setup.describe()["spread_scattering"] == how
        tables = setup.lightfield_tables()
        assert ("cone_offset_cdf_nodes" in tables) == (how == "multiple")
        res = shade_gbuffer(gb, **setup.medium(gb.materials), return_radiance=True,
                            lightfield=tables)
        out[how] = res["radiance"]
        # The camera RGB is that of the spread radiance (it was not, with
        # "multiple", until 2026-11-24).
        w = setup.medium(gb.materials)["response_weights"]
        np.testing.assert_allclose(res["camera_rgb"], out[how] @ w, rtol=1e-9, atol=1e-15)
    single, multi = out["single"], out["multiple"]
    white = m["patches"][18]
    assert multi[white].mean() < 0.97 * single[white].mean()
    assert multi[board].mean() > 1.03 * single[board].mean()
    assert multi.sum() == pytest.approx(single.sum(), rel=0.01)
    with pytest.raises(AquaspecError, match="needs cone_spread=True"):
        SpectralSetup(load_water("II"), get_sensor("human"), surface_light("overcast"),
                      Bands(3), ms_model="lightfield", cone_spread=False,
                      spread_scattering="multiple").lightfield_tables()
