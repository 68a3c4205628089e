"""The analytic model against numerical quadrature and closed forms."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import integrate

from aquaspec.transport import monzon2022 as model
from aquaspec.medium.water import JERLOV_TYPES, load_water

REL_TOL = 1e-9


def quad_path_integral(c, kd, d_o, v_y, s):
    """int_0^S exp(-c t) exp(-Kd (d_o - t v_y)) dt by adaptive quadrature.

    The integrand is exp(-Kd d_o - k t); the interval is split at multiples
    of the decay length so quad sees a smooth, well-scaled function.
    """
    s = float(model.ray_length(s, d_o, v_y))
    k = c - kd * v_y
    f = lambda t: np.exp(-kd * d_o - k * t)  # noqa: E731
    if np.isinf(s):
        val, _ = integrate.quad(f, 0, np.inf, epsabs=0, epsrel=1e-13, limit=500)
        return val
    scale = 1.0 / max(abs(k), 1e-12)
    if k > 0:
        s = min(s, 100 * scale)  # the rest is below exp(-100) of the total
    edges = np.unique(np.r_[np.arange(0.0, s, scale)[:200], s])
    total = 0.0
    for a, b in zip(edges[:-1], edges[1:]):
        val, _ = integrate.quad(f, a, b, epsabs=0, epsrel=1e-13, limit=200)
        total += val
    return total


def jerlov_coefficients():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for t in JERLOV_TYPES:
            w = load_water(t)
            sel = (w.wavelength_nm >= 400) & (w.wavelength_nm <= 700)
            for c, kd in zip(w.c[sel], w.kd[sel]):
                yield t, float(c), float(kd)


class TestPathIntegralAgainstQuadrature:
    @pytest.mark.parametrize("depth", [0.0, 0.5, 5.0, 20.0, 50.0])
    @pytest.mark.parametrize("v_y", [-1.0, -0.6, -0.1, 0.0, 0.1, 0.5, 1.0])
    @pytest.mark.parametrize("s", [0.01, 0.7, 3.0, 25.0, np.inf])
    def test_all_jerlov_types(self, depth, v_y, s):
        for wtype, c, kd in jerlov_coefficients():
            got = float(model.ms_path_integral(c, kd, depth, v_y, s))
            want = quad_path_integral(c, kd, depth, v_y, s)
            assert np.isfinite(got), (wtype, c, kd)
            np.testing.assert_allclose(got, want, rtol=REL_TOL, atol=0,
                                       err_msg=f"{wtype} c={c} Kd={kd}")

    @pytest.mark.parametrize("eps", [0.0, 1e-14, -1e-14, 1e-9, -1e-9, 1e-5, -1e-5])
    def test_k_near_zero(self, eps):
        # Choose c so that k = c - Kd v_y is eps exactly: the 0/0 limit.
        kd, v_y, depth, s = 0.3, 0.5, 40.0, 30.0
        c = kd * v_y + eps
        got = float(model.ms_path_integral(c, kd, depth, v_y, s))
        want = quad_path_integral(c, kd, depth, v_y, s)
        np.testing.assert_allclose(got, want, rtol=REL_TOL)

    def test_k_negative_clear_water_looking_up(self):
        # Kd > c happens in clear water; looking up k < 0 and exp(-k S) grows.
        c, kd, depth, v_y = 0.02, 0.08, 50.0, 0.9
        assert c - kd * v_y < 0
        for s in (1.0, 10.0, 55.0, np.inf):
            got = float(model.ms_path_integral(c, kd, depth, v_y, s))
            np.testing.assert_allclose(got, quad_path_integral(c, kd, depth, v_y, s), rtol=REL_TOL)

    def test_up_rays_end_at_surface(self):
        got = model.ms_path_integral(0.2, 0.1, 6.0, 0.5, np.inf)
        np.testing.assert_allclose(got, model.ms_path_integral(0.2, 0.1, 6.0, 0.5, 12.0), rtol=0)

    def test_grazing_up_ray_far_from_the_surface(self):
        # d_o / v_y is finite but k S overflows: the result is exp(-Kd d_o) / k.
        got = model.ms_path_integral(45.0, 0.0, 164.0, 4.0861542384272654e-305, np.inf)
        np.testing.assert_allclose(got, 1 / 45.0, rtol=1e-15)

    def test_zero_length(self):
        assert model.ms_path_integral(0.2, 0.1, 6.0, -0.3, 0.0) == 0.0
        assert model.ms_path_integral(0.2, 0.1, 0.0, 0.3, np.inf) == 0.0

    @settings(max_examples=400, deadline=None)
    @given(c=st.floats(1e-4, 50.0), kd=st.floats(0.0, 50.0), depth=st.floats(0.0, 1e4),
           v_y=st.floats(-1.0, 1.0), s=st.one_of(st.floats(0.0, 1e6), st.just(np.inf)))
    def test_never_nan_or_inf(self, c, kd, depth, v_y, s):
        got = model.ms_path_integral(c, kd, depth, v_y, s)
        assert np.isfinite(got) and got >= 0

    @settings(max_examples=150, deadline=None)
    @given(c=st.floats(0.01, 5.0), kd=st.floats(0.0, 5.0), depth=st.floats(0.0, 50.0),
           v_y=st.floats(-1.0, 1.0), s=st.one_of(st.floats(0.01, 200.0), st.just(np.inf)))
    def test_property_against_quadrature(self, c, kd, depth, v_y, s):
        got = float(model.ms_path_integral(c, kd, depth, v_y, s))
        want = quad_path_integral(c, kd, depth, v_y, s)
        np.testing.assert_allclose(got, want, rtol=REL_TOL, atol=1e-300)


class TestLms:
    def test_horizontal_open_water_closed_form(self):
        b, c, kd, e0, d = 0.3, 0.5, 0.2, 1.7, 4.0
        want = b * e0 / (4 * np.pi) * np.exp(-kd * d) / c
        np.testing.assert_allclose(model.l_ms_seeds(b, c, kd, e0, d, 0.0, np.inf), want,
                                   rtol=1e-14)

    def test_vectorised_over_pixels_and_bands(self):
        b = np.array([0.1, 0.2, 0.3])
        c = b + 0.1
        kd = np.array([0.05, 0.1, 0.2])
        v_y = np.linspace(-1, 1, 5)[:, None]
        s = np.array([1.0, 2.0, np.inf, 3.0, np.inf])[:, None]
        out = model.l_ms_seeds(b, c, kd, 1.0, 5.0, v_y, s)
        assert out.shape == (5, 3)
        for i in range(5):
            for j in range(3):
                np.testing.assert_allclose(
                    out[i, j], model.l_ms_seeds(b[j], c[j], kd[j], 1.0, 5.0, v_y[i, 0], s[i, 0]))

    def test_saturates_with_distance(self):
        vals = [model.l_ms_seeds(0.3, 0.5, 0.2, 1.0, 5.0, -0.2, s) for s in (1, 5, 20, 80, np.inf)]
        assert np.all(np.diff(vals[:-1]) > 0)
        np.testing.assert_allclose(vals[-2], vals[-1], rtol=1e-12)


class TestSurfaces:
    def test_transmittance(self):
        np.testing.assert_allclose(model.transmittance(0.5, 2.0), np.exp(-1.0))
        assert model.transmittance(0.5, np.inf) == 0.0

    def test_ambient_models(self):
        e = model.ambient_irradiance(2.0, 0.1, 10.0, np.array([1.0, 0.0, -1.0]), "cosine")
        np.testing.assert_allclose(e, 2.0 * np.exp(-1.0) * np.array([1.0, 0.5, 0.0]))
        u = model.ambient_irradiance(2.0, 0.1, 10.0, np.array([1.0, 0.0, -1.0]), "uniform")
        np.testing.assert_allclose(u, 2.0 * np.exp(-1.0))

    def test_unknown_ambient_model(self):
        with pytest.raises(ValueError, match="unknown ambient model 'flat'.*cosine"):
            model.ambient_irradiance(1, 0.1, 1, 0.0, "flat")

    def test_pixel_radiance_grey_card(self):
        a, b, kd, e0, d, s, rho = 0.2, 0.3, 0.15, 1.0, 5.0, 3.0, 0.18
        c = a + b
        want = (np.exp(-c * s) * rho / np.pi * e0 * np.exp(-kd * d) * 0.5
                + b * e0 / (4 * np.pi) * np.exp(-kd * d) * (1 - np.exp(-c * s)) / c)
        got = model.pixel_radiance(a=a, b=b, kd=kd, e0=e0, depth_o=d, v_y=0.0, s=s, rho=rho,
                                   surface_depth=d, n_y=0.0)
        np.testing.assert_allclose(got, want, rtol=1e-14)
