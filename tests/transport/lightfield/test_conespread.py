"""The pyramid that spreads the forward cone's light, against the exact convolution."""

import numpy as np
import pytest

from aquaspec.transport.lightfield import conespread
from aquaspec.errors import AquaspecError
from aquaspec.transport.lightfield.cone import cone_spread_kernel
from aquaspec.transport.lightfield.tables import ConeTables
from aquaspec.medium.phase_bands import band_cone_offset_cdf

CONE_DEG = 40.0
OFFSETS = np.radians(CONE_DEG) * np.concatenate([[0.0], np.geomspace(1e-5, 1.0, 255)])


def ff_cdf():
    return band_cone_offset_cdf("ff", CONE_DEG, OFFSETS, backscatter=0.0183)[0]


def test_steps_keep_constants_and_shapes():
    x = np.full((7, 10, 3), 2.5)
    d = conespread.downsample(x)
    assert d.shape == (4, 5, 3)
    np.testing.assert_allclose(d, 2.5)
    np.testing.assert_allclose(conespread.upsample(d, (7, 10)), 2.5)
    assert conespread.level_shapes(7, 10, 3) == [(7, 10), (4, 5), (2, 3), (1, 2)]
    w = np.array([0.2, 0.3, 0.5])
    np.testing.assert_allclose(conespread.spread(x, w), 2.5)
    with pytest.raises(AquaspecError, match="pyramid weights"):
        conespread.spread(x, [1.0])


def test_steps_keep_the_total_inside_the_image():
    """[1,3,3,1]/8 halving and bilinear doubling move light, they do not make
    or lose it, away from the border."""
    x = np.zeros((64, 64))
    x[30:34, 28:31] = 1.0
    assert conespread.downsample(x).sum() * 4 == pytest.approx(x.sum())
    d = conespread.downsample(x)
    assert conespread.upsample(d, x.shape).sum() == pytest.approx(4 * d.sum())


@pytest.mark.parametrize("fy", [99.0, 300.0])
def test_pyramid_matches_the_kernel(fy):
    """The fitted pyramid's point response has the kernel's radial
    distribution (within 0.03 at every radius), and on a blocky target its
    spread image is within 3 % (mean over the target) of the exact
    convolution."""
    from scipy.signal import fftconvolve
    cdf = ff_cdf()
    h, w = 72, 96
    levels = conespread.level_count(h, w, OFFSETS[-1] * fy)
    a = conespread.fit_weights(OFFSETS, cdf, fy, levels)
    assert a.shape == (levels + 1,) and np.all(a >= 0) and a.sum() == pytest.approx(1.0)
    radii = 2.0 ** (np.arange(0, 4 * levels) / 4.0)     # from 1 pixel out
    model = sum(a[k] * conespread.level_cdf(k, radii) for k in range(levels + 1))
    want = np.interp(radii, OFFSETS * fy, cdf, right=1.0)
    assert np.abs(model - want).max() < 0.03
    rng = np.random.default_rng(0)
    img = np.zeros((h, w))
    img[18:54, 24:72] = 0.3 + (rng.random((36, 48)) > 0.5)
    kern = cone_spread_kernel(OFFSETS, cdf, fy)
    r = kern.shape[0] // 2
    exact = fftconvolve(np.pad(img, r, mode="edge"), kern, mode="valid")
    approx = conespread.spread(img, a)
    target = (slice(18, 54), slice(24, 72))
    assert np.abs(approx - exact)[target].mean() < 0.03 * exact[target].mean()


def test_measured_levels_follow_the_scale_law():
    """Level l's response tends to level l - 1's at twice the radius (the law
    used beyond the measured levels): within 0.01 from level 5 on."""
    radii = 2.0 ** (np.arange(0, 28) / 4.0)
    for lev in (5, 6):
        finer = conespread.level_cdf(lev - 1, radii / 2.0)
        np.testing.assert_allclose(conespread.level_cdf(lev, radii), finer, atol=0.01)


def test_one_kernel_for_all_bands():
    t = ConeTables(offset_rad=OFFSETS, offset_cdf=np.stack([ff_cdf(), np.sqrt(ff_cdf())]),
                   weight=np.array([3.0, 1.0]))
    off, cdf = conespread.cone_cdf(t)
    np.testing.assert_allclose(cdf, 0.75 * ff_cdf() + 0.25 * np.sqrt(ff_cdf()))
    with pytest.raises(AquaspecError, match="pixels_per_radian"):
        conespread.fit_weights(off, cdf, -1.0, 4)


