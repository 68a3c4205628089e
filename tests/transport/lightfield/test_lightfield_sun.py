"""The sun's beam as a source of the discrete-ordinates light field (its diffuse field)."""

import warnings

import numpy as np
import pytest
from numpy.polynomial.legendre import leggauss
from scipy.integrate import quad

from aquaspec.errors import AquaspecError
from aquaspec.transport.lightfield.bake import lightfield_tables, tables_key
from aquaspec.transport.lightfield.solve import SUN_RESONANCE_GAP, solve_lightfield


def _pbar(phase, g, v, mu0):
    """Azimuthal average of the phase function between the beam (seen looking up at
    ``+mu0``) and the direction looked along ``v``: cos theta = v mu0 + sin sin cos phi."""
    if phase == "isotropic":
        return 1.0 / (4.0 * np.pi)

    def p(phi):
        ct = v * mu0 + np.sqrt(1 - v * v) * np.sqrt(1 - mu0 * mu0) * np.cos(phi)
        return (1 - g * g) / (4 * np.pi * (1 + g * g - 2 * g * ct) ** 1.5)

    return quad(p, 0.0, np.pi, epsabs=0.0, epsrel=1e-11)[0] / np.pi


@pytest.mark.parametrize("phase,g", [("isotropic", None), ("hg", 0.8)])
@pytest.mark.parametrize("bed", [None, 5.0])
def test_single_scattering_limit(phase, g, bed):
    # b << a: the diffuse field is the beam scattered once along the line of sight,
    # L(d, v) = b pbar(v, mu0) F0 int_0^s exp(-c t) exp(-c (d - t v) / mu0) dt.
    a, b, mu0, f0 = 1.0, 1e-4, 0.8, 2.0
    kw = {} if g is None else {"g": g}
    lf = solve_lightfield([a], [b], phase=phase, e0=0.0, sun_mu0=mu0, sun_beam=f0,
                          n_streams=32, seabed_depth_m=bed, seabed_albedo=0.0, **kw)
    c = a + b
    for d in (0.5, 3.0):
        for v in (-0.9, -0.3, 0.1, 0.5, 0.95):
            s_end = d / v if v > 0 else (np.inf if bed is None else (bed - d) / -v)
            ref = b * _pbar(phase, g, v, mu0) * f0 * quad(
                lambda t: np.exp(-c * t - c * (d - t * v) / mu0), 0.0, s_end)[0]
            assert lf.radiance(d, v)[0] == pytest.approx(ref, rel=2e-3), (d, v)


def _h_function(omega, mu):
    """Chandrasekhar's H for isotropic scattering, by iterating
    1/H(mu) = sqrt(1 - omega) + omega/2 int_0^1 mu' H(mu') / (mu + mu') dmu'."""
    x, w = leggauss(400)
    x, w = 0.5 * (x + 1), 0.5 * w
    h = np.ones_like(x)
    for _ in range(2000):
        new = 1.0 / (np.sqrt(1 - omega) + omega / 2 * np.sum(w * x * h / (x[:, None] + x),
                                                              axis=1))
        if np.max(np.abs(new - h)) < 1e-14:
            break
        h = new
    mu = np.asarray(mu, dtype=float)
    return 1.0 / (np.sqrt(1 - omega) + omega / 2 * np.sum(w * x * h / (mu[..., None] + x),
                                                          axis=-1))


@pytest.mark.parametrize("omega", [0.5, 0.9])
def test_semi_infinite_isotropic_reflection_chandrasekhar(omega):
    # Independent closed form (Chandrasekhar 1960, Ch. IV): a half-space of isotropic
    # scatterers under a beam of normal irradiance F0 at mu0 sends back
    # L(0, -mu) = omega F0/(4 pi) mu0/(mu + mu0) H(mu) H(mu0), and its diffuse
    # albedo is E_u(0) / (mu0 F0) = 1 - H(mu0) sqrt(1 - omega).
    mu0, f0 = 0.75, 1.0
    lf = solve_lightfield([1 - omega], [omega], phase="isotropic", e0=0.0, sun_mu0=mu0,
                          sun_beam=f0, n_streams=32)
    mu = np.array([0.05, 0.2, 0.5, 0.8, 1.0])
    ref = omega * f0 / (4 * np.pi) * mu0 / (mu + mu0) * _h_function(omega, mu) \
        * _h_function(omega, mu0)
    np.testing.assert_allclose(lf.radiance(0.0, -mu)[0], ref, rtol=1e-4)
    albedo = 1 - _h_function(omega, mu0) * np.sqrt(1 - omega)
    assert lf.e_u(0.0)[0] / (mu0 * f0) == pytest.approx(albedo, rel=1e-5)
    assert lf.e_d(0.0)[0] == pytest.approx(0.0, abs=1e-12)


