"""The GPU light-field pass against its NumPy twin (lightfield_compiled.shade_compiled).

How far the compiled model is from the model itself (shade_gbuffer with
tables) is tests/transport/lightfield/test_compiled.py's subject."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import PER_PIXEL
from aquaspec.light.sky import surface_light
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.colour.sensors import get_sensor
from aquaspec.shading.shade import shade_gbuffer
from aquaspec.medium.water import load_water

from support.lightfield_passes import gpu_pass, setup_of

pytestmark = pytest.mark.gpu



def with_per_pixel_materials(gb):
    """The G-buffer with two of every three hit pixels (so four-pixel groups
    mix both kinds) given their own sigmoid reflectances (varying, some steep)."""
    material = gb.material.copy()
    sigmoid = gb.sigmoid.copy()
    rows, cols = np.indices(gb.material.shape)
    sel = gb.hit & ((rows + cols) % 3 != 0)
    material[sel] = PER_PIXEL
    cols = np.broadcast_to(np.arange(gb.camera.width)[None, :], sel.shape)[sel]
    sigmoid[sel] = np.stack([0.3 * np.sin(cols / 7.0), 2.0 * np.cos(cols / 5.0),
                             -1.0 + cols / gb.camera.width], axis=1)
    return dataclasses.replace(gb, material=material, sigmoid=sigmoid)


def assert_fused_display_matches(lp, gb, fused_and_two_pass):
    """The pass's fused display image is the display pass's on its linear output (1 step)."""
    fused, expected = fused_and_two_pass(lp, gb.camera.width, gb.camera.height,
                                         exposure_ev=2.0, tonemap="filmic")
    diff = np.abs(fused.astype(int) - expected.astype(int))
    assert diff.max() <= 1 and np.mean(diff == 0) > 0.99


def assert_matches(got, ref, rtol=1e-3):
    scale = np.abs(ref).max()
    np.testing.assert_allclose(got, ref, rtol=rtol, atol=2e-6 * scale)


def twin_of(lp, gb, medium):
    """shade_compiled with the pass's compiled model (and pyramid weights)."""
    from aquaspec.transport.lightfield.conespread import node_pyramid_weights, pyramid_weights
    from aquaspec.transport.lightfield.compiled import shade_compiled
    tables = lp.tables
    cam = gb.camera
    weights = None
    if lp.nodes:
        weights = np.array(node_pyramid_weights(tables.cone, cam.fy, cam.height, cam.width))
    elif lp.spread:
        weights = pyramid_weights(tables.cone, cam.fy, cam.height, cam.width)
    return shade_compiled(gb, lp.reference_compiled(), material_bands=medium["material_bands"],
                          sigmoid_centers_t=medium["sigmoid_centers_t"],
                          pyramid_weights=weights, start_level=lp.spread_start_level)


@pytest.mark.parametrize("water,n,phase,kind,depth,cone", [
    ("IB", 8, "petzold", "builtin", 5.0, 0.0),
    ("3C", 3, "isotropic", "builtin", 9.0, 0.0),
    ("I", 16, "hg", "up", 4.0, 0.0),
    ("IB", 8, "hg", "up", 4.0, 15.0),
    ("II", 8, "petzold", "builtin", 5.0, 15.0),
    # A last group of four bands with one band in it, and with three.
    ("IB", 5, "petzold", "up", 4.0, 15.0),
    ("3C", 7, "isotropic", "builtin", 9.0, 15.0),
    # Four bands per loop iteration (aquaspec.gpu.materials.GROUPED_MIN_BANDS)
    # with one or two left over.
    ("IB", 17, "petzold", "builtin", 5.0, 15.0),
    ("II", 18, "hg", "up", 4.0, 0.0),
])
@pytest.mark.parametrize("filtering", [None, False])
def test_matches_reference(water, n, phase, kind, depth, cone, filtering, lightfield_gbuffer):
    """Both table reads (the sampler's filtering where the device has
    float32-filterable, the shader's own bilinear interpolation) match."""
    gb = lightfield_gbuffer(kind, depth)
    setup = setup_of(water, n, phase, cone)
    medium = setup.medium(gb.materials)
    lp = gpu_pass(gb, setup, filtering=filtering)
    lp.run()
    got = lp.read_rgb()
    assert lp.reference_compiled().depth_o == pytest.approx(depth)
    # f32 tables and arithmetic against float64 (measured up to 5e-6).
    assert_matches(got, twin_of(lp, gb, medium), rtol=1e-4)


