"""shade_gbuffer with the scene's occlusion of the ambient light field: a
board under a ledge darkens, the water under it too, and its checks."""

import dataclasses
import warnings

import numpy as np
import pytest

from aquaspec.colour.bands import Bands
from aquaspec.colour.reflectance import Reflectance
from aquaspec.errors import AquaspecError
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.scene.occlusion import occlusion_maps
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.shading.shade import shade_gbuffer
from aquaspec.transport.lightfield.bake import lightfield_tables


def box(lo, hi):
    """A closed axis-aligned box, faces wound counter-clockwise from outside."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    c = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                  for z in (lo[2], hi[2])])
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                      [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    tri = c[faces]
    out = np.einsum("ij,ij->i", np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                    tri.mean(axis=1) - c.mean(axis=0))
    return Mesh.flat(c, np.where(out[:, None] < 0, faces[:, ::-1], faces), material=1,
                     name="ledge")


@pytest.fixture(scope="module")
def ledge():
    """A grey board 3 m in front of the camera (5 m deep), a dark slab 0.3 m
    above its top edge reaching 1.5 m towards the camera; IB water, 6 bands."""
    from aquaspec.medium.water import load_water
    bands = Bands(6)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        bw = load_water("IB").on_bands(bands)
    scene = Scene()
    grey = Reflectance.constant(0.18, "grey")
    dark = Reflectance.constant(0.05, "dark")
    scene.add_material(grey)
    scene.add_material(dark)
    scene.add(Mesh(np.array([[-0.6, -5.5, -3], [0.6, -5.5, -3], [0.6, -4.5, -3],
                             [-0.6, -4.5, -3]], float), np.array([[0, 1, 2], [0, 2, 3]]),
                   np.tile([0.0, 0.0, 1.0], (4, 1)), 0, name="board"))
    scene.add(box([-1.5, -4.2, -3.5], [1.5, -4.0, -1.5]))
    cam = Camera.look_at([0, -5, 0], [0, -5, -3], width=24, height=18, fov_y_deg=40)
    gb = raycast_gbuffer(scene, cam)
    medium = dict(a=bw.a, b=bw.b, kd=bw.kd, e0=np.full(6, 0.5), response_weights=np.eye(6)[:, :3],
                  material_bands=np.stack([grey.on_bands(bands), dark.on_bands(bands)]),
                  sigmoid_centers_t=np.zeros(6))
    return scene, cam, gb, medium, lightfield_tables(bw, phase="petzold")


def test_board_under_the_ledge_darkens_and_open_water_stays(ledge):
    scene, cam, gb, medium, tables = ledge
    maps = occlusion_maps(scene, cam, directions=64, size=512)
    base = shade_gbuffer(gb, **medium, lightfield=tables, return_radiance=True)
    occ = shade_gbuffer(gb, **medium, lightfield=tables, return_radiance=True, occlusion=maps)
    board = gb.hit & (gb.material == 0)
    assert board.sum() > 20
    ratio = occ["radiance"][board].mean(0) / base["radiance"][board].mean(0)
    # The ledge hides most of the downwelling light: clearly darker in every
    # band, most in the red (the longest path lengths' light is lost least
    # in the blue, where the water is clearest).
    assert np.all(ratio < 0.9) and np.all(ratio > 0.1)
    assert ratio[-1] < ratio[0]
    assert np.all(occ["radiance"] <= base["radiance"] * (1 + 1e-12))
    # Open water: the water under the ledge is in its shadow (the water's
    # own ambient shadow), the water far below it hardly.
    water = ~gb.hit
    loss = 1.0 - occ["radiance"][..., 1] / base["radiance"][..., 1]
    rows = np.nonzero(water)[0]
    upper = water & (np.arange(gb.hit.shape[0])[:, None] < rows.min() + 3)
    lower = water & (np.arange(gb.hit.shape[0])[:, None] > rows.max() - 3)
    assert upper.any() and lower.any()
    assert loss[upper].mean() > 0.05
    assert loss[lower].mean() < loss[upper].mean()
    assert np.all(occ["radiance"] >= 0.0)


def test_nothing_to_occlude_changes_nothing(ledge):
    _, cam, gb, medium, tables = ledge
    empty = occlusion_maps(Scene(), cam)
    base = shade_gbuffer(gb, **medium, lightfield=tables)
    np.testing.assert_array_equal(shade_gbuffer(gb, **medium, lightfield=tables,
                                                occlusion=empty)["camera_rgb"], base["camera_rgb"])


def test_occlusion_needs_the_light_field_and_maps(ledge):
    scene, cam, gb, medium, tables = ledge
    maps = occlusion_maps(scene, cam, directions=16, size=64)
    with pytest.raises(AquaspecError, match="light-field"):
        shade_gbuffer(gb, **medium, occlusion=maps)
    with pytest.raises(AquaspecError, match="OcclusionMaps"):
        shade_gbuffer(gb, **medium, lightfield=tables, occlusion="maps")
    # The tables' own first-order shadow takes the same light: one or the other.
    shadowed = dataclasses.replace(tables, shadow=object())
    with pytest.raises(AquaspecError, match="ambient shadow"):
        shade_gbuffer(gb, **medium, lightfield=shadowed, occlusion=maps)
