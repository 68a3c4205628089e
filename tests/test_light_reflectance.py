"""Surface light spectra and reflectances."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light import LIGHTS, fresnel_transmittance, surface_light
from aquaspec.reflectance import (Reflectance, _srgb_matrix, _FIT_WL, colorchecker,
                                  fit_sigmoid, fit_sigmoid_image, sigmoid_band_values,
                                  sigmoid_spectrum)


class TestLight:
    @pytest.mark.parametrize("kind", LIGHTS)
    def test_scaled_total(self, kind):
        l = surface_light(kind, total_w_m2=50.0)
        np.testing.assert_allclose(l.total_w_m2(), 50.0, rtol=1e-9)
        np.testing.assert_allclose((l.on_bands(Bands(10)) * 30).sum(), 50.0, rtol=1e-9)

    def test_overcast_flat(self):
        e = surface_light("overcast").on_bands(Bands(5))
        np.testing.assert_allclose(e, 100 / 300)

    def test_sun_sky_level(self):
        hi = surface_light("sun-sky", sun_elevation_deg=80)
        lo = surface_light("sun-sky", sun_elevation_deg=10)
        assert lo.total_w_m2() < 0.2 * hi.total_w_m2()
        # Clear-sky global irradiance is about 1000 W/m^2 at high sun, about
        # 40-45 % of it in 400-700 nm, minus a few percent of Fresnel loss.
        assert 350 < hi.total_w_m2() < 500

    def test_fresnel(self):
        # Normal incidence: 1 - ((n-1)/(n+1))^2.
        np.testing.assert_allclose(fresnel_transmittance(1.0), 1 - (0.33 / 2.33) ** 2)
        assert fresnel_transmittance(0.0) == pytest.approx(0.0, abs=1e-12)

    @pytest.mark.parametrize("kwargs,match", [
        ({"kind": "moonlight"}, "unknown surface light 'moonlight'"),
        ({"kind": "overcast", "total_w_m2": -1.0}, "positive"),
        ({"kind": "sun-sky", "sun_elevation_deg": 95.0}, "1 to 90"),
    ])
    def test_bad(self, kwargs, match):
        with pytest.raises(AquaspecError, match=match):
            surface_light(**kwargs)


class TestSigmoidUpsampling:
    def test_round_trip_rgb(self):
        rgb = np.array([[0.5, 0.3, 0.1], [0.05, 0.2, 0.6], [0.18, 0.18, 0.18], [0.7, 0.6, 0.02]])
        c, res = fit_sigmoid(rgb)
        assert np.all(res < 1e-6)
        back = sigmoid_spectrum(c, _FIT_WL) @ _srgb_matrix().T
        np.testing.assert_allclose(back, rgb, atol=1e-6)

    def test_grey_is_flat(self):
        c, _ = fit_sigmoid(np.array([0.18, 0.18, 0.18]))
        spec = sigmoid_spectrum(c, np.linspace(400, 700, 31))
        assert np.ptp(spec) < 0.01

    def test_image_fit_matches_single(self):
        img = np.array([[[0.5, 0.3, 0.1], [0.1, 0.5, 0.3]]])
        c_img = fit_sigmoid_image(img)
        c_one, _ = fit_sigmoid(np.round(img[0, 1] * 1023) / 1023)
        np.testing.assert_allclose(c_img[0, 1], c_one, rtol=1e-8)

    def test_band_values_are_centre_samples(self):
        c = np.array([0.1, -0.5, 0.3])
        b = Bands(4)
        np.testing.assert_allclose(sigmoid_band_values(c, b), sigmoid_spectrum(c, b.centers_nm))

    def test_nan_refused(self):
        with pytest.raises(AquaspecError, match="NaN"):
            fit_sigmoid(np.array([0.1, np.nan, 0.2]))


class TestReflectance:
    def test_colorchecker(self):
        cc = colorchecker()
        assert len(cc) == 24
        greys = [r.on_bands(Bands(8)).mean() for r in cc[18:]]
        assert np.all(np.diff(greys) < 0)      # white ... black
        red = cc[14].on_bands(Bands(3))        # "red" patch
        assert red[2] > red[0]

    def test_from_rgb(self):
        r = Reflectance.from_rgb([0.6, 0.2, 0.1], name="rust")
        v = r.on_bands(Bands(3))
        assert v[2] > v[1] > v[0] and r.rgb == (0.6, 0.2, 0.1)

    @pytest.mark.parametrize("rgb", [[1.2, 0, 0], [0.1, 0.2], [-0.1, 0.2, 0.3]])
    def test_bad_rgb(self, rgb):
        with pytest.raises(AquaspecError, match="albedo"):
            Reflectance.from_rgb(rgb)