@pytest.mark.parametrize("water,n,depth_h,rank,spread", [
    # Five irradiance functions of eight slots (a second texture read, one term).
    ("I", 6, 12.0, 5, False), ("I", 6, 12.0, 5, True), ("IB", 8, 7.8, 5, True),
    ("IB", 8, 7.8, 5, "multiple"),
])
def test_seabed_tables(water, n, depth_h, rank, spread, lightfield_gbuffer):
    """Tables with a Lambertian seabed: the water table is built on the GPU
    (watertable.wgsl, with the multiple-scattering spread's node layers and
    kept share too) and the pass matches its twin."""
    from aquaspec.transport.lightfield.bake import lightfield_tables
    gb = lightfield_gbuffer("builtin", 5.0)
    setup = setup_of(water, n, "petzold", cone=40.0 if spread else 15.0,
                     cone_spread=bool(spread))
    how = "multiple" if spread == "multiple" else "single"
    tables = lightfield_tables(setup.water.on_bands(setup.bands), phase="petzold",
                               seabed_depth_m=depth_h, seabed_albedo=0.3,
                               forward_cone_deg=setup.cone_deg, cone_spread=bool(spread),
                               spread_scattering=how)
    medium = setup.medium(gb.materials)
    lp = gpu_pass(gb, setup, tables=tables)
    assert lp.seabed and lp.spread == bool(spread) and lp.rank == rank
    lp.spread_start_level = 1 if how == "multiple" else None
    lp.run()
    if how == "multiple":
        from aquaspec.transport.lightfield.spreadplan import node_alpha
        comp = lp.reference_compiled()
        assert lp.nodes == 6 and comp.water.shape[0] == 7
        np.testing.assert_allclose(lp.water.read(channels=4)[0, :, :-1, 3],
                                   node_alpha(comp, lp.water.distances(5.0)), atol=1e-6)
    assert_matches(lp.read_rgb(), twin_of(lp, gb, medium), rtol=1e-3 if spread else 1e-4)
    plain = gpu_pass(gb, setup)                      # the same water over deep water
    plain.run()
    assert not plain.seabed and (lp.read_rgb() - plain.read_rgb()).mean() > 0


@pytest.mark.parametrize("rank", [5, 6, 7, 8])
def test_every_irradiance_rank(rank, lightfield_gbuffer, monkeypatch):
    """Ranks past four: the second texture read and one term per function
    (compile-time), against the twin with the same factorisation."""
    from aquaspec.transport.lightfield import compiled as lfc
    monkeypatch.setattr(lfc, "IRRADIANCE_RANKS", (rank,))
    gb = lightfield_gbuffer("builtin", 5.0)
    setup = setup_of("I", 12, "petzold", cone=15.0)
    lp = gpu_pass(gb, setup)
    assert lp.rank == rank
    lp.run()
    assert_matches(lp.read_rgb(), twin_of(lp, gb, setup.medium(gb.materials)), rtol=1e-4)


