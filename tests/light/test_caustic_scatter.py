"""The small-angle transfer of caustics into the scattered light
(aquaspec.light.caustic_scatter): the phase function's transform against a
closed form, the transfer against a Monte Carlo of small-angle paths, and
the slices' filter."""

import numpy as np
import pytest
from scipy.special import erf

from aquaspec.errors import AquaspecError
from aquaspec.light import caustic_scatter as cs
from aquaspec.light.photon_map import half_wavenumbers
from aquaspec.medium.phase import PhaseFunction, get_phase


class GaussianTan(PhaseFunction):
    """A phase function whose ``tan(theta)`` is a 2-D Gaussian of standard
    deviation ``sigma`` per axis (forward hemisphere only): ``P(v) =
    exp(-sigma^2 v^2 / 2)`` exactly."""

    name = "gaussian-tan"

    def __init__(self, sigma):
        self.sigma = sigma

    def value(self, mu):
        mu = np.clip(np.asarray(mu, dtype=float), -1.0, 1.0)
        fwd = mu > 1e-6
        m = np.where(fwd, mu, 1.0)
        rho2 = (1.0 - m * m) / (m * m)
        g = np.exp(-rho2 / (2 * self.sigma ** 2)) / (2 * np.pi * self.sigma ** 2)
        return np.where(fwd, g / m ** 3, 0.0)


def test_transform_of_a_gaussian_in_tan_theta_is_gaussian():
    sigma = 0.05
    v = np.array([0.0, 1.0, 10.0, 20.0, 40.0, 80.0, 400.0])
    got = cs.transform_of(GaussianTan(sigma), v)
    np.testing.assert_allclose(got, np.exp(-0.5 * (sigma * v) ** 2), atol=2e-4)


def test_petzold_transform_starts_at_the_forward_share_and_falls():
    ph = get_phase("petzold")
    v = cs.table_wavenumbers()
    p = cs.transform_of(ph, v)
    assert abs(p[0] - (1.0 - ph.backscatter_fraction())) < 1e-4
    assert np.all(np.diff(p) <= 1e-6)
    # The sharp forward peak keeps part of it out to fine scales.
    assert 0.05 < np.interp(1e3, v, p) < 0.3


def _gaussian_transfer(b, sigma, gap, mu0=1.0):
    return cs.ScatterTransfer(b=(b,), beam_gap=(gap,), wavelength_nm=(550.0,), mu0=mu0,
                              phase=GaussianTan(sigma))


def test_transfer_matches_a_monte_carlo_of_small_angle_paths():
    """Photons along a slant path of length s, scattering events a Poisson
    process of rate b, each turning the direction by a Gaussian tan(theta):
    the mean of cos(q . displacement) over all photons is M(q, s) exp(a s),
    and G = M exp(c* s) with c* = c - gap."""
    rng = np.random.default_rng(1)
    b, sigma, s, gap = 0.6, 0.04, 5.0, 0.2
    n = 200_000
    counts = rng.poisson(b * s, n)
    disp = np.zeros((n, 2))
    for k in range(1, counts.max() + 1):
        sel = counts >= k
        where = rng.uniform(0.0, s, sel.sum())
        disp[sel] += rng.normal(0.0, sigma, (sel.sum(), 2)) * (s - where)[:, None]
    tr = _gaussian_transfer(b, sigma, gap)
    for q in (0.5, 3.0, 10.0, 40.0):
        mc = np.mean(np.cos(q * disp[:, 0]))       # M exp(a s), any a
        expected = np.exp(-b * s) * np.exp(b * np.sqrt(np.pi / 2) / sigma
                                          * erf(sigma * q * s / np.sqrt(2)) / q)
        assert abs(mc - expected) < 4e-3
        g = tr.gain(np.array([q]), np.array([0.0]), s)[0]
        assert g == pytest.approx(mc * np.exp((b - gap) * s), rel=0.02, abs=2e-3)


def test_slant_beam_stretches_the_displacement_along_the_sun():
    tr = _gaussian_transfer(0.5, 0.05, 0.1, mu0=0.8)
    tr_up = _gaussian_transfer(0.5, 0.05, 0.1, mu0=1.0)
    d = 4.0
    # Along the sun's horizontal direction (x here), k/mu0 over the slant d/mu0.
    along = tr.log_gain(np.array([5.0]), np.array([0.0]), d)
    across = tr.log_gain(np.array([0.0]), np.array([5.0]), d)
    # For mu0 = 1 with the same slant path s = d / 0.8 and the q's.
    assert along[0] == pytest.approx(tr_up.log_gain(np.array([5.0 / 0.8]), np.array([0.0]),
                                                    d / 0.8)[0], rel=1e-6)
    assert across[0] == pytest.approx(tr_up.log_gain(np.array([5.0]), np.array([0.0]),
                                                     d / 0.8)[0], rel=1e-6)


