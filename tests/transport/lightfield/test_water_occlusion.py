"""The water's own ambient shadow (aquaspec.transport.lightfield.water_occlusion):
the blocked share under a roof against quadrature, the ray integral against
the transfer equation's closed form, open water, and the map lookup."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.camera import Camera
from aquaspec.scene.occlusion import occlusion_maps, sphere_directions
from aquaspec.transport.lightfield import occlusion as lo
from aquaspec.transport.lightfield import water_occlusion as wo
from aquaspec.transport.lightfield.bake import lightfield_tables

DEPTH_M, ROOF_M = 5.0, 0.5
#: K = 64 Fibonacci directions against Gauss-Legendre in mu (measured
#: 0.002-0.004 for IB, 4 bands).
SHARE_TOL = 0.01
#: 16 intervals against the closed form, measured: exact on level rays
#: (the source is constant along them), 0.2 % up to the surface, 2.9 %
#: steeply down into deep water (the long last interval's source is taken
#: at its middle).
RAY_RTOL = 0.04


@pytest.fixture(scope="module")
def ib_tables(ib):
    """The conftest's IB water and field, with the renderer's tables."""
    bw, lf = ib
    return bw, lf, lightfield_tables(bw, phase="petzold")


def test_share_under_a_roof_is_the_integral(ib_tables):
    """A roof ROOF_M above takes the upper hemisphere: ``R`` is the light it
    lets through from above, attenuated over the roof's distance, over the
    whole sphere's light (isotropic weighting, no cone)."""
    _, lf, _ = ib_tables
    dirs, om = sphere_directions(64)
    w = lo.weights_from_field(lf, dirs, om)
    up = dirs[:, 1] > 0
    vis = np.where(up, 0.0, 1.0)[None]
    dist = np.where(up, ROOF_M / np.where(up, dirs[:, 1], 1.0), np.inf)[None]
    got = wo.blocked_share(w, np.array([DEPTH_M]), np.array([[1.0, 0.0, 0.0]]), vis, dist)[0]
    x, q = np.polynomial.legendre.leggauss(400)
    mu = np.concatenate([0.5 * x - 0.5, 0.5 * x + 0.5])
    wq = np.concatenate([0.5 * q, 0.5 * q])
    total = (lf.radiance(DEPTH_M, mu) * wq).sum(-1)
    pos = mu > 0
    lost = (lf.radiance(DEPTH_M - ROOF_M, mu[pos])
            * np.exp(-lf.c_star[:, None] * ROOF_M / mu[pos]) * wq[pos]).sum(-1)
    ref = lost / total
    assert np.all(ref > 0.5)             # downwelling light dominates
    np.testing.assert_allclose(got, ref, atol=SHARE_TOL)


def test_open_water_loses_nothing(ib_tables):
    _, lf, _ = ib_tables
    dirs, om = sphere_directions(32)
    w = lo.weights_from_field(lf, dirs, om)
    rng = np.random.default_rng(3)
    v = rng.normal(size=(20, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    share = wo.blocked_share(w, rng.uniform(1, 20, 20), v, np.ones((20, 32)),
                             np.full((20, 32), np.inf))
    assert np.all(share == 0.0)
    # Blocked directions inside the forward cone are the camera ray's own.
    cone = np.where(v @ dirs.T > 0.9, 0.0, 1.0)
    share = wo.blocked_share(w, rng.uniform(1, 20, 20), v, cone,
                             np.where(cone == 0, 0.0, np.inf), cone_cos=0.9)
    assert np.all(share == 0.0)


@pytest.mark.parametrize("view, length", [([1.0, 0.0, 0.0], np.inf),
                                          ([0.6, -0.8, 0.0], np.inf),
                                          ([0.0, 0.6, -0.8], 4.0),
                                          ([0.8, 0.0, -0.6], 3.0)])
def test_everything_blocked_removes_the_whole_in_scattering(ib_tables, view, length):
    """All directions blocked at zero distance (no cone): the ray loses its
    whole in-scattering, which by the transfer equation along the ray is
    ``L(o, v) - T(S) L(y(S), v)`` of the tables' open-water radiance."""
    bw, _, tab = ib_tables
    dirs, om = sphere_directions(16)
    w = lo.weights_from_tables(tab, dirs, om, a=bw.a, b=bw.b)
    o = np.array([0.0, -DEPTH_M, 0.0])
    v = np.array([view])

    def hidden(points):
        return np.zeros((len(points), 16)), np.zeros((len(points), 16))

    e0 = np.full(4, 0.7)
    got = wo.water_shadow(tab, w, hidden, o, v, np.array([length]), a=bw.a, b=bw.b, e0=e0)[0]

    def open_l(depth):
        return tab.pixel_radiance(a=bw.a, b=bw.b, e0=e0, depth_o=np.array([[depth]]),
                                  v_y=np.array([[v[0, 1]]]), s=np.array([[np.inf]]))[0]
    k = tab.ray_extinction(bw.a, bw.b)
    end = length if np.isfinite(length) else wo.OPEN_WATER_OPTICAL_DEPTH / k.mean()
    if v[0, 1] > 0:
        end = min(end, DEPTH_M / v[0, 1])
    ref = open_l(DEPTH_M) - np.exp(-k * end) * open_l(DEPTH_M - end * v[0, 1])
    np.testing.assert_allclose(got, ref, rtol=RAY_RTOL)


def test_water_visibility_under_a_slab():
    """Points under a wide slab see it in every upward direction at
    ``h / w_y``, and nothing below."""
    slab = Mesh.flat(np.array([[-30, -4, -30], [30, -4, -30], [30, -4, 30], [-30, -4, 30]],
                              float), np.array([[0, 2, 1], [0, 3, 2]]), material=0, name="slab")
    scene = Scene()
    scene.add(slab)
    cam = Camera.look_at([0, -5, 0], [0, -5, -3], width=8, height=6, fov_y_deg=40)
    maps = occlusion_maps(scene, cam, directions=32, size=256)
    pts = np.array([[0.0, -5.0, 0.0], [2.0, -6.0, 1.0]])
    vis, dist = wo.water_visibility(maps)(pts)
    up = maps.directions[:, 1] > 0.2           # away from the slab's far edges
    assert np.all(vis[:, up] == 0.0)
    h = np.array([1.0, 2.0])[:, None]
    np.testing.assert_allclose(dist[:, up], h / maps.directions[up, 1][None], rtol=0.05,
                               atol=0.05)
    down = maps.directions[:, 1] < 0
    assert np.all(vis[:, down] == 1.0) and np.all(np.isinf(dist[:, down]))


def test_bad_inputs(ib_tables):
    bw, lf, tab = ib_tables
    dirs, om = sphere_directions(16)
    w = lo.weights_from_field(lf, dirs, om)
    with pytest.raises(AquaspecError, match="one each per point"):
        wo.blocked_share(w, np.ones(2), np.ones((3, 3)), np.ones((2, 16)), np.ones((2, 16)))
    with pytest.raises(AquaspecError, match="never NaN"):
        wo.blocked_share(w, np.ones(1), np.ones((1, 3)), np.ones((1, 16)),
                         np.full((1, 16), np.nan))
    with pytest.raises(AquaspecError, match="one length"):
        wo.water_shadow(tab, w, None, np.zeros(3), np.ones((2, 3)), np.ones(3),
                        a=bw.a, b=bw.b, e0=np.ones(4))