def test_band_group_texture_layout():
    from aquaspec.gpu.passes.lightfield import band_group_texture
    n, nd, nm = 6, 3, 5
    table = np.arange(n * nd * nm, dtype=np.float64).reshape(n, nd, nm)
    tex = band_group_texture(table)
    assert tex.shape == (2, nd, nm, 4) and tex.dtype == np.float32
    for band in range(n):
        np.testing.assert_array_equal(tex[band // 4, :, :, band % 4], table[band])
    # The last group's unused channels are zero.
    assert not tex[1, :, :, 2:].any()


def test_filtering_needs_the_device_feature(device):
    from aquaspec.gpu.gbuffer import GBufferTextures
    from aquaspec.gpu.passes.lightfield import LightfieldPass

    class NoFeatures:
        def __init__(self, dev):
            self._dev = dev
            self.features = set()

        def __getattr__(self, name):
            return getattr(self._dev, name)

    g = GBufferTextures(NoFeatures(device), 8, 4)
    assert LightfieldPass(g).filtering is False
    with pytest.raises(AquaspecError, match="float32-filterable"):
        LightfieldPass(g, filtering=True)


@pytest.mark.parametrize("kind,n,cone,filtering,start,projected", [
    ("builtin", 8, 40.0, None, None, False),
    ("builtin", 8, 40.0, None, 2, False),
    ("builtin", 8, 40.0, None, 2, True),
    ("builtin", 16, 40.0, None, 2, True),
    ("builtin", 19, 40.0, None, None, False),
    ("up", 5, 30.0, None, 3, True),
    ("up", 4, 40.0, False, 1, False),
])
def test_cone_spread_matches_reference(kind, n, cone, filtering, start, projected,
                                       fused_and_two_pass, lightfield_gbuffer, monkeypatch):
    """The pyramid on the GPU (the light-field pass split into radiance and
    cone term, then conespread.wgsl) against shade_gbuffer's NumPy pyramid,
    linear RGB and the fused display; the kept share with its term per band
    and projected (spreadplan.kept_projection, here from any band
    count; alpha = 0 without a coarse start never projects)."""
    import aquaspec.transport.lightfield.spreadplan as lfs
    monkeypatch.setattr(lfs, "KEPT_PROJECTION_MIN_BANDS", 1 if projected else 10 ** 6)
    gb = lightfield_gbuffer(kind, 5.0)
    setup = dataclasses.replace(setup_of("II", n, "ff", cone=cone),
                                phase_params=(("backscatter", 0.0183),), cone_spread=True)
    medium = setup.medium(gb.materials)
    lp = gpu_pass(gb, setup, filtering=filtering)
    lp.spread_start_level = start
    assert lp.spread
    lp.run()
    assert lp.spread_plan[0] == (0 if start is None else start)   # 96 pixels: no coarse start
    assert (lp.kept_projection(lp.spread_plan[1]) is not None) == projected
    linear = lp.read_rgb()
    ref = twin_of(lp, gb, medium)
    comp = lp.reference_compiled()
    assert comp.split and comp.water.shape[0] == 2
    assert_matches(linear, ref)
    plain = gpu_pass(gb, dataclasses.replace(setup, cone_spread=False))
    plain.run()
    # The spread does something (less when it starts coarse on a small image).
    assert np.abs(ref - plain.read_rgb()).max() > 0.005 * np.abs(ref).max()
    assert_fused_display_matches(lp, gb, fused_and_two_pass)


@pytest.mark.parametrize("start", [None, 2])
def test_cone_spread_with_far_targets_in_turbid_water(start, lightfield_gbuffer):
    """Targets 50x farther in Jerlov 7C: exp(-f b S) underflows float32 (f b S
    over 100), the pixel's kept share (spreadplan.kept_share)
    must stay finite with alpha = 0 (start at level 0) and alpha > 0."""
    gb = lightfield_gbuffer("builtin", 5.0)
    gb = dataclasses.replace(gb, distance=np.where(np.isfinite(gb.distance),
                                                   gb.distance * 50.0, gb.distance))
    setup = dataclasses.replace(setup_of("7C", 4, "ff", cone=40.0),
                                phase_params=(("backscatter", 0.0183),), cone_spread=True)
    lp = gpu_pass(gb, setup)
    lp.spread_start_level = start
    lp.run()
    assert (lp.spread_plan[1] == 0.0) == (start is None)
    linear = lp.read_rgb()                               # raises on NaN / infinity
    assert_matches(linear, twin_of(lp, gb, setup.medium(gb.materials)))


def test_render_api_uses_the_lightfield_pass():
    from aquaspec.rendering.api import render
    gpu = render(water="IB", depth_m=5.0, size=(48, 27), bands=4, ms_model="lightfield",
                 phase="isotropic")
    cpu = render(water="IB", depth_m=5.0, size=(48, 27), bands=4, ms_model="lightfield",
                 phase="isotropic", backend="numpy")
    assert gpu.params["ms_model"] == "lightfield" and gpu.params["phase"] == "isotropic"
    # Different rasterisers (GPU vs ray casting) agree away from silhouettes;
    # the GPU shades with the compiled model (tests/transport/lightfield/test_compiled.py:
    # within a few 1e-3 of the model on most pixels).
    close = np.isclose(gpu.linear_rgb, cpu.linear_rgb, rtol=5e-3).all(axis=-1)
    assert close.mean() > 0.9


@pytest.mark.parametrize("kind,depth,cone", [("builtin", 5.0, 0.0), ("up", 4.0, 15.0)])
def test_per_pixel_materials(kind, depth, cone, lightfield_gbuffer):
    """per_pixel True compiles the pipeline that reads the sigmoid texture."""
    gb = with_per_pixel_materials(lightfield_gbuffer(kind, depth))
    setup = setup_of("IB", 8, "petzold", cone)
    lp = gpu_pass(gb, setup)
    assert lp.gbuffer.per_pixel
    lp.run()
    got = lp.read_rgb()
    ref = twin_of(lp, gb, setup.medium(gb.materials))
    assert_matches(got, ref, rtol=1e-4)
    # The sigmoid pixels really differ from what their mesh material gives.
    plain = shade_gbuffer(lightfield_gbuffer(kind, depth), **setup.medium(gb.materials),
                          lightfield=setup.lightfield_tables())["camera_rgb"]
    changed = gb.material == PER_PIXEL
    assert np.abs(plain - ref)[changed].max() > 0.05 * np.abs(ref).max()


def test_per_pixel_false_ignores_the_sigmoid_texture(lightfield_gbuffer):
    """per_pixel False: the sigmoid texture is not read (garbage there changes
    nothing), and a PER_PIXEL material then is reported as a bad index."""
    from aquaspec.gpu.buffers import upload_texture
    from aquaspec.gpu.gbuffer import pack_gbuffer
    gb = lightfield_gbuffer("builtin", 5.0)
    setup = setup_of("IB", 8, "petzold")
    lp = gpu_pass(gb, setup)
    assert not lp.gbuffer.per_pixel
    lp.run()
    clean = lp.read_rgb()
    upload_texture(lp.device, lp.gbuffer.textures["sigmoid"],
                   np.full((gb.camera.height, gb.camera.width, 4), np.nan, np.float32))
    lp.run()
    np.testing.assert_array_equal(lp.read_rgb(), clean)
    pp = with_per_pixel_materials(gb)
    lp.gbuffer.use_textures(gb.camera, per_pixel=False)
    upload_texture(lp.device, lp.gbuffer.textures["surface"],
                   pack_gbuffer(pp)["surface"])
    lp.run()
    with pytest.raises(AquaspecError, match="material index"):
        lp.read_rgb()


@pytest.mark.parametrize("kind,depth,cone,tonemap", [("builtin", 5.0, 0.0, "filmic"),
                                                     ("up", 4.0, 15.0, "none")])
def test_fused_display_equals_display_pass(kind, depth, cone, tonemap, fused_and_two_pass,
                                           lightfield_gbuffer):
    from aquaspec.colour import display
    gb = lightfield_gbuffer(kind, depth)
    setup = setup_of("IB", 8, "hg", cone)
    lp = gpu_pass(gb, setup)
    lp.run()
    linear = lp.read_rgb()
    settings = display.display_settings(linear, white_balance="grey-world")
    kw = dict(exposure_ev=settings["exposure_ev"],
              white_balance_gains=settings["white_balance_gains"], tonemap=tonemap)
    fused, expected = fused_and_two_pass(lp, gb.camera.width, gb.camera.height, **kw)
    assert fused.shape == expected.shape and fused.dtype == np.uint8
    diff = np.abs(fused.astype(int) - expected.astype(int))
    assert diff.max() <= 1 and np.mean(diff == 0) > 0.99
    assert len(np.unique(fused.reshape(-1, 3), axis=0)) > 50   # a real picture
    with pytest.raises(AquaspecError, match="display image"):
        lp.read_rgb()
    lp.run()   # and back to linear output
    np.testing.assert_array_equal(lp.read_rgb(), linear)


def test_read_display_errors(lightfield_gbuffer):
    from aquaspec.gpu.buffers import upload_texture
    from aquaspec.gpu.gbuffer import pack_gbuffer
    gb = lightfield_gbuffer("builtin", 5.0)
    setup = setup_of("IB", 3, "isotropic")
    lp = gpu_pass(gb, setup, e0_scale=1e36)
    with pytest.raises(AquaspecError, match="set_display"):
        lp.run(display=True)
    lp.run()
    with pytest.raises(AquaspecError, match="display=True"):
        lp.read_display()
    with pytest.raises(AquaspecError, match="unknown tone map 'aces'"):
        lp.set_display(exposure_ev=0.0, tonemap="aces")
    # Overflow after exposure (E0 scaled by 1e36): counted, and the first
    # pixel named (row 0, column 0 sees open water, so it is the first).
    lp.set_display(exposure_ev=20.0)
    lp.run(display=True)
    with pytest.raises(AquaspecError, match=r"non-finite .* first is at \(row 0, column 0\)"):
        lp.read_display()
    # A material index out of range is reported first.
    packed = pack_gbuffer(gb)
    packed["surface"][gb.hit, 3] = 1000
    upload_texture(lp.device, lp.gbuffer.textures["surface"], packed["surface"])
    lp.set_display(exposure_ev=-64.0)
    lp.run(display=True)
    with pytest.raises(AquaspecError, match="material index >= "):
        lp.read_display()


@pytest.mark.parametrize("water,n,kind,start,filtering", [
    ("II", 8, "builtin", None, None),
    ("II", 8, "builtin", 2, None),
    ("3C", 5, "up", 1, False),
    ("IB", 17, "builtin", 3, None),
])
def test_multiple_scattering_spread_matches_its_twin(water, n, kind, start, filtering,
                                                     fused_and_two_pass, lightfield_gbuffer):
    """spread_scattering="multiple" on the GPU: the water table's node layers
    (watertable.wgsl), the coarse pass's node images, the pyramid with a
    weight set per node and the exact kept share per band, against
    lightfield_compiled (float64); it differs from the single-scattering
    spread, and the fused display agrees with the display pass."""
    from aquaspec.transport.lightfield.conespread import LAMBDA_NODES
    gb = lightfield_gbuffer(kind, 5.0)
    setup = SpectralSetup(load_water(water), get_sensor("nikon-5100-npl"),
                          surface_light("overcast"), Bands(n), ms_model="lightfield",
                          phase="petzold", cone_spread=True, spread_scattering="multiple")
    medium = setup.medium(gb.materials)
    lp = gpu_pass(gb, setup, filtering=filtering)
    lp.spread_start_level = start
    lp.run()
    assert lp.nodes == len(LAMBDA_NODES) and lp.spread_plan[0] == (start or 0)
    comp = lp.reference_compiled()
    assert comp.water.shape[0] == 1 + lp.nodes
    table = lp.water.read(channels=4)
    np.testing.assert_allclose(table[..., :3], comp.water, rtol=2e-4,
                               atol=2e-6 * np.abs(comp.water).max())
    # Layer 0's fourth channel: the share a hit pixel keeps (node_alpha).
    from aquaspec.transport.lightfield.spreadplan import node_alpha
    kept = node_alpha(comp, lp.water.distances(5.0))
    np.testing.assert_allclose(table[0, :, :-1, 3], kept, atol=1e-5)
    assert 0.0 <= kept.min() and kept.max() < 1.0
    assert np.ptp(kept) > 0.01 if start else kept.max() == 0.0   # start 0: nothing kept
    linear = lp.read_rgb()
    ref = twin_of(lp, gb, medium)
    assert_matches(linear, ref)
    single = gpu_pass(gb, dataclasses.replace(setup, spread_scattering="single"))
    single.spread_start_level = start
    single.run()
    assert np.abs(ref - single.read_rgb()).max() > 0.005 * np.abs(ref).max()
    assert_fused_display_matches(lp, gb, fused_and_two_pass)

