"""A RenderResult in a notebook: its image, and a one-line summary."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image

from aquaspec.rendering.result import RenderResult

PARAMS = {"water": {"name": "IB"}, "depth_m": 5.0, "sensor": {"name": "human"},
          "bands": {"n": 8}, "ms_model": "lightfield",
          "display": {"exposure_mode": "auto", "exposure_ev": -2.5},
          "light": {"total_w_m2_400_700": 100.0}}


def result(display=None, linear=None, params=PARAMS):
    rng = np.random.default_rng(1)
    display = rng.integers(0, 256, (6, 8, 3), dtype=np.uint8) if display is None else display
    linear = np.ones((6, 8, 3)) if linear is None else linear
    return RenderResult(display, linear, None, None, params)


class TestRenderResultInANotebook:
    def test_repr_is_a_short_summary(self):
        text = repr(result())
        assert text == ("RenderResult(8x6, water IB, depth 5 m, sensor human, 8 bands, "
                        "model lightfield, exposure -2.50 EV)")
        assert "array" not in text

    def test_repr_png_is_the_display_image(self):
        res = result()
        png = res._repr_png_()
        assert png.startswith(b"\x89PNG")
        np.testing.assert_array_equal(np.asarray(Image.open(io.BytesIO(png))), res.display)

    def test_repr_without_parameters(self):
        assert repr(result(params={})) == "RenderResult(8x6)"


class TestWarnings:
    def test_black(self):
        (w,) = result(linear=np.zeros((6, 8, 3))).warnings()
        assert w.startswith("the image is black: no light reaches the camera at 5 m in water IB")

    def test_lift_relative_to_the_light(self):
        dark = {**PARAMS, "display": {"exposure_mode": "auto", "exposure_ev": 30.0}}
        (w,) = result(params=dark).warnings()
        assert "brightened the image by +30.0 EV, 30 stops more" in w
        # (The same EV under a light 2^15 times dimmer is no more than it needs.)
        dim = {**dark, "light": {"total_w_m2_400_700": 100.0 / 2 ** 15}}
        assert result(params=dim).warnings() == []

    def test_manual_exposure_is_the_users_choice(self):
        fixed = {**PARAMS, "display": {"exposure_mode": "manual", "exposure_ev": 40.0}}
        assert result(params=fixed).warnings() == []
        assert result().warnings() == []
