"""Tests of the display transform (aquaspec.colour.display)."""

import math

import numpy as np
import pytest

from aquaspec.colour import display
from aquaspec.colour.srgb import srgb_encode
from aquaspec.errors import AquaspecError

EXACT = dict(rtol=1e-12, atol=1e-12)


def _scene(h=24, w=32, seed=0):
    """A smooth, blue-green underwater-like image with a bright patch."""
    rng = np.random.default_rng(seed)
    base = np.array([0.02, 0.10, 0.15])
    img = base * rng.uniform(0.5, 1.5, size=(h, w, 1))
    img[:3, :5] = [400.0, 600.0, 700.0]       # Snell's window: 15 bright pixels (2 %)
    return img


class TestQuantize:
    def test_uint8_codes(self):
        q = display.quantize(np.array([0.0, 1 / 255, 0.5, 1.0, 1.7, -0.2]), 8)
        assert q.dtype == np.uint8
        assert q.tolist() == [0, 1, 128, 255, 255, 0]

    def test_uint16_codes(self):
        q = display.quantize(np.array([0.0, 1.0, 0.5]), 16)
        assert q.dtype == np.uint16
        assert q.tolist() == [0, 65535, 32768]

    @pytest.mark.parametrize("bad", [12, 32, True, "8"])
    def test_bad_bit_depth(self, bad):
        with pytest.raises(AquaspecError, match="accepted: 8, 16"):
            display.quantize(np.zeros(3), bad)


class TestTonemap:
    @pytest.mark.parametrize("method", sorted(display.TONEMAPS))
    def test_monotonic_zero_and_bounded(self, method):
        x = np.concatenate([np.linspace(0, 2, 4001), np.geomspace(2, 1e6, 2000)])
        y = display.tonemap(x, method)
        assert y[0] == 0.0
        assert np.all(np.diff(y) >= 0)
        assert np.all((y >= 0) & (y <= 1))

    @pytest.mark.parametrize("method", ["filmic", "hable", "reinhard"])
    def test_curves_rise_strictly_below_saturation(self, method):
        x = np.linspace(0, 1, 1001)
        assert np.all(np.diff(display.tonemap(x, method)) > 0)

    def test_filmic_is_narkowicz_curve_and_saturates(self):
        # Independent evaluation of the published fit at x = 1.
        assert display.tonemap(1.0, "filmic") == pytest.approx(2.54 / 3.16, rel=1e-12)
        # It reaches 1 where 0.08 x^2 - 0.56 x - 0.14 = 0, x ~= 7.24, and stays there.
        x_sat = (0.56 + math.sqrt(0.56 ** 2 + 4 * 0.08 * 0.14)) / 0.16
        assert display.tonemap(0.99 * x_sat, "filmic") < 1.0
        assert display.tonemap(1.01 * x_sat, "filmic") == 1.0
        assert display.tonemap(1e9, "filmic") == 1.0

    @pytest.mark.parametrize("method", sorted(display.TONEMAPS))
    def test_huge_finite_values_saturate_without_nan(self, method):
        assert display.tonemap(np.array([1e200, 1e308]), method) == pytest.approx(1.0)

    def test_reinhard_never_reaches_one(self):
        assert display.tonemap(1e6, "reinhard") < 1.0

    def test_none_clips(self):
        np.testing.assert_array_equal(display.tonemap(np.array([-1, 0.25, 3.0]), "none"),
                                      [0, 0.25, 1])

    def test_negative_input_gives_zero(self):
        for m in display.TONEMAPS:
            assert display.tonemap(-3.0, m) == 0.0

    def test_unknown_method_names_value_and_accepted(self):
        with pytest.raises(AquaspecError) as e:
            display.tonemap(1.0, "aces2")
        assert "'aces2'" in str(e.value) and "'filmic'" in str(e.value)


