"""The occlusion factors on the GPU (aquaspec.gpu.passes.occlusion) against
their NumPy twin (occlusion_factor on occlusion_maps), the closed occluder's
maps against the NumPy maps, and what is kept between frames."""

import warnings

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.occlusion import occlusion_layout, occlusion_maps
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.transport.lightfield.occlusion import occlusion_factor, weights_from_tables

#: Pixels whose GPU factor may differ from NumPy's by more than FACTOR_TOL
#: (rasterisation and float32 at the occluders' edges), share of hit pixels.
EDGE_SHARE = 0.03
FACTOR_TOL = 0.01


def box(lo, hi, name):
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                  for z in (lo[2], hi[2])])
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    # Every other face wound the wrong way: the pass must orient them itself.
    return Mesh.flat(c, faces, material=1, name=name)


@pytest.fixture(scope="module")
def ledge():
    """A board 3 m in front of a camera at 5 m, a closed slab above it, an
    open quad (a single-sided wall) behind it; IB water, 5 bands."""
    from aquaspec.colour.bands import Bands
    from aquaspec.colour.reflectance import Reflectance
    from aquaspec.medium.water import load_water
    from aquaspec.transport.lightfield.bake import lightfield_tables
    bands = Bands(5)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bw = load_water("IB").on_bands(bands)
    scene = Scene()
    scene.add_material(Reflectance.constant(0.18, "grey"))
    scene.add_material(Reflectance.constant(0.05, "dark"))
    scene.add(Mesh(np.array([[-0.6, -5.5, -3], [0.6, -5.5, -3], [0.6, -4.5, -3],
                             [-0.6, -4.5, -3]], float), np.array([[0, 1, 2], [0, 2, 3]]),
                   np.tile([0.0, 0.0, 1.0], (4, 1)), 0, name="board"))
    scene.add(box([-1.5, -4.2, -3.5], [1.5, -4.0, -1.5], "ledge"))
    scene.add(Mesh.flat(np.array([[-2, -6.5, -3.6], [2, -6.5, -3.6], [2, -3.5, -3.6],
                                  [-2, -3.5, -3.6]], float), np.array([[0, 1, 2], [0, 2, 3]]),
                        material=1, name="wall"))
    cam = Camera.look_at([0.3, -5, 0], [0, -5, -3], width=48, height=36, fov_y_deg=50)
    tables = lightfield_tables(bw, phase="petzold")
    return scene, cam, raycast_gbuffer(scene, cam), bw, tables


def _numpy_factors(scene, cam, gb, weights, size):
    maps = occlusion_maps(scene, cam, directions=32, size=size)
    hit = gb.hit
    dirs = cam.ray_directions()[hit]
    pts = cam.position + dirs * gb.distance[hit][:, None]
    nrm = gb.normal[hit].astype(float)
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    return maps, occlusion_factor(weights, -pts[:, 1], nrm, *maps.visibility(pts, nrm))


def _gpu(device, gb, scene, cam, weights, size, scale):
    from aquaspec.gpu.gbuffer import GBufferTextures
    from aquaspec.gpu.passes.occlusion import OcclusionPass
    from aquaspec.scene.occlusion import BIAS_TEXELS, NORMAL_OFFSET_TEXELS
    tex = GBufferTextures(device, cam.width, cam.height)
    tex.upload(gb)
    occ = OcclusionPass(device, cam.width, cam.height, weights.n_bands, scale=scale)
    occ.set_weights(weights)
    lay = occlusion_layout(scene, cam, directions=32, size=size)
    enc = device.create_command_encoder()
    assert occ.encode(enc, tex, lay, normal_offset_texels=NORMAL_OFFSET_TEXELS,
                      bias_texels=BIAS_TEXELS)
    device.queue.submit([enc.finish()])
    return occ, tex, lay


