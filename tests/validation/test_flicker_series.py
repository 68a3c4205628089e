"""The flicker in time under a moving sea (aquaspec.validation.flicker_series)."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.validation import flicker_series as fs


def test_dominant_period_of_a_sinusoid():
    """A 1.6 Hz sinusoid on noise-free samples: the spectrum peaks at its
    frequency (to the grid's resolution) and its mean frequency is there too."""
    dt, n = 0.05, 200                      # 10 s: 0.1 Hz apart
    t = np.arange(n) * dt
    series = 3.0 + 0.5 * np.sin(2 * np.pi * 1.6 * t + np.array([0.0, 1.0, 2.0])[:, None])
    f, p = fs.power_spectrum(series[None], dt)
    assert p.shape == (1, n // 2 + 1) and f[1] == pytest.approx(0.1)
    period, mean_f = fs.dominant_period(f, p)
    assert period[0] == pytest.approx(1 / 1.6, rel=1e-9)
    assert mean_f[0] == pytest.approx(1.6, abs=0.05)
    with pytest.raises(AquaspecError, match="at least 4 samples"):
        fs.power_spectrum(series[:, :3], dt)


@pytest.mark.slow
def test_flicker_series_of_a_small_sea():
    """A 2 m sea of 32 samples, 8 instants: the CVs in time and over the
    places are finite and positive, fall with depth, and the period is
    within what the record resolves."""
    res = fs.flicker_series(wavelengths_nm=(532.0,), depths=(0.86, 6.73), duration_s=0.8,
                            dt_s=0.1, points=4, tile_m=2.0, grid=32)
    cv_t, cv_s = np.array(res["cv_time"]), np.array(res["cv_space"])
    assert cv_t.shape == (2, 1) and cv_s.shape == (2, 1)
    assert np.all(np.isfinite(cv_t) & (cv_t > 0)) and np.all(cv_s > 0)
    assert cv_t[1, 0] < cv_t[0, 0] and cv_s[1, 0] < cv_s[0, 0]
    period = np.array(res["dominant_period_s"])
    assert np.all((period >= 0.2 - 1e-9) & (period <= 0.8 + 1e-9))
    with pytest.raises(AquaspecError, match="at least 4 instants"):
        fs.flicker_series(duration_s=0.1, dt_s=0.05)
