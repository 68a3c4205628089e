"""The light field's tables and their lookups: error bound, surfaces, the forward cone."""

import dataclasses
import warnings

import numpy as np
import pytest

from aquaspec.transport.lightfield.bake import lightfield_tables
from aquaspec.transport.lightfield.solve import solve_lightfield


@pytest.fixture(scope="module")
def ib_tables():
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import load_water
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bw = load_water("IB").on_bands(Bands(8))
    lf = solve_lightfield(bw.a, bw.b, phase="petzold", wavelength_nm=bw.bands.centers_nm,
                          n_streams=32)
    return bw, lf, lightfield_tables(bw, phase="petzold")


def test_table_error_bound(ib_tables):
    """Measured: mean < 0.3 %, steep rays (|v_y| > 0.5) < 3 %, all S from 0.1 m to inf."""
    bw, lf, tab = ib_tables
    rng = np.random.default_rng(7)
    d = rng.uniform(0.5, 50, 300)
    v = rng.uniform(-1, 1, 300)
    for s in (0.1, 1.0, 10.0, np.inf):
        exact = lf.l_ms(d, v, s).T
        approx = tab.l_ms(a=bw.a, b=bw.b, e0=1.0, depth_o=d[:, None], v_y=v[:, None], s=s)
        err = np.abs(approx / exact - 1)
        assert err.mean() < 3e-3
        assert err[np.abs(v) > 0.5].max() < 3e-2


def test_tables_dtype_and_surfaces(ib_tables):
    bw, lf, tab = ib_tables
    assert tab.ms_log_prefactor.dtype == np.float32
    assert tab.irradiance_per_e0.shape == (8, 64, 65)
    ny = np.array([1.0, 0.0, -1.0])
    e0 = np.linspace(1, 2, 8)
    lrad = tab.pixel_radiance(a=bw.a, b=bw.b, e0=e0, depth_o=np.full((3, 1), 5.0),
                              v_y=np.zeros((3, 1)), s=np.full((3, 1), 2.0), rho=0.5,
                              surface_depth=np.full((3, 1), 5.0), n_y=ny[:, None])
    e_exact = lf.irradiance(5.0, ny).T * e0
    t = np.exp(-(bw.a + bw.b) * 2.0)
    l_ms = lf.l_ms(5.0, 0.0, 2.0) * e0
    np.testing.assert_allclose(lrad, t * 0.5 * e_exact / np.pi + l_ms, rtol=1e-2)
    assert np.all(np.isfinite(lrad))


def test_forward_cone_zero_limit_and_effect():
    """A vanishing forward cone gives the plain two-point form; a real one
    leaves open water untouched and gives targets more contrast against it
    (less veil from light that the target blocks)."""
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import load_water
    bw = load_water("IB").on_bands(Bands(4))
    t0 = lightfield_tables(bw, phase="hg", g=0.92)
    tiny = dataclasses.replace(t0, forward_fraction=np.full(4, 1e-12, np.float32))
    cone = lightfield_tables(bw, phase="hg", g=0.92, forward_cone_deg=15.0)
    assert np.all(cone.forward_fraction > 0.5)
    v = np.array([[-0.5], [0.0], [0.3], [0.9]])
    s = np.array([[2.0], [3.0], [3.0], [1.0]])
    kw = dict(a=bw.a, b=bw.b, e0=np.full(4, 0.3), depth_o=5.0, v_y=v, s=s,
              rho=np.full(4, 0.2), surface_depth=5.0 - s * v, n_y=np.zeros((4, 1)))
    plain = t0.pixel_radiance(**kw)
    np.testing.assert_allclose(tiny.pixel_radiance(**kw), plain, rtol=1e-10)
    open_kw = dict(kw, s=np.full((4, 1), np.inf))
    for key in ("rho", "surface_depth", "n_y"):
        open_kw.pop(key)
    background = t0.pixel_radiance(**open_kw)
    np.testing.assert_allclose(cone.pixel_radiance(**open_kw), background,
                               rtol=1e-12)
    contrast_cone = np.abs(cone.pixel_radiance(**kw) - background)
    assert np.all(contrast_cone > np.abs(plain - background))


