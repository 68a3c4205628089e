"""The solved light field evaluated anywhere: tilted irradiance, ray integrals."""

import numpy as np
import pytest
from scipy.integrate import quad

from aquaspec.transport.lightfield.field import clamped_cosine_azimuth
from aquaspec.transport.lightfield.solve import solve_lightfield


RAY_TOL = 1e-9


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
