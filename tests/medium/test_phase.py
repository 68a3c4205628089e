"""Phase functions: normalisation, backscatter and moments against closed forms."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.medium.phase import (FournierForand, HenyeyGreenstein, Isotropic, PetzoldParticles,
                            PureWaterPhase, ff_backscatter_fraction, get_phase,
                            hg_backscatter_fraction)
from aquaspec.medium.phase_bands import band_moments, redistribution_matrix

NORM_TOL = 1e-6


class TestHenyeyGreenstein:
    @pytest.mark.parametrize("g", [0.2, 0.7, 0.92, 0.97])
    def test_normalised_and_backscatter(self, g):
        p = HenyeyGreenstein(g)
        assert abs(p.normalisation() - 1.0) < NORM_TOL
        assert p.backscatter_fraction() == pytest.approx(
            (1 - g) / (2 * g) * ((1 + g) / np.sqrt(1 + g * g) - 1), rel=1e-9)

    def test_moments_are_powers_of_g(self):
        chi = HenyeyGreenstein(0.95).legendre_moments(128)
        np.testing.assert_allclose(chi, 0.95 ** np.arange(129), atol=1e-9)

    def test_bad_g(self):
        with pytest.raises(AquaspecError, match="g=1.0"):
            HenyeyGreenstein(1.0)


class TestFournierForand:
    @pytest.mark.parametrize("bb", [0.005, 0.0183, 0.05])
    def test_backscatter_recovered(self, bb):
        p = FournierForand(bb)
        assert abs(p.normalisation() - 1.0) < 1e-4
        assert p.backscatter_fraction() == pytest.approx(bb, rel=1e-4)
        assert ff_backscatter_fraction(p.n, p.mu_slope) == pytest.approx(bb, rel=1e-9)

    def test_mobley_petzold_parameters(self):
        # Mobley et al. (2002): B = 0.0183 <-> n = 1.10, mu = 3.5835.
        p = FournierForand(0.0183)
        assert p.n == pytest.approx(1.10, abs=1e-3)
        assert p.mu_slope == pytest.approx(3.5835, abs=2e-3)

    def test_out_of_range(self):
        with pytest.raises(AquaspecError, match="B=0.9"):
            FournierForand(0.9)


def test_petzold_normalised_forward_peaked():
    p = PetzoldParticles()
    assert abs(p.normalisation() - 1.0) < NORM_TOL
    chi = p.legendre_moments(64)
    assert 0.9 < chi[1] < 0.96          # particle mean cosine
    assert 0.005 < p.backscatter_fraction() < 0.03
    assert np.all(np.diff(chi) < 0)


def test_pure_water_moments_closed_form():
    p = PureWaterPhase()
    numerical = super(PureWaterPhase, p).legendre_moments(6)   # the graded-grid integral
    np.testing.assert_allclose(p.legendre_moments(6), numerical, atol=1e-9)


def test_petzold_band_mix_moves_towards_water():
    chi = band_moments("petzold", 4, b=[0.004, 1.0], wavelength_nm=[450.0, 450.0])
    # Where water dominates b the mean cosine is near 0 (water's chi_1 = 0).
    assert chi[0, 1] < 0.6 * chi[1, 1]


def test_registry_errors():
    with pytest.raises(AquaspecError, match="'rayleigh'.*isotropic"):
        get_phase("rayleigh")
    with pytest.raises(AquaspecError, match="bad parameters"):
        get_phase("hg", k=3)
    with pytest.raises(AquaspecError, match="wavelength_nm"):
        band_moments("petzold", 4, b=[0.1])


def test_redistribution_rows_sum_to_one():
    from numpy.polynomial.legendre import leggauss
    x, w = leggauss(16)
    mu = np.concatenate([0.5 * (x + 1), -0.5 * (x + 1)])
    ww = np.concatenate([0.5 * w, 0.5 * w])
    chi = HenyeyGreenstein(0.8).legendre_moments(31)
    q = redistribution_matrix(chi, mu, mu, ww)
    np.testing.assert_allclose(q.sum(axis=1), 1.0, atol=1e-12)
    # Isotropic: every direction gets the same share.
    qi = redistribution_matrix(Isotropic().legendre_moments(31), mu, mu, ww)
    np.testing.assert_allclose(qi, np.broadcast_to(ww / 2, qi.shape), atol=1e-14)


class TestTabulated:
    """The piecewise-linear table shared with Mitsuba's ``tabphase``."""

    def test_exact_integrals_of_a_small_table(self):
        """Normalisation, B, cone fraction and moments against Gauss on every cell."""
        from numpy.polynomial.legendre import leggauss
        from aquaspec.medium.phase import TabulatedPhase
        from aquaspec.numerics import legendre_table
        rng = np.random.default_rng(3)
        raw = rng.random(21) + np.linspace(0, 5, 21) ** 3      # 20 cells, forward-heavy
        tab = TabulatedPhase(raw)
        # The piecewise-linear function is the table, whatever the normalisation.
        np.testing.assert_allclose(tab.values / raw, tab.values[0] / raw[0], rtol=1e-14)
        x, w = leggauss(40)             # exact for the degree <= 79 integrands below
        edges = np.linspace(-1, 1, 21)
        lo, hi = edges[:-1, None], edges[1:, None]
        mu = (0.5 * (hi - lo) * x + 0.5 * (hi + lo)).ravel()
        wt = (0.5 * (hi - lo) * w).ravel()
        dens = 2 * np.pi * tab.value(mu) * wt
        assert tab.normalisation() == pytest.approx(1.0, abs=1e-14)
        assert dens.sum() == pytest.approx(1.0, abs=1e-13)
        np.testing.assert_allclose(tab.legendre_moments(30), legendre_table(30, mu) @ dens,
                                   atol=1e-13)
        assert tab.backscatter_fraction() == pytest.approx(dens[mu < 0].sum(), abs=1e-14)
        # A cone ending inside a cell: integrate the cell's linear piece directly.
        t = np.radians(50.0)
        sel = mu > np.cos(t)
        c0 = np.cos(t)
        k = int(np.floor((c0 + 1) / 0.1))
        a, b_ = edges[k], edges[k + 1]
        va, vb = tab.value(a), tab.value(b_)
        part = 2 * np.pi * (b_ - c0) * 0.5 * (tab.value(c0) + vb)
        full = dens[sel & (mu > b_)].sum()
        assert tab.cone_fraction(t) == pytest.approx(full + part, abs=1e-14)
        assert tab.value(c0) == pytest.approx(va + (vb - va) * (c0 - a) / (b_ - a), rel=1e-14)

    def test_bad_tables(self):
        from aquaspec.medium.phase import TabulatedPhase, tabulate
        for bad in ([1.0], [1.0, -1.0, 2.0], [0.0, 0.0], [1.0, np.nan]):
            with pytest.raises(AquaspecError, match="tabulated phase"):
                TabulatedPhase(bad)
        with pytest.raises(AquaspecError, match="n_nodes=2"):
            tabulate(Isotropic(), 2)

    @pytest.mark.parametrize("make, b_want, g_want", [
        (lambda: HenyeyGreenstein(0.92), float(hg_backscatter_fraction(0.92)), 0.92),
        (lambda: FournierForand(0.0183), 0.0183, None),
        (lambda: FournierForand(0.005), 0.005, None),
        (lambda: FournierForand(0.05), 0.05, None),
        (lambda: PetzoldParticles(), None, None)])
    def test_default_table_keeps_b_and_moments(self, make, b_want, g_want):
        """At 10^5 + 1 nodes the table changes B by < 1e-5 relative (measured: 2e-6),
        chi_1 and chi_2 by < 1e-5 (measured: 8e-7, 2e-6) and chi_8 by < 1e-4 (3e-5)."""
        from aquaspec.medium.phase import DEFAULT_TABLE_NODES, tabulate
        ph = make()
        tab = tabulate(ph)
        assert tab.values.size == DEFAULT_TABLE_NODES
        assert tab.normalisation() == pytest.approx(1.0, abs=1e-14)
        chi_ref = ph.legendre_moments(8)
        chi = tab.legendre_moments(8)
        if b_want is None:
            b_want = ph.backscatter_fraction()
        if g_want is None:
            g_want = chi_ref[1]
        assert tab.backscatter_fraction() == pytest.approx(b_want, rel=1e-5)
        assert chi[0] == pytest.approx(1.0, abs=1e-14)
        assert abs(chi[1] - g_want) < 1e-5
        assert abs(chi[2] - chi_ref[2]) < 1e-5
        assert abs(chi[8] - chi_ref[8]) < 1e-4

    def test_hg_table_moments_are_powers_of_g(self):
        from aquaspec.medium.phase import tabulate
        chi = tabulate(HenyeyGreenstein(0.92)).legendre_moments(64)
        np.testing.assert_allclose(chi, 0.92 ** np.arange(65), atol=2e-6)

    def test_coarse_table_misses_the_peak(self):
        """The table size matters: with 1001 nodes (forward peak resolved to ~3.6
        degrees) FF's chi_8 is off by > 1e-3; the default's by < 1e-4 (above)."""
        from aquaspec.medium.phase import tabulate
        ph = FournierForand(0.0183)
        coarse = tabulate(ph, 1001).legendre_moments(8)[8]
        assert abs(coarse - ph.legendre_moments(8)[8]) > 1e-3

    def test_registry_and_band_moments(self):
        from aquaspec.medium.phase import TabulatedPhase, tabulated_phase
        from aquaspec.medium.phase_bands import band_cone_fraction
        tab = get_phase("tabulated", of="ff", backscatter=0.0183)
        assert isinstance(tab, TabulatedPhase)
        assert tab is tabulated_phase("ff", backscatter=0.0183)       # cached
        assert tab.describe()["of"]["name"] == "ff"
        # One function for every band: no wavelength needed, not mixed with water.
        chi = band_moments("tabulated", 4, b=[0.01, 1.0], of="petzold")
        np.testing.assert_array_equal(chi[0], chi[1])
        np.testing.assert_allclose(chi[0], tabulated_phase("petzold").legendre_moments(4))
        f = band_cone_fraction("tabulated", 10.0, b=[0.1], of="ff", backscatter=0.0183)
        assert f[0] == pytest.approx(FournierForand(0.0183).cone_fraction(np.radians(10)),
                                     abs=1e-4)
        with pytest.raises(AquaspecError, match="cannot tabulate.*'rayleigh'"):
            get_phase("tabulated", of="rayleigh")
        with pytest.raises(AquaspecError, match="cannot tabulate"):
            get_phase("tabulated", of="tabulated")
        with pytest.raises(AquaspecError, match="B=0.9"):
            get_phase("tabulated", of="ff", backscatter=0.9)