def test_fine_pattern_keeps_only_the_unscattered_beam():
    """At large wavenumbers G -> exp(-gap s): the share of the renderer's beam
    that is unscattered (what the path tracer's check compares)."""
    tr = cs.ScatterTransfer.for_beam(b=[0.5], c=[0.6], c_sun=[0.45], wavelength_nm=[532.0],
                                     to_sun=[0.0, 1.0, 0.0])
    d = 3.0
    g_fine = tr.gain(np.array([1e6]), np.array([0.0]), d)[0]
    assert g_fine == pytest.approx(np.exp(-0.15 * d), rel=0.01)
    # Coarser patterns are carried by more of the scattered light.
    ks = np.array([1e4, 1e3, 1e2, 10.0, 1.0])
    g = tr.gain(ks, np.zeros_like(ks), d)
    assert np.all(np.diff(g) > 0) and g[-1] > 1.0
    assert tr.gain(np.array([0.0]), np.array([0.0]), d)[0] == 1.0


def test_scatter_slices_filters_each_slice_by_its_depth():
    n, tile = 64, 4.0
    x = (np.arange(n) + 0.5) * tile / n
    kx0 = 2 * np.pi * 5 / tile
    pattern = 1.0 + 0.4 * np.cos(kx0 * x)[None, :] * np.ones((n, 1))
    level0 = np.stack([pattern, pattern]).astype(np.float32)
    depths = np.array([0.5, 6.0])
    tr = cs.ScatterTransfer.for_beam(b=[0.4], c=[0.5], c_sun=[0.4], wavelength_nm=[532.0],
                                     to_sun=[0.0, 1.0, 0.0])
    out = cs.scatter_slices(level0, depths, tile, tr)
    for k, d in enumerate(depths):
        g = tr.gain(np.array([kx0]), np.array([0.0]), d)[0]
        np.testing.assert_allclose(out[k], 1.0 + g * (pattern - 1.0),
                                   atol=2e-5)
        assert out[k].mean() == pytest.approx(level0[k].mean(), abs=1e-6)
    # No scattering: nothing changes.
    clear = cs.ScatterTransfer.for_beam(b=[0.0], c=[0.1], c_sun=[0.1], wavelength_nm=[532.0],
                                        to_sun=[0.0, 1.0, 0.0])
    np.testing.assert_allclose(cs.scatter_slices(level0, depths, tile, clear), level0,
                               atol=1e-6)


def test_turbid_deep_slices_stay_finite():
    """G grows as exp(b (1 - B - f) s) at coarse scales (e^85 here): the
    factor is bounded, finite, at half-float range."""
    rng = np.random.default_rng(2)
    level0 = (1.0 + 0.5 * rng.standard_normal((2, 32, 32))).astype(np.float32)
    tr = cs.ScatterTransfer.for_beam(b=[5.0], c=[5.1], c_sun=[4.0], wavelength_nm=[532.0],
                                     to_sun=[0.0, 1.0, 0.0])
    assert tr.log_gain(np.array([0.5]), np.array([0.0]), 40.0)[0] > 80.0
    out = cs.scatter_slices(level0, np.array([1.0, 40.0]), 8.0, tr)
    assert np.all(np.isfinite(out)) and np.max(np.abs(out)) <= cs.FACTOR_LIMIT
    assert np.all(np.isfinite(out.astype(np.float16)))