def _net_flux(lf, d):
    """Downward net flux of beam and diffuse light, (n, ...)."""
    mu0 = lf.sun_mu0.reshape((-1,) + (1,) * np.ndim(d))
    return mu0 * lf.beam_irradiance(d) + lf.e_d(d) - lf.e_u(d)


@pytest.mark.parametrize("albedo", [1.0, 0.3])
def test_energy_conservation_without_absorption(albedo):
    mu0, f0, e_sky = 0.75, 1.0, 0.4
    lf = solve_lightfield([1e-6], [0.3], phase="hg", g=0.9, e0=e_sky, sun_mu0=mu0,
                          sun_beam=f0, n_streams=16, seabed_depth_m=10.0, seabed_albedo=albedo)
    d = np.linspace(0.0, 10.0, 21)
    net = _net_flux(lf, d)[0]
    e_in = e_sky + mu0 * f0
    # The little absorption left (1e-6 1/m) takes about 1e-6 * E0_scalar * 10 m.
    np.testing.assert_allclose(net - net[0], 0.0, atol=1e-4 * e_in)
    # The seabed absorbs 1 - albedo of what reaches it, beam included.
    at_bed = lf.e_d(10.0)[0] + mu0 * lf.beam_irradiance(10.0)[0]
    assert net[-1] == pytest.approx((1 - albedo) * at_bed, abs=1e-9 + 1e-6 * e_in)


@pytest.mark.parametrize("phase,kw", [("isotropic", {}), ("hg", {"g": 0.9}),
                                      ("petzold", {"wavelength_nm": [450.0, 550.0]})])
@pytest.mark.parametrize("bed", [None, 8.0])
def test_flux_divergence_is_absorption(phase, kw, bed):
    # -d(E_net)/dd = a (E0_scalar,diffuse + F_beam) in the delta-M problem (a* = a).
    a = np.array([0.05, 0.12])
    lf = solve_lightfield(a, [0.25, 0.2], phase=phase, e0=0.5, sun_mu0=0.7,
                          sun_beam=[1.2, 0.8], n_streams=24, seabed_depth_m=bed,
                          seabed_albedo=0.3, **kw)
    assert np.allclose(lf.c_star - lf.b_star, a)
    h = 1e-4
    for d in (0.3, 3.0, 7.0):
        div = -(_net_flux(lf, d + h) - _net_flux(lf, d - h)) / (2 * h)
        absorbed = a * (lf.e_scalar(d) + lf.beam_irradiance(d))
        np.testing.assert_allclose(div, absorbed, rtol=1e-3)


@pytest.mark.parametrize("bed", [None, 6.0])
def test_superposition(bed):
    kw = dict(phase="hg", g=0.92, n_streams=16, seabed_depth_m=bed, seabed_albedo=0.25)
    a, b, mu0 = [0.04, 0.3], [0.3, 0.1], 0.83
    sky = solve_lightfield(a, b, e0=[1.0, 0.7], sun_mu0=mu0, sun_beam=0.0, **kw)
    sun = solve_lightfield(a, b, e0=0.0, sun_mu0=mu0, sun_beam=[1.3, 0.9], **kw)
    both = solve_lightfield(a, b, e0=[1.0, 0.7], sun_mu0=mu0, sun_beam=[1.3, 0.9], **kw)
    plain = solve_lightfield(a, b, e0=[1.0, 0.7], **kw)
    d = np.array([0.0, 0.7, 4.0, 6.0])[:, None]
    v = np.array([-1.0, -0.6, -0.05, 0.2, 0.83, 0.9, 1.0])
    for name, call in (("radiance", lambda lf: lf.radiance(d, v)),
                       ("irradiance", lambda lf: lf.irradiance(d, v)),
                       ("e_scalar", lambda lf: lf.e_scalar(d)),
                       ("source", lambda lf: lf.source(d, v)),
                       ("l_ms", lambda lf: lf.l_ms(d, v, 2.5)),
                       ("l_ms inf", lambda lf: lf.l_ms(d, v, np.inf))):
        np.testing.assert_allclose(call(sky) + call(sun), call(both), rtol=1e-10,
                                   atol=1e-14, err_msg=name)
        # A sun with no beam is the sky alone.
        np.testing.assert_allclose(call(sky), call(plain), rtol=1e-10, atol=1e-14,
                                   err_msg=name)
    # The sun's diffuse light: none comes down at the top, some everywhere else.
    l_sun = sun.radiance(d, v)
    np.testing.assert_array_equal(l_sun[:, 0, v > 0], 0.0)
    assert np.all(l_sun[:, 1:] > 0) and np.all(l_sun[:, 0, v < 0] > 0)


