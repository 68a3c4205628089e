"""The scene mirrored in the sea surface seen from below (shading.below_mirror)."""

from __future__ import annotations

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import Reflectance
from aquaspec.colour.sensors import get_sensor
from aquaspec.light.sky import surface_light
from aquaspec.medium.interface import N_WATER, fresnel_transmittance_out
from aquaspec.medium.water import load_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.shading.below_mirror import (mirror_background_table, mirror_hits, mirrored_camera,
                                           scene_in_mirror)
from aquaspec.transport.lightfield.tables import table_depths


def _setup(light=None):
    return SpectralSetup(load_water("IB"), get_sensor("human"), light or surface_light("overcast"),
                         Bands(4), surface="flat")


def _plate(depth, material=0, half=30.0):
    """A horizontal square at ``depth`` m, facing up."""
    y = -float(depth)
    return Mesh(np.array([[-half, y, -half], [-half, y, half], [half, y, half], [half, y, -half]]),
                np.array([[0, 1, 2], [0, 2, 3]]), material=material)


def test_the_mirrored_camera_sees_the_mirrored_rays():
    cam = Camera(np.array([0.3, -2.0, 0.1]), np.array([0.2, 0.7, -0.6]), np.array([0, 1.0, 0]),
                 9, 6, 7.5, 8.0, 3.7, 2.2)
    m = mirrored_camera(cam)
    np.testing.assert_allclose(m.ray_directions()[:, ::-1], cam.ray_directions() * [1, -1, 1],
                               atol=1e-12)
    np.testing.assert_allclose(m.position, [0.3, 2.0, 0.1])


def test_a_plate_seen_in_the_mirror():
    """A grey plate 3 m under the surface, the camera 2 m deep looking up
    and out: every ray going up sees the plate in the mirror at S2 = 3 / v_y
    beyond the surface, at the plate's depth; the change is T'(S) R
    (L(plate) - L(open water)) from the light field's pixel radiance, largest
    outside Snell's window (total internal reflection, R = 1), and nothing
    changes for rays going down or stopped by a surface before the water's."""
    setup = _setup()
    tables, med = setup.lightfield_tables(), setup.medium([Reflectance.constant(0.6)])
    scene = Scene([_plate(3.0)], [Reflectance.constant(0.6)])
    p = np.array([0.0, -2.0, 0.0])
    cam = Camera.look_at(p, p + [0.0, 0.5, -0.866], width=40, height=30, fov_y_deg=100.0)
    v = cam.ray_directions()
    open_up = np.ones(v.shape[:2], bool)
    open_up[:, :5] = False
    hits = mirror_hits(cam, open_up, raycast_gbuffer(scene, mirrored_camera(cam)))
    t = 5.0 / np.maximum(v[..., 1], 1e-9)                # to the plate along the mirror
    expect = open_up & (v[..., 1] > 0) & (np.abs(v[..., 0] * t) < 29.5) \
        & (np.abs(v[..., 2] * t) < 29.5)
    assert expect.sum() > 300 and np.all(hits.mask[expect]) and not hits.mask[~open_up].any()
    assert not hits.mask[v[..., 1] <= 0].any()
    np.testing.assert_allclose(hits.s2, 3.0 / hits.v_y, rtol=1e-4)
    np.testing.assert_allclose(hits.depth, 3.0, atol=1e-4)
    np.testing.assert_allclose(hits.normal, np.tile([0.0, 1.0, 0.0], (len(hits.s2), 1)),
                               atol=1e-6)
    kw = {k: med[k] for k in ("a", "b", "e0", "material_bands", "sigmoid_centers_t")}
    d = scene_in_mirror(cam, open_up, raycast_gbuffer(scene, mirrored_camera(cam)), tables,
                        **kw)
    assert np.all(d[~hits.mask] == 0) and np.all(np.isfinite(d))
    i = np.argmax(hits.v_y < np.sqrt(1.0 - 1.0 / N_WATER ** 2))      # outside the window
    vy = hits.v_y[i]
    col = (lambda x: np.array([[x]]))
    plate = tables.pixel_radiance(a=med["a"], b=med["b"], e0=med["e0"], depth_o=col(0.0),
                                  v_y=col(-vy), s=col(3.0 / vy), rho=np.full((1, 4), 0.6),
                                  surface_depth=col(3.0), n_y=col(1.0))
    water = tables.pixel_radiance(a=med["a"], b=med["b"], e0=med["e0"], depth_o=col(0.0),
                                  v_y=col(-vy), s=col(np.inf))
    c_beam = tables.ray_extinction(med["a"], med["b"])
    want = np.exp(-c_beam * 2.0 / vy) * (plate - water)[0]
    assert fresnel_transmittance_out(vy) == 0
    np.testing.assert_allclose(d[hits.mask][i], want, rtol=1e-5)     # float32 distances
    assert np.all(want > 0)                          # a bright plate brightens the mirror
    window = hits.v_y > 0.8
    assert np.abs(d[hits.mask][window]).max() < 0.2 * np.abs(d[hits.mask][~window]).max()


