"""The surface seen from under the sea in render(): the waves' change to Snell's window."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import Reflectance
from aquaspec.colour.sensors import get_sensor, radiance_to_rgb
from aquaspec.light.sky import surface_light
from aquaspec.light.wave_facets import surface_facets
from aquaspec.light.waves import Waves
from aquaspec.medium.interface import N_WATER
from aquaspec.medium.water import load_water
from aquaspec.rendering.api import _Shaded, _View
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.rendering.surface_view import surface_seen_from_water
from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import GBuffer
from aquaspec.shading.above_water import sky_shape
from aquaspec.shading.below_waves import window_correction


def _case(waves, light=None):
    light = light or surface_light("sun-sky", sun_elevation_deg=50.0)
    setup = SpectralSetup(load_water("IB"), get_sensor("human"), light, Bands(4),
                          surface="flat", ms_model="lightfield", waves=waves)
    p = np.array([0.0, -3.0, 0.0])
    cam = Camera.look_at(p, p + [0.0, 0.8, -0.6], width=40, height=24, fov_y_deg=80.0)
    h, w = cam.height, cam.width
    dist = np.full((h, w), np.inf, np.float32)
    dist[:, :8] = 2.0                               # a surface in the way on the left
    gb = GBuffer(cam, dist, np.tile(np.float32([0, 0, 1]), (h, w, 1)),
                 np.zeros((h, w), np.uint32), np.zeros((h, w, 3), np.float32),
                 materials=[Reflectance.constant(0.3)])
    view = _View(None, cam, gb, False, {"kind": "test"})
    shaded = _Shaded(np.ones((h, w, 3)), np.ones((h, w, 4)), gb)
    return setup, view, shaded


def test_waves_change_the_open_water_looking_up_and_nothing_else():
    """(The sun at 10 degrees, behind the camera: its disc out of view.)"""
    waves = Waves(6.0, grid=32)
    setup, view, shaded = _case(waves, surface_light("sun-sky", sun_elevation_deg=10.0,
                                                     sun_azimuth_deg=180.0))
    out = surface_seen_from_water(setup, view, shaded, "numpy")
    med = setup.medium([])
    v = view.camera.ray_directions()
    open_up = (v[..., 1] > 0) & ~np.isfinite(shaded.gbuffer.distance)
    bands = window_correction(view.camera, open_up, setup.lightfield_tables(),
                              surface_facets(waves), a=med["a"], b=med["b"], e0=med["e0"],
                              sky_at=sky_shape(setup.sun_inputs()))
    rgb = radiance_to_rgb(bands, med["response_weights"])
    np.testing.assert_allclose(out.linear, 1.0 + rgb, rtol=1e-12)
    np.testing.assert_allclose(out.radiance, 1.0 + bands, rtol=1e-12)
    np.testing.assert_allclose(out.surface_change, rgb)
    assert np.abs(rgb[:, 8:]).max() > 0 and np.all(rgb[:, :8] == 0)


def test_a_flat_sea_under_an_overcast_sky_is_left_alone():
    setup, view, shaded = _case(None, surface_light("overcast"))
    assert surface_seen_from_water(setup, view, shaded, "numpy") is shaded


def test_the_sun_s_disc_seen_from_below():
    """The sun ahead of a camera looking up through the flat surface: a few
    pixels gain its disc, very bright; the rest of the window gains the
    clear sky's shape against the uniform sky (window_correction), and the
    pixels outside the window do not change."""
    light = surface_light("sun-sky", sun_elevation_deg=60.0, sun_azimuth_deg=0.0)
    setup, view, shaded = _case(None, light)
    out = surface_seen_from_water(setup, view, shaded, "numpy")
    med = setup.medium([])
    v = view.camera.ray_directions()
    open_up = (v[..., 1] > 0) & ~np.isfinite(shaded.gbuffer.distance)
    sky = radiance_to_rgb(window_correction(
        view.camera, open_up, setup.lightfield_tables(), None, a=med["a"], b=med["b"],
        e0=med["e0"], sky_at=sky_shape(setup.sun_inputs())), med["response_weights"])
    disc = out.surface_change - sky
    lit = np.any(np.abs(disc) > 1e-9, axis=-1)
    assert 1 <= lit.sum() <= 12
    assert disc[lit].min() > 100.0
    window = v[..., 1] > np.sqrt(1.0 - 1.0 / N_WATER ** 2)
    assert np.abs(sky[window & ~lit]).max() > 0.01 * np.abs(shaded.linear).max()
    np.testing.assert_array_equal(out.linear[~window & ~lit], shaded.linear[~window & ~lit])


def _box_scene():
    from aquaspec.scene.mesh import Scene
    from aquaspec.validation.scenes import cuboid
    return Scene([cuboid([-1.0, -1.5, -5.0], [1.0, -0.5, -3.5], 0, "box")],
                 [Reflectance.constant(0.8)])


def test_the_scene_mirrored_in_the_surface():
    """A bright box near the surface ahead of a camera looking up: the
    surface mirrors it (NumPy: below_mirror.scene_in_mirror on the mirrored
    camera's ray-cast G-buffer), and the pixels that see the box directly
    or look down do not change."""
    from aquaspec.scene.raycast import raycast_gbuffer
    from aquaspec.shading.below_mirror import mirrored_camera, scene_in_mirror
    scene = _box_scene()
    setup = SpectralSetup(load_water("IB"), get_sensor("human"), surface_light("overcast"),
                          Bands(4), surface="flat", ms_model="lightfield")
    p = np.array([0.0, -3.0, 0.0])
    cam = Camera.look_at(p, p + [0.0, 0.55, -0.83], width=48, height=32, fov_y_deg=90.0)
    gb = raycast_gbuffer(scene, cam)
    view = _View(scene, cam, gb, False, {"kind": "test"})
    h, w = cam.height, cam.width
    shaded = _Shaded(np.ones((h, w, 3)), np.ones((h, w, 4)), gb)
    out = surface_seen_from_water(setup, view, shaded, "numpy")
    med = setup.medium(scene.materials)
    v = cam.ray_directions()
    open_up = (v[..., 1] > 0) & ~np.isfinite(gb.distance)
    bands = scene_in_mirror(cam, open_up, raycast_gbuffer(scene, mirrored_camera(cam)),
                            setup.lightfield_tables(), a=med["a"], b=med["b"], e0=med["e0"],
                            material_bands=med["material_bands"],
                            sigmoid_centers_t=med["sigmoid_centers_t"])
    np.testing.assert_allclose(out.radiance, 1.0 + bands, rtol=1e-12)
    changed = np.any(out.surface_change != 0, axis=-1)
    assert changed.sum() > 10 and not changed[np.isfinite(gb.distance)].any()
    assert not changed[v[..., 1] <= 0].any()
    assert out.surface_change[changed].mean() > 0      # a bright box on darker water


@pytest.mark.gpu
def test_the_mirrored_scene_on_the_gpu_matches_numpy(device):
    """render() with a box mirrored in the surface: the GPU frame (raster
    pass from the mirrored camera, below_mirror.wgsl) against the NumPy frame
    (ray cast, below_mirror.py), within 1 % of the frame's brightest pixel
    (measured 0.44 %, the frames' own difference, 2026-11-28)."""
    from aquaspec.rendering.api import render
    p = np.array([0.0, -3.0, 0.0])
    cam = Camera.look_at(p, p + [0.0, 0.55, -0.83], width=96, height=64, fov_y_deg=90.0)
    kw = dict(scene=_box_scene(), camera=cam, size=(96, 64), bands=6, surface="flat")
    gpu = render(backend="gpu", **kw).linear_rgb
    ref = render(backend="numpy", **kw).linear_rgb
    np.testing.assert_allclose(gpu, ref, atol=0.01 * ref.max())