def test_l_ms_is_the_diffuse_in_scattering_along_the_ray():
    # L_MS = int exp(-c t) j(d(t), v) dt with j the diffuse field's in-scattering;
    # the beam's own first scattering (source(beam=True) - source()) is the renderer's.
    lf = solve_lightfield([0.05], [0.3], phase="hg", g=0.9, e0=0.3, sun_mu0=0.8,
                          sun_beam=1.0, n_streams=16, seabed_depth_m=9.0, seabed_albedo=0.2)
    c = lf.c[0]
    for d_o, v, s in ((3.0, 0.6, 4.0), (3.0, -0.4, 5.0), (2.0, 0.05, 6.0), (8.0, 0.95, 7.0)):
        t = np.linspace(0.0, min(s, d_o / v if v > 0 else (9.0 - d_o) / -v), 4001)
        jt = lf.source(d_o - t * v, v)[0] * np.exp(-c * t)
        ref = np.sum(0.5 * (jt[1:] + jt[:-1]) * np.diff(t))
        assert lf.l_ms(d_o, v, s)[0] == pytest.approx(ref, rel=1e-5)
        assert np.all(lf.source(d_o, v, beam=True) > lf.source(d_o, v))


def test_boundaries_and_nodes():
    mu0, f0, bed, rho = 0.9, 1.5, 6.0, 0.4
    lf = solve_lightfield([0.06], [0.25], phase="hg", g=0.9, e0=0.0, sun_mu0=mu0,
                          sun_beam=f0, n_streams=16, seabed_depth_m=bed, seabed_albedo=rho)
    # No diffuse light comes down at the top from the sun.
    np.testing.assert_allclose(lf.node_radiance(0.0)[0, :16], 0.0, atol=1e-13)
    # The seabed reflects the diffuse E_d and the beam.
    e_bed = lf.e_d(bed)[0] + mu0 * f0 * np.exp(-lf.c_star[0] * bed / mu0)
    np.testing.assert_allclose(lf.node_radiance(bed)[0, 16:], rho * e_bed / np.pi, rtol=1e-10)
    np.testing.assert_allclose(lf.radiance(bed, [-0.3, -0.9])[0], rho * e_bed / np.pi,
                               rtol=1e-10)
    # At the nodes the line-of-sight integral gives the DO values back.
    for d in (0.5, 3.0):
        np.testing.assert_allclose(lf.radiance(d, lf.mu)[0], lf.node_radiance(d)[0],
                                   rtol=1e-6)
    assert lf.k_inf[0] == lf.kappa[0, 0] and lf.kappa.shape == (1, 17)
    assert lf.kappa[0, -1] == pytest.approx(lf.c_star[0] / mu0)


@pytest.mark.parametrize("a,b", [(1.0, 1e-4), (0.05, 0.3)])
def test_resonance_and_node_cosines(a, b):
    kw = dict(phase="hg", g=0.9, n_streams=16, seabed_depth_m=12.0, seabed_albedo=0.3)
    plain = solve_lightfield([a], [b], **kw)
    mu_nodes = plain.mu[:16]
    rate = plain.c_star[0] / plain.kappa[0]
    cases = [m for m in mu_nodes if 0.66 <= m <= 1.0] \
        + [r for r in rate if 0.66 <= r <= 1.0]
    assert len(cases) > 4
    d = np.array([0.0, 1.0, 5.0, 12.0])[:, None]
    v = np.array([-0.8, 0.1, 0.7, 0.99])
    for mu0 in cases:
        lf = solve_lightfield([a], [b], e0=0.0, sun_mu0=mu0, sun_beam=1.0, **kw)
        assert abs(lf.sun_mu0[0] / mu0 - 1) <= 1.01 * SUN_RESONANCE_GAP
        out = [lf.radiance(d, v), lf.irradiance(d, v), lf.l_ms(d, v, np.inf)]
        assert all(np.all(np.isfinite(x)) for x in out)
        # Smooth in mu0 across the resonance: the mean of two neighbours.
        step = 2e-4
        near = [solve_lightfield([a], [b], e0=0.0, sun_mu0=mu0 + s, sun_beam=1.0, **kw)
                for s in (-step, step)]
        mean = 0.5 * (near[0].irradiance(d, v) + near[1].irradiance(d, v))
        np.testing.assert_allclose(out[1], mean, rtol=1e-4, atol=1e-12)
    # An exact resonance was moved off.
    exact = [r for r in rate if 0.66 <= r < 1.0][0]
    lf = solve_lightfield([a], [b], e0=0.0, sun_mu0=exact, sun_beam=1.0, **kw)
    assert lf.sun_mu0[0] != exact


