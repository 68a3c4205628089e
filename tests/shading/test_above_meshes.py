"""Meshes under the water seen from above, and the sun's caustics on them
and on the seabed (aquaspec.shading.above_meshes)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import Reflectance
from aquaspec.colour.sensors import get_sensor
from aquaspec.light.sky import surface_light
from aquaspec.light.wave_facets import surface_facets
from aquaspec.light.waves import Waves
from aquaspec.medium.interface import N_WATER
from aquaspec.medium.water import get_water
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.camera import camera_above
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.seabed import Seabed
from aquaspec.shading.above_meshes import (seabed_caustics, surface_reflectance,
                                           water_to_hits)
from aquaspec.shading.above_water import sea_from_above

W, H = 40, 24
DEPTH = 4.0


def _square(depth, half, albedo=0.3, x0=0.0, z0=0.0):
    """A horizontal square facing up at ``depth``, side ``2 half``, grey ``albedo``."""
    v = np.array([[x0 - half, -depth, z0 - half], [x0 + half, -depth, z0 - half],
                  [x0 + half, -depth, z0 + half], [x0 - half, -depth, z0 + half]])
    faces = np.array([[0, 2, 1], [0, 3, 2]])
    mesh = Mesh(v, faces, np.tile([0.0, 1.0, 0.0], (4, 1)), 0, name="square")
    return Scene([mesh], [Reflectance.constant(albedo, name="grey")])


def _setup(light="overcast", waves=None, **kw):
    return SpectralSetup(get_water("IB"), get_sensor("human"), surface_light(light, **kw),
                         Bands(6), surface="flat", seabed=Seabed(DEPTH + 1e-6, 0.3),
                         waves=waves)


def _pair(setup, cam, caustics=False):
    """The sea from above with a grey square just above the light field's
    (equally grey) seabed, and without it."""
    scene = _square(DEPTH, 60.0)
    tables = setup.lightfield_tables()
    med = setup.medium(scene.materials)
    facets = None if setup.waves is None else surface_facets(setup.waves)
    sun = setup.sun_inputs(caustics=caustics)
    kw = dict(a=med["a"], b=med["b"], e0=med["e0"], sun=sun, facets=facets)
    hit, l_hit, spread = water_to_hits(scene, cam, tables, **kw,
                                       material_bands=med["material_bands"],
                                       sigmoid_centers_t=med["sigmoid_centers_t"])
    with_mesh = sea_from_above(cam, tables, **kw, under=(hit, l_hit, spread))
    without = sea_from_above(cam, tables, **kw)
    return hit, with_mesh, without, tables, sun, facets


def _inside(hit, margin=3):
    """``hit`` less ``margin`` pixels at its edges and the image's: where the
    forward cone's spread light (the mesh's, and the tables' seabed's kept in
    its pixel) is the same on both sides."""
    out = hit.copy()
    for _ in range(margin):
        out[1:-1, 1:-1] &= out[:-2, 1:-1] & out[2:, 1:-1] & out[1:-1, :-2] & out[1:-1, 2:]
        out[[0, -1], :] = False
        out[:, [0, -1]] = False
    return out


def test_a_mesh_on_the_seabed_looks_like_the_light_fields_seabed():
    """Overcast: a grey plane just above the light field's grey seabed is
    shaded (lit by the irradiance table, seen through the water over S) as
    the seabed boundary itself is, within 0.1 %."""
    cam = camera_above(3.0, 40.0, width=W, height=H)
    hit, a, b, *_ = _pair(_setup(), cam)
    down = cam.ray_directions()[..., 1] < 0
    assert hit[down].mean() > 0.9
    np.testing.assert_allclose(a[_inside(hit)], b[_inside(hit)], rtol=1e-3)


def test_with_the_sun_the_beam_on_the_mesh_is_the_seabeds():
    """With the sun: the beam on the plane, its single scattering over S and
    the tables' diffuse light give what the tables' seabed (lit by the beam)
    and the beam's scattering down to it give."""
    cam = camera_above(3.0, 40.0, width=W, height=H)
    setup = _setup("sun-sky", sun_elevation_deg=50.0, sun_azimuth_deg=180.0)
    hit, a, b, *_ = _pair(setup, cam)
    np.testing.assert_allclose(a[_inside(hit)], b[_inside(hit)], rtol=2e-3)