def test_several_bands_take_the_mean_exponent():
    one = [cs.ScatterTransfer.for_beam(b=[b], c=[b + 0.1], c_sun=[0.1 + 0.7 * b],
                                       wavelength_nm=[w], to_sun=[0.0, 1.0, 0.0])
           for b, w in ((0.3, 450.0), (0.6, 600.0))]
    both = cs.ScatterTransfer.for_beam(b=[0.3, 0.6], c=[0.4, 0.7], c_sun=[0.31, 0.52],
                                       wavelength_nm=[450.0, 600.0], to_sun=[0.0, 1.0, 0.0])
    kx, kz = half_wavenumbers(16, 2.0)
    want = 0.5 * (one[0].log_gain(kx, kz, 2.0) + one[1].log_gain(kx, kz, 2.0))
    np.testing.assert_allclose(both.log_gain(kx, kz, 2.0), want, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("kw, word", [
    ({"b": (-0.1,)}, "scattering b"),
    ({"beam_gap": (0.9,)}, "beam_gap"),
    ({"mu0": 0.0}, "mu0"),
    ({"sun_xz": (1.0, 1.0)}, "sun_xz"),
    ({"wavelength_nm": (1.0, 2.0)}, "one value per band"),
])
def test_bad_transfer_is_refused_by_name(kw, word):
    args = dict(b=(0.5,), beam_gap=(0.1,), wavelength_nm=(532.0,), mu0=0.9)
    args.update(kw)
    with pytest.raises(AquaspecError, match=word):
        cs.ScatterTransfer(**args)


def test_the_renderers_setup_carries_its_map_into_the_scattered_light():
    """A setup with waves reads the still map through the transfer of its own
    bands (b, c - c_sun), and a loop read through it is the same map at t = 0."""
    from aquaspec.colour.bands import Bands
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.light import caustics
    from aquaspec.light.sky import surface_light
    from aquaspec.medium.water import load_water
    from aquaspec.rendering.setup import SpectralSetup

    sea = caustics.Waves(4.0, grid=32, tile_m=2.0, seed=3)
    setup = SpectralSetup(load_water("1C"), get_sensor("human"),
                          surface_light("sun-sky", sun_elevation_deg=55.0), Bands(4),
                          ms_model="seeds", waves=sea)
    inputs = setup.sun_inputs()
    tr = inputs.caustics.scatter
    bw = setup.water.on_bands(setup.bands)
    np.testing.assert_allclose(tr.b, bw.b)
    np.testing.assert_allclose(tr.beam_gap, bw.c - inputs.c_sun, atol=1e-12)
    sun = setup.light.sun
    plain = caustics.cached_caustic_map(sea, sun.elevation_deg, sun.azimuth_deg,
                                        n_water=sun.n_water)
    want = caustics.mip_levels(cs.scatter_slices(plain.levels[0], plain.depths, 2.0, tr))
    for got, w in zip(inputs.caustics.levels, want):
        np.testing.assert_array_equal(got, w)
    assert np.std(want[0][8] - plain.levels[0][8]) > 0.01          # it changed the map
    loop = caustics.caustic_loop(sea, sun.elevation_deg, sun.azimuth_deg, frames=2,
                                 n_water=sun.n_water, scatter=tr)
    # Several bands: each reads the factor scaled (its contrast against the
    # bands' mean transfer), the loop by frame 0's scales, the still map's.
    assert inputs.caustics.band_scale.shape == (plain.depths.size, 4)
    np.testing.assert_allclose(inputs.caustics.band_scale, cs.band_scales(
        plain.levels[0], plain.depths, 2.0, tr), rtol=1e-6)
    np.testing.assert_array_equal(loop.band_scale, inputs.caustics.band_scale)
    assert loop.scatter is tr and caustics.caustic_loop(
        sea, sun.elevation_deg, sun.azimuth_deg, frames=2, n_water=sun.n_water,
        scatter=tr) is loop
    for got, w in zip(loop.frame_levels(0), want):
        np.testing.assert_array_equal(got, w)


def _random_slices(n=64, tile=4.0, k=5, seed=1):
    """Slices of mean 1 with a red spectrum (detail at every scale of the tile)."""
    rng = np.random.default_rng(seed)
    kx, kz = half_wavenumbers(n, tile)
    spec = (rng.normal(size=(k,) + kx.shape) + 1j * rng.normal(size=(k,) + kx.shape)) \
        / (1.0 + np.hypot(kx, kz))
    c = np.fft.irfft2(spec, s=(n, n))
    return (1.0 + 0.3 * c / c.std(axis=(1, 2), keepdims=True)).astype(np.float32)


def test_band_scales_give_each_band_its_own_contrast():
    """1 + s_i (C_shared - 1) has the standard deviation of band i's own
    transfer (the exact filter's, within the binning's 1 %), and the band
    of the mean exponent (one band) is scaled by 1."""
    level0 = _random_slices()
    depths = np.array([0.0, 0.5, 2.0, 6.0, 12.0])
    tr = cs.ScatterTransfer.for_beam(b=[0.9, 0.6, 0.4], c=[1.2, 0.8, 0.9],
                                     c_sun=[1.0, 0.7, 0.85], wavelength_nm=[443, 532, 670],
                                     to_sun=[0.35, 0.9, 0.25] / np.linalg.norm([0.35, 0.9, 0.25]))
    scales = cs.band_scales(level0, depths, 4.0, tr)
    assert scales.shape == (5, 3)
    shared = cs.scatter_slices(level0, depths, 4.0, tr).std(axis=(1, 2))
    for i in range(3):
        own = cs.scatter_slices(level0, depths, 4.0, tr.band(i)).std(axis=(1, 2))
        np.testing.assert_allclose(scales[:, i], own / shared, rtol=0.01)
    np.testing.assert_allclose(scales[0], 1.0, atol=1e-12)        # at the surface
    assert scales[-1, 0] > 1.5 and scales[-1, 2] < 0.7             # blue and red part deep
    one = tr.band(1)
    np.testing.assert_allclose(cs.band_scales(level0, depths, 4.0, one), 1.0, rtol=1e-9)
    with pytest.raises(AquaspecError, match="band 3"):
        tr.band(3)
    with pytest.raises(AquaspecError, match="depths"):
        cs.band_scales(level0, depths[:3], 4.0, tr)


def test_band_tables_are_the_bands_own():
    tr = cs.ScatterTransfer.for_beam(b=[0.9, 0.4], c=[1.2, 0.9], c_sun=[1.0, 0.85],
                                     wavelength_nm=[443, 670], to_sun=[0.0, 1.0, 0.0])
    v, rows = tr.band_tables()
    for i in range(2):
        np.testing.assert_allclose(rows[i], tr.band(i).table()[1], rtol=1e-12)
    np.testing.assert_allclose(rows.mean(axis=0), tr.table()[1], rtol=1e-12)