class TestExposure:
    def test_manual_ev_scales_by_power_of_two(self):
        img = _scene()
        np.testing.assert_allclose(display.exposure_ev(img, 3), img * 8, **EXACT)
        np.testing.assert_allclose(display.exposure_ev(img, -1.5), img * 2 ** -1.5, **EXACT)

    @pytest.mark.parametrize("bad", [float("nan"), float("inf"), 100, "bright", None, True])
    def test_bad_ev(self, bad):
        with pytest.raises(AquaspecError, match="EV"):
            display.exposure_ev(_scene(), bad)

    @pytest.mark.parametrize("level", [1e-6, 0.03, 1.0, 250.0])
    @pytest.mark.parametrize("key", [0.18, 0.5])
    def test_auto_maps_constant_image_to_key(self, level, key):
        img = np.full((8, 10, 3), level)
        ev = display.auto_exposure(img, key=key)
        out = display.exposure_ev(img, ev)
        np.testing.assert_allclose(out, key, rtol=1e-12)

    def test_auto_uses_mean_of_channels(self):
        img = np.ones((4, 4, 3)) * [0.1, 0.2, 0.6]   # mean 0.3
        ev = display.auto_exposure(img, key=0.18)
        assert ev == pytest.approx(math.log2(0.18 / 0.3), rel=1e-12)

    def test_auto_is_geometric_mean(self):
        img = np.ones((2, 1, 3))
        img[0] *= 0.1
        img[1] *= 0.4           # geometric mean 0.2
        ev = display.auto_exposure(img, key=0.18, percentile=100)
        assert ev == pytest.approx(math.log2(0.18 / 0.2), rel=1e-12)

    def test_auto_ignores_a_few_bright_pixels(self):
        img = _scene()
        dark = img.copy()
        dark[:3, :5] = dark[5, 5]
        ev_bright = display.auto_exposure(img)
        ev_dark = display.auto_exposure(dark)
        assert abs(ev_bright - ev_dark) < 0.05
        # Without the percentile cut the window would drag the exposure down.
        assert display.auto_exposure(img, percentile=100) < ev_dark - 0.2

    def test_auto_scale_invariant(self):
        img = _scene()
        ev = display.auto_exposure(img)
        assert display.auto_exposure(img * 1e-4) == pytest.approx(ev + math.log2(1e4), rel=1e-9)

    def test_black_pixels_do_not_send_exposure_to_infinity(self):
        img = np.full((10, 10, 3), 0.1)
        img[:5] = 0.0
        ev = display.auto_exposure(img)
        assert math.isfinite(ev)
        assert display.auto_exposure(np.zeros((4, 4, 3))) == 0.0

    @pytest.mark.parametrize("kw", [dict(key=0), dict(key=2), dict(percentile=0),
                                    dict(percentile=101), dict(key="mid")])
    def test_bad_auto_settings(self, kw):
        with pytest.raises(AquaspecError, match="accepted"):
            display.auto_exposure(_scene(), **kw)


class TestWhiteBalance:
    def test_grey_world_equalises_channel_means(self):
        img = _scene()
        out = display.white_balance(img, "grey-world")
        means = out.reshape(-1, 3).mean(axis=0)
        np.testing.assert_allclose(means, means.mean(), rtol=1e-12)
        # The overall level is kept.
        assert out.mean() == pytest.approx(img.mean(), rel=1e-12)

    def test_white_patch_makes_reference_neutral(self):
        ref = np.array([0.012, 0.08, 0.11])        # a grey card at depth: little red
        img = _scene()
        img[10, 10] = ref
        out = display.white_balance(img, "white-patch", reference_rgb=ref)
        np.testing.assert_allclose(out[10, 10], np.full(3, ref.mean()), rtol=1e-12)
        # Other pixels get the same per-channel gains.
        np.testing.assert_allclose(out[4, 7] / img[4, 7], ref.mean() / ref, rtol=1e-12)

    def test_none_is_identity(self):
        img = _scene()
        np.testing.assert_array_equal(display.white_balance(img, "none"), img)

    def test_white_patch_needs_positive_reference(self):
        with pytest.raises(AquaspecError, match="reference_rgb"):
            display.white_balance(_scene(), "white-patch")
        with pytest.raises(AquaspecError, match="positive"):
            display.white_balance(_scene(), "white-patch", reference_rgb=[0.0, 0.1, 0.2])
        with pytest.raises(AquaspecError, match="only used by"):
            display.white_balance(_scene(), "grey-world", reference_rgb=[0.1, 0.1, 0.2])

    def test_grey_world_with_empty_channel(self):
        img = _scene()
        img[..., 0] = 0.0
        with pytest.raises(AquaspecError, match="grey-world"):
            display.white_balance(img, "grey-world")

    def test_unknown_method(self):
        with pytest.raises(AquaspecError) as e:
            display.white_balance(_scene(), "auto")
        msg = str(e.value)
        assert "'auto'" in msg and "'grey-world'" in msg and "'white-patch'" in msg