def test_factors_match_numpy_per_pixel(device, ledge):
    scene, cam, gb, bw, tables = ledge
    lay = occlusion_layout(scene, cam, directions=32, size=512)
    weights = weights_from_tables(tables, lay.directions, lay.solid_angle, a=bw.a, b=bw.b)
    maps, ref = _numpy_factors(scene, cam, gb, weights, 512)
    occ, _, _ = _gpu(device, gb, scene, cam, weights, 512, 1)
    got = occ.read()
    assert got.shape == (36, 48, 5)
    np.testing.assert_array_equal(got[~gb.hit], 1.0)
    hit_got = got[gb.hit]
    assert ref.min() < 0.6              # the slab and the wall do take light
    bad = np.abs(hit_got - ref).max(axis=1) > FACTOR_TOL
    assert bad.mean() < EDGE_SHARE, (bad.mean(), np.abs(hit_got - ref).max())
    np.testing.assert_allclose(hit_got.mean(0), ref.mean(0), atol=3e-3)


def test_coarse_grid_takes_each_cell_centre(device, ledge):
    scene, cam, gb, bw, tables = ledge
    lay = occlusion_layout(scene, cam, directions=32, size=512)
    weights = weights_from_tables(tables, lay.directions, lay.solid_angle, a=bw.a, b=bw.b)
    full, _, _ = _gpu(device, gb, scene, cam, weights, 512, 1)
    coarse, tex, lay = _gpu(device, gb, scene, cam, weights, 512, 4)
    f, c = full.read(), coarse.read()
    assert c.shape == (9, 12, 5)
    np.testing.assert_allclose(c, f[2::4, 2::4], atol=2e-3)
    # Same camera and scene: kept; a turned camera computes them again.
    from aquaspec.scene.occlusion import BIAS_TEXELS, NORMAL_OFFSET_TEXELS
    enc = device.create_command_encoder()
    assert not coarse.encode(enc, tex, lay, normal_offset_texels=NORMAL_OFFSET_TEXELS,
                             bias_texels=BIAS_TEXELS)
    turned = Camera.look_at([0.3, -5, 0], [0.2, -5, -3], width=48, height=36, fov_y_deg=50)
    tex.upload(raycast_gbuffer(scene, turned))
    assert coarse.encode(enc, tex, lay, normal_offset_texels=NORMAL_OFFSET_TEXELS,
                         bias_texels=BIAS_TEXELS)
    device.queue.submit([enc.finish()])
    assert coarse.compute_count == 2


def test_bad_inputs(device, ledge):
    from aquaspec.gpu.passes.occlusion import OcclusionPass
    with pytest.raises(AquaspecError, match="occlusion scale 0"):
        OcclusionPass(device, 48, 36, 5, scale=0)
    scene, cam, gb, bw, tables = ledge
    occ = OcclusionPass(device, 48, 36, 5)
    with pytest.raises(AquaspecError, match="set_weights"):
        occ.encode(device.create_command_encoder(), None, None, normal_offset_texels=1.0,
                   bias_texels=1.0)
    lay = occlusion_layout(scene, cam, directions=16, size=64)
    with pytest.raises(AquaspecError, match="4 bands"):
        from aquaspec.colour.bands import Bands
        from aquaspec.medium.water import load_water
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            w4 = load_water("IB").on_bands(Bands(4))
        from aquaspec.transport.lightfield.bake import lightfield_tables
        occ.set_weights(weights_from_tables(lightfield_tables(w4), lay.directions,
                                            lay.solid_angle, a=w4.a, b=w4.b))


