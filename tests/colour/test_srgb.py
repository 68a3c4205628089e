"""sRGB's transfer curve (aquaspec.colour.srgb): the standard's formula, both ways."""

import numpy as np
import pytest

from aquaspec.colour import srgb

EXACT = dict(rtol=1e-12, atol=1e-12)


class TestSrgbEncode:
    def test_known_points_match_standard_formula(self):
        # IEC 61966-2-1: 12.92 x below 0.0031308, 1.055 x^(1/2.4) - 0.055 above.
        np.testing.assert_allclose(srgb.srgb_encode(0.0), 0.0, **EXACT)
        np.testing.assert_allclose(srgb.srgb_encode(0.0031308), 12.92 * 0.0031308, **EXACT)
        np.testing.assert_allclose(srgb.srgb_encode(1.0), 1.0, **EXACT)
        np.testing.assert_allclose(srgb.srgb_encode(0.5), 1.055 * 0.5 ** (1 / 2.4) - 0.055,
                                   **EXACT)
        np.testing.assert_allclose(srgb.srgb_encode(0.001), 0.01292, **EXACT)

    def test_continuous_at_the_breakpoint(self):
        lo = srgb.srgb_encode(0.0031308)
        hi = srgb.srgb_encode(np.nextafter(0.0031308, 1.0))
        assert abs(hi - lo) < 1e-6

    def test_monotonic_and_clipped(self):
        x = np.linspace(-0.5, 1.5, 20001)
        y = srgb.srgb_encode(x)
        assert np.all(np.diff(y) >= 0)
        assert np.all(np.diff(y[(x > 0) & (x < 1)]) > 0)
        assert y.min() == 0.0 and y.max() == pytest.approx(1.0, abs=1e-15)

    def test_decode_inverts_encode(self):
        x = np.linspace(0, 1, 1001)
        np.testing.assert_allclose(srgb.srgb_decode(srgb.srgb_encode(x)), x,
                                   rtol=1e-9, atol=1e-12)


def test_decode_is_the_standard_formula():
    # IEC 61966-2-1: v / 12.92 up to 0.04045, ((v + 0.055) / 1.055)^2.4 above; clipped.
    v = np.array([-0.1, 0.0, 0.04045, 0.5, 1.0, 1.2])
    want = np.array([0.0, 0.0, 0.04045 / 12.92, (0.555 / 1.055) ** 2.4, 1.0, 1.0])
    np.testing.assert_allclose(srgb.srgb_decode(v), want, **EXACT)
