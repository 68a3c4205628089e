"""Discrete-ordinates light field: the solver's closed forms, conservation, convergence."""

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import expn

from aquaspec.errors import AquaspecError
from aquaspec.transport.lightfield.solve import solve_lightfield


def test_absorbing_slab_exact():
    a = np.array([0.2, 0.05])
    lf = solve_lightfield(a, [0.0, 0.0], phase="isotropic", n_streams=16)
    d = np.array([0.0, 1.0, 5.0, 20.0])
    # Uniform L0 = E0/pi looking up: E_d(d) = 2 pi L0 E3(a d) = 2 E3(a d).
    np.testing.assert_allclose(lf.e_d(d), 2 * expn(3, a[:, None] * d), rtol=1e-5)
    v = np.array([0.9, 0.3, 0.05])
    np.testing.assert_allclose(lf.radiance(3.0, v), np.exp(-a[:, None] * 3.0 / v) / np.pi,
                               rtol=1e-12)
    np.testing.assert_allclose(lf.e_u(d), 0.0, atol=1e-15)


@pytest.mark.parametrize("omega", [0.5, 0.9, 0.99])
def test_isotropic_asymptotic_kappa(omega):
    # Case: omega/(2 k) ln((1 + k)/(1 - k)) = 1, k in units of c.
    k_exact = brentq(lambda k: omega / (2 * k) * np.log((1 + k) / (1 - k)) - 1, 1e-9, 1 - 1e-12)
    lf = solve_lightfield([1 - omega], [omega], phase="isotropic", n_streams=32)
    assert lf.k_inf[0] == pytest.approx(k_exact, rel=1e-8)


@pytest.mark.parametrize("phase,kw", [("isotropic", {}), ("hg", {"g": 0.9})])
def test_energy_conservation_without_absorption(phase, kw):
    lf = solve_lightfield([0.0], [0.3], phase=phase, n_streams=16, seabed_depth_m=10.0,
                          seabed_albedo=0.3, **kw)
    d = np.linspace(0, 10, 11)
    net = (lf.e_d(d) - lf.e_u(d))[0]
    np.testing.assert_allclose(net, net[0], rtol=1e-5)
    # At the seabed the net flux is what it absorbs.
    assert net[-1] == pytest.approx(0.7 * lf.e_d(10.0)[0], rel=1e-6)


def test_convergence_with_streams():
    kw = dict(phase="hg", g=0.92, seabed_depth_m=15.0, seabed_albedo=0.2)
    d = np.array([1.0, 5.0, 12.0])
    ref = solve_lightfield([0.05], [0.25], n_streams=48, **kw)
    errs = []
    for n in (8, 16, 32):
        lf = solve_lightfield([0.05], [0.25], n_streams=n, **kw)
        errs.append(np.max(np.abs(lf.e_scalar(d) / ref.e_scalar(d) - 1)))
    assert errs[2] < errs[0]
    assert errs[2] < 2e-3


def test_bad_input():
    with pytest.raises(AquaspecError, match="n_streams"):
        solve_lightfield([0.1], [0.1], phase="isotropic", n_streams=2)
    with pytest.raises(AquaspecError, match="surface"):
        solve_lightfield([0.1], [0.1], phase="isotropic", surface="wavy")
    with pytest.raises(AquaspecError, match="seabed_depth_m"):
        solve_lightfield([0.1], [0.1], phase="isotropic", seabed_depth_m=-1)


