"""Scene containers, the built-in scene and mesh loading."""

import numpy as np
import pytest
import trimesh
from PIL import Image

from aquaspec.scene.camera import Camera
from aquaspec.errors import AquaspecError
from aquaspec.scene.raycast import bilinear_repeat, raycast_gbuffer
from aquaspec.colour.reflectance import Reflectance, colorchecker
from aquaspec.scene import Mesh, Scene, builtin_scene, load_mesh, place_in_front
from aquaspec.colour.srgb import srgb_decode

UNIT_TOL = 1e-12


class TestMesh:
    def test_flat_box_normals_are_axis_aligned(self):
        box = trimesh.creation.box((1, 2, 3))
        m = Mesh.flat(box.vertices, box.faces)
        assert np.allclose(np.abs(m.normals).max(axis=1), 1.0)
        # Each flat-shaded vertex's normal is its own face's normal.
        tri = m.vertices[m.faces]
        fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        fn /= np.linalg.norm(fn, axis=1, keepdims=True)
        np.testing.assert_allclose(m.normals[m.faces[:, 0]], fn, atol=UNIT_TOL)

    def test_smooth_sphere_normals_are_radial(self):
        s = trimesh.creation.icosphere(3)
        m = Mesh(s.vertices, s.faces)
        np.testing.assert_allclose(np.einsum("ij,ij->i", m.normals, s.vertices), 1.0,
                                   atol=2e-3)

    def test_mirror_transform_keeps_normals_unit_and_consistent(self):
        s = trimesh.creation.icosphere(2)
        m = Mesh(s.vertices, s.faces).transformed(np.diag([-2.0, 1.0, 1.0, 1.0]))
        np.testing.assert_allclose(np.linalg.norm(m.normals, axis=1), 1.0, atol=UNIT_TOL)
        # Normals still point outwards from the (stretched) centre.
        assert np.all(np.einsum("ij,ij->i", m.normals, m.vertices) > 0)

    @pytest.mark.parametrize("faces,match", [([[0, 1, 5]], "index vertices"),
                                             (np.zeros((0, 3), int), "no triangles"),
                                             ([[0.0, 1.0, 2.0]], "integer")])
    def test_bad_faces(self, faces, match):
        with pytest.raises(AquaspecError, match=match):
            Mesh(np.eye(3), faces)

    def test_texture_needs_uv(self):
        with pytest.raises(AquaspecError, match="no uv"):
            Mesh(np.eye(3), [[0, 1, 2]], texture=np.zeros((2, 2, 3)))

    def test_scene_checks_material_indices(self):
        s = Scene([Mesh(np.eye(3), [[0, 1, 2]], material=2)], [Reflectance.constant(0.5)])
        with pytest.raises(AquaspecError, match="material 2"):
            s.validate()
        with pytest.raises(AquaspecError, match="no meshes"):
            Scene().validate()


def _by_name(scene, prefix):
    return [m for m in scene.meshes if m.name.startswith(prefix)]


@pytest.fixture(scope="module")
def built():
    return builtin_scene(6.0, width=320, height=180)


class TestBuiltinScene:
    def test_deterministic(self, built):
        again, cam = builtin_scene(6.0, width=320, height=180)
        scene, cam0 = built
        assert len(again.meshes) == len(scene.meshes)
        for a, b in zip(scene.meshes, again.meshes):
            np.testing.assert_array_equal(a.vertices, b.vertices)
            np.testing.assert_array_equal(a.faces, b.faces)
            np.testing.assert_array_equal(a.normals, b.normals)
            assert a.material == b.material
        np.testing.assert_array_equal(cam.view_matrix(), cam0.view_matrix())
        other, _ = builtin_scene(6.0, seed=1, width=320, height=180)
        assert not np.array_equal(other.meshes[0].vertices, scene.meshes[0].vertices)

    def test_camera_depth_and_height_above_seabed(self, built):
        scene, cam = built
        np.testing.assert_allclose(cam.position, [0.0, -6.0, 0.0])
        assert cam.forward[1] < 0 and abs(cam.forward[1]) < 0.3   # slightly down
        seabed = _by_name(scene, "seabed")
        down = Camera(cam.position, (0, -1, 0), (0, 0, -1), 3, 3, 2.0, 2.0, 1.5, 1.5)
        g = raycast_gbuffer(Scene(seabed, scene.materials), down)
        np.testing.assert_allclose(g.distance[1, 1], 1.5, atol=5e-3)

    def test_colorchecker_board(self, built):
        scene, cam = built
        patches = _by_name(scene, "colorchecker patch")
        assert len(patches) == 24
        chart = colorchecker()
        centres = np.array([p.vertices.mean(axis=0) for p in patches])
        to_cam = cam.position - centres.mean(axis=0)
        to_cam /= np.linalg.norm(to_cam)
        for k, p in enumerate(patches):
            mat = scene.materials[p.material]
            assert mat.name == chart[k].name
            np.testing.assert_array_equal(mat.values, chart[k].values)
            # The board as a whole faces the camera.
            np.testing.assert_allclose(p.normals, np.tile(to_cam, (len(p.normals), 1)),
                                       atol=1e-12)
        dist = np.linalg.norm(centres.mean(axis=0) - cam.position)
        assert 2.5 < dist < 3.5
        # Grey row (white ... black) at the bottom; columns left to right in the image.
        rows = centres[:, 1].reshape(4, 6)
        assert np.all(np.diff(rows.mean(axis=1)) < 0)
        greys = [scene.materials[patches[k].material] for k in range(18, 24)]
        assert [g.name.split()[0] for g in greys] == ["white"] + ["neutral"] * 4 + ["black"]
        assert np.all(np.diff([g.values.mean() for g in greys]) < 0)
        cols = (centres - cam.position) @ cam.right
        assert np.all(np.diff(cols.reshape(4, 6), axis=1) > 0)

    def test_objects_are_at_2_to_15_m(self, built):
        scene, cam = built
        names = ["concrete block", "pipe", "barrel", "crate", "rock"]
        for name in names:
            for m in _by_name(scene, name):
                d = np.linalg.norm(m.vertices.mean(axis=0) - cam.position)
                assert 1.5 < d < 16, (m.name, d)
            assert _by_name(scene, name)

    def test_everything_under_water(self, built):
        scene, _ = built
        assert scene.bounds()[1, 1] < 0

    @pytest.mark.parametrize("depth", [-1.0, float("nan"), float("inf"), "5"])
    def test_bad_depth(self, depth):
        with pytest.raises(AquaspecError, match=f"depth_m={depth!r}".replace("(", r"\(")):
            builtin_scene(depth)


