"""Phase functions: normalisation, backscatter and moments against closed forms."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.phase import (FournierForand, HenyeyGreenstein, Isotropic, PetzoldParticles,
                            PureWaterPhase, band_moments, ff_backscatter_fraction, get_phase,
                            hg_backscatter_fraction, redistribution_matrix)

NORM_TOL = 1e-6


class TestHenyeyGreenstein:
    @pytest.mark.parametrize("g", [0.2, 0.7, 0.92, 0.97])
    def test_normalised_and_backscatter(self, g):
        p = HenyeyGreenstein(g)
        assert abs(p.normalisation() - 1.0) < NORM_TOL
        assert p.backscatter_fraction() == pytest.approx(
            (1 - g) / (2 * g) * ((1 + g) / np.sqrt(1 + g * g) - 1), rel=1e-9)

    def test_moments_are_powers_of_g(self):
        chi = HenyeyGreenstein(0.95).legendre_moments(128)
        np.testing.assert_allclose(chi, 0.95 ** np.arange(129), atol=1e-9)

    def test_bad_g(self):
        with pytest.raises(AquaspecError, match="g=1.0"):
            HenyeyGreenstein(1.0)


class TestFournierForand:
    @pytest.mark.parametrize("bb", [0.005, 0.0183, 0.05])
    def test_backscatter_recovered(self, bb):
        p = FournierForand(bb)
        assert abs(p.normalisation() - 1.0) < 1e-4
        assert p.backscatter_fraction() == pytest.approx(bb, rel=1e-4)
        assert ff_backscatter_fraction(p.n, p.mu_slope) == pytest.approx(bb, rel=1e-9)

    def test_mobley_petzold_parameters(self):
        # Mobley et al. (2002): B = 0.0183 <-> n = 1.10, mu = 3.5835.
        p = FournierForand(0.0183)
        assert p.n == pytest.approx(1.10, abs=1e-3)
        assert p.mu_slope == pytest.approx(3.5835, abs=2e-3)

    def test_out_of_range(self):
        with pytest.raises(AquaspecError, match="B=0.9"):
            FournierForand(0.9)


def test_petzold_normalised_forward_peaked():
    p = PetzoldParticles()
    assert abs(p.normalisation() - 1.0) < NORM_TOL
    chi = p.legendre_moments(64)
    assert 0.9 < chi[1] < 0.96          # particle mean cosine
    assert 0.005 < p.backscatter_fraction() < 0.03
    assert np.all(np.diff(chi) < 0)


def test_pure_water_moments_closed_form():
    p = PureWaterPhase()
    numerical = super(PureWaterPhase, p).legendre_moments(6)   # the graded-grid integral
    np.testing.assert_allclose(p.legendre_moments(6), numerical, atol=1e-9)


def test_petzold_band_mix_moves_towards_water():
    chi = band_moments("petzold", 4, b=[0.004, 1.0], wavelength_nm=[450.0, 450.0])
    # Where water dominates b the mean cosine is near 0 (water's chi_1 = 0).
    assert chi[0, 1] < 0.6 * chi[1, 1]


def test_registry_errors():
    with pytest.raises(AquaspecError, match="'rayleigh'.*isotropic"):
        get_phase("rayleigh")
    with pytest.raises(AquaspecError, match="bad parameters"):
        get_phase("hg", k=3)
    with pytest.raises(AquaspecError, match="wavelength_nm"):
        band_moments("petzold", 4, b=[0.1])


def test_redistribution_rows_sum_to_one():
    from numpy.polynomial.legendre import leggauss
    x, w = leggauss(16)
    mu = np.concatenate([0.5 * (x + 1), -0.5 * (x + 1)])
    ww = np.concatenate([0.5 * w, 0.5 * w])
    chi = HenyeyGreenstein(0.8).legendre_moments(31)
    q = redistribution_matrix(chi, mu, mu, ww)
    np.testing.assert_allclose(q.sum(axis=1), 1.0, atol=1e-12)
    # Isotropic: every direction gets the same share.
    qi = redistribution_matrix(Isotropic().legendre_moments(31), mu, mu, ww)
    np.testing.assert_allclose(qi, np.broadcast_to(ww / 2, qi.shape), atol=1e-14)
