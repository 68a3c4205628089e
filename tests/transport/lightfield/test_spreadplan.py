"""The compiled model's share of the cone's light (aquaspec.transport.lightfield.spreadplan):
where the pyramid starts, which pixels feed it, and what each pixel keeps."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import load_water
from aquaspec.transport.lightfield import compiled as lfc
from aquaspec.transport.lightfield import spreadplan
from aquaspec.transport.lightfield.bake import lightfield_tables


def test_spread_plan():
    w = np.array([0.1, 0.1, 0.1, 0.3, 0.4])
    assert spreadplan.spread_plan(w, 623.0)[0] == 3                 # 1280x720: 8 px = 0.74 degrees
    assert spreadplan.spread_plan(w, 47.0)[0] == 0                  # 96 px wide: the whole pyramid
    start, alpha, coarse = spreadplan.spread_plan(w, 623.0, start_level=2)
    assert start == 2 and alpha == pytest.approx(0.2)
    np.testing.assert_array_equal(coarse, w[2:])
    assert spreadplan.spread_plan(w[:3], 623.0)[0] == 2             # no deeper than the pyramid
    with pytest.raises(AquaspecError, match="weights"):
        spreadplan.spread_plan(w[:1], 623.0)


def test_coarse_sample_pixels():
    ys, xs = spreadplan.coarse_sample_pixels(20, 30, 3)
    assert ys.shape == (3, 4, 2)
    np.testing.assert_array_equal(xs[0, 0], [2, 6])
    np.testing.assert_array_equal(ys[0, 0], [2, 6])
    np.testing.assert_array_equal(xs[1, 2], [18, 22])
    np.testing.assert_array_equal(ys[1, 2], [10, 14])
    assert xs.max() == 29 and ys.max() == 19                 # clamped at the edges
    np.testing.assert_array_equal(spreadplan.coarse_sample_pixels(5, 5, 0)[1][2, 3], [3, 3])


class TestKeptShare:
    """The pixel's own share of its forward cone, tangent in f b (kept_share)."""

    @staticmethod
    def share(fb, fb_mean, alpha, s):
        dk, slope = spreadplan.kept_share(fb_mean, alpha, s)
        return dk[:, None] * np.exp(slope[:, None] * s[:, None] * (fb - fb_mean))

    def test_exact_where_it_must_be(self):
        s = np.array([0.0, 0.3, 2.0, 9.0, 40.0])
        for alpha in (0.0, 0.3, 0.9):
            # All bands with the mean f b: the tangent is the function itself.
            np.testing.assert_allclose(self.share(np.array([0.4]), 0.4, alpha, s)[:, 0],
                                       alpha + (1 - alpha) * np.exp(-0.4 * s), rtol=1e-12)
        # Far targets in turbid water: exp(-x) underflows, the share stays finite.
        for alpha in (0.0, 0.3):
            dk, slope = spreadplan.kept_share(3.0, alpha, np.array([300.0, 1e4]))
            assert np.all(np.isfinite(dk)) and np.all(np.isfinite(slope))
        fb = np.array([0.1, 0.4, 0.9])                      # alpha = 0: T / T' exactly
        np.testing.assert_allclose(self.share(fb, fb.mean(), 0.0, s),
                                   np.exp(-fb * s[:, None]), rtol=1e-12)

    def test_error_for_ocean_waters(self):
        # f b spread 2.4x over the bands, as Jerlov II-9C with a 40 degree cone
        # (evenly here): the kept light within 10 %, the misplaced share within
        # 6 % of the cone (3.6 % with Jerlov II's own 16 bands).
        fb = np.linspace(0.226, 0.550, 16)
        s = np.linspace(0.0, 40.0, 4001)[:, None]
        x = fb * s
        got = self.share(fb, fb.mean(), 0.3, s[:, 0])
        exact = 0.3 + 0.7 * np.exp(-x)
        err = np.abs(got - exact)
        assert (err / exact).max() < 0.10
        assert (err / np.maximum(1 - np.exp(-x), 1e-9)).max() < 0.06
        assert (err / exact).max() > 0.01                    # an approximation, measured

    def test_slope_bound(self):
        assert spreadplan.kept_slope_bound(0.0) == np.inf
        x = np.linspace(0.0, 60.0, 600001)
        for alpha in (0.05, 0.3, 0.9):
            dk, slope = spreadplan.kept_share(1.0, alpha, x)
            assert spreadplan.kept_slope_bound(alpha) == pytest.approx(np.max(-slope * x), rel=1e-4)
        assert spreadplan.kept_slope_bound(0.3) < spreadplan.kept_slope_bound(0.1)

    @staticmethod
    def compiled(water, n):
        w = load_water(water).on_bands(Bands(n))
        tables = lightfield_tables(w, phase="ff", backscatter=0.0183, forward_cone_deg=40.0,
                                   cone_spread=True)
        e0 = surface_light("overcast").on_bands(Bands(n))
        resp = get_sensor("human").band_weights(Bands(n))
        return lfc.compile_lightfield(tables, a=w.a, b=w.b, e0=e0, response_weights=resp,
                                      depth_o=5.0)

    def test_projection(self):
        """f b - mean(f b) from the band's own coefficients: exact with up to
        rank + 3 bands, and within the tolerance of the kept light where used."""
        comp = self.compiled("II", 6)                       # rank 4: exact
        lam, hat, res = spreadplan.fb_projection(comp.k_depth, comp.c_beam, comp.g, comp.fb)
        delta = comp.fb - comp.fb.mean()
        assert res < 1e-10 * np.abs(delta).max()
        np.testing.assert_allclose(hat, delta, atol=1e-10 * np.abs(delta).max())
        comp = self.compiled("II", 16)
        delta = comp.fb - comp.fb.mean()
        assert spreadplan.kept_projection(comp, 0.0) is None      # alpha = 0: slope -1 everywhere
        proj = spreadplan.kept_projection(comp, 0.3)
        assert proj is not None and 0 < proj["error_bound"] <= spreadplan.KEPT_PROJECTION_TOLERANCE
        # The kept light with and without the projection, over distances and
        # random surfaces: within the bound, which is not loose by orders.
        rng = np.random.default_rng(5)
        m = 400
        rho = rng.uniform(0.05, 0.9, (m, 16))
        s = np.linspace(0.01, 40.0, m)
        sd = rng.uniform(2.0, 9.0, m)
        ny = rng.uniform(-1.0, 1.0, m)
        dk, slope = spreadplan.kept_share(comp.fb.mean(), 0.3, s)
        moved = np.abs(slope[:, None] * s[:, None] * (proj["fb_offset"] - delta))
        assert moved.max() <= proj["error_bound"] * (1 + 1e-9)
        assert moved.max() > 0.05 * proj["error_bound"]
        # surface_rgb uses it (and conserves light either way).
        kept, spread = lfc.surface_rgb(comp, rho, s, sd, ny, alpha=0.3)
        exact = dataclasses.replace(comp, fb=comp.fb.copy())
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(lfc, "kept_projection", lambda c, a: None)
            kept_x, spread_x = lfc.surface_rgb(exact, rho, s, sd, ny, alpha=0.3)
        assert not np.allclose(kept, kept_x, rtol=1e-9)
        np.testing.assert_allclose(kept + 0.7 * spread, kept_x + 0.7 * spread_x, rtol=1e-10)
        # A medium whose residual is too large for the tolerance keeps the band term.
        bad = dataclasses.replace(comp, fb=comp.fb * (1 + 0.5 * np.sin(np.arange(16.0))))
        assert spreadplan.kept_projection(bad, 0.3) is None

    def test_light_is_conserved(self, lightfield_gbuffer):
        """kept + (1 - alpha) spread = the whole target light T' (surface_rgb)."""
        w = load_water("II").on_bands(Bands(8))
        tables = lightfield_tables(w, phase="ff", backscatter=0.0183, forward_cone_deg=40.0,
                                   cone_spread=True)
        e0 = surface_light("overcast").on_bands(Bands(8))
        resp = get_sensor("human").band_weights(Bands(8))
        comp = lfc.compile_lightfield(tables, a=w.a, b=w.b, e0=e0, response_weights=resp,
                                      depth_o=5.0)
        rng = np.random.default_rng(3)
        rho = rng.uniform(0.05, 0.9, (50, 8))
        s = rng.uniform(0.1, 12.0, 50)
        sd = rng.uniform(2.0, 9.0, 50)
        ny = rng.uniform(-1.0, 1.0, 50)
        whole, _ = lfc.surface_rgb(dataclasses.replace(comp, split=False), rho, s, sd, ny)
        kept, spread = lfc.surface_rgb(comp, rho, s, sd, ny, alpha=0.3)
        np.testing.assert_allclose(kept + 0.7 * spread, whole, rtol=1e-12)
        assert np.abs(spread).max() > 0.05 * np.abs(whole).max()