# --- The cone's light scattered a Poisson number of times (spread_scattering="multiple")

def second_moment(cdf):
    mid = 0.5 * (OFFSETS[1:] + OFFSETS[:-1])
    return float(np.sum(np.diff(cdf) * mid ** 2))


def test_multiple_scattering_cdf_adds_offsets_as_vectors():
    """Independent isotropic 2-D offsets: the mean square of their sum is the
    number of them times one's, so over N Poisson (mean lam) given N >= 1 the
    mean square grows by lam / (1 - exp(-lam)). A narrow single kernel (a
    uniform disc 1 degree across) keeps every sum inside the table."""
    single = np.clip(OFFSETS / np.radians(0.5), 0.0, 1.0) ** 2
    np.testing.assert_array_equal(conespread.multiple_scattering_cdf(OFFSETS, single, 0.0),
                                  single)
    for lam in (0.5, 3.0, 40.0):
        m = conespread.multiple_scattering_cdf(OFFSETS, single, lam)
        assert np.all(np.diff(m) >= 0) and m[0] >= 0 and m[-1] == 1.0
        want = second_moment(single) * lam / (1.0 - np.exp(-lam))
        assert second_moment(m) == pytest.approx(want, rel=0.01), lam
    with pytest.raises(AquaspecError, match="lam=-1"):
        conespread.multiple_scattering_cdf(OFFSETS, single, -1.0)


def test_multiple_scattering_spreads_wider_with_lambda():
    """Petzold-like (here Fournier-Forand) kernels: more scatterings, more
    light far from the pixel, and never less within any offset than a wider one."""
    f = ff_cdf()
    cdfs = [conespread.multiple_scattering_cdf(OFFSETS, f, lam) for lam in (0.0, 1.0, 4.0)]
    r1 = np.radians(1.0)
    inside = [np.interp(r1, OFFSETS, c) for c in cdfs]
    assert inside[0] > inside[1] > inside[2]
    assert np.all(cdfs[1] <= cdfs[0] + 0.01)


def test_lambda_node_weights_are_hat_functions():
    nodes = conespread.LAMBDA_NODES
    lam = np.array([0.0, 0.3, 1.0, 2.5, 13.0, 80.0, 1e4])
    w = conespread.lambda_node_weights(lam)
    assert w.shape == (len(nodes), lam.size)
    np.testing.assert_allclose(w.sum(axis=0), 1.0)
    assert np.all(w >= 0)
    for k, node in enumerate(nodes):
        np.testing.assert_allclose(conespread.lambda_node_weights(np.array(node)),
                                   np.eye(len(nodes))[k], atol=1e-12)
    # Linear in log3(1 + 2 lambda) between two nodes, clamped past the last.
    x = np.log1p(2 * 2.5) / np.log(3)
    np.testing.assert_allclose(w[1:3, 3], [2.0 - x, x - 1.0])
    np.testing.assert_allclose(w[:, -1], np.eye(len(nodes))[-1])
    with pytest.raises(AquaspecError, match="ascending"):
        conespread.lambda_node_weights(lam, nodes=(1.0, 0.5))


def test_spread_by_lambda_is_the_node_pyramids_mixed():
    """lambda on a node everywhere: that node's pyramid alone; between two
    nodes: their pyramids, weighted by the hat functions."""
    rng = np.random.default_rng(2)
    cone = rng.random((24, 32, 2))
    w = [np.array([0.5, 0.3, 0.2]), np.array([0.1, 0.3, 0.6])]
    nodes = (0.0, 1.0)
    got = conespread.spread_by_lambda(cone, np.ones_like(cone), nodes, w)
    np.testing.assert_allclose(got, conespread.spread(cone, w[1]), atol=1e-12)
    lam = np.full(cone.shape, 0.5)
    x = np.log1p(1.0) / np.log(3)
    want = (1 - x) * conespread.spread(cone, w[0]) + x * conespread.spread(cone, w[1])
    np.testing.assert_allclose(conespread.spread_by_lambda(cone, lam, nodes, w), want,
                               atol=1e-12)


