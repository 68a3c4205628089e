"""The lamps' GPU pass (aquaspec.gpu.passes.lamps) against its NumPy twin
(aquaspec.shading.lamp.lamp_radiance) on the same rasterised G-buffer: a wall
and a blocker lit by a spot lamp and a point lamp, with and without shadows;
the shadow maps against the NumPy ray-cast ones."""

import numpy as np
import pytest

from aquaspec.colour.reflectance import Reflectance
from aquaspec.colour.sensors import radiance_to_rgb
from aquaspec.light.lamp import Lamp
from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import hit_reflectance
from aquaspec.scene.lamp_shadow import face_depth_map, lamp_shadow_faces
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.shading.lamp import lamp_radiance
from aquaspec.transport.lamp_scattering import LampInputs
from aquaspec.transport.sun_scattering import log_phase_table

N = 4
WL = np.linspace(420.0, 680.0, N)
#: float32 against float64 with the same samples, per pixel and channel, relative
#: (measured: at most 2.5e-3, median 5e-5; the profile's 513-entry table near its kink;
#: the veil's columns in a 3-D texture of float32, or float16 where float32 is not filterable).
RTOL = 5e-3
#: With shadows, the rasterised and the ray-cast maps differ by a texel at shadow
#: edges: the share of pixels allowed beyond RTOL (measured: none).
EDGE_SHARE = 0.01


def scene_and_camera(width=48, height=32):
    grey = Reflectance("grey", np.array([400.0, 700.0]), np.array([0.6, 0.3]))
    scene = Scene(materials=[grey])
    faces = np.array([[0, 1, 2], [0, 2, 3]])
    wall = np.array([[-4, -10, -5], [4, -10, -5], [4, -3, -5], [-4, -3, -5]], float)
    block = np.array([[-0.5, -6.6, -2.5], [0.3, -6.6, -2.5], [0.3, -5.9, -2.5],
                      [-0.5, -5.9, -2.5]], float)
    scene.add(Mesh.flat(wall, faces, name="wall"))
    scene.add(Mesh.flat(block, faces, name="block"))
    cam = Camera.look_at([0.0, -6.0, 0.0], [0.0, -6.3, -5.0], width=width, height=height,
                         fov_y_deg=70.0)
    return scene, cam


def lamp_inputs(cam, phase="petzold", halo=True):
    a = np.linspace(0.05, 0.4, N)
    b = np.linspace(0.3, 0.2, N)
    lamps = [Lamp((1.5, 0.5, 0.0), direction=(-0.3, -0.2, -1.0), cone_deg=35.0,
                  power_w=30.0, spectrum="led"),
             Lamp((-1.0, -5.5, -1.0), cone_deg=180.0, intensity_w_sr=0.8, spectrum="halogen",
                  frame="world")]
    from aquaspec.colour.bands import Bands
    bands = Bands(N, 400.0, 700.0)
    table = log_phase_table(phase, b=b, wavelength_nm=bands.centers_nm)
    return [LampInputs(lamp.placed(cam), lamp.intensity_on(bands), a + b, a + 0.8 * b, b, table,
                       forward=np.full(N, 0.2), halo=halo) for lamp in lamps], bands


def run(device, scene, cam, inputs, shadows: bool):
    from aquaspec.gpu.gbuffer import GBufferTextures
    from aquaspec.gpu.passes.lamps import LampPass
    from aquaspec.gpu.passes.raster import RasterPass
    raster = RasterPass(device)
    gbt = GBufferTextures(device, cam.width, cam.height)
    lp = LampPass(device, cam.width, cam.height, N, map_size=256)
    mb = np.stack([m.on_bands(inputs[1]) for m in scene.materials])
    w = np.ones((N, 3)) * np.array([1.0, 2.0, 0.5])
    t = (inputs[1].centers_nm - 550.0) / 100.0
    lp.set_inputs(inputs[0], response_weights=w, material_bands=mb, sigmoid_centers_t=t)
    enc = device.create_command_encoder()
    raster.render_to(gbt, scene, cam, encoder=enc)
    lp.encode_shadow_maps(enc, raster, scene if shadows else None)
    lp.encode(enc, cam, gbt.textures)
    device.queue.submit([enc.finish()])
    gpu = lp.read_rgb()
    g = raster.read_gbuffer(scene, cam, gbt.textures)
    maps = None
    if shadows:
        maps = []
        for inp in inputs[0]:
            faces = lamp_shadow_faces(inp.lamp, 256)
            maps.append((faces, [face_depth_map(scene, f) for f in faces]))
    rad = lamp_radiance(g, inputs[0], shadows=maps, rho_of_hits=lambda m: hit_reflectance(
        g.material[m], g.sigmoid[m], mb, t))
    ref = radiance_to_rgb(rad.reshape(-1, N), w).reshape(gpu.shape)
    return gpu, ref, lp, g


