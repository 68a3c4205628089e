"""Caustics (aquaspec.light.caustics): the sea, the photon map, its lookup, and the
sun's terms with it (NumPy, GPU, CLI)."""

import numpy as np
import pytest

from aquaspec.light import caustics as cst
from aquaspec.light import waves as W
from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import N_WATER, refract
from aquaspec.light.sun import air_to_sun
from support.plates import plate


# ---- the sea ------------------------------------------------------------------------


# ---- refraction and the photon map --------------------------------------------------


def test_splat_conserves_weight_and_a_regular_lattice_is_uniform():
    m, n, tile = 64, 16, 2.0
    jj, ii = np.meshgrid(np.arange(m), np.arange(m))
    u = np.stack([jj, ii], axis=-1).reshape(-1, 2) * (tile / m) + [3 * tile, -7 * tile]
    out = cst.splat(u, np.full(m * m, (n / m) ** 2), n, tile)
    np.testing.assert_allclose(out, 1.0, atol=1e-12)
    rng = np.random.default_rng(0)
    w = rng.random(500)
    out = cst.splat(rng.normal(size=(500, 2)) * 5, w, n, tile)
    assert out.sum() == pytest.approx(w.sum(), rel=1e-12)


def _splat_by_corners(u, w, n, tile):
    """The bilinear splat written out: each corner of each point's cell by itself."""
    i0, i1, j0, j1, fz, fx = cst.periodic_cell(u, n, tile)
    out = np.zeros(n * n)
    for ii, wz in ((i0, 1.0 - fz), (i1, fz)):
        for jj, wx in ((j0, 1.0 - fx), (j1, fx)):
            np.add.at(out, ii * n + jj, w * wz * wx)
    return out.reshape(n, n)


@pytest.mark.parametrize("n", [16, 12])
def test_splat_by_moments_is_the_bilinear_splat(n):
    """One bincount pass per moment at the cell's corner (splat_texels) against
    each corner added by itself: the same texels, in float64 and (to float32's
    precision) from float32 coordinates; points on every edge of the wrap."""
    tile = 2.0
    rng = np.random.default_rng(1)
    u = np.concatenate([rng.uniform(-3 * tile, 4 * tile, (4000, 2)),
                        [[0.0, 0.0], [tile - 1e-9, tile - 1e-9], [tile * (n - 0.5) / n, 0.3],
                         [0.7, tile * (n - 0.5) / n], [-tile / (2 * n), -tile / (2 * n)]]])
    w = rng.random(len(u))
    want = _splat_by_corners(u, w, n, tile)
    np.testing.assert_allclose(cst.splat(u, w, n, tile), want, rtol=1e-12, atol=1e-12)
    ux, uz = (np.float32(c * (n / tile) - 0.5) for c in u.T)
    got = cst.splat_texels(ux, uz, w, n)
    assert got.dtype == np.float64
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5 * w.max())


def _sinusoid(amp, wavelength, tile, m, n_y=8):
    """A single wave along x on an (n_y, m) grid (the map accepts any periodic surface)."""
    x = np.arange(m) * tile / m
    k = 2 * np.pi / wavelength
    h = np.broadcast_to(amp * np.sin(k * x), (m, m)).copy()
    hx = np.broadcast_to(amp * k * np.cos(k * x), (m, m)).copy()
    return h, hx, np.zeros_like(h), x, k


