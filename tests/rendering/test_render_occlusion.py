"""render(occlusion=True): the scene's occlusion of the ambient light on both
backends, recorded in the metadata, refused where it cannot apply."""

import json

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.rendering.api import render
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Mesh, Scene
from aquaspec.colour.reflectance import Reflectance
from aquaspec.validation.scenes import cuboid


@pytest.fixture(scope="module")
def ledge():
    scene = Scene()
    scene.add_material(Reflectance.constant(0.18, "grey"))
    scene.add_material(Reflectance.constant(0.05, "dark"))
    scene.add(Mesh(np.array([[-0.6, -5.5, -3], [0.6, -5.5, -3], [0.6, -4.5, -3],
                             [-0.6, -4.5, -3]], float), np.array([[0, 1, 2], [0, 2, 3]]),
                   np.tile([0.0, 0.0, 1.0], (4, 1)), 0, name="board"))
    scene.add(cuboid([-1.5, -4.2, -3.5], [1.5, -4.0, -1.5], 1, "ledge"))
    cam = Camera.look_at([0, -5, 0], [0, -5, -3], width=40, height=30, fov_y_deg=40)
    return scene, cam


@pytest.mark.parametrize("backend", ["gpu", "numpy"])
def test_board_under_the_ledge_darkens(ledge, backend):
    scene, cam = ledge
    kw = dict(water="IB", scene=scene, camera=cam, bands=8, backend=backend, exposure=0.0)
    plain = render(**kw)
    occ = render(**kw, occlusion=True)
    # The board's centre (the human observer's linear RGB: its sum).
    centre = occ.linear_rgb[12:18, 17:23].sum(-1).mean()
    base = plain.linear_rgb[12:18, 17:23].sum(-1).mean()
    assert centre < 0.9 * base
    assert np.all(np.isfinite(occ.linear_rgb))
    assert '"occlusion": true' in json.dumps(occ.params)
    assert '"occlusion": false' in json.dumps(plain.params)


def test_refused_where_it_cannot_apply(ledge):
    scene, cam = ledge
    with pytest.raises(AquaspecError, match="occlusion is part of the light-field model"):
        render(water="IB", scene=scene, camera=cam, bands=8, ms_model="seeds", occlusion=True)
    with pytest.raises(AquaspecError, match="accepted: one of them"):
        render(water="IB", scene=scene, camera=cam, bands=8, occlusion=True,
               ambient_shadow=True)


@pytest.mark.parametrize("backend", ["gpu", "numpy"])
def test_rgbd_visible_surface_occludes(ledge, backend):
    """An RGB-D photograph of the ledge (a wall behind it fills the view): its
    visible surface, the ledge's underside included, darkens the board."""
    from aquaspec.scene.raycast import raycast_gbuffer
    scene, cam = ledge
    walled = Scene()
    for m in scene.materials:
        walled.add_material(m)
    for m in scene.meshes:
        walled.add(m)
    walled.add(Mesh.flat(np.array([[-9, -12, -6], [9, -12, -6], [9, -0.5, -6],
                                   [-9, -0.5, -6]], float), np.array([[0, 1, 2], [0, 2, 3]]),
                         material=0, name="wall"))
    gb = raycast_gbuffer(walled, cam)
    assert gb.hit.all()
    z = gb.distance * (cam.ray_directions() @ cam.forward)
    rgb = np.full(z.shape + (3,), 0.5)
    rgbd = (rgb, z, (cam.fx, cam.fy, cam.cx, cam.cy))
    kw = dict(water="IB", rgbd=rgbd, depth_m=5.0, bands=8, backend=backend, exposure=0.0)
    plain = render(**kw)
    occ = render(**kw, occlusion=True)
    centre = occ.linear_rgb[12:18, 17:23].sum(-1).mean()
    base = plain.linear_rgb[12:18, 17:23].sum(-1).mean()
    assert centre < 0.95 * base
    assert np.all(np.isfinite(occ.linear_rgb))


def test_visible_surface_mesh_cuts_depth_jumps():
    from aquaspec.scene.gbuffer import GBuffer
    from aquaspec.scene.occlusion import visible_surface_occluders
    cam = Camera.look_at([0, -5, 0], [0, -5, -3], width=64, height=6, fov_y_deg=5)
    dist = np.full((6, 64), 3.0)
    dist[:, 4:] = 6.0                     # a step in depth between columns 3 and 4
    from aquaspec.scene.gbuffer import PER_PIXEL
    gb = GBuffer(cam, dist, np.tile([0.0, 0.0, 1.0], (6, 64, 1)),
                 np.full((6, 64), PER_PIXEL, np.uint32), np.zeros((6, 64, 3)), [])
    mesh = visible_surface_occluders(gb, step=1).meshes[0]
    # Cells of 3 + 59 columns on either side of the step, 5 rows, two
    # triangles each; the cells across the step are seen edge-on.
    assert len(mesh.faces) == 2 * 5 * (3 + 59)
    with pytest.raises(AquaspecError, match="occluder step 0"):
        visible_surface_occluders(gb, step=0)