class TestMatrix:
    def test_identity_default_and_applied_per_pixel(self):
        img = _scene()
        np.testing.assert_array_equal(display.apply_matrix(img), img)
        m = np.array([[1.5, -0.3, -0.2], [-0.1, 1.2, -0.1], [0.0, -0.4, 1.4]])
        out = display.apply_matrix(img, m)
        np.testing.assert_allclose(out[3, 4], m @ img[3, 4], rtol=1e-12)

    @pytest.mark.parametrize("bad", [np.eye(2), np.full((3, 3), np.nan), [[1, 2, 3]]])
    def test_bad_matrix(self, bad):
        with pytest.raises(AquaspecError, match="3x3"):
            display.apply_matrix(_scene(), bad)


class TestNonFinite:
    @pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
    def test_to_display_refuses_and_locates(self, bad):
        img = _scene()
        img[5, 7, 1] = bad
        img[9, 2, 0] = bad
        with pytest.raises(AquaspecError) as e:
            display.to_display(img)
        msg = str(e.value)
        assert "2 non-finite" in msg and "row 5, column 7, channel 1" in msg

    @pytest.mark.parametrize("fn", [lambda a: display.auto_exposure(a),
                                    lambda a: display.white_balance(a, "grey-world"),
                                    lambda a: display.exposure_ev(a, 1.0),
                                    lambda a: display.tonemap(a)])
    def test_every_step_refuses_nan(self, fn):
        img = _scene()
        img[0, 0, 0] = np.nan
        with pytest.raises(AquaspecError, match="non-finite"):
            fn(img)

    def test_overflowing_exposure_is_caught(self):
        img = np.full((2, 2, 3), 1e300)
        with pytest.raises(AquaspecError, match="non-finite"):
            display.to_display(img, exposure=64)


class TestToDisplay:
    def test_auto_exposed_constant_image_is_tonemapped_key(self):
        img = np.full((6, 8, 3), 3.7e-3)
        out, info = display.to_display(img, tonemap="none")
        expected = round(255 * (1.055 * 0.18 ** (1 / 2.4) - 0.055))
        assert out.dtype == np.uint8 and out.shape == (6, 8, 3)
        assert np.all(out == expected)
        assert info["exposure_mode"] == "auto"
        assert info["exposure_ev"] == pytest.approx(math.log2(0.18 / 3.7e-3))
        assert info["size"] == [8, 6]

    def test_manual_chain_matches_steps(self):
        img = _scene()
        m = np.array([[1.2, -0.1, -0.1], [-0.05, 1.1, -0.05], [0.0, -0.2, 1.2]])
        out, info = display.to_display(img, exposure=2.5, white_balance="grey-world",
                                       tonemap="hable", matrix=m, bit_depth=16)
        step = display.white_balance(img, "grey-world")
        step = display.apply_matrix(step, m) * 2 ** 2.5
        expect = display.quantize(srgb_encode(display.tonemap(step, "hable")), 16)
        assert out.dtype == np.uint16
        np.testing.assert_array_equal(out, expect)
        assert info["exposure_mode"] == "manual" and info["exposure_ev"] == 2.5
        assert info["matrix"] == m.tolist() and info["bit_depth"] == 16

    def test_white_patch_reference_comes_out_grey(self):
        ref = np.array([0.01, 0.07, 0.09])
        img = _scene()
        img[10:14, 10:14] = ref
        out, info = display.to_display(img, white_balance="white-patch", reference_rgb=ref)
        patch = out[10:14, 10:14].astype(int)
        assert np.all(patch.max(axis=-1) - patch.min(axis=-1) <= 0)
        assert info["reference_rgb"] == pytest.approx(ref.tolist())

    def test_negative_values_counted_and_zeroed(self):
        img = _scene()
        img[1, 1] = [-0.01, 0.02, 0.03]
        out, info = display.to_display(img, exposure=0, tonemap="none")
        assert info["negative_values"] == 1
        assert out[1, 1, 0] == 0

    def test_info_is_json_ready(self):
        import json
        _, info = display.to_display(_scene(), white_balance="grey-world")
        assert json.loads(json.dumps(info, allow_nan=False)) == info

    @pytest.mark.parametrize("kw,match", [
        (dict(exposure="bright"), "'bright'"),
        (dict(exposure=float("nan")), "EV"),
        (dict(exposure=80), "EV"),
        (dict(tonemap="aces"), "'aces'"),
        (dict(white_balance="greyworld"), "'greyworld'"),
        (dict(bit_depth=10), "10"),
    ])
    def test_bad_arguments(self, kw, match):
        with pytest.raises(AquaspecError, match=match):
            display.to_display(_scene(), **kw)

    def test_bad_shape(self):
        with pytest.raises(AquaspecError, match="shape"):
            display.to_display(np.zeros((4, 4)))
        with pytest.raises(AquaspecError, match="height, width, 3"):
            display.to_display(np.zeros((4, 3)))