def test_photon_map_matches_the_jacobian_of_a_sinusoid():
    """Before the first focus each point at depth d is lit from one facet:
    C(u) = w(x0) / (du/dx0). The map (texel-wide tent) against that, sampled densely."""
    tile, m, n = 2.0, 1024, 128
    amp, lam = 0.01, 1.0
    h, hx, hz, x, k = _sinusoid(amp, lam, tile, m)
    air = air_to_sun(70.0, 90.0)          # sun towards +x: the plane of the wave
    d = 2.0
    out, _ = cst.caustic_slices(h, hx, hz, tile, n, air, [d], sun_radius_deg=0.0)
    # Analytic, on a fine x0 grid: refract, land, take the derivative.
    x0 = np.linspace(0, tile, 200001)
    slope = amp * k * np.cos(k * x0)
    hh = amp * np.sin(k * x0)
    nrm = np.stack([-slope, np.ones_like(x0), np.zeros_like(x0)], -1)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    t, cos_i = refract(np.broadcast_to(-air, nrm.shape), nrm)
    w = cst.facet_weights(cos_i, nrm[:, 1], air[1])
    sx = t[:, 0] / np.abs(t[:, 1])
    s_flat = refract(-air[None], np.array([[0.0, 1.0, 0.0]]))[0][0]
    u = x0 + d * (sx - s_flat[0] / abs(s_flat[1])) + hh * sx
    dudx = np.gradient(u, x0)
    assert dudx.min() > 0.2                  # one facet per point: before the focus
    c = w / dudx
    # The tent average over each texel of the analytic C(u) (u mod tile).
    centres = (np.arange(n) + 0.5) * tile / n
    um = np.mod(u, tile)
    texel = tile / n
    expect = np.empty(n)
    for j, uc in enumerate(centres):
        dist = np.abs((um - uc + tile / 2) % tile - tile / 2)
        tent = np.clip(1 - dist / texel, 0, None)
        expect[j] = np.sum(tent * c * dudx) / np.sum(tent * dudx)
    got = out[0].mean(axis=0)
    assert np.std(got) > 0.1                  # a real pattern
    np.testing.assert_allclose(got, expect, rtol=0.01, atol=0.01)


def test_a_sinusoid_focuses_at_its_paraxial_depth():
    """Overhead sun, h = A sin(kx): a ray refracted at slope s turns by
    (1 - 1/n) s, so the crests focus at d_f = 1 / ((1 - 1/n) A k^2)."""
    tile, m, n = 1.0, 2048, 256
    amp, lam = 0.002, 0.5
    h, hx, hz, _, k = _sinusoid(amp, lam, tile, m)
    d_f = 1 / ((1 - 1 / N_WATER) * amp * k * k)
    depths = np.linspace(0.3, 2.0, 69) * d_f
    out, _ = cst.caustic_slices(h, hx, hz, tile, n, air_to_sun(90.0, 0.0), depths,
                                sun_radius_deg=0.0)
    brightest = out.max(axis=(1, 2))
    peak = depths[np.argmax(brightest)]
    # The crests' rays meet in a cusp at d_f; beyond it two fold lines part,
    # and a texel's mean is highest just past the cusp.
    assert d_f * 0.98 <= peak <= d_f * 1.15
    assert brightest.max() > 8.0
    assert brightest[depths < 0.6 * d_f].max() < 0.3 * brightest.max()


def test_map_keeps_the_mean_and_the_sun_disc_blurs():
    waves = W.Waves(3.0, grid=64, tile_m=2.0)
    sharp = cst.caustic_map(waves, 50.0, 0.0, slices=6, max_depth_m=20.0, sun_radius_deg=0.0)
    soft = cst.caustic_map(waves, 50.0, 0.0, slices=6, max_depth_m=20.0)
    for cm in (sharp, soft):
        means = cm.levels[0].mean(axis=(1, 2))
        np.testing.assert_allclose(means, cm.mean_weight, rtol=2e-3)
        for lv in cm.levels[1:]:
            np.testing.assert_allclose(lv.mean(axis=(1, 2)), means, rtol=2e-3)
        assert abs(cm.mean_weight - 1) < 0.01
    # The disc's blur grows with depth: the deepest slice loses contrast, the first does not.
    assert soft.levels[0][-1].std() < 0.9 * sharp.levels[0][-1].std()
    np.testing.assert_allclose(soft.levels[0][0], sharp.levels[0][0], atol=1e-6)