def test_under_waves_the_caustics_on_mesh_and_seabed_agree():
    """Under waves with the sun, the caustics on the plane and on the light
    field's seabed (seabed_caustics) are the same pattern: the mesh's image
    equals the seabed's plus its caustics, and the caustics are there (the
    seabed's radiance varies by over 10 % where the flat-lit one does not)."""
    cam = camera_above(3.0, 60.0, width=W, height=H)
    setup = _setup("sun-sky", waves=Waves(5.0), sun_elevation_deg=60.0,
                   sun_azimuth_deg=180.0)
    hit, a, b, tables, sun, facets = _pair(setup, cam, caustics=True)
    extra = (1.0 - surface_reflectance(cam, facets))[..., None] / N_WATER ** 2 \
        * seabed_caustics(cam, tables, sun, facets=facets)
    core = _inside(hit)
    np.testing.assert_allclose(a[core], (b + extra)[core], rtol=2e-3,
                               atol=2e-3 * float(np.abs(b[hit]).max()))
    assert np.abs(extra[hit]).max() > 0.1 * np.abs(b[hit]).max()
    skipped = seabed_caustics(cam, tables, sun, facets=facets, skip=hit)
    assert np.all(skipped[hit] == 0.0)


def test_a_square_under_water_looks_larger_by_refraction():
    """Looking straight down from h at a white square of side 2a at depth D,
    the square's apparent half-angle is a / (h + D / n) (paraxial, the
    square small): its width in pixels, within one pixel."""
    h, d, a = 2.0, 2.0, 0.2
    cam = camera_above(h, 90.0, width=161, height=161, fov_y_deg=20.0)
    setup = SpectralSetup(get_water("IB"), get_sensor("human"), surface_light("overcast"),
                          Bands(4), surface="flat")
    scene = _square(d, a, albedo=0.9)
    med = setup.medium(scene.materials)
    hit, *_ = water_to_hits(scene, cam, setup.lightfield_tables(), a=med["a"], b=med["b"],
                           e0=med["e0"], material_bands=med["material_bands"],
                           sigmoid_centers_t=med["sigmoid_centers_t"])
    width = hit[80].sum()
    expect = 2.0 * cam.fx * np.tan(a / (h + d / N_WATER))
    assert width == pytest.approx(expect, abs=1.0)
    in_air = 2.0 * cam.fx * a / (h + d)                  # without refraction: smaller
    assert width > in_air + 5


def test_occlusion_darkens_the_seabed_beside_a_box_seen_from_above():
    """With the scene's occlusion maps the hits get the light of the
    directions they see: the seabed hugging a box's side loses ambient light
    (over 3 %), the box's top and the open seabed far from it keep theirs
    (within 0.5 %)."""
    from aquaspec.scene.occlusion import occlusion_maps
    from aquaspec.validation.above_check import above_camera, box_scene
    cam = above_camera(64)
    box, centre = box_scene(3.0, cam)
    floor = _square(3.0, 30.0)
    scene = Scene(list(box.meshes) + [dataclasses.replace(m, material=1) for m in floor.meshes],
                  list(box.materials) + list(floor.materials))
    setup = SpectralSetup(get_water("IB"), get_sensor("human"), surface_light("overcast"),
                          Bands(4), surface="flat", seabed=Seabed(3.0 + 1e-6, 0.3))
    tables, med = setup.lightfield_tables(), setup.medium(scene.materials)
    kw = dict(a=med["a"], b=med["b"], e0=med["e0"], material_bands=med["material_bands"],
              sigmoid_centers_t=med["sigmoid_centers_t"])
    hit, plain, _ = water_to_hits(scene, cam, tables, **kw)
    hit2, shaded, _ = water_to_hits(scene, cam, tables, **kw,
                                    occlusion=occlusion_maps(scene, cam, directions=64))
    np.testing.assert_array_equal(hit, hit2)
    from aquaspec.shading.above_meshes import rays_into_water
    from aquaspec.scene.raycast import raycast_rays
    _, o, t = rays_into_water(cam)
    p = (o + t * raycast_rays(scene, o, t).distance[..., None])[hit]
    change = shaded.sum(axis=1) / plain.sum(axis=1) - 1.0
    half = np.array([0.5, 0.4, 0.5])
    rel = np.abs(p - centre) - half
    top = (np.abs(p[:, 1] - (centre[1] + half[1])) < 1e-6) & np.all(rel[:, [0, 2]] < -0.05, 1)
    on_floor = np.abs(p[:, 1] + 3.0) < 1e-6
    gap = np.max(rel[:, [0, 2]], axis=1)          # distance outside the box's footprint
    beside = on_floor & (gap > 0) & (gap < 0.1)
    far = on_floor & (np.hypot(p[:, 0] - centre[0], p[:, 2] - centre[2]) > 3.0)
    assert top.sum() > 20 and beside.sum() > 5 and far.sum() > 20
    assert np.abs(change[top]).max() < 5e-3
    assert np.abs(change[far]).max() < 5e-3
    assert change[beside].max() < -0.03
