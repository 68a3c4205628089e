"""A mesh given a seabed stands on it: a plane the camera sees at the light
field's lower boundary (aquaspec.scene.seabed.with_seabed_plane, render()'s
``_with_seabed_plane``)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from aquaspec.cli import main
from aquaspec.colour.bands import Bands
from aquaspec.errors import AquaspecError
from aquaspec.rendering.api import render
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.seabed import (PLANE_TRANSMISSION, Seabed, plane_radius_m,
                                   with_seabed_plane)

CAMERA_DEPTH_M = 12.0
SEABED_DEPTH_M = 15.0
#: Float32 distances in the G-buffer: positions a few tens of metres away
#: hold about 1e-5 of their distance; 1 mm is far below any other surface.
DEPTH_TOL_M = 1e-3


@pytest.fixture(scope="module")
def box(tmp_path_factory):
    """A 1 m box: place_in_front puts it 3 m ahead at the camera's depth, so
    its bottom is 0.5 m below the camera and 2.5 m above the seabed."""
    import trimesh
    path = tmp_path_factory.mktemp("mesh") / "box.ply"
    trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(path)
    return path


def kw(box, **more):
    return dict(mesh=box, depth_m=CAMERA_DEPTH_M, water="IB", size=(48, 27), bands=4,
                exposure=0.0, **more)


def hit_depth(gbuffer):
    """(H, W) depth below the surface of each hit, m (nan for open water)."""
    cam = gbuffer.camera
    s = np.where(gbuffer.hit, gbuffer.distance, np.nan)
    return -(cam.position[1] + cam.ray_directions()[..., 1] * s)


def seabed_pixels(gbuffer):
    """(H, W) bool: hits on a surface at the seabed's depth."""
    return gbuffer.hit & (np.abs(hit_depth(gbuffer) - SEABED_DEPTH_M) < DEPTH_TOL_M)


class TestPlane:
    def test_geometry(self):
        scene, cam = builtin_scene(5.0, width=16, height=9)
        bed = Seabed(9.0, 0.3)
        out = with_seabed_plane(scene, bed, cam, 100.0)
        plane = out.meshes[-1]
        assert out.seabed is bed and len(out.meshes) == len(scene.meshes) + 1
        assert len(scene.materials) + 1 == len(out.materials)      # the input is untouched
        np.testing.assert_array_equal(plane.vertices[:, 1], -9.0)
        # Faces wound towards +y (the rasteriser's front faces), normals up.
        e1 = plane.vertices[plane.faces[:, 1]] - plane.vertices[plane.faces[:, 0]]
        e2 = plane.vertices[plane.faces[:, 2]] - plane.vertices[plane.faces[:, 0]]
        assert np.all(np.cross(e1, e2)[:, 1] > 0)
        np.testing.assert_array_equal(plane.normals, np.tile([0.0, 1.0, 0.0], (33, 1)))
        ring = np.hypot(*(plane.vertices[1:, [0, 2]] - cam.position[[0, 2]]).T)
        np.testing.assert_allclose(ring, 100.0)
        np.testing.assert_allclose(out.materials[plane.material].on_bands(Bands(5)), 0.3)
        with pytest.raises(AquaspecError, match="radius_m=0.0; accepted: a distance > 0 m"):
            with_seabed_plane(scene, bed, cam, 0.0)

    def test_radius(self):
        # ln(1000) / min(a): where the clearest band keeps a thousandth.
        r = plane_radius_m([0.05, 0.02, 0.3], below_camera_m=3.0, far_m=1000.0)
        assert r == pytest.approx(np.log(1 / PLANE_TRANSMISSION) / 0.02)
        # At least under the whole scene; at most within the far plane.
        assert plane_radius_m([0.5], below_camera_m=3.0, far_m=1000.0, reach_m=40.0) == 40.0
        assert plane_radius_m([0.0], below_camera_m=30.0, far_m=1000.0) == pytest.approx(
            np.sqrt(900.0 ** 2 - 30.0 ** 2))