class TestDisplaySettings:
    def test_settings_are_what_to_display_uses(self):
        img = _scene()
        s = display.display_settings(img, white_balance="grey-world")
        out, info = display.to_display(img, white_balance="grey-world", tonemap="reinhard")
        for k, v in s.items():
            assert info[k] == v
        # Applying the settings by hand gives the same pixels.
        x = display.white_balance(img, "grey-world") * s["exposure_scale"]
        expect = display.quantize(srgb_encode(display.tonemap(x, "reinhard")))
        np.testing.assert_array_equal(out, expect)

    def test_auto_exposure_measured_after_white_balance(self):
        img = np.ones((4, 4, 3)) * [0.01, 0.1, 0.19]     # mean 0.1
        ref = [0.01, 0.1, 0.19]
        s = display.display_settings(img, white_balance="white-patch", reference_rgb=ref)
        # White-patch keeps the reference's channel mean, so the level stays 0.1.
        assert s["exposure_ev"] == pytest.approx(math.log2(0.18 / 0.1), rel=1e-12)
        assert "auto_key" in s and s["exposure_mode"] == "auto"


class TestVonKries:
    @classmethod
    def cones(cls):
        from aquaspec.colour.sensors import get_sensor
        return get_sensor("human").cone_matrix()

    def test_reference_becomes_neutral(self):
        ref = np.array([-0.05, 0.57, 0.88])           # blue water: red outside sRGB
        m = display.von_kries(ref, self.cones())
        np.testing.assert_allclose(m @ ref, np.full(3, ref.mean()), rtol=1e-12)

    def test_grey_reference_changes_nothing(self):
        np.testing.assert_allclose(display.von_kries([0.3, 0.3, 0.3], self.cones()),
                                   np.eye(3), atol=1e-12)

    def test_is_diagonal_in_the_cones(self):
        cones = self.cones()
        m = display.von_kries([0.2, 0.5, 0.9], cones)
        d = cones @ m @ np.linalg.inv(cones)
        np.testing.assert_allclose(d - np.diag(np.diag(d)), 0.0, atol=1e-12)

    def test_bad_reference(self):
        with pytest.raises(AquaspecError, match="cone responses"):
            display.von_kries([-1.0, -1.0, 0.1], self.cones())
        with pytest.raises(AquaspecError, match="three finite"):
            display.von_kries([np.nan, 1.0, 1.0], self.cones())

    def test_to_display_with_cones(self):
        ref = np.array([0.1, 0.5, 0.9])
        img = np.broadcast_to(ref, (4, 4, 3)).copy()
        colour = np.diag([1.0, 1.1, 0.9])
        out, info = display.to_display(img, white_balance="white-patch", reference_rgb=ref,
                                       matrix=colour, cone_matrix=self.cones(),
                                       exposure=0.0, tonemap="none")
        adapt = np.array(info["adaptation_matrix"])
        np.testing.assert_allclose(info["matrix"], colour @ adapt, rtol=1e-12)
        assert info["white_balance_gains"] == [1.0, 1.0, 1.0]
        # Without the colour matrix the reference's pixels come out grey.
        out, _ = display.to_display(img, white_balance="white-patch", reference_rgb=ref,
                                    cone_matrix=self.cones(), exposure=0.0, tonemap="none")
        assert np.ptp(out[0, 0].astype(int)) <= 1
