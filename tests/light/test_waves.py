"""The wind sea (aquaspec.light.waves): its spectrum, slopes and surface."""

import dataclasses

import numpy as np
import pytest
from scipy.integrate import quad

from aquaspec.errors import AquaspecError
from aquaspec.light import waves as W


def test_pm_spectrum_integrates_to_its_closed_form_variance():
    # int_0^inf alpha / (2 k^3) exp(-beta g^2 / (k^2 U^4)) dk = alpha U^4 / (4 beta g^2)
    for u in (2.0, 7.0):
        num, _ = quad(lambda k: W.pm_spectrum(k, u), 1e-4, np.inf, limit=400)
        exact = W.PM_ALPHA * u ** 4 / (4 * W.PM_BETA * W.GRAVITY ** 2)
        assert num == pytest.approx(exact, rel=1e-6)


def test_spreading_keeps_the_omnidirectional_spectrum():
    # On a ring of wavenumbers the directional spectrum integrates (k dtheta) back to S(k).
    waves = W.Waves(5.0, wind_azimuth_deg=30.0, tile_m=200.0, grid=1024)
    f, kx, kz = W.directional_spectrum(waves)
    k = np.hypot(kx, kz)
    dk = 2 * np.pi / waves.tile_m
    ring = (k > 0.8) & (k < 1.2)
    total = f[ring].sum() * dk * dk
    s_int, _ = quad(lambda q: W.pm_spectrum(q, 5.0), 0.8, 1.2)
    assert total == pytest.approx(s_int, rel=0.02)
    # The waves run downwind: nothing travels against the wind.
    wx, wz = np.sin(np.radians(30.0)), -np.cos(np.radians(30.0))
    assert np.all(f[(kx * wx + kz * wz) < 0] == 0)


def test_sea_statistics_follow_the_spectrum():
    waves = [W.Waves(4.0, seed=s, tile_m=8.0, grid=256) for s in range(4)]
    slope_var = W.resolved_slope_variance(waves[0])
    f, kx, kz = W.directional_spectrum(waves[0])
    dk2 = (2 * np.pi / 8.0) ** 2
    on = f > 0
    ratio = []
    for w in waves:
        amp = W._amplitudes(w)
        h, hx, hz = W.surface(w)
        # Parseval: each mode adds |A|^2 / 2 to the height's variance, k^2 |A|^2 / 2 to the slopes'.
        assert h.var() == pytest.approx(np.sum(np.abs(amp) ** 2) / 2, rel=1e-6)
        assert np.mean(hx ** 2 + hz ** 2) == pytest.approx(
            np.sum((kx ** 2 + kz ** 2) * np.abs(amp) ** 2) / 2, rel=1e-4)   # (Nyquist rows)
        ratio.append(np.abs(amp[on]) ** 2 / (2 * f[on] * dk2))
    # E|A|^2 = 2 F dk^2 over some 10^5 modes
    assert np.mean(ratio) == pytest.approx(1.0, abs=0.01)
    # Cox & Munk's measured slope variance, the plausibility check of the default tile.
    assert 0.7 < slope_var / W.cox_munk_slope_variance(4.0) < 1.3


def test_oversampled_surface_is_the_same_surface():
    w = W.Waves(3.0, grid=64, seed=3)
    h1, hx1, _ = W.surface(w, 1)
    h4, hx4, _ = W.surface(w, 4)
    np.testing.assert_allclose(h4[::4, ::4], h1, atol=1e-12)
    np.testing.assert_allclose(hx4[::4, ::4], hx1, atol=1e-10)


def test_waves_move_with_time():
    a = W.surface(W.Waves(3.0, grid=64, time_s=0.0))[0]
    b = W.surface(W.Waves(3.0, grid=64, time_s=0.7))[0]
    assert np.abs(a - b).max() > 0.1 * np.abs(a).max()