# --- The renderer's form of it (node images in one pyramid)

def test_node_tables_and_node_spread():
    """Start level 2: each node keeps its first two weights (alpha) and
    spreads with the rest; the node images spread and summed are
    spread_by_lambda's node pyramids at the coarse level."""
    rng = np.random.default_rng(3)
    w = np.array([[0.1, 0.2, 0.3, 0.25, 0.15], [0.0, 0.05, 0.15, 0.3, 0.5]])
    t = conespread.node_level_tables(w, 2)
    np.testing.assert_allclose(t["alpha"], [0.3, 0.05])
    np.testing.assert_allclose(t["a"], w[:, 2:])
    x = rng.random((21, 30, 2, 3))
    want = conespread.spread(x[:, :, 0], w[0, 2:]) + conespread.spread(x[:, :, 1], w[1, 2:])
    np.testing.assert_allclose(conespread.spread_nodes(x, t["a"]), want, atol=1e-12)
    np.testing.assert_allclose(conespread.spread_nodes(x, t["a"][:, :1]),
                               0.3 * x[:, :, 0] + 0.15 * x[:, :, 1], atol=1e-12)
    # Hat weights at z = 0 .. K - 1, clamped.
    np.testing.assert_allclose(conespread.interp_nodes(np.arange(6.0) * 2,
                                                       np.array([[0.5, 7.0], [2.25, -1.0]])),
                               [[1.0, 10.0], [4.5, 0.0]])
    assert conespread.node_coordinates_are_integers()
    with pytest.raises(AquaspecError, match="start level"):
        conespread.node_level_tables(w, 5)