class TestLoadMesh:
    def test_obj_with_material_colour(self, tmp_path):
        box = trimesh.creation.box((1, 1, 1))
        box.visual = trimesh.visual.TextureVisuals(
            material=trimesh.visual.material.SimpleMaterial(diffuse=[51, 102, 204, 255]))
        box.export(tmp_path / "box.obj")
        scene = load_mesh(tmp_path / "box.obj")
        assert len(scene.meshes) == 1 and len(scene.materials) == 1
        np.testing.assert_allclose(scene.materials[0].rgb, [0.2, 0.4, 0.8], atol=1e-6)
        np.testing.assert_allclose(scene.bounds(), [[-0.5] * 3, [0.5] * 3])

    def test_ply_vertex_colours_are_decoded_from_srgb(self, tmp_path):
        s = trimesh.creation.icosphere(1)
        colours = np.tile([255, 128, 0, 255], (len(s.vertices), 1)).astype(np.uint8)
        s.visual = trimesh.visual.ColorVisuals(s, vertex_colors=colours)
        s.export(tmp_path / "s.ply")
        m = load_mesh(tmp_path / "s.ply").meshes[0]
        assert m.per_pixel
        np.testing.assert_allclose(m.vertex_rgb[0], srgb_decode([1.0, 128 / 255, 0.0]))

    def test_glb_texture_orientation(self, tmp_path):
        img = np.zeros((8, 8, 3), np.uint8)
        img[:4] = (255, 0, 0)                  # top half red
        img[4:] = (0, 0, 255)                  # bottom half blue
        quad = trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]],
                               [[0, 1, 2], [0, 2, 3]], process=False)
        material = trimesh.visual.material.PBRMaterial(
            baseColorTexture=Image.fromarray(img), baseColorFactor=[255, 255, 51, 255])
        quad.visual = trimesh.visual.TextureVisuals(uv=[[0, 0], [1, 0], [1, 1], [0, 1]],
                                                    material=material)
        quad.export(tmp_path / "q.glb")
        m = load_mesh(tmp_path / "q.glb").meshes[0]
        assert m.texture is not None and m.texture.dtype == np.float32
        # uv v = 1 is the top of the image (red), at the quad's top (y = 1);
        # glTF multiplies the texture by the (linear) base colour factor.
        top_v = m.uv[np.argmax(m.vertices[:, 1]), 1]
        bottom_v = m.uv[np.argmin(m.vertices[:, 1]), 1]
        got = bilinear_repeat(m.texture.astype(float),
                               np.array([[0.5, 0.9 * top_v + 0.1 * bottom_v],
                                         [0.5, 0.1 * top_v + 0.9 * bottom_v]]))
        np.testing.assert_allclose(got, [[1, 0, 0], [0, 0, 0.2]], atol=1e-6)

    def test_albedo_override(self, tmp_path):
        trimesh.creation.box((1, 1, 1)).export(tmp_path / "b.stl")
        s = load_mesh(tmp_path / "b.stl", albedo=(0.1, 0.2, 0.3))
        np.testing.assert_allclose(s.materials[0].rgb, [0.1, 0.2, 0.3])
        with pytest.raises(AquaspecError, match="albedo"):
            load_mesh(tmp_path / "b.stl", albedo=(1.2, 0, 0))

    def test_errors_name_path_and_formats(self, tmp_path):
        missing = tmp_path / "missing.obj"
        with pytest.raises(AquaspecError, match=r"missing\.obj.*\.obj, \.ply, \.gltf, \.glb"):
            load_mesh(missing)
        with pytest.raises(AquaspecError, match=r"\.xyz.*accepted formats"):
            load_mesh(tmp_path / "a.xyz")
        corrupt = tmp_path / "corrupt.glb"
        corrupt.write_bytes(b"glTF\x02\x00\x00\x00garbage")
        with pytest.raises(AquaspecError, match=r"corrupt\.glb.*accepted formats"):
            load_mesh(corrupt)
        points = tmp_path / "points.obj"
        points.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\n")
        with pytest.raises(AquaspecError, match=r"points\.obj.*no triangles"):
            load_mesh(points)

    def test_size_limit_before_parsing(self, tmp_path, monkeypatch):
        big = tmp_path / "big.obj"
        big.write_bytes(b"v 0 0 0\n" * 300_000)                   # 2.3 MB
        monkeypatch.setenv("AQUASPEC_MAX_FILE_MB", "2")
        with pytest.raises(AquaspecError, match=r"mesh file '.*big\.obj' is 2.29 MB, above the "
                                                "limit of 2 MB for mesh files"):
            load_mesh(big)