@pytest.fixture(scope="module")
def mitsuba_variant():
    pytest.importorskip("mitsuba", reason="Mitsuba 3 is not installed (extra 'validation')")
    from aquaspec.validation.reference import require_mitsuba
    return require_mitsuba()


def _interactions(mi, n, ray_dir):
    import drjit as dr
    it = dr.zeros(mi.MediumInteraction3f, n)
    # Mitsuba's wi points away from the interaction, back along the ray.
    it.wi = mi.Vector3f(*[-float(c) for c in ray_dir])
    it.sh_frame = mi.Frame3f(it.wi)
    return it


@pytest.mark.slow
class TestMitsubaTabphase:
    """Mitsuba's ``tabphase`` holds the same function as :class:`TabulatedPhase`."""

    DIR = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])

    def test_eval_equals_the_table(self, mitsuba_variant):
        from aquaspec.validation.reference import phase_function, reference_phase
        mi = mitsuba_variant
        ph = mi.load_dict(reference_phase("ff", backscatter=0.0183))
        tab = phase_function("ff", backscatter=0.0183)
        # Directions at scattering cosines from -1 to cos(2 deg), in a frame
        # around the ray (float32 directions: mu from the same vectors).
        mu = np.concatenate([np.linspace(-1, 0.99939, 400)])
        frame = mi.Frame3f(mi.Vector3f(*[float(c) for c in self.DIR]))
        local = mi.Vector3f(np.sqrt(1 - mu ** 2), 0 * mu, mu)
        wo = frame.to_world(local)
        val, pdf = ph.eval_pdf(mi.PhaseFunctionContext(None),
                               _interactions(mi, mu.size, self.DIR), wo)
        wo_np = np.stack([np.array(wo.x), np.array(wo.y), np.array(wo.z)], axis=1)
        mu_used = wo_np.astype(float) @ self.DIR
        np.testing.assert_allclose(np.array(pdf), tab.value(mu_used), rtol=2e-4)
        np.testing.assert_allclose(np.array(val)[0], np.array(pdf), rtol=1e-6)

    def test_sampling_follows_the_table_forward(self, mitsuba_variant):
        """Histogram of sampled scattering cosines against the table's cell masses."""
        from aquaspec.validation.reference import phase_function, reference_phase
        mi = mitsuba_variant
        ph = mi.load_dict(reference_phase("petzold"))
        tab = phase_function("petzold")
        n = 400_000
        rng = np.random.default_rng(5)
        wo, weight, _ = ph.sample(mi.PhaseFunctionContext(None), _interactions(mi, n, self.DIR),
                                  mi.Float(rng.random(n)),
                                  mi.Point2f(rng.random(n), rng.random(n)))
        np.testing.assert_array_equal(np.array(weight), 1.0)
        wo_np = np.stack([np.array(wo.x), np.array(wo.y), np.array(wo.z)], axis=1)
        mu = wo_np.astype(float) @ self.DIR
        # Bins in angle, fine towards forward (the peak) and coarse backwards.
        edges_deg = np.array([0, 0.5, 1, 2, 4, 8, 15, 30, 60, 90, 120, 180])
        edges_mu = np.cos(np.radians(edges_deg))[::-1]
        counts, _ = np.histogram(mu, bins=edges_mu)
        p = np.diff(tab.cumulative(edges_mu))
        sigma = np.sqrt(n * p * (1 - p))
        assert np.all(np.abs(counts - n * p) < 5 * sigma), (counts, n * p)
        # Forward is forward: the mean cosine to the ray direction is the table's chi_1.
        g = tab.legendre_moments(1)[1]
        assert g > 0.9
        assert abs(mu.mean() - g) < 5 * mu.std() / np.sqrt(n)