def test_disc_blur_is_an_ellipse_along_the_beam():
    n, tile = 256, 4.0
    img = np.zeros((n, n))
    img[n // 2, n // 2] = 1.0
    along = np.array([np.cos(0.5), np.sin(0.5)])
    out = cst.disc_blur(img, (0.4, 0.2), along, tile)
    assert out.sum() == pytest.approx(1.0, rel=1e-9)
    c = (np.arange(n) - n // 2) * tile / n
    xx, zz = np.meshgrid(c, c)
    pa = xx * along[0] + zz * along[1]
    pc = -xx * along[1] + zz * along[0]
    # Inside the ellipse the response is flat; well outside it is (nearly) zero.
    r = np.hypot(pa / 0.4, pc / 0.2)
    inside, outside = out[r < 0.7], out[r > 1.3]
    assert inside.std() < 0.15 * inside.mean()
    assert np.abs(outside).max() < 0.2 * inside.mean()
    assert inside.sum() * 0 + inside.mean() == pytest.approx(
        1.0 / (np.pi * 0.4 * 0.2 / (tile / n) ** 2), rel=0.1)


# ---- the lookup ---------------------------------------------------------------------

@pytest.fixture(scope="module")
def cmap():
    return cst.caustic_map(W.Waves(3.0, grid=64, tile_m=2.0), 60.0, 150.0, slices=8,
                           max_depth_m=10.0)


def test_sample_reads_texels_slices_and_tiles(cmap):
    lv = cmap.levels[0]
    n = lv.shape[-1]
    s = cmap.to_sun
    k, i, j = 3, 5, 17
    d = cmap.depths[k]
    u = ((np.array([j, i]) + 0.5) * cmap.texel)
    # a point at depth d whose foot is u
    p = np.array([u[0] - d / s[1] * s[0], -d, u[1] - d / s[1] * s[2]])
    assert cst.sample(cmap, p) == pytest.approx(lv[k, i, j], rel=1e-6)
    shifted = p + [cmap.waves.tile_m * 3, 0, -cmap.waves.tile_m]
    assert cst.sample(cmap, shifted) == pytest.approx(lv[k, i, j], rel=1e-6)
    # linear in sqrt(d / D) between slices
    d_mid = cmap.max_depth * ((k + 0.25) / (cmap.depths.size - 1)) ** 2
    q = np.array([u[0] - d_mid / s[1] * s[0], -d_mid, u[1] - d_mid / s[1] * s[2]])
    assert cst.sample(cmap, q) == pytest.approx(0.75 * lv[k, i, j] + 0.25 * lv[k + 1, i, j],
                                                rel=1e-6)
    # a footprint of the whole tile reads the mean
    assert cst.sample(cmap, p, footprint_m=10 * cmap.waves.tile_m) == pytest.approx(
        lv[k].mean(), rel=2e-3)
    # a footprint of two texels reads level 1
    lv1 = cmap.levels[1]
    u1 = (np.array([4, 6]) + 0.5) * cmap.texel * 2
    p1 = np.array([u1[0] - d / s[1] * s[0], -d, u1[1] - d / s[1] * s[2]])
    assert cst.sample(cmap, p1, 2 * cmap.texel) == pytest.approx(lv1[k, 6, 4], rel=1e-6)
    assert n == 64


# ---- the sun's terms with caustics --------------------------------------------------

def test_surface_term_is_modulated_by_the_sampled_factor(cmap):
    """No scattering (b = 0): a plate's sun term with caustics over the one
    without is the caustic factor read at each pixel's footprint."""
    from aquaspec.shading.sun import sun_radiance
    from aquaspec.transport.sun_scattering import PHASE_TABLE_SIZE, SunInputs
    from aquaspec.scene.camera import Camera
    from aquaspec.scene.raycast import raycast_gbuffer
    from aquaspec.colour.reflectance import Reflectance
    from aquaspec.scene import Scene
    scene = Scene()
    scene.add_material(Reflectance.constant(0.4))
    scene.add(plate(-5.0, -50, 50, -50, 50))
    cam = Camera.look_at([0.0, -2.0, 0.0], [0.0, -5.0, 0.0], width=24, height=24,
                         fov_y_deg=60.0, up=(0.0, 0.0, -1.0))
    gb = raycast_gbuffer(scene, cam)
    to_sun = cmap.to_sun
    base = SunInputs(beam0=np.array([2.0, 1.0]), c_sun=np.array([0.1, 0.3]),
                     c_view=np.array([0.1, 0.3]), b=np.zeros(2), to_sun=to_sun,
                     log_phase=np.log(np.full((2, PHASE_TABLE_SIZE), 1 / (4 * np.pi))))
    import dataclasses
    rho = dict(rho_of_hits=lambda m: np.full((m.sum(), 2), 0.4))
    flat = sun_radiance(gb, base, **rho)
    wavy = sun_radiance(gb, dataclasses.replace(base, caustics=cmap), **rho)
    hit = gb.hit
    expect = cst.sample(cmap, gb.positions()[hit], gb.distance[hit] / cam.fx)
    np.testing.assert_allclose(wavy[hit] / flat[hit], expect[:, None] * [1, 1], rtol=1e-9)
    assert expect.std() > 0.1


def _setup(wind, **kw):
    from aquaspec.colour.bands import Bands
    from aquaspec.light.sky import surface_light
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.medium.water import get_water
    light = surface_light("sun-sky", sun_elevation_deg=50.0, sun_azimuth_deg=30.0)
    return SpectralSetup(get_water("IB"), get_sensor("human"), light, Bands(6),
                         waves=None if wind is None else W.Waves(wind, **kw), ms_model="seeds")


def test_froxels_with_caustics_against_a_fine_march():
    """The veil's caustics: froxels (2 footprint-filtered reads per slice)
    against each pixel's own ray in 400 steps, built-in scene at 3 m. The
    froxels are 8 pixels wide, so their pattern is the column's mean."""
    import dataclasses
    from aquaspec.scene.shadowmap import numpy_shadow_map
    from aquaspec.shading.sun import sun_radiance
    from aquaspec.scene.raycast import raycast_gbuffer
    from aquaspec.scene.builtin import builtin_scene
    scene, cam = builtin_scene(3.0, width=160, height=90)
    setup = _setup(3.0)
    gb = raycast_gbuffer(scene, cam)
    sun = setup.sun_inputs()
    hmap, spec = numpy_shadow_map(scene, cam, sun.to_sun, size=512)
    black = dict(rho_of_hits=lambda m: np.zeros((m.sum(), 6)), height_map=hmap, spec=spec)
    frox = sun_radiance(gb, sun, **black)
    march = sun_radiance(gb, dataclasses.replace(sun, n_steps=400), method="march", **black)
    flat = sun_radiance(gb, dataclasses.replace(sun, caustics=None), **black)
    rel = np.abs(frox / march - 1.0)
    assert np.median(rel) < 0.05
    assert np.percentile(rel, 99) < 0.2
    assert abs(frox.sum() / march.sum() - 1.0) < 0.01
    # ... and the froxels follow the pattern the caustics put in the veil.
    gm, gf = (march / flat - 1.0).ravel(), (frox / flat - 1.0).ravel()
    assert np.median(np.abs(gm)) > 0.03
    assert np.corrcoef(gm, gf)[0, 1] > 0.7, np.corrcoef(gm, gf)[0, 1]   # measured 0.81


def _render(backend, **kw):
    from aquaspec.rendering.api import render
    base = dict(water="IB", depth_m=3.0, size=(96, 54), bands=6, light="sun-sky",
                sun_elevation_deg=50.0, sun_azimuth_deg=30.0, sun_shadow_map=256,
                exposure=0.0, waves=W.Waves(3.0, grid=128))
    return render(backend=backend, **{**base, **kw})


@pytest.mark.parametrize("ms_model", ["seeds", "lightfield"])
def test_gpu_caustics_match_numpy(device, ms_model):
    g = _render("gpu", ms_model=ms_model).linear_rgb
    n = _render("numpy", ms_model=ms_model).linear_rgb
    flat = _render("numpy", ms_model=ms_model, waves=None).linear_rgb
    scale = np.abs(n).max()
    err = np.abs(g - n).max(axis=-1) / scale
    assert np.percentile(err, 99) < 2e-4, np.percentile(err, [50, 99, 100])
    assert err.max() < 2e-3
    assert np.abs(n - flat).max() / scale > 0.05          # the caustics are there


@pytest.mark.parametrize("backend", ["numpy", "gpu"])
def test_layers_carry_the_caustics(backend, request):
    """D = t J still holds with the caustic factor in J."""
    if backend == "gpu":
        request.getfixturevalue("device")
    res = _render(backend, ms_model="seeds", sensor="nikon-5100-npl", layers=True)
    lay = res.layers
    hit = lay["range_m"] > 0
    tj = lay["transmission"] * lay["surface"]
    assert np.abs(lay["direct"] - tj)[hit].mean() < 1e-5 * np.abs(lay["direct"][hit]).mean()
    flat = _render(backend, ms_model="seeds", sensor="nikon-5100-npl", layers=True,
                   waves=None).layers
    ratio = lay["surface"][hit][:, 1] / flat["surface"][hit][:, 1]
    assert ratio.std() > 0.05


def test_render_records_the_waves_and_refuses_them_without_a_sun():
    res = _render("numpy", ms_model="seeds", size=(32, 18))
    c = res.params["caustics"]
    assert c["wind_speed_m_s"] == 3.0 and c["grid"] == 128 and c["slices"] == 32
    assert abs(c["mean_facet_weight"] - 1) < 0.01
    with pytest.raises(AquaspecError, match="sun-sky"):
        _render("numpy", light="overcast", size=(32, 18))
    with pytest.raises(AquaspecError, match="waves="):
        _render("numpy", waves="calm", size=(32, 18))


def test_cli_wind(tmp_path, capsys):
    import json
    from aquaspec.cli import main
    out = tmp_path / "c.png"
    base = ["render", "--size", "48x27", "--bands", "4", "--backend", "numpy", "-o", str(out)]
    assert main([*base, "--light", "sun-sky", "--wind", "2.5", "--wave-time", "1.5",
                 "--wind-azimuth", "45"]) == 0
    meta = json.loads((tmp_path / "c.png.json").read_text())
    assert meta["caustics"]["time_s"] == 1.5 and meta["caustics"]["wind_azimuth_deg"] == 45.0
    assert main([*base, "--wind", "2.5"]) == 2
    assert "needs --light sun-sky" in capsys.readouterr().err
    assert main([*base, "--light", "sun-sky", "--wave-seed", "4"]) == 2
    assert "needs --wind" in capsys.readouterr().err
    assert main([*base, "--light", "sun-sky", "--wind", "99"]) == 2
    assert "wind speed 99.0" in capsys.readouterr().err


# ---- the waves the tile leaves out ---------------------------------------------------


def test_run_jacobian_closed_forms():
    n = 1.33
    np.testing.assert_allclose(cst.run_jacobian([0.0, 1.0, 0.0], n), (1 - 1 / n) * np.eye(2),
                               rtol=1e-6)
    # Sun at azimuth 0 (towards -z), elevation 40: in the plane of incidence
    # the run tan(theta_t) changes by sec^2(theta_t) (1 - cos_i / (n cos_t))
    # per radian of tilt; across it the matrix has no cross terms.
    air = air_to_sun(40.0, 0.0)
    jac = cst.run_jacobian(air, n)
    cos_i = air[1]
    sin_t = np.sqrt(1 - cos_i ** 2) / n
    cos_t = np.sqrt(1 - sin_t ** 2)
    assert abs(jac[1, 1]) == pytest.approx((1 - cos_i / (n * cos_t)) / cos_t ** 2, rel=1e-5)
    assert abs(jac[0, 1]) < 1e-6 and abs(jac[1, 0]) < 1e-6
    assert 0 < jac[0, 0] < jac[1, 1]


def test_gaussian_blur_has_the_covariance():
    n, tile = 256, 8.0
    img = np.zeros((n, n))
    img[n // 2, n // 2] = 1.0
    cov = np.array([[0.09, 0.03], [0.03, 0.04]])
    out = cst.disc_blur(img, (0.0, 0.0), np.array([1.0, 0.0]), tile, cov=cov)
    assert out.sum() == pytest.approx(1.0, rel=1e-9)
    c = (np.arange(n) - n // 2) * tile / n
    xx, zz = np.meshgrid(c, c)
    got = np.array([[np.sum(out * xx * xx), np.sum(out * xx * zz)],
                    [np.sum(out * xx * zz), np.sum(out * zz * zz)]])
    np.testing.assert_allclose(got, cov, atol=1e-6)


def test_strong_wind_blurs_deep_caustics():
    waves = W.Waves(10.0, grid=64, tile_m=2.0)
    assert W.unresolved_slope_variance(waves) > 0.01
    kw = dict(slices=4, max_depth_m=9.0, sun_radius_deg=0.0)
    sharp = cst.caustic_map(waves, 60.0, 20.0, unresolved_slopes=False, **kw)
    soft = cst.caustic_map(waves, 60.0, 20.0, **kw)
    assert soft.info["unresolved_slope_blur"] and not sharp.info["unresolved_slope_blur"]
    np.testing.assert_allclose(soft.levels[0].mean(axis=(1, 2)),
                               sharp.levels[0].mean(axis=(1, 2)), rtol=2e-3)
    # Unchanged at the surface, less contrast below (the blur grows with depth).
    np.testing.assert_allclose(soft.levels[0][0], sharp.levels[0][0], atol=1e-6)
    assert soft.levels[0][1].std() < 0.8 * sharp.levels[0][1].std()
    calm = W.Waves(2.0, grid=64, tile_m=2.0)
    assert W.unresolved_slope_variance(calm) == 0.0


def test_slice_interp_reads_the_slices_as_the_lookup():
    """Per-slice values read between slices linearly in sqrt(d / D), as
    sample() reads a map whose slices are constant."""
    from aquaspec.light.caustic_sample import slice_interp

    depths = cst.slice_depths(10.0, 5)
    values = np.array([1.0, 2.0, 4.0, 3.0, 0.5])
    level0 = np.broadcast_to(values[:, None, None], (5, 16, 16)).astype(np.float32)
    cmap = cst.CausticMap(waves=W.Waves(3.0, tile_m=2.0, grid=16),
                               to_sun=np.array([0.0, 1.0, 0.0]), depths=depths,
                               levels=cst.mip_levels(level0), mean_weight=1.0)
    d = np.array([0.0, 0.3, 1.7, 5.0, 9.9, 12.0])
    pts = np.stack([np.full_like(d, 0.4), -d, np.full_like(d, 1.1)], axis=-1)
    np.testing.assert_allclose(slice_interp(values, d, 10.0), cst.sample(cmap, pts),
                               rtol=1e-6)
    np.testing.assert_allclose(slice_interp(values, depths, 10.0), values, rtol=1e-12)


def test_band_factor_scales_each_band_by_its_polynomial():
    """Scales whose ln is a polynomial in sqrt(d / D) of degree <= 8 are held
    exactly; band i reads 1 + s_i (C - 1); no scales: C itself."""
    from aquaspec.light.caustic_sample import scale_at, scale_polynomial

    depths = cst.slice_depths(20.0, 32)
    x = np.sqrt(depths / 20.0)
    scale = np.stack([np.exp(0.5 * x - 0.2 * x ** 3), np.exp(-1.5 * x ** 2), np.ones(32)], 1)
    coeffs = scale_polynomial(scale)
    d = np.array([0.0, 0.37, 3.3, 19.9, 25.0, np.nan])
    xd = np.sqrt(np.clip(np.nan_to_num(d), 0, 20.0) / 20.0)
    want = np.stack([np.exp(0.5 * xd - 0.2 * xd ** 3), np.exp(-1.5 * xd ** 2), np.ones(6)], 1)
    np.testing.assert_allclose(scale_at(coeffs, d, 20.0), want, rtol=1e-8)
    level0 = np.ones((32, 16, 16), np.float32)
    cmap = cst.CausticMap(waves=W.Waves(3.0, tile_m=2.0, grid=16), to_sun=np.array([0, 1.0, 0]),
                          depths=depths, levels=cst.mip_levels(level0), mean_weight=1.0,
                          band_scale=scale.astype(np.float32))
    c = np.array([0.2, 1.0, 3.0, 1.7, 0.0, 2.0])
    np.testing.assert_allclose(cst.band_factor(cmap, c, d), 1.0 + want * (c[:, None] - 1.0),
                               rtol=1e-6)
    plain = cst.CausticMap(waves=cmap.waves, to_sun=cmap.to_sun, depths=depths,
                           levels=cmap.levels, mean_weight=1.0)
    np.testing.assert_array_equal(cst.band_factor(plain, c, d), c[:, None])
    with pytest.raises(AquaspecError, match="band scales"):
        scale_polynomial(np.zeros((32, 2)))