class TestPlaceInFront:
    def test_scaled_and_centred(self):
        box = trimesh.creation.box((2.0, 4.0, 1.0))
        s = Scene([Mesh.flat(box.vertices + 10.0, box.faces)], [Reflectance.constant(0.5)])
        placed = place_in_front(s, depth_m=8.0, distance_m=3.0, size_m=1.0, width=64, height=48)
        lo, hi = placed.bounds()
        np.testing.assert_allclose(hi - lo, [0.5, 1.0, 0.25])
        np.testing.assert_allclose((lo + hi) / 2, [0, -8.0, -3.0], atol=1e-12)
        np.testing.assert_allclose(placed.camera.position, [0, -8.0, 0])
        g = raycast_gbuffer(placed, placed.camera)
        # The box's front face is the plane z = -3 + 0.125.
        cos = placed.camera.ray_directions()[24, 32] @ placed.camera.forward
        np.testing.assert_allclose(g.distance[24, 32], (3.0 - 0.125) / cos, rtol=1e-6)

    def test_above_surface_is_an_error(self):
        box = trimesh.creation.box((1.0, 1.0, 1.0))
        s = Scene([Mesh.flat(box.vertices, box.faces)], [Reflectance.constant(0.5)])
        with pytest.raises(AquaspecError, match="above the water surface"):
            place_in_front(s, depth_m=1.0, size_m=3.0)


def test_gbuffer_positions_are_inf_in_open_water_and_exact_on_hits():
    """Open-water pixels get inf (never NaN from inf * 0 in a zero ray component);
    a hit lies at distance S along its ray."""
    from aquaspec.scene.gbuffer import GBuffer
    cam = Camera.look_at([0.0, -5.0, 0.0], [0.0, -5.0, -1.0], width=7, height=5, fov_y_deg=40.0)
    dist = np.full((5, 7), np.inf, np.float32)
    dist[2, 3] = 2.0
    g = GBuffer(cam, dist, np.zeros((5, 7, 3)), np.zeros((5, 7), np.uint32), np.zeros((5, 7, 3)),
                materials=[Reflectance.constant(0.5, "grey")])
    p = g.positions()
    assert not np.any(np.isnan(p))
    assert np.all(np.isinf(p[~g.hit]))
    ray = cam.ray_directions()[2, 3]
    assert np.allclose(p[2, 3], cam.position + 2.0 * ray)


class TestResized:
    def test_camera_keeps_its_field_of_view(self):
        cam = Camera.look_at((0, -5, 0), (0, -5, -1), width=640, height=360, fov_y_deg=50)
        half = cam.resized(320, 180)
        assert (half.width, half.height) == (320, 180)
        # The same rays through the same fractions of the image.
        np.testing.assert_allclose(half.ray_directions()[45, 80],
                                   cam.ray_directions()[90:92, 160:162].mean(axis=(0, 1)),
                                   atol=2e-3)
        assert cam.resized(640, 360) is cam
        with pytest.raises(AquaspecError, match="width 0"):
            cam.resized(0, 10)

    def test_gbuffer_takes_the_pixel_under_each_centre(self):
        scene, cam = builtin_scene(5.0, width=64, height=36)
        gb = raycast_gbuffer(scene, cam)
        small = gb.resized(16, 9)
        assert small.camera.width == 16 and small.distance.shape == (9, 16)
        # Pixel (i, j) of the quarter-size image holds pixel (4i + 2, 4j + 2).
        np.testing.assert_array_equal(small.distance, gb.distance[2::4, 2::4])
        np.testing.assert_array_equal(small.material, gb.material[2::4, 2::4])
        np.testing.assert_array_equal(small.normal, gb.normal[2::4, 2::4])
        assert small.materials == gb.materials
        assert gb.resized(64, 36) is gb