class TestRender:
    def test_mesh_stands_on_the_seabed(self, box):
        """--seabed with a mesh: pixels at the seabed's depth, of its albedo,
        facing up; without it, none (deep water below)."""
        res = render(**kw(box), seabed=Seabed(SEABED_DEPTH_M, 0.3), backend="numpy")
        gb = res.gbuffer
        bed = seabed_pixels(gb)
        # The camera looks level: the plane fills the lower half of the image
        # (a 60 degree view sees it from 5 m ahead to the horizon).
        assert bed[-3:].all() and not bed[:13].any()
        np.testing.assert_allclose(gb.normal[bed], np.tile([0, 1, 0], (bed.sum(), 1)),
                                   atol=1e-6)
        (index,) = np.unique(gb.material[bed])
        np.testing.assert_allclose(gb.materials[index].on_bands(Bands(4)), 0.3)
        plane = res.params["scene"]["seabed_plane"]
        assert plane["depth_m"] == SEABED_DEPTH_M and plane["reflectance"] == 0.3
        # The light field's lower boundary is the same seabed.
        assert res.params["seabed"] == {"depth_m": SEABED_DEPTH_M, "reflectance": 0.3}
        for seabed in ("scene", None):
            deep = render(**kw(box), seabed=seabed, backend="numpy")
            assert not seabed_pixels(deep.gbuffer).any()
            assert not (hit_depth(deep.gbuffer) > CAMERA_DEPTH_M + 0.6).any()
            assert "seabed_plane" not in deep.params["scene"]

    def test_with_the_seeds_model(self, box):
        """The plane is geometry: the thesis's model (no light field) sees it too."""
        res = render(**kw(box), seabed=Seabed(SEABED_DEPTH_M, 0.3), ms_model="seeds",
                     backend="numpy")
        assert seabed_pixels(res.gbuffer)[-3:].all()
        with pytest.raises(AquaspecError, match="the seabed at 10 m is not below the camera "
                                                "at 12 m; accepted"):
            render(**kw(box), seabed=Seabed(10.0, 0.3), ms_model="seeds", backend="numpy")

    @pytest.mark.gpu
    def test_gpu_layers(self, box):
        """On the GPU: the same seabed pixels, at the seabed's range, and the
        albedo layer (rho E0 / pi) proportional to the albedo given."""
        bright = render(**kw(box), seabed=Seabed(SEABED_DEPTH_M, 0.6), layers=True)
        dark = render(**kw(box), seabed=Seabed(SEABED_DEPTH_M, 0.3), layers=True)
        bed = seabed_pixels(bright.gbuffer)
        cpu = seabed_pixels(render(**kw(box), seabed=Seabed(SEABED_DEPTH_M, 0.6),
                                   backend="numpy").gbuffer)
        assert bed[-3:].all() and (bed != cpu).mean() < 0.02
        np.testing.assert_allclose(bright.layers["range_m"][bed], bright.gbuffer.distance[bed])
        np.testing.assert_allclose(bright.layers["albedo"][bed],
                                   2.0 * dark.layers["albedo"][bed], rtol=1e-5)
        # The seabed's own light: brighter seabed, brighter pixels (the
        # human sensor's camera RGB can be negative in red: compare the sum).
        assert bright.linear_rgb[bed].sum() > 1.2 * dark.linear_rgb[bed].sum()

    def test_other_views_keep_their_geometry(self):
        """The built-in scene keeps its sand; an RGB-D photograph its surfaces."""
        res = render(water="IB", depth_m=5.0, size=(32, 18), bands=4,
                     seabed=Seabed(9.0, 0.3), backend="numpy")
        assert "seabed_plane" not in res.params["scene"]
        assert not (hit_depth(res.gbuffer) > 8.9).any()
        image = np.full((18, 32, 3), 0.5)
        depth = np.full((18, 32), 2.0)
        photo = dict(rgbd=(image, depth, (20.0, 20.0, 16.0, 9.0)), depth_m=5.0, bands=4,
                     backend="numpy")
        rgbd = render(**photo, seabed=Seabed(9.0, 0.3))
        assert "seabed_plane" not in rgbd.params["scene"]
        np.testing.assert_array_equal(rgbd.gbuffer.distance,
                                      render(**photo, seabed=None).gbuffer.distance)


def test_cli(box, tmp_path):
    """`aquaspec render --mesh m --seabed D,A`: the sidecar names the plane."""
    out = tmp_path / "m.png"
    base = ["render", "--mesh", str(box), "--depth", "12", "--size", "32x18", "--bands", "3",
            "-o", str(out)]
    assert main([*base, "--seabed", "15,0.3"]) == 0
    side = json.loads((tmp_path / "m.png.json").read_text())
    assert side["scene"]["seabed_plane"]["depth_m"] == 15.0
    assert side["scene"]["seabed_plane"]["reflectance"] == 0.3
    assert main([*base, "--seabed", "none"]) == 0
    assert "seabed_plane" not in json.loads((tmp_path / "m.png.json").read_text())["scene"]