@pytest.mark.parametrize("cone,scale", [(0.0, 1), (15.0, 1), (0.0, 4)])
def test_lightfield_pass_applies_the_factors(device, ledge, cone, scale):
    """The light-field pass with the factors (both of its pipelines with the
    cone spread) against its twin shade_compiled given the same factors
    (scale 1: each pixel its own; 4: the grid read as the shader reads it,
    one bilinear sample per four adjacent pixels at their centre)."""
    from support.lightfield_passes import gpu_pass, setup_of
    from aquaspec.transport.lightfield.compiled import shade_compiled
    from aquaspec.transport.lightfield.conespread import pyramid_weights
    scene, cam, gb, _, _ = ledge
    setup = setup_of("IB", 5, "petzold", cone, cone_spread=cone > 0)
    lp = gpu_pass(gb, setup)
    assert lp.spread == (cone > 0)
    lp.run()
    plain = lp.read_rgb()
    lay = occlusion_layout(scene, cam, directions=32, size=512)
    medium = setup.medium(gb.materials)
    weights = weights_from_tables(lp.tables, lay.directions, lay.solid_angle, a=medium["a"],
                                  b=medium["b"])
    occ, _, _ = _gpu(device, gb, scene, cam, weights, 512, scale)
    lp.set_occlusion(occ)
    lp.run()
    got = lp.read_rgb()
    factors = occ.read()
    if scale > 1:
        factors = _upsample(factors, scale, cam.height, cam.width)
    pw = pyramid_weights(lp.tables.cone, cam.fy, cam.height, cam.width) if lp.spread else None
    ref = shade_compiled(gb, lp.reference_compiled(), material_bands=medium["material_bands"],
                         sigmoid_centers_t=medium["sigmoid_centers_t"], pyramid_weights=pw,
                         start_level=lp.spread_start_level, surface_scale=factors)
    np.testing.assert_allclose(got, ref, rtol=2e-3, atol=2e-6 * np.abs(ref).max())
    board = gb.hit & (gb.material == 0)
    assert np.all(got[board].mean(0) < 0.9 * plain[board].mean(0))
    lp.set_occlusion(None)
    lp.run()
    np.testing.assert_array_equal(lp.read_rgb(), plain)


def _upsample(grid, scale, h, w):
    """Bilinear read of the factors' grid as occlusion_sample.wgsl does with
    cells of 4 pixels or more: cell coordinate (p - scale // 2) / scale,
    clamped at the edges, one sample per four pixels of a row at p = 4 g + 1.5."""
    gh, gw = grid.shape[:2]
    y = np.clip((np.arange(h) - scale // 2) / scale, 0, gh - 1)
    x = np.clip((4 * (np.arange(w) // 4) + 1.5 - scale // 2) / scale, 0, gw - 1)
    y0 = np.minimum(np.floor(y).astype(int), gh - 2)
    x0 = np.minimum(np.floor(x).astype(int), gw - 2)
    fy, fx = (y - y0)[:, None, None], (x - x0)[None, :, None]
    g = grid.astype(float)
    top = g[y0][:, x0] * (1 - fx) + g[y0][:, x0 + 1] * fx
    bot = g[y0 + 1][:, x0] * (1 - fx) + g[y0 + 1][:, x0 + 1] * fx
    return top * (1 - fy) + bot * fy


def test_renderer_occludes_surfaces_as_numpy_does(ledge):
    """Renderer.set_occlusion: the frame's surfaces against shade_gbuffer with
    the NumPy maps (surfaces only, occlude_water=False); open water unchanged;
    a still camera keeps the factors, a moved one computes them again."""
    from aquaspec.rendering.renderer import Renderer
    from aquaspec.shading.shade import shade_gbuffer
    from support.lightfield_passes import setup_of
    scene, cam, gb, _, _ = ledge
    setup = setup_of("IB", 5, "petzold")
    r = Renderer(cam.width, cam.height, 5)
    plain = r.render_scene(scene, cam, setup)
    r.set_occlusion(True, directions=32, scale=1, map_size=512)
    occ = r.render_scene(scene, cam, setup)
    again = r.render_scene(scene, cam, setup)
    assert r.occlusion.compute_count == 1
    np.testing.assert_array_equal(again, occ)
    medium = setup.medium(gb.materials)
    tables = setup.lightfield_tables()
    maps = occlusion_maps(scene, cam, directions=32, size=512)
    base = shade_gbuffer(gb, **medium, lightfield=tables)["camera_rgb"]
    ref = shade_gbuffer(gb, **medium, lightfield=tables, occlusion=maps,
                        occlude_water=False)["camera_rgb"]
    np.testing.assert_allclose(occ[~gb.hit], plain[~gb.hit], rtol=1e-6)
    board = gb.hit & (gb.material == 0)
    np.testing.assert_allclose(occ[board].mean(0) / plain[board].mean(0),
                               ref[board].mean(0) / base[board].mean(0), rtol=0.02)
    moved = Camera.look_at([0.3, -5.1, 0], [0, -5, -3], width=48, height=36, fov_y_deg=50)
    r.render_scene(scene, moved, setup)
    assert r.occlusion.compute_count == 2
    r.set_occlusion(False)
    np.testing.assert_array_equal(r.render_scene(scene, cam, setup), plain)
