"""Wavelength bands and band averaging."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.colour.bands import Bands, band_average
from aquaspec.errors import AquaspecError, DataRangeError


class TestBands:
    def test_geometry(self):
        b = Bands(3)
        np.testing.assert_allclose(b.edges_nm, [400, 500, 600, 700])
        np.testing.assert_allclose(b.centers_nm, [450, 550, 650])
        assert b.width_nm == 100 and b.weights_nm.sum() == 300

    @pytest.mark.parametrize("n", [0, -3, 1025, 2.5, "8", True])
    def test_bad_n(self, n):
        with pytest.raises(AquaspecError, match="band"):
            Bands(n)

    @pytest.mark.parametrize("lo,hi", [(700, 400), (-5, 700), (400, np.inf)])
    def test_bad_range(self, lo, hi):
        with pytest.raises(AquaspecError, match="wavelength range"):
            Bands(8, lo, hi)


class TestBandAverage:
    def test_linear_function_exact(self):
        wl = np.array([300.0, 800.0])
        vals = 2 * wl + 1
        got = Bands(7).average(wl, vals)
        np.testing.assert_allclose(got, 2 * Bands(7).centers_nm + 1, rtol=1e-12)

    def test_against_fine_integration(self):
        wl = np.linspace(380, 720, 35)
        vals = np.sin(wl / 30.0) ** 2
        b = Bands(5)
        fine = np.linspace(380, 720, 340001)
        f = np.interp(fine, wl, vals)
        for i, (lo, hi) in enumerate(zip(b.edges_nm[:-1], b.edges_nm[1:])):
            m = (fine >= lo) & (fine <= hi)
            np.testing.assert_allclose(b.average(wl, vals)[i],
                                       np.trapezoid(f[m], fine[m]) / (hi - lo), rtol=1e-6)

    def test_narrow_feature_is_averaged_not_sampled(self):
        # A spike between band centres is missed by point sampling but not
        # by averaging: the integral is preserved.
        wl = np.array([400, 419, 420, 421, 700.0])
        vals = np.array([0, 0, 1.0, 0, 0])
        b = Bands(3)
        np.testing.assert_allclose((b.average(wl, vals) * b.width_nm).sum(), 1.0)

    def test_leading_axes(self):
        wl = np.array([400.0, 700.0])
        vals = np.array([[1.0, 1.0], [0.0, 3.0]])
        got = Bands(3).average(wl, vals)
        assert got.shape == (2, 3)
        np.testing.assert_allclose(got[1], [0.5, 1.5, 2.5])

    def test_outside_range_error_and_zero(self):
        wl = np.array([450.0, 650.0])
        with pytest.raises(DataRangeError, match="450-650 nm.*400-700"):
            Bands(3).average(wl, np.ones(2), name="test curve")
        got = Bands(3).average(wl, np.ones(2), outside="zero")
        np.testing.assert_allclose(got, [0.5, 1.0, 0.5], atol=1e-6)

    def test_nan_refused(self):
        with pytest.raises(AquaspecError, match="NaN"):
            band_average([400, 700], [400, 700], [1.0, np.nan])