@pytest.mark.parametrize("shadows", [False, True])
def test_gpu_matches_numpy(device, shadows):
    scene, cam = scene_and_camera()
    gpu, ref, _, g = run(device, scene, cam, lamp_inputs(cam), shadows)
    assert np.all(np.isfinite(gpu))
    # Every pixel sees the point lamp's light at least (its veil).
    assert np.all(ref > 0)
    rel = np.abs(gpu - ref) / ref
    if not shadows:
        assert rel.max() < RTOL
    else:
        assert np.mean(rel.max(axis=-1) > RTOL) < EDGE_SHARE
        assert np.median(rel) < 1e-3


@pytest.mark.slow
def test_gpu_matches_numpy_with_wide_columns(device):
    """At 288x192 the veil's columns are 3 pixels wide: the GPU's trilinear read
    of the columns is the NumPy twin's (the shadowed veil included)."""
    from aquaspec.transport.lamp_froxels import lamp_tile
    scene, cam = scene_and_camera(288, 192)
    assert lamp_tile(cam) == 3
    gpu, ref, _, _ = run(device, scene, cam, lamp_inputs(cam), True)
    rel = np.abs(gpu - ref) / ref
    assert np.mean(rel.max(axis=-1) > RTOL) < EDGE_SHARE
    assert np.median(rel) < 1e-3


@pytest.mark.slow
def test_many_bands_read_the_glow_table_from_storage(device):
    """Past 64 bands the glow's table no longer fits a uniform buffer (nor, past
    32, the phase table) and is read from storage: the GPU still matches NumPy
    (a point lamp, whose spot factors are 1, with 72 bands)."""
    from aquaspec.colour.bands import Bands
    from aquaspec.gpu.gbuffer import GBufferTextures
    from aquaspec.gpu.passes.lamps import LampPass
    from aquaspec.gpu.passes.raster import RasterPass
    n = 72
    scene, cam = scene_and_camera(24, 16)
    bands = Bands(n, 400.0, 700.0)
    b = np.linspace(0.3, 0.2, n)
    lamp = Lamp((-1.0, -5.5, -1.0), cone_deg=180.0, intensity_w_sr=0.8, frame="world")
    inp = LampInputs(lamp.placed(cam), lamp.intensity_on(bands), 0.1 + b, 0.1 + b, b,
                     log_phase_table("petzold", b=b, wavelength_nm=bands.centers_nm),
                     forward=np.full(n, 0.3))
    raster = RasterPass(device)
    gbt = GBufferTextures(device, cam.width, cam.height)
    lp = LampPass(device, cam.width, cam.height, n, map_size=64)
    assert not lp._halo_uniform and not lp._phase_uniform
    mb = np.stack([m.on_bands(bands) for m in scene.materials])
    w = np.ones((n, 3)) * np.array([1.0, 2.0, 0.5])
    t = (bands.centers_nm - 550.0) / 100.0
    lp.set_inputs([inp], response_weights=w, material_bands=mb, sigmoid_centers_t=t)
    enc = device.create_command_encoder()
    raster.render_to(gbt, scene, cam, encoder=enc)
    lp.encode_shadow_maps(enc, raster, None)
    lp.encode(enc, cam, gbt.textures)
    device.queue.submit([enc.finish()])
    gpu = lp.read_rgb()
    g = raster.read_gbuffer(scene, cam, gbt.textures)
    rad = lamp_radiance(g, [inp], rho_of_hits=lambda m: hit_reflectance(
        g.material[m], g.sigmoid[m], mb, t))
    ref = radiance_to_rgb(rad.reshape(-1, n), w).reshape(gpu.shape)
    assert np.all(ref > 0)
    assert np.max(np.abs(gpu - ref) / ref) < RTOL


def test_display_fused_into_the_pixel_pass(device):
    """encode_pixels(display=True) gives the display pass's image of its linear
    result, byte for byte but for rounding (at most 1 of 255)."""
    from aquaspec.gpu.passes.display import DisplayPass
    scene, cam = scene_and_camera()
    _, _, lp, _ = run(device, scene, cam, lamp_inputs(cam), True)
    disp = DisplayPass(cam.width, cam.height, device=device)
    disp.use_input(lp.rgb_buffer)
    settings = dict(exposure_ev=3.0, white_balance_gains=(1.0, 0.9, 1.2), tonemap="filmic")
    disp.set_settings(**settings)
    lp.set_display(**settings)
    enc = device.create_command_encoder()
    disp.encode(enc)
    device.queue.submit([enc.finish()])
    ref = disp.read().astype(int)
    lin = lp.read_rgb()
    # The pixel pass again, this time from a black image, into the display.
    enc = device.create_command_encoder()
    enc.clear_buffer(lp.rgb_buffer)
    lp.encode_pixels(enc, display=True)
    device.queue.submit([enc.finish()])
    got = lp.read_display().astype(int)
    assert np.all(np.abs(got - ref) <= 1) and ref.max() > 50
    np.testing.assert_allclose(lp.read_rgb(), 0.0)     # the linear image left alone
    assert lin.max() > 0