def test_asymptotic_regime_forgets_the_sun():
    # Deep down the sun's diffuse field decays with kappa_1 and has the asymptotic
    # radiance shape, whatever the sun's zenith angle.
    kw = dict(phase="hg", g=0.9, n_streams=16, e0=0.0, sun_beam=1.0)
    v = np.linspace(-1, 1, 9)
    shapes = []
    for mu0 in (0.67, 0.85, 1.0):
        lf = solve_lightfield([0.1], [0.4], sun_mu0=mu0, **kw)
        k1 = lf.k_inf[0]
        # (kappa_2 - kappa_1 = 0.11 1/m: the next mode is down by 1e-8 at 170 m.)
        l1, l2 = lf.radiance(170.0, v)[0], lf.radiance(171.0, v)[0]
        np.testing.assert_allclose(l2 / l1, np.exp(-k1), rtol=1e-6)
        lam = lf.asymptotic_radiance(v)[0]
        np.testing.assert_allclose(l1 / l1[-1], lam / lam[-1], rtol=1e-6)
        shapes.append(l1 / l1[-1])
    np.testing.assert_allclose(shapes[0], shapes[2], rtol=1e-6)
    # Not yet near the surface, where the beam's direction shows.
    lf0 = solve_lightfield([0.1], [0.4], sun_mu0=0.67, **kw)
    lf1 = solve_lightfield([0.1], [0.4], sun_mu0=1.0, **kw)
    s0, s1 = lf0.radiance(1.0, v)[0], lf1.radiance(1.0, v)[0]
    assert np.max(np.abs(s0 / s0[-1] - s1 / s1[-1])) > 0.05


def test_bad_sun_input():
    with pytest.raises(AquaspecError, match="sun_mu0"):
        solve_lightfield([0.1], [0.2], sun_mu0=0.0, sun_beam=1.0)
    with pytest.raises(AquaspecError, match="sun_mu0"):
        solve_lightfield([0.1], [0.2], sun_mu0=1.2, sun_beam=1.0)
    with pytest.raises(AquaspecError, match="sun_beam"):
        solve_lightfield([0.1], [0.2], sun_mu0=0.8, sun_beam=-1.0)
    with pytest.raises(AquaspecError, match="sun_mu0"):
        solve_lightfield([0.1], [0.2], sun_beam=1.0)


@pytest.fixture(scope="module")
def ib4():
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import load_water
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_water("IB").on_bands(Bands(4))


TABLE_KW = dict(phase="petzold", n_depth=9, n_mu=11, n_streams=16, seabed_depth_m=12.0,
                seabed_albedo=0.3)


