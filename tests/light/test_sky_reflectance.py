"""Surface light spectra and reflectances."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import LIGHTS, surface_light
from aquaspec.colour.reflectance import (Reflectance, _srgb_matrix, _FIT_WL, colorchecker,
                                  fit_sigmoid, fit_sigmoid_image, fit_sigmoid_many,
                                  sigmoid_band_values, sigmoid_spectrum)


class TestLight:
    # ("none", no daylight, takes no total: tests/light/test_lamp.py.)
    @pytest.mark.parametrize("kind", [k for k in LIGHTS if k != "none"])
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

    def test_many_matches_continuation(self):
        # Random colours in the cube: the table's start and the continuation
        # from grey end at the same coefficients, never at a worse fit.
        rgb = np.random.default_rng(5).random((400, 3))
        c_ref, r_ref = fit_sigmoid(rgb)
        c, r = fit_sigmoid_many(rgb)
        assert np.all(r <= r_ref + 1e-12)
        good = r_ref < 1e-9
        assert good.mean() > 0.9
        np.testing.assert_allclose(c[good], c_ref[good], rtol=1e-6, atol=1e-8)

    def test_many_needs_no_continuation_in_the_gamut(self, monkeypatch):
        # The table's guesses converge on their own: the continuation is only
        # a fallback (for colours no reflectance has).
        import aquaspec.colour.reflectance as refl

        def refuse(*args, **kwargs):
            raise AssertionError("fell back to the continuation fit")
        rgb = 0.05 + 0.9 * np.random.default_rng(6).random((300, 3))
        monkeypatch.setattr(refl, "fit_sigmoid", refuse)
        c, r = refl.fit_sigmoid_many(rgb)
        assert np.all(r < 1e-9)

    def test_many_at_the_cube_edges(self):
        # Black, white, the primaries and their neighbours: finite, and no
        # worse than the continuation.
        v = np.array([0.0, 1 / 1023, 0.01, 0.5, 0.99, 1022 / 1023, 1.0])
        rgb = np.stack(np.meshgrid(v, v, v, indexing="ij"), axis=-1).reshape(-1, 3)
        c_ref, r_ref = fit_sigmoid(rgb)
        c, r = fit_sigmoid_many(rgb)
        assert np.all(np.isfinite(c))
        assert np.all(r <= r_ref + 1e-12)

    def test_sigmoid_table_holds_fits_of_its_colours(self):
        from aquaspec.colour.reflectance import (_build_sigmoid_table, _fit_residual,
                                          _table_brightness, _table_colours)
        n = 6
        table = _build_sigmoid_table(n)
        z = _table_brightness(n)
        for j in (0, n // 2, n - 1):
            colours = _table_colours(n, z[j]).reshape(-1, 3)
            coeffs = table[:, :, :, j].reshape(-1, 3)
            res = np.abs(_fit_residual(coeffs, colours)[0]).max(axis=1)
            _, res_ref = fit_sigmoid(colours)
            assert np.all(res <= np.maximum(res_ref, 1e-12) * (1 + 1e-6) + 1e-12)

    def test_table_guess_is_exact_at_nodes(self):
        from aquaspec.colour.reflectance import (SIGMOID_TABLE_SIZE, _table_brightness,
                                          _table_colours, _table_guess, sigmoid_table)
        n = SIGMOID_TABLE_SIZE
        table = sigmoid_table()
        j = 5
        # Nodes of table 1 (green largest) away from the clipped corners.
        colours = _table_colours(n, _table_brightness(n)[j])[1, 3:-3:5, 3:-3:7].reshape(-1, 3)
        expect = table[1, 3:-3:5, 3:-3:7, j].reshape(-1, 3)
        np.testing.assert_allclose(_table_guess(colours), expect, rtol=1e-9, atol=1e-9)

    def test_sigmoid_table_is_cached_on_disk(self, tmp_path, monkeypatch):
        import aquaspec.colour.reflectance as refl
        monkeypatch.setenv("AQUASPEC_CACHE", str(tmp_path))
        monkeypatch.setattr(refl, "SIGMOID_TABLE_SIZE", 5)
        refl.sigmoid_table.cache_clear()
        try:
            first = refl.sigmoid_table()
            files = list(tmp_path.glob("sigmoid-table-*.npz"))
            assert len(files) == 1
            # A damaged file is computed again, to the same numbers.
            files[0].write_bytes(b"not a zip")
            refl.sigmoid_table.cache_clear()
            np.testing.assert_array_equal(refl.sigmoid_table(), first)
        finally:
            refl.sigmoid_table.cache_clear()

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


def test_image_fit_remembers_colours(monkeypatch):
    import aquaspec.colour.reflectance as refl
    monkeypatch.setattr(refl, "_memo_keys", np.zeros(0, dtype=np.int64))
    monkeypatch.setattr(refl, "_memo_coeffs", np.zeros((0, 3)))
    rng = np.random.default_rng(8)
    first = rng.random((6, 5, 3))
    c_first = refl.fit_sigmoid_image(first)
    # A second image with half its colours new: only those are fitted.
    second = np.concatenate([first[:3], rng.random((3, 5, 3))])
    fitted = []
    many = refl.fit_sigmoid_many
    monkeypatch.setattr(refl, "fit_sigmoid_many", lambda rgb: (fitted.append(len(rgb)),
                                                                many(rgb))[1])
    c_second = refl.fit_sigmoid_image(second)
    assert fitted == [15]
    np.testing.assert_array_equal(c_second[:3], c_first[:3])
    # Every colour as fitted alone, whichever call fitted it.
    for img, c in ((first, c_first), (second, c_second)):
        one, _ = fit_sigmoid(np.round(img.reshape(-1, 3) * 1023) / 1023)
        np.testing.assert_allclose(c.reshape(-1, 3), one, rtol=1e-6, atol=1e-8)
    assert np.all(np.diff(refl._memo_keys) > 0) and refl._memo_keys.size == 45
    # Over the limit the memory starts again from the last image.
    monkeypatch.setattr(refl, "MEMO_COLOURS", 40)
    refl.fit_sigmoid_image(rng.random((2, 4, 3)))
    assert refl._memo_keys.size == 8