def test_forward_cone_over_a_seabed_hides_the_seabed_too():
    """Down rays over a seabed: the cone's share of a target is measured
    against the background it hides, L_bg(d_S, v), which ends on the seabed
    (the open-water radiance looking the same way from the target's depth).
    So the seabed seen as a surface, or as open water, has no cone term and
    does not depend on the cone: its forward-scattered light is already in
    the 1-D field. (Leaving the seabed out of L_bg made the seabed 27-46 %
    too bright in Jerlov IB with Fournier-Forand water, against Mitsuba.)"""
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import load_water
    n = 4
    bw = load_water("IB").on_bands(Bands(n))
    bed = dict(seabed_depth_m=6.0, seabed_albedo=np.full(n, 0.3))
    plain = lightfield_tables(bw, phase="hg", g=0.92, **bed)
    cone = lightfield_tables(bw, phase="hg", g=0.92, forward_cone_deg=40.0,
                             cone_spread=True, **bed)
    d_o = 4.0
    v = np.array([[-0.1], [-0.4], [-0.9]])
    kw = dict(a=bw.a, b=bw.b, e0=np.full(n, 0.5), depth_o=d_o, v_y=v)
    far = np.full_like(v, np.inf)
    background = plain.pixel_radiance(**kw, s=far)
    # Open water going down ends on the seabed: the same with or without the cone.
    base, share = cone.pixel_radiance(**kw, s=far, split_cone=True)
    np.testing.assert_allclose(base, background, rtol=1e-12)
    np.testing.assert_allclose(share, 0.0, atol=1e-15)
    np.testing.assert_allclose(cone.pixel_radiance(**kw, s=far), background,
                               rtol=1e-12)
    # The seabed as a hit surface (a seabed mesh) is the same radiance, no cone term.
    to_bed = (6.0 - d_o) / -v
    bed_hit = dict(kw, s=to_bed, rho=np.full(n, 0.3), surface_depth=np.full_like(v, 6.0),
                   n_y=np.ones_like(v))
    base, share = cone.pixel_radiance(**bed_hit, split_cone=True)
    np.testing.assert_allclose(share, 0.0, atol=1e-7 * background.max())
    np.testing.assert_allclose(base, background, rtol=1e-6)
    # A black target halfway: its cone share is -(T' - T) L_bg(d_S, v).
    s = 0.5 * to_bed
    d_s = d_o - s * v
    black = dict(kw, s=s, rho=np.zeros(n), surface_depth=d_s, n_y=np.zeros_like(v))
    _, share = cone.pixel_radiance(**black, split_cone=True)
    hidden = cone.pixel_radiance(**dict(kw, depth_o=d_s), s=far)
    c = bw.a + bw.b
    t_beam = np.exp(-(c - cone.forward_fraction * bw.b) * s)
    np.testing.assert_allclose(share, -(t_beam - np.exp(-c * s)) * hidden, rtol=1e-9)


def test_fresnel_surface_in_the_tables(ib_tables):
    """With the real interface the tables see what LightField sees: looking up at
    open water from 4 m, inside Snell's window the sky (Fresnel-weighted) and
    outside it the water below, mirrored; exact at the table's cosines, within
    a percent between them; the cache round trip keeps the surface."""
    from aquaspec.transport.lightfield.tables import LightfieldTables
    bw, _, _ = ib_tables
    lf = solve_lightfield(bw.a, bw.b, phase="petzold", wavelength_nm=bw.bands.centers_nm,
                          n_streams=32, surface="fresnel")
    tab = lightfield_tables(bw, phase="petzold", surface="fresnel")
    assert tab.surface == "fresnel" and tab.mirrored_top_per_e0.shape == (8, 65)
    v = np.array([0.15, 0.4, 0.6, 0.7, 0.9])              # window edge at 0.66
    exact = lf.radiance(0.0, v).T                         # just below the surface
    np.testing.assert_allclose(tab.top_radiance(v, 1.0), exact, rtol=1e-2)
    seen = tab.pixel_radiance(a=bw.a, b=bw.b, e0=1.0, depth_o=np.full((5, 1), 4.0),
                              v_y=v[:, None], s=np.full((5, 1), np.inf))
    np.testing.assert_allclose(seen, lf.radiance(4.0, v).T, rtol=3e-2)
    # Outside the window: the mirrored water, not black as for "refracted".
    refracted = lightfield_tables(bw, phase="petzold", surface="refracted")
    np.testing.assert_allclose(refracted.top_radiance(v[:2], 1.0), 0.0)
    assert np.all(tab.top_radiance(v[:2], 1.0) > 0)
    again = LightfieldTables.from_arrays(tab.to_arrays())
    assert again.surface == "fresnel"
    np.testing.assert_array_equal(again.top_radiance(v, 1.0), tab.top_radiance(v, 1.0))