@pytest.mark.parametrize("kwargs, message", [
    ({"wind_speed": 0.0}, "wind speed 0.0"),
    ({"wind_speed": float("nan")}, "wind speed nan"),
    ({"wind_speed": 3.0, "grid": 300}, "power of two"),
    ({"wind_speed": 3.0, "tile_m": -1.0}, "wave tile"),
    ({"wind_speed": 3.0, "seed": -2}, "wave seed"),
    ({"wind_speed": 3.0, "time_s": float("inf")}, "wave time"),
])
def test_bad_waves_are_refused(kwargs, message):
    with pytest.raises(AquaspecError, match=message):
        W.Waves(**kwargs)


@pytest.mark.parametrize("wind, k_lo, k_hi", [(7.0, 0.3, 20.0), (2.0, 0.05, 300.0),
                                              (12.0, 0.01, 0.8)])
def test_pm_slope_variance_is_the_integral(wind, k_lo, k_hi):
    from scipy.integrate import quad
    num = quad(lambda k: k * k * W.pm_spectrum(k, wind), k_lo, k_hi, limit=400,
               points=[np.sqrt(W.PM_BETA) * W.GRAVITY / wind ** 2])[0]
    assert W.pm_slope_variance(k_lo, k_hi, wind) == pytest.approx(num, rel=1e-7)


def test_unresolved_variance_completes_cox_munk():
    for wind in (1.0, 2.0, 3.0):
        # The default tile holds all of Cox & Munk's variance up to 3 m/s.
        assert W.unresolved_slope_variance(W.Waves(wind)) == 0.0
    for wind in (5.0, 10.0):
        w = W.Waves(wind)
        long = W.long_wave_slope_variance(w)
        assert long == pytest.approx(W.pm_slope_variance(1e-9, 2 * np.pi / w.tile_m, wind),
                                     rel=1e-9)
        total = W.resolved_slope_variance(w) + long + W.unresolved_slope_variance(w)
        assert total == pytest.approx(W.cox_munk_slope_variance(wind), rel=1e-12)
        assert W.unresolved_slope_variance(w) > 0.1 * W.cox_munk_slope_variance(wind)
    doc = W.Waves(10.0).describe()
    assert doc["unresolved_slope_variance"] > 0 and doc["longer_than_tile_slope_variance"] > 0


def test_a_looping_sea_closes_and_keeps_its_frequencies_within_pi_over_t():
    period = 1.5
    k = np.linspace(0.0, 200.0, 2001)
    true = W.angular_frequency(k)
    looped = W.angular_frequency(k, period)
    assert looped[0] == 0.0 and np.all(looped[1:] > 0)
    turns = looped * period / (2 * np.pi)
    np.testing.assert_allclose(turns, np.round(turns), atol=1e-9)       # whole turns
    fine = true[1:] > np.pi / period                                    # not clamped to 1 turn
    assert np.all(np.abs(looped[1:] - true[1:])[fine] <= np.pi / period + 1e-12)
    sea = W.Waves(4.0, grid=64, tile_m=4.0, seed=2, period_s=period)
    for t in (0.0, 0.37):
        a = W.surface(dataclasses.replace(sea, time_s=t))
        b = W.surface(dataclasses.replace(sea, time_s=t + period))
        for x, y in zip(a, b):
            np.testing.assert_allclose(y, x, atol=1e-9 * np.abs(x).max())
    # At t = 0 it is the true sea; later the two part (their phases drift by <= pi t / T).
    true_sea = dataclasses.replace(sea, period_s=None)
    np.testing.assert_array_equal(W.surface(sea)[0], W.surface(true_sea)[0])
    later = [W.surface(dataclasses.replace(s, time_s=0.4))[0] for s in (sea, true_sea)]
    assert np.abs(later[0] - later[1]).max() > 1e-3 * np.abs(later[1]).max()


@pytest.mark.parametrize("period", [0.0, -1.0, float("nan")])
def test_bad_loop_periods_are_refused(period):
    with pytest.raises(AquaspecError, match="wave loop period"):
        W.Waves(3.0, period_s=period)