def test_shadow_darkens_the_wall_behind_the_blocker(device):
    """(Without the glow, which the shadows do not darken.)"""
    scene, cam = scene_and_camera()
    inputs = lamp_inputs(cam, halo=False)
    lit, _, _, g = run(device, scene, cam, inputs, False)
    shaded, _, lp, _ = run(device, scene, cam, inputs, True)
    assert lp.shadowed
    assert np.mean(shaded[..., 1] < 0.7 * lit[..., 1]) > 0.01
    assert np.all(shaded <= lit * (1 + 1e-4) + 1e-9)


def test_shadow_maps_match_ray_casting(device):
    scene, cam = scene_and_camera()
    inputs, _ = lamp_inputs(cam)
    _, _, lp, _ = run(device, scene, cam, (inputs, lamp_inputs(cam)[1]), True)
    faces = lamp_shadow_faces(inputs[0].lamp, 256)
    gpu = lp.read_shadow_depths(0)
    ref = face_depth_map(scene, faces[0])
    both = np.isfinite(gpu) & np.isfinite(ref)
    assert np.mean(np.isfinite(gpu) != np.isfinite(ref)) < 5e-3
    assert np.mean(np.abs(gpu[both] - ref[both]) < 1e-3 * ref[both]) > 0.99


@pytest.mark.parametrize("start", [0, 2])
def test_cone_share_into_the_spread_input(device, start):
    """With the light field's cone spread the pass writes its lit surfaces'
    forward-cone share (lamp_radiance(split_cone=True)) at the spread's start
    level, the mean of each block's two diagonal pixels, into the spread's
    extra input, and its pixels keep alpha of their share."""
    from aquaspec.gpu.buffers import read_buffer
    from aquaspec.gpu.passes.conespread import ConeSpreadPass
    from aquaspec.gpu.passes.lamps import LampPass
    from aquaspec.gpu.gbuffer import GBufferTextures
    from aquaspec.gpu.passes.raster import RasterPass
    from aquaspec.transport.lightfield.conespread import level_shapes
    from aquaspec.transport.lightfield.spreadplan import coarse_sample_pixels
    import dataclasses
    scene, cam = scene_and_camera()
    inputs, bands = lamp_inputs(cam)
    # The spot lamp alone, with a strong forward cone: its lit wall is most of
    # the image.
    inputs = [dataclasses.replace(inputs[0], forward=np.full(N, 0.9))]
    raster = RasterPass(device)
    gbt = GBufferTextures(device, cam.width, cam.height)
    lp = LampPass(device, cam.width, cam.height, N, map_size=256)
    mb = np.stack([m.on_bands(bands) for m in scene.materials])
    w = np.ones((N, 3)) * np.array([1.0, 2.0, 0.5])
    t = (bands.centers_nm - 550.0) / 100.0
    lp.set_inputs(inputs, response_weights=w, material_bands=mb, sigmoid_centers_t=t)
    ch, cw = level_shapes(cam.height, cam.width, start)[-1]
    sp = ConeSpreadPass(device, cw, ch, 1)
    alpha = 0.25
    lp.set_cone_spread(sp, start, alpha)
    enc = device.create_command_encoder()
    raster.render_to(gbt, scene, cam, encoder=enc)
    lp.encode_shadow_maps(enc, raster, None)
    lp.encode_veil(enc, cam, gbt.textures)
    lp.encode_cone(enc)
    lp.encode_pixels(enc)
    device.queue.submit([enc.finish()])
    assert sp.extra_on
    extra = read_buffer(device, sp.extra, np.float32, (ch, cw, 4))[..., :3]
    gpu = lp.read_rgb()
    g = raster.read_gbuffer(scene, cam, gbt.textures)
    full, cone = lamp_radiance(g, inputs, split_cone=True, rho_of_hits=lambda m: hit_reflectance(
        g.material[m], g.sigmoid[m], mb, t))
    to_rgb = lambda x: radiance_to_rgb(x.reshape(-1, N), w).reshape(gpu.shape)
    full, cone = to_rgb(full), to_rgb(cone)
    assert np.abs(cone).max() > 0.3 * full.max()
    ys, xs = coarse_sample_pixels(cam.height, cam.width, start)
    want = cone[ys, xs].mean(axis=2)
    np.testing.assert_allclose(extra, want, atol=RTOL * np.abs(want).max())
    pixels = full - (1.0 - alpha) * cone
    np.testing.assert_allclose(gpu, pixels, rtol=RTOL, atol=1e-3 * pixels.max())
    assert np.abs(full - pixels).max() > 0.2 * full.max()
    sp.set_extra(False)
    assert not sp.extra_on