@pytest.mark.parametrize("level", [1, 2, 3, 4])
def test_measured_level_cdf_is_the_whole_canvas_sorted(level):
    # The definition on a canvas twice as wide, every pixel sorted by distance
    # (ties in row order): the cropped, smaller computation gives the same.
    size = 2 ** (level + 4)
    radii = 2.0 ** (np.arange(-4, 4 * (level + 3) + 1) / 4.0)
    half = 2 ** max(level - 1, 0)
    w = np.zeros(level + 1)
    w[level] = 1.0
    cdfs = []
    for dy, dx in ((0, 0), (half, 0), (0, half), (half, half)):
        pos = (size // 2 + dy, size // 2 + dx)
        img = np.zeros((size, size))
        img[pos] = 1.0
        k = conespread.spread(img, w).ravel()
        y, x = np.indices((size, size))
        r = np.hypot(y - pos[0], x - pos[1]).ravel()
        order = np.argsort(r, kind="stable")
        cdfs.append(np.interp(radii, r[order], np.cumsum(k[order]), left=0.0))
    got_radii, got = conespread._measured_level_cdf(level)
    np.testing.assert_array_equal(got_radii, radii)
    np.testing.assert_allclose(got, np.mean(cdfs, axis=0), rtol=0, atol=1e-14)
    assert got[-1] == pytest.approx(1.0, abs=1e-12)


def test_nnls_matches_scipy():
    from scipy.optimize import nnls as scipy_nnls
    rng = np.random.default_rng(7)
    for _ in range(300):
        m, n = rng.integers(2, 40), rng.integers(1, 13)
        a = rng.normal(size=(m, n))
        b = rng.normal(size=m)
        x = conespread.nnls(a, b)
        assert x.min() >= 0.0
        np.testing.assert_allclose(x, scipy_nnls(a, b)[0], rtol=0,
                                   atol=1e-10 * max(1.0, np.abs(x).max()))


def test_nnls_known_answers():
    # Unconstrained optimum inside the orthant: it is the answer.
    a = np.eye(3)
    np.testing.assert_allclose(conespread.nnls(a, [1.0, 2.0, 3.0]), [1.0, 2.0, 3.0])
    # A negative unconstrained component is clamped to 0.
    np.testing.assert_allclose(conespread.nnls(a, [1.0, -2.0, 3.0]), [1.0, 0.0, 3.0])
    # All negative: x = 0.
    np.testing.assert_array_equal(conespread.nnls(a, [-1.0, -2.0, -3.0]), np.zeros(3))


def test_multiple_scattering_cdf_is_kept_on_disk(tmp_path, monkeypatch):
    from aquaspec import cache
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
    cdf = ff_cdf()
    conespread._multiple_cdf.cache_clear()
    first = conespread.multiple_scattering_cdf(OFFSETS, cdf, 3.0, samples=4000)
    (path,) = tmp_path.glob("spread-cdf-*.npz")
    assert not list(tmp_path.glob("*.part*"))
    # Read back (no Monte Carlo: the file's numbers, marked, come out).
    with np.load(path) as z:
        stored = z["cdf"]
    np.testing.assert_array_equal(stored, first)
    cache.save_arrays(path, {"cdf": stored * 0.5})
    conespread._multiple_cdf.cache_clear()
    np.testing.assert_array_equal(
        conespread.multiple_scattering_cdf(OFFSETS, cdf, 3.0, samples=4000), 0.5 * first)
    # Another lambda, sample count or seed is another file.
    conespread.multiple_scattering_cdf(OFFSETS, cdf, 3.0, samples=4001)
    conespread.multiple_scattering_cdf(OFFSETS, cdf, 3.5, samples=4000)
    conespread.multiple_scattering_cdf(OFFSETS, cdf, 3.0, samples=4000, seed=1)
    assert len(list(tmp_path.glob("spread-cdf-*.npz"))) == 4
    # A damaged file is computed again.
    path.write_bytes(b"damaged")
    conespread._multiple_cdf.cache_clear()
    np.testing.assert_array_equal(
        conespread.multiple_scattering_cdf(OFFSETS, cdf, 3.0, samples=4000), first)
    conespread._multiple_cdf.cache_clear()


def test_multiple_scattering_cdf_without_a_cache(monkeypatch, tmp_path):
    from aquaspec import cache
    monkeypatch.setenv(cache.CACHE_ENV, "off")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    conespread._multiple_cdf.cache_clear()
    a = conespread.multiple_scattering_cdf(OFFSETS, ff_cdf(), 2.0, samples=3000)
    conespread._multiple_cdf.cache_clear()
    assert not list(tmp_path.iterdir())
    assert a[-1] == 1.0 and np.all(np.diff(a) >= 0)


def test_multiple_scattering_spread_moves_light_off_bright_targets():
    """spread_scattering="multiple" in Jerlov II (about one to three scatterings
    inside the cone over the board's 3 m): the white patch keeps less of its
    light and the black board around the patches gets more, the light moved,
    not made (the image's total within 1 %); the setup says which it used."""
    from aquaspec.colour.bands import Bands
    from aquaspec.scene.raycast import raycast_gbuffer
    from aquaspec.light.sky import surface_light
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.shading.shade import shade_gbuffer
    from aquaspec.validation.scenes import board_scene, masks
    from aquaspec.medium.water import load_water
    scene, cam = board_scene(3.0, width=96, height=72)
    gb = raycast_gbuffer(scene, cam)
    m = masks(gb)
    board = gb.hit & (gb.material == 24)
    out = {}
    for how in ("single", "multiple"):
        setup = SpectralSetup(load_water("II"), get_sensor("human"), surface_light("overcast"),
                              Bands(8), ms_model="lightfield", phase="petzold",
                              cone_spread=True, spread_scattering=how)
        assert setup.describe()["spread_scattering"] == how
        tables = setup.lightfield_tables()
        assert tables.cone.multiple == (how == "multiple")
        res = shade_gbuffer(gb, **setup.medium(gb.materials), return_radiance=True,
                            lightfield=tables)
        out[how] = res["radiance"]
        # The camera RGB is that of the spread radiance (it was not, with
        # "multiple", until 2026-11-24).
        w = setup.medium(gb.materials)["response_weights"]
        np.testing.assert_allclose(res["camera_rgb"], out[how] @ w, rtol=1e-9, atol=1e-15)
    single, multi = out["single"], out["multiple"]
    white = m["patches"][18]
    assert multi[white].mean() < 0.97 * single[white].mean()
    assert multi[board].mean() > 1.03 * single[board].mean()
    assert multi.sum() == pytest.approx(single.sum(), rel=0.01)
    with pytest.raises(AquaspecError, match="needs cone_spread=True"):
        SpectralSetup(load_water("II"), get_sensor("human"), surface_light("overcast"),
                      Bands(3), ms_model="lightfield", cone_spread=False,
                      spread_scattering="multiple").lightfield_tables()
