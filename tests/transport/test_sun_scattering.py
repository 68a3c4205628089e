"""The sun's single scattering (aquaspec.transport.sun_scattering): closed forms, the march, phase tables."""

import numpy as np
import pytest

from aquaspec.transport import monzon2022 as model
from aquaspec.transport import sun_scattering as S
from aquaspec.medium.phase_bands import band_phase_values
from aquaspec.light.sun import refracted_to_sun
from aquaspec.scene.shadowmap import map_visibility, shadow_map_numpy, shadow_map_spec
from support.plates import exact_visibility, plate_scene


B = np.array([0.05, 0.2, 0.4])
C = np.array([0.08, 0.3, 0.9])
BEAM = np.array([1.0, 2.0, 0.5])
MU0 = 0.8


def _quad_ss(phase_value, d_o, v_y, s, c_sun=C, c_view=C, n=200001):
    """``b p int_0^S E_b(d(t)) exp(-c t) dt`` by the trapezoid rule."""
    s_end = model.ray_length(s, d_o, v_y)
    s_end = min(float(s_end), 400.0)
    t = np.linspace(0.0, s_end, n)[:, None]
    d = d_o - t * v_y
    f = BEAM * np.exp(-c_sun * d / MU0) * np.exp(-c_view * t)
    return B * phase_value * np.trapezoid(f, t[:, 0], axis=0)


@pytest.mark.parametrize("v_y,s", [(-0.5, 7.0), (0.0, np.inf), (-0.9, np.inf), (0.6, np.inf),
                                   (0.95, 2.0), (0.3, 0.0)])
def test_open_single_scattering_against_quadrature(v_y, s):
    p = np.array([0.1, 0.05, 0.02])
    got = S.single_scattering_open(b=B, phase_value=p, beam0=BEAM, c_sun=C, c_view=C,
                                   depth_o=4.0, v_y=v_y, s=s, mu0=MU0)
    want = _quad_ss(p, 4.0, v_y, s)
    assert np.allclose(got, want, rtol=1e-5, atol=1e-12)


def test_open_single_scattering_k_negative():
    # Clear water looking up steeply: k = c_view - c_sun v_y / mu0 < 0.
    c_sun, c_view = np.array([0.5, 0.5, 0.5]), np.array([0.1, 0.2, 0.3])
    p = np.ones(3)
    got = S.single_scattering_open(b=B, phase_value=p, beam0=BEAM, c_sun=c_sun, c_view=c_view,
                                   depth_o=10.0, v_y=0.99, s=np.inf, mu0=MU0)
    assert np.all(c_view - c_sun * 0.99 / MU0 < 0)
    assert np.allclose(got, _quad_ss(p, 10.0, 0.99, np.inf, c_sun, c_view), rtol=1e-6)


@pytest.mark.parametrize("k", [-0.3, -1e-12, 0.0, 1e-9, 0.7, 40.0])
def test_march_weights_sum_to_the_integral(k):
    w = S.march_weights(np.array([k]), np.array(5.0), 48)
    exact = 5.0 if k == 0 else -np.expm1(-k * 5.0) / k
    assert np.isclose(w.sum(), exact, rtol=1e-9)
    assert np.all(w > 0)


@pytest.mark.parametrize("v_y,s", [(-0.5, 7.0), (0.0, np.inf), (0.6, np.inf), (-0.2, np.inf)])
def test_march_without_shadow_is_the_closed_form(v_y, s):
    p = np.array([0.1, 0.05, 0.02])
    kw = dict(b=B, phase_value=p, beam0=BEAM, c_sun=C, c_view=C, depth_o=4.0, v_y=np.array(v_y),
              s=np.array(s), mu0=MU0)
    open_ = S.single_scattering_open(**kw)
    marched = S.single_scattering_marched(**kw, visibility=np.ones_like)
    # Exact up to the tail left out (at most TAIL of the slowest band).
    assert np.all(marched <= open_ * (1 + 1e-12))
    assert np.allclose(marched, open_, rtol=S.TAIL * 1.01)


def test_march_with_half_the_ray_shadowed():
    # V = 0 beyond t = 3 m: the integral stops there, in closed form.
    p = np.ones(3)
    kw = dict(b=B, phase_value=p, beam0=BEAM, c_sun=C, c_view=C, depth_o=4.0,
              v_y=np.array(0.0), s=np.array(6.0), mu0=MU0)
    got = S.single_scattering_marched(**kw, visibility=lambda t: (t < 3.0).astype(float),
                                      n_steps=60)
    want = S.single_scattering_open(**{**kw, "s": np.array(3.0)})
    assert np.allclose(got, want, rtol=1e-9)


def test_phase_table_interpolates_the_band_phase():
    wl = np.array([450.0, 550.0, 650.0])
    b = np.array([0.1, 0.2, 0.3])
    tab = S.log_phase_table("petzold", b=b, wavelength_nm=wl)
    cos = np.cos(np.radians([0.05, 0.5, 3.0, 20.0, 90.0, 170.0]))
    exact = band_phase_values("petzold", cos, b=b, wavelength_nm=wl)
    assert np.allclose(S.phase_from_log_table(tab, cos), exact, rtol=0.02)
    # Normalised: 2 pi int p dmu = 1 per band (on the table's own grid).
    theta = np.pi * np.linspace(0, 1, 20001) ** 2
    dens = S.phase_from_log_table(tab, np.cos(theta)) * np.sin(theta)[:, None] * 2 * np.pi
    assert np.allclose(np.trapezoid(dens, theta, axis=0), 1.0, rtol=0.02)


def test_shadowed_veil_against_direct_integration():
    """A camera looking through the plate's shadow: marched against the map
    vs the integral with the exact visibility on a fine grid."""
    scene = plate_scene()
    to_sun = refracted_to_sun(50.0, 120.0)
    spec = shadow_map_spec(scene.bounds(), np.array([0.0, -3.0, 0.0]), to_sun, size=512,
                             radius_m=25.0)
    hmap = shadow_map_numpy(scene, spec)
    o = np.array([0.0, -3.0, 0.0])
    rays = np.array([[-0.5, 0.0, -1.0], [-1.0, -0.2, -0.3], [0.3, -0.1, -1.0]])
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    c = np.array([0.1, 0.3])
    b = np.array([0.05, 0.2])
    beam = np.array([1.0, 1.0])
    mu0 = to_sun[1]
    for v in rays:
        s_end = (6.0 - 3.0) / -v[1] if v[1] < 0 else np.inf
        got = S.single_scattering_marched(
            b=b, phase_value=np.ones(2), beam0=beam, c_sun=c, c_view=c, depth_o=3.0,
            v_y=np.array(v[1]), s=np.array(s_end), mu0=mu0, n_steps=96,
            visibility=lambda t, v=v: map_visibility(hmap, spec, o + t[..., None] * v))
        t = np.linspace(0.0, min(s_end, 80.0), 400001)
        pts = o + t[:, None] * v
        f = exact_visibility(pts, to_sun)[:, None] * np.exp(
            -c * (-pts[:, 1:2]) / mu0 - c * t[:, None])
        want = b * beam * np.trapezoid(f, t, axis=0)
        assert np.allclose(got, want, rtol=0.02), (v, got, want)