@pytest.mark.parametrize("g", [0.0, 0.3, 0.5])
def test_weakly_forward_hg_gives_finite_tables_and_g0_is_isotropic(g):
    """HG moments from quadrature end a few 1e-14 below 0 at order 2N for small g;
    the delta-M fraction must not go negative (it made exp(-f b s) overflow and
    the tables non-finite). HG with g = 0 is the isotropic phase function."""
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import get_water
    from aquaspec.transport.lightfield.bake import lightfield_tables
    bw = get_water("IB").on_bands(Bands(4, 400, 700))
    t = lightfield_tables(bw, phase="hg", g=g, n_depth=8, n_mu=9)
    assert np.all(np.asarray(t.forward_fraction) >= 0)
    assert np.all(np.isfinite(t.irradiance_per_e0)) and np.all(np.isfinite(t.ms_log_prefactor))
    if g == 0.0:
        iso = lightfield_tables(bw, phase="isotropic", n_depth=8, n_mu=9)
        assert np.allclose(t.irradiance_per_e0, iso.irradiance_per_e0, rtol=1e-6)


class TestFresnelSurface:
    """The surface as a mirror from below (``surface="fresnel"``): the sky
    through Snell's window with Fresnel transmission, the water's light going
    up reflected with 1 - T inside the window and totally outside it."""

    def test_absorbing_slab_on_a_seabed_is_the_sum_of_its_reflections(self):
        """No scattering: light bounces between the Lambertian seabed and the
        mirroring surface; per stream the series sums in closed form (the
        seabed's irradiance E_b = 2 pi s sum w mu e^-tau T / (1 - B), B =
        2 rho sum w mu R e^-2tau), with s set by E_d(0) = E0."""
        from aquaspec.medium.interface import below_surface
        a, h, rho = 0.15, 4.0, 0.6
        lf = solve_lightfield([a], [0.0], phase="isotropic", n_streams=16, surface="fresnel",
                              seabed_depth_m=h, seabed_albedo=rho)
        n = lf.n_streams
        mu, w = lf.mu[:n], lf.w[:n]
        t, r, _ = below_surface(mu, "fresnel")
        att = np.exp(-a * h / mu)
        big_a = 2 * np.pi * np.sum(w * mu * att * t)
        big_b = 2 * rho * np.sum(w * mu * r * att ** 2)
        unit = 2 * np.pi * np.sum(w * mu * t) + 2 * rho * np.sum(w * mu * r * att) \
            * big_a / (1 - big_b)
        s = 1.0 / unit                                   # E0 = 1
        e_bed = s * big_a / (1 - big_b)
        up0 = rho * e_bed / np.pi * att                  # L(0, -mu): the seabed seen through the water
        down0 = s * t + r * up0                          # L(0, +mu): sky and mirror
        nodes = lf.node_radiance(0.0)[0]
        np.testing.assert_allclose(nodes[:n], down0, rtol=1e-9)
        np.testing.assert_allclose(nodes[n:], up0, rtol=1e-9)
        assert lf.e_d(0.0)[0] == pytest.approx(1.0, rel=1e-12)
        # Outside the window the surface is a perfect mirror.
        out = mu < lf.window_cos
        assert out.sum() >= 4
        np.testing.assert_allclose(nodes[:n][out], nodes[n:][out], rtol=1e-12)

    @pytest.mark.parametrize("kw", [{}, {"seabed_depth_m": 12.0, "seabed_albedo": 0.3},
                                    {"sun_mu0": 0.8, "sun_beam": 2.0}])
    def test_looking_up_outside_the_window_sees_the_water_below_mirrored(self, kw):
        """Between the nodes too (LightField.radiance): just below the surface,
        beyond the critical angle, the radiance looking up is the radiance
        looking down at the same angle; inside the window it is more (the sky)."""
        lf = solve_lightfield([0.08, 0.3], [0.25, 0.5], phase="hg", g=0.9, n_streams=24,
                              surface="fresnel", **kw)
        outside = np.array([0.1, 0.35, 0.6])            # below cos(48.75 deg) = 0.66
        np.testing.assert_allclose(lf.radiance(0.0, outside), lf.radiance(0.0, -outside),
                                   rtol=1e-10)
        inside = np.array([0.75, 0.95])
        assert np.all(lf.radiance(0.0, inside) > 3 * lf.radiance(0.0, -inside))
        assert np.all(lf.radiance(0.0, outside) > 0)

    def test_split_nodes_integrate_each_side_of_the_window_exactly(self):
        """Under a window the hemisphere's nodes are Gauss rules on [0, w] and
        [w, 1]: polynomials of degree 2k - 1 on each side are exact, so a
        step at the window's edge (the sky inside, nothing outside) is too."""
        from aquaspec.medium.interface import snell_window_cos
        from aquaspec.transport.lightfield.solve import hemisphere_nodes
        w_c = snell_window_cos()
        mu, w = hemisphere_nodes(32, w_c)
        assert mu.size == 32 and w.sum() == pytest.approx(1.0, rel=1e-14)
        assert np.all(np.diff(mu) < 0)                     # zenith first
        inside = mu > w_c
        assert inside.sum() == 17                       # 48.75 of 90 degrees
        for k in range(8):
            exact = (1.0 - w_c ** (k + 1)) / (k + 1)
            assert np.sum(w[inside] * mu[inside] ** k) == pytest.approx(exact, rel=1e-12)
        mu0, w0 = hemisphere_nodes(32)
        gauss_step = np.sum(w0[mu0 > w_c] * mu0[mu0 > w_c])
        assert abs(gauss_step - (1.0 - w_c ** 2) / 2) > 1e-3      # what the split avoids

    @pytest.mark.parametrize("phase", ["isotropic", "petzold"])
    def test_looking_up_under_the_window_converges_with_the_streams(self, phase):
        """Clear water (Jerlov IB-like, blue) at 5 m under the flat surface:
        the radiance looking up inside and outside the window moves by under
        0.5 % from 16 to 64 streams (with Gauss nodes across the edge it moved
        by 2-4 %), and near the zenith it rises smoothly to its top (no bump
        between the top node and v = 1)."""
        v = np.array([0.99, 0.8, 0.5, 0.3])
        got = [solve_lightfield([0.032], [0.078], phase=phase, wavelength_nm=[450.0],
                                n_streams=n, surface="fresnel").radiance(5.0, v)[0]
               for n in (16, 32, 64)]
        np.testing.assert_allclose(got[0], got[2], rtol=5e-3)
        np.testing.assert_allclose(got[1], got[2], rtol=3e-3)
        top = solve_lightfield([0.032], [0.078], phase=phase, wavelength_nm=[450.0],
                               surface="fresnel").radiance(5.0, np.linspace(0.97, 1.0, 31))[0]
        assert np.all(np.diff(top) >= 0)

    def test_scattering_under_split_nodes_conserves_energy(self):
        """Forward-peaked water: what the split nodes lose in the phase
        function's orthogonality is renormalised, so the net flux falls only
        by what is absorbed, d(E_d - E_u)/dz = -a E_scalar (Gershun)."""
        a = 0.02
        lf = solve_lightfield([a], [0.4], phase="hg", g=0.9, n_streams=24, surface="fresnel")
        z = np.linspace(0.0, 10.0, 2001)
        net = np.array([float(lf.e_d(d)[0] - lf.e_u(d)[0]) for d in (z[0], z[-1])])
        scalar = np.array([float(lf.e_scalar(d)[0]) for d in z])
        absorbed = a * np.sum(0.5 * (scalar[1:] + scalar[:-1]) * np.diff(z))
        assert net[0] - net[1] == pytest.approx(absorbed, rel=2e-3)

    def test_refracted_and_null_mirror_nothing(self):
        for surface in ("null", "refracted"):
            lf = solve_lightfield([0.1], [0.3], phase="isotropic", n_streams=16,
                                  surface=surface)
            assert lf.e_d(0.0)[0] == pytest.approx(1.0, rel=1e-12)
        refracted = lf.radiance(0.0, np.array([0.3]))
        np.testing.assert_allclose(refracted, 0.0, atol=1e-15)