def test_tables_with_and_without_sun(ib4):
    sky = lightfield_tables(ib4, **TABLE_KW).to_arrays()
    assert np.isnan(sky["sun_mu0"][0]) and np.all(sky["sun_fraction"] == 0)
    zero = lightfield_tables(ib4, sun_mu0=0.8, sun_fraction=np.zeros(4), **TABLE_KW).to_arrays()
    for k in sky:
        if k != "sun_mu0":
            np.testing.assert_allclose(zero[k], sky[k], rtol=2e-6, atol=1e-12, err_msg=k)
    share = np.array([0.2, 0.5, 0.6, 0.9])
    sun = lightfield_tables(ib4, sun_mu0=0.8, sun_fraction=share, **TABLE_KW).to_arrays()
    assert sun["sun_mu0"][0] == pytest.approx(0.8)
    # Down-welling diffuse light at d = 0 is the sky's share only.
    assert sun["cosine"][-1] == 1.0 and sun["depth_m"][0] == 0.0
    np.testing.assert_allclose(sun["irradiance_per_e0"][:, 0, -1], 1 - share, rtol=1e-5)
    np.testing.assert_allclose(sun["sky_radiance_per_e0"], (1 - share)
                               * sky["sky_radiance_per_e0"], rtol=1e-6)
    # beam_extinction is the delta-M c*, the same with and without a sun.
    lf = solve_lightfield(ib4.a, ib4.b, phase="petzold", wavelength_nm=ib4.bands.centers_nm,
                          n_streams=16, seabed_depth_m=12.0, seabed_albedo=0.3,
                          e0=1 - share, sun_mu0=0.8, sun_beam=share / 0.8)
    np.testing.assert_allclose(sun["beam_extinction"], lf.c_star, rtol=1e-6)
    np.testing.assert_array_equal(sun["beam_extinction"], sky["beam_extinction"])
    depth, cos = sun["depth_m"].astype(float), sun["cosine"].astype(float)
    np.testing.assert_allclose(sun["irradiance_per_e0"],
                               lf.irradiance(depth[:, None], cos[None, :]), rtol=1e-5,
                               atol=1e-9)
    # The sun's diffuse light adds up-welling light and changes the prefactor.
    assert np.all(sun["irradiance_per_e0"][:, 3, 0] != sky["irradiance_per_e0"][:, 3, 0])
    assert np.max(np.abs(sun["ms_log_prefactor"] - sky["ms_log_prefactor"])) > 0.01


def test_tables_key_and_arguments(ib4):
    base = dict(TABLE_KW, n_depth=9, n_mu=11, max_depth_m=50.0, surface="null",
                forward_cone_deg=0.0, cone_spread=False, spread_scattering="single",
                ambient_shadow=False)
    keys = {tables_key(ib4, dict(base, sun_mu0=mu0, sun_fraction=sf))
            for mu0, sf in ((None, None), (0.8, np.full(4, 0.5)), (0.9, np.full(4, 0.5)),
                            (0.8, np.full(4, 0.4)))}
    assert len(keys) == 4
    with pytest.raises(AquaspecError, match="sun_mu0 and sun_fraction"):
        lightfield_tables(ib4, sun_mu0=0.8, **TABLE_KW)
    with pytest.raises(AquaspecError, match="sun_mu0 and sun_fraction"):
        lightfield_tables(ib4, sun_fraction=[0.5] * 4, **TABLE_KW)
    with pytest.raises(AquaspecError, match="sun_fraction"):
        lightfield_tables(ib4, sun_mu0=0.8, sun_fraction=[1.5] * 4, **TABLE_KW)


def test_tables_ambient_shadow_with_sun(ib4):
    # The scene's shadow in the light field works on the diffuse field of sky + sun.
    share = np.full(4, 0.5)
    t = lightfield_tables(ib4, sun_mu0=0.8, sun_fraction=share, ambient_shadow=True,
                          **TABLE_KW).to_arrays()
    lf = solve_lightfield(ib4.a, ib4.b, phase="petzold", wavelength_nm=ib4.bands.centers_nm,
                          n_streams=16, seabed_depth_m=12.0, seabed_albedo=0.3,
                          e0=1 - share, sun_mu0=0.8, sun_beam=share / 0.8)
    depth, cos = t["depth_m"].astype(float), t["cosine"].astype(float)
    np.testing.assert_allclose(t["radiance_per_e0"], lf.radiance(depth[:, None], cos[None, :]),
                               rtol=1e-5, atol=1e-9)


def test_open_water_sees_the_sun_lit_seabed(ib4):
    """A down ray ending just above the tables' own seabed sees it lit by the
    diffuse field and by the beam, as the solution's boundary does."""
    share = np.array([0.2, 0.5, 0.6, 0.9])
    tables = lightfield_tables(ib4, sun_mu0=0.8, sun_fraction=share, **TABLE_KW)
    lf = solve_lightfield(ib4.a, ib4.b, phase="petzold", wavelength_nm=ib4.bands.centers_nm,
                          n_streams=16, seabed_depth_m=12.0, seabed_albedo=0.3,
                          e0=1 - share, sun_mu0=0.8, sun_beam=share / 0.8)
    d = 12.0 - 0.01
    got = tables.pixel_radiance(a=ib4.a, b=ib4.b, e0=np.ones(4), depth_o=np.array([[d]]),
                                v_y=np.array([[-1.0]]), s=np.array([[np.inf]]))[0]
    np.testing.assert_allclose(got, lf.radiance(d, -1.0).ravel(), rtol=0.02)
