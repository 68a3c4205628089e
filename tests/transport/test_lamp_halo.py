"""The lamps' glow (aquaspec.transport.lamp_halo): the diffusion solution against
its one-dimensional convolution integral and the diffusion equation, its far
field, the phase functions' mean cosine, the table and what it adds."""

import numpy as np
import pytest
from scipy.integrate import quad

from aquaspec.light.lamp import Lamp
from aquaspec.transport import lamp_halo as lh
from aquaspec.transport.lamp_depths import depth_boundaries, depth_coordinate
from aquaspec.transport.lamp_scattering import LampInputs
from aquaspec.transport.sun_scattering import log_phase_table

A, BS, G = 0.1, 0.8, 0.2


def medium():
    c = A + BS
    d = 1.0 / (3.0 * (A + BS * (1.0 - G)))
    return BS, c, d, np.sqrt(A / d)


@pytest.mark.parametrize("r", [0.05, 0.5, 2.0, 10.0])
def test_closed_form_against_the_convolution(r):
    """phi(r) = b* / (2 D kappa r) int_0^inf exp(-c rho) / rho
    (exp(-kappa |r - rho|) - exp(-kappa (r + rho))) d rho: the unscattered
    light's first scattering convolved with the diffusion Green function."""
    bs, c, d, k = medium()
    f = lambda rho: np.exp(-c * rho) / rho * (np.exp(-k * abs(r - rho)) - np.exp(-k * (r + rho)))
    integral = quad(f, 0, r, limit=200)[0] + quad(f, r, np.inf, limit=200)[0]
    np.testing.assert_allclose(lh.halo_fluence(r, bs, c, d, k), bs / (2 * d * k * r) * integral,
                               rtol=1e-8)


def test_diffusion_equation_and_far_field():
    """-D (1/r) (r phi)'' + a phi = b* exp(-c r) / r^2 (unit intensity); far away
    r phi exp(kappa r) -> b* ln((c + kappa) / (c - kappa)) / (2 D kappa)."""
    bs, c, d, k = medium()
    r = np.array([0.3, 1.0, 3.0, 8.0])
    h = 1e-3
    phi = lambda x, *m: lh.halo_fluence(x, *(np.atleast_1d(v) for v in m))[..., 0]
    rp = lambda x: x * phi(x, bs, c, d, k)
    second = (rp(r + h) - 2 * rp(r) + rp(r - h)) / h ** 2
    lhs = -d * second / r + A * phi(r, bs, c, d, k)
    np.testing.assert_allclose(lhs, bs * np.exp(-c * r) / r ** 2, rtol=2e-4)
    far = 40.0 * lh.halo_fluence(40.0, bs, c, d, k) * np.exp(k * 40.0)
    np.testing.assert_allclose(far, bs * np.log((c + k) / (c - k)) / (2 * d * k), rtol=1e-3)
    # Absorption above diffusion's kappa (alpha = c - kappa < 0): still the equation.
    d2 = 1.0 / (3.0 * (2.0 + 0.1))
    k2 = np.sqrt(2.0 / d2)
    assert k2 > 2.1
    rp2 = lambda x: x * phi(x, 0.1, 2.1, d2, k2)
    second = (rp2(r + h) - 2 * rp2(r) + rp2(r - h)) / h ** 2
    lhs = -d2 * second / r + 2.0 * phi(r, 0.1, 2.1, d2, k2)
    np.testing.assert_allclose(lhs, 0.1 * np.exp(-2.1 * r) / r ** 2, rtol=2e-3)


def test_phase_asymmetry():
    b = np.array([0.1, 0.3])
    wl = np.array([450.0, 600.0])
    np.testing.assert_allclose(lh.phase_asymmetry(log_phase_table("hg", b=b, wavelength_nm=wl,
                                                                  g=0.8)), 0.8, atol=1e-4)
    assert np.all(np.abs(lh.phase_asymmetry(log_phase_table("isotropic", b=b,
                                                            wavelength_nm=wl))) < 1e-6)


def inputs(lamp, b=(0.4, 0.2), forward=(0.5, 0.3)):
    b = np.asarray(b, float)
    table = log_phase_table("hg", b=b, wavelength_nm=np.array([450.0, 600.0]), g=0.8)
    f = np.asarray(forward, float)
    return LampInputs(lamp, np.array([2.0, 1.0]), 0.1 + (1 - f) * b, 0.1 + (1 - f) * b, b,
                      table, forward=f)


