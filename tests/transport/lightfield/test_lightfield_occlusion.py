"""The water's part of the occlusion (aquaspec.transport.lightfield.occlusion):
closed form under a roof, open water, occluders behind, the compressed form."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.scene.occlusion import sphere_directions
from aquaspec.transport.lightfield import occlusion as lo
from aquaspec.transport.lightfield.bake import lightfield_tables
from aquaspec.transport.lightfield.field import clamped_cosine_azimuth

DEPTH_M, ROOF_M = 5.0, 0.5
#: Measured (IB, 4 bands, 5 m, roof 0.5 m): |O_K - O_quadrature| <= 0.0035
#: at K = 32, 0.0009 at 64, 1e-4 at 512 and beyond.
K64_TOL = 2e-3
#: Tables against the field's own radiance (the tables' interpolation, 1-3 %).
TABLE_RTOL = 0.05
#: Compressed form (hats, M = 6, two extinction nodes) against the direct
#: sum under the roof, measured 0.0007 (up) and 0.013 (sideways).
COMPRESSED_TOL = 0.02


def roof(dirs):
    """Visibility and distance under an infinite roof ROOF_M above."""
    up = dirs[:, 1] > 0
    return (np.where(up, 0.0, 1.0)[None],
            np.where(up, ROOF_M / np.where(up, dirs[:, 1], 1.0), np.inf)[None])


def quadrature(lf, n):
    """``O`` under the roof by Gauss-Legendre over ``mu`` (azimuth in closed form)."""
    x, w = np.polynomial.legendre.leggauss(400)
    mu = np.concatenate([0.5 * x - 0.5, 0.5 * x + 0.5])
    wq = np.concatenate([0.5 * w, 0.5 * w])
    h = clamped_cosine_azimuth(mu, n[1])
    e = (lf.radiance(DEPTH_M, mu) * h * wq).sum(-1)
    up = mu > 0
    lost = (lf.radiance(DEPTH_M - ROOF_M, mu[up]) * np.exp(-lf.c_star[:, None] * ROOF_M / mu[up])
            * h[up] * wq[up]).sum(-1)
    return 1.0 - lost / e


@pytest.mark.parametrize("normal", [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
def test_roof_converges_to_the_integral(ib, normal):
    _, lf = ib
    n = np.array(normal)
    ref = quadrature(lf, n)
    assert np.all(ref < 0.5)            # the roof takes most of the light
    errs = []
    for k in (16, 64, 512):
        dirs, om = sphere_directions(k)
        o = lo.occlusion_factor(lo.weights_from_field(lf, dirs, om), np.array([DEPTH_M]),
                                n[None], *roof(dirs))[0]
        errs.append(np.abs(o - ref).max())
    assert errs[1] < K64_TOL
    assert errs[2] < errs[0] and errs[2] < 5e-4


def test_open_water_and_occluders_behind_give_exactly_one(ib):
    _, lf = ib
    dirs, om = sphere_directions(64)
    w = lo.weights_from_field(lf, dirs, om)
    rng = np.random.default_rng(2)
    n = rng.normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    d = rng.uniform(0.5, 20, 50)
    o = lo.occlusion_factor(w, d, n, np.ones((50, 64)), np.full((50, 64), np.inf))
    assert np.all(o == 1.0)
    behind = (n @ dirs.T) <= 0
    o = lo.occlusion_factor(w, d, n, np.where(behind, 0.0, 1.0),
                            np.where(behind, 0.3, np.inf))
    assert np.all(o == 1.0)
    o = lo.occlusion_factor(w, d, n, np.where(behind, 1.0, 0.0), np.where(behind, np.inf, 0.3))
    assert np.all(o < 0.9)              # the same occluder in front does act


def test_weights_from_tables_match_the_field(ib):
    bw, lf = ib
    dirs, om = sphere_directions(32)
    tab = lightfield_tables(bw, phase="petzold")
    wt = lo.weights_from_tables(tab, dirs, om, a=bw.a, b=bw.b)
    wf = lo.weights_from_field(lf, dirs, om)
    d = np.full((3, 32), 1.0) * np.array([[2.0], [5.0], [12.0]])
    np.testing.assert_allclose(wt.radiance(d), wf.radiance(d), rtol=TABLE_RTOL)
    np.testing.assert_allclose(wt.extinction, lf.c_star, rtol=1e-6)


@pytest.mark.parametrize("normal", [[0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
def test_compressed_form(ib, normal):
    _, lf = ib
    dirs, om = sphere_directions(64)
    w = lo.weights_from_field(lf, dirs, om)
    cw = lo.compress(w, "hats", 6)
    n = np.array([normal])
    d = np.array([DEPTH_M])
    vis, dist = roof(dirs)
    direct = lo.occlusion_factor(w, d, n, vis, dist)
    mom = lo.occlusion_moments(cw, d, n, vis, dist, extinctions=lo.nodes_for(w.extinction, 2))
    np.testing.assert_allclose(lo.factor_from_moments(cw, d, mom), direct, atol=COMPRESSED_TOL)
    # Open water: exactly 1 in the compressed form too.
    mom = lo.occlusion_moments(cw, d, n, np.ones_like(vis), np.full_like(dist, np.inf))
    assert np.all(lo.factor_from_moments(cw, d, mom) == 1.0)


def test_bad_inputs(ib):
    _, lf = ib
    dirs, om = sphere_directions(16)
    w = lo.weights_from_field(lf, dirs, om)
    with pytest.raises(AquaspecError, match="one each per receiver"):
        lo.occlusion_factor(w, np.ones(2), np.ones((3, 3)), np.ones((2, 16)), np.ones((2, 16)))
    with pytest.raises(AquaspecError, match="never NaN"):
        lo.occlusion_factor(w, np.ones(1), np.ones((1, 3)), np.ones((1, 16)),
                            np.full((1, 16), np.nan))
    with pytest.raises(AquaspecError, match="not modelled yet"):
        lo.occlusion_factor(w, np.ones(1), np.ones((1, 3)), np.ones((1, 16)),
                            np.ones((1, 16)), reflected=1.0)
    with pytest.raises(AquaspecError, match="accepted"):
        lo.basis_matrix("wavelets", 4, dirs[:, 1])