def test_the_sun_lights_the_mirrored_scene():
    """With a sun, the plate's mirror image gains its direct beam, rho E_b(d) mu0 / pi,
    attenuated over both legs and by the surface's reflectance."""
    light = surface_light("sun-sky", sun_elevation_deg=60.0)
    setup = _setup(light)
    tables, med, sun = setup.lightfield_tables(), setup.medium([]), setup.sun_inputs()
    mats = [Reflectance.constant(0.5)]
    scene = Scene([_plate(2.0)], mats)
    p = np.array([0.0, -1.0, 0.0])
    cam = Camera.look_at(p, p + [0.0, 0.4, -0.9], width=24, height=16, fov_y_deg=60.0)
    gb = raycast_gbuffer(scene, mirrored_camera(cam))
    open_up = np.ones((16, 24), bool)
    kw = dict(a=med["a"], b=med["b"], e0=med["e0"], material_bands=np.full((1, 4), 0.5),
              sigmoid_centers_t=med["sigmoid_centers_t"])
    lit = scene_in_mirror(cam, open_up, gb, tables, sun=sun, **kw)
    dark = scene_in_mirror(cam, open_up, gb, tables, **kw)
    hits = mirror_hits(cam, open_up, gb)
    beam = 0.5 / np.pi * sun.beam0 * np.exp(-sun.c_sun * 2.0 / sun.mu0) * sun.to_sun[1]
    want = (np.exp(-tables.ray_extinction(med["a"], med["b"])
                   * (hits.s_top + hits.s2)[:, None])
            * (1.0 - fresnel_transmittance_out(hits.v_y))[:, None] * beam)
    np.testing.assert_allclose((lit - dark)[hits.mask], want, rtol=1e-6)   # float32 distances


def test_the_background_table_is_the_open_water_s_radiance():
    """The table the GPU reads (mirror_background_table) against the light
    field's pixel radiance at points between its nodes: within 1 %."""
    setup = _setup()
    tables, med = setup.lightfield_tables(), setup.medium([])
    table = mirror_background_table(tables, a=med["a"], b=med["b"], e0=med["e0"])
    nd, nm = table.shape[:2]
    depth = np.array([0.3, 2.0, 7.5, 20.0])
    r_y = np.array([-0.97, -0.7, -0.35, -0.1])
    x = np.sqrt(depth / tables.max_depth_m) * (nd - 1)
    y = np.arccos(-r_y) * 2 / np.pi * (nm - 1)
    i, j = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - i)[:, None], (y - j)[:, None]
    lerp = ((1 - fx) * ((1 - fy) * table[i, j] + fy * table[i, j + 1])
            + fx * ((1 - fy) * table[i + 1, j] + fy * table[i + 1, j + 1]))
    direct = tables.pixel_radiance(a=med["a"], b=med["b"], e0=med["e0"], depth_o=depth[:, None],
                                   v_y=r_y[:, None], s=np.full((4, 1), np.inf))
    np.testing.assert_allclose(lerp, direct, rtol=0.01)
    assert table_depths(tables.max_depth_m, 2)[-1] == tables.max_depth_m


def test_waves_move_the_scene_in_the_mirror():
    """Under a 6 m/s sea each ray is mirrored by the tile's facet: an upright
    tile gives the flat surface's mirror exactly; the waves' facets move
    where the plate is seen (still at its depth) and change the image."""
    from aquaspec.light.wave_facets import SurfaceFacets, surface_facets
    from aquaspec.light.waves import Waves
    setup = _setup()
    tables, med = setup.lightfield_tables(), setup.medium([Reflectance.constant(0.6)])
    scene = Scene([_plate(3.0)], [Reflectance.constant(0.6)])
    p = np.array([0.0, -2.0, 0.0])
    cam = Camera.look_at(p, p + [0.0, 0.5, -0.866], width=40, height=30, fov_y_deg=100.0)
    gb = raycast_gbuffer(scene, mirrored_camera(cam))
    open_up = np.ones((30, 40), bool)
    kw = {k: med[k] for k in ("a", "b", "e0", "material_bands", "sigmoid_centers_t")}
    flat = scene_in_mirror(cam, open_up, gb, tables, **kw)
    upright = SurfaceFacets(np.zeros((8, 8, 2), np.float32), 4.0, 0.0)
    np.testing.assert_allclose(scene_in_mirror(cam, open_up, gb, tables, facets=upright, **kw),
                               flat, rtol=1e-12)
    facets = surface_facets(Waves(6.0, grid=64))
    wavy = scene_in_mirror(cam, open_up, gb, tables, facets=facets, **kw)
    hits = mirror_hits(cam, open_up, gb, facets)
    np.testing.assert_allclose(hits.depth, 3.0, atol=1e-3)
    assert np.all(hits.r_y < 0) and hits.mask.sum() > 300
    assert not np.allclose(hits.r_y, -hits.v_y, atol=1e-3)
    assert np.abs(wavy - flat).max() > 0.1 * np.abs(flat).max()
    assert np.all(np.isfinite(wavy))