def test_table_and_what_it_adds():
    lamp = Lamp((0.0, -5.0, 0.0), cone_deg=180.0, intensity_w_sr=1.0, frame="world")
    inp = inputs(lamp)
    assert inp.iso_fraction == pytest.approx(1.0, rel=1e-6)
    table = lh.lamp_halo_table(inp)
    t = depth_boundaries()[1:-1]
    _, bs, gs, d, k = lh.reduced_medium(inp.b, inp.c_lamp, inp.forward_share,
                                        lh.phase_asymmetry(inp.log_phase))
    np.testing.assert_allclose(bs, (1 - inp.forward_share) * inp.b)
    np.testing.assert_allclose(gs, (0.8 - inp.forward_share) / (1 - inp.forward_share),
                               atol=1e-4)
    phi = lh.halo_fluence(t, bs, inp.c_lamp, d, k)
    values = lh.halo_lookup(table, t, depth_coordinate)
    np.testing.assert_allclose(values[..., 0], phi / 4, rtol=1e-9)
    # Between the nodes up to 5 m, linear in r phi: within 1 % of the closed form
    # (further out the steps are metres long and the glow's exponential bends within them).
    mid = np.sqrt(t[3:-1] * t[4:])
    mid = mid[mid < 5.0]
    np.testing.assert_allclose(lh.halo_lookup(table, mid, depth_coordinate)[..., 0],
                               lh.halo_fluence(mid, bs, inp.c_lamp, d, k) / 4, rtol=0.01)
    # The flux is cut where a P1 radiance would go negative (|F| <= phi / 3).
    assert np.all(values[..., 1] <= values[..., 0] * 2.0 / 3.0 * (1 + 1e-9))
    # On a wall 2 m away: facing the lamp brighter than facing away, never negative;
    # the glow along a ray grows with its length.
    p = np.array([[0.0, -5.0, -2.0], [0.0, -5.0, -2.0]])
    n = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, -1.0]])
    e = lh.halo_on_surfaces(inp, p, n)
    assert np.all(e[0] > e[1]) and np.all(e[1] >= 0)
    v = np.array([[0.0, 0.0, -1.0]])
    short = lh.halo_veil(inp, [0.3, -5.0, 0.0], v, np.array([1.0]))
    long = lh.halo_veil(inp, [0.3, -5.0, 0.0], v, np.array([4.0]))
    assert np.all(long > short) and np.all(short > 0)
    # No scattering, no glow.
    clear = inputs(lamp, b=(0.0, 0.0))
    assert np.all(lh.halo_on_surfaces(clear, p, n) == 0)


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")
def test_spot_factor():
    """A spot lamp's glow over the point source's of the same power: 1 for a
    point lamp; its mean over the sphere 1 (the power); on the axis 2 m out,
    against the diffusion source integrated directly (the line integrals of the
    Green function along the lamp's directions, weighted by its profile)."""
    from aquaspec.transport.lamp_halo import halo_tables  # noqa: F401 (public API)
    point = Lamp((0.0, -5.0, 0.0), cone_deg=180.0, intensity_w_sr=1.0, frame="world")
    np.testing.assert_allclose(lh.spot_factor(inputs(point), [0.5, 2.0]), 1.0)
    spot = Lamp((0.0, -5.0, 0.0), direction=(0, 0, -1), cone_deg=40.0, power_w=10.0,
                frame="world")
    inp = inputs(spot, b=(0.547, 1.627), forward=(0.117, 0.117))
    alpha = np.linspace(0.0, np.pi, 721)
    a = lh.spot_factor(inp, [2.0], alpha)
    mean = 0.5 * np.sum(0.5 * (a[..., 1:] * np.sin(alpha[1:]) + a[..., :-1] * np.sin(alpha[:-1]))
                        * np.diff(alpha), axis=-1)
    np.testing.assert_allclose(mean, 1.0, rtol=2e-3)
    # l = 0 is the closed form.
    _, bs, _, d, k = lh.reduced_medium(inp.b, inp.c_lamp, inp.forward_share,
                                       lh.phase_asymmetry(inp.log_phase))
    q0 = lh._radial_moments(np.array([0.5, 2.0]), inp.c_lamp[0], k[0], [0])[:, 0]
    np.testing.assert_allclose(4 * np.pi * bs[0] / d[0] * q0,
                               lh.halo_fluence(np.array([0.5, 2.0]), bs[0], inp.c_lamp[0], d[0],
                                               k[0])[:, 0], rtol=1e-6)
    # Directly: phi(x) = b* int dOmega' f int drho exp(-c rho) G(|x - rho w'|).
    i = 1
    c = inp.c_lamp[i]

    def line(mu):
        def g(rho):
            s = np.sqrt(max(4.0 + rho * rho - 4.0 * rho * mu, 1e-12))
            return np.exp(-c * rho - k[i] * s) / (4 * np.pi * d[i] * s)
        return quad(g, 0, 60, points=[2.0 * mu] if mu > 0 else None, limit=400)[0]
    th = np.linspace(0.0, np.pi, 181)
    ks = np.array([line(np.cos(x)) for x in th])
    w = np.sin(th)
    integ = lambda y: np.sum(0.5 * (y[1:] + y[:-1]) * np.diff(th))
    direct = integ(spot.relative_intensity(th) * ks * w) / (inp.iso_fraction * integ(ks * w))
    assert a[i, 0, 0] == pytest.approx(direct, rel=0.03)