def test_cone_offset_cdf_isotropic_closed_form():
    """Isotropic scattering: F(a) = [1 - cos a + a (Si(theta_c) - Si(a))] / (1 - cos theta_c)."""
    from scipy.special import sici
    from aquaspec.medium.phase_bands import band_cone_offset_cdf
    tc = np.radians(30.0)
    a = np.linspace(0.0, tc, 13)
    got = band_cone_offset_cdf("isotropic", 30.0, a, b=[0.1, 0.2])
    want = ((1 - np.cos(a)) + a * (sici(tc)[0] - sici(a)[0])) / (1 - np.cos(tc))
    assert got.shape == (2, a.size)
    np.testing.assert_allclose(got[0], want, atol=1e-5)
    np.testing.assert_array_equal(got[0], got[1])


def test_cone_offset_cdf_forward_peaked_and_mixed():
    """A forward-peaked cone puts its light close to the pixel; Petzold's bands
    mix in pure water (wider) the more of b it is; beyond the cone F = 1."""
    from aquaspec.medium.phase_bands import band_cone_offset_cdf
    a = np.radians([0.5, 2.0, 10.0, 40.0, 50.0])
    ff = band_cone_offset_cdf("ff", 40.0, a, backscatter=0.0183)[0]
    iso = band_cone_offset_cdf("isotropic", 40.0, a)[0]
    assert np.all(np.diff(ff) >= 0) and ff[-1] == pytest.approx(1.0) and ff[-2] == ff[-1]
    assert np.all(ff[:3] > iso[:3])
    pz = band_cone_offset_cdf("petzold", 40.0, a, b=[0.003, 0.3], wavelength_nm=[450.0, 450.0])
    # The band with little particle scattering is more like pure water: spread wider.
    assert np.all(pz[0, :3] < pz[1, :3])
    with pytest.raises(AquaspecError, match="half-angle"):
        band_cone_offset_cdf("ff", 0.0, a)
