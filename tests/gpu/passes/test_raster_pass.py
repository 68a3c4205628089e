"""The GPU geometry pass against its ray-cast NumPy reference."""

import numpy as np
import pytest
import trimesh

from aquaspec.scene.camera import Camera
from aquaspec.errors import AquaspecError
from aquaspec.scene.gbuffer import PER_PIXEL
from aquaspec.gpu.passes.raster import RasterPass
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.colour.reflectance import Reflectance
from aquaspec.scene import Mesh, Scene, builtin_scene

pytestmark = pytest.mark.gpu

DIST_RTOL = 1e-4        # float32 positions on the GPU
#: Quantisation of the 16-bit octahedral normal (x and z components).
OCT_ATOL = 1e-4
NORMAL_ATOL = 1e-5
COEFF_ATOL = 2e-3


@pytest.fixture(scope="module")
def raster():
    return RasterPass()


def plane_and_box():
    s = Scene(materials=[Reflectance.constant(0.5, "floor"), Reflectance.constant(0.3, "box")])
    s.add(Mesh([[-6, -4, -12], [6, -4, -12], [6, -4, 1], [-6, -4, 1]],
               [[0, 1, 2], [0, 2, 3]], material=0, name="floor"))
    box = trimesh.creation.box((1.0, 1.2, 0.8))
    rot = trimesh.transformations.rotation_matrix(0.5, [0, 1, 0])
    rot[:3, 3] = [0.4, -3.4, -4.5]
    s.add(Mesh.flat(box.vertices, box.faces, material=1, name="box").transformed(rot))
    return s


def interior(ref):
    """Pixels whose 3x3 neighbourhood shows the same surface in the reference."""
    key = np.concatenate([ref.material[..., None].astype(float),
                          np.round(ref.normal, 9), np.isfinite(ref.distance)[..., None]], -1)
    same = np.ones(ref.distance.shape, bool)
    h, w = same.shape
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            shifted = np.roll(key, (di, dj), axis=(0, 1))
            same &= np.all(shifted == key, axis=-1)
    same[[0, -1], :] = False
    same[:, [0, -1]] = False
    return same


def compare(gpu, ref, *, normal_atol=NORMAL_ATOL, min_pixels=200):
    m = interior(ref)
    assert m.sum() >= min_pixels
    np.testing.assert_array_equal(np.isfinite(gpu.distance[m]), np.isfinite(ref.distance[m]))
    hit = m & np.isfinite(ref.distance)
    np.testing.assert_allclose(gpu.distance[hit], ref.distance[hit], rtol=DIST_RTOL)
    # n_y (all the shading uses) is stored exactly; the horizontal part goes
    # through a 16-bit octahedral encoding (aquaspec.gpu.gbuffer).
    np.testing.assert_allclose(gpu.normal[hit][:, 1], ref.normal[hit][:, 1], atol=normal_atol)
    np.testing.assert_allclose(gpu.normal[hit], ref.normal[hit], atol=max(normal_atol, OCT_ATOL))
    np.testing.assert_array_equal(gpu.material[hit], ref.material[hit])
    return hit


class TestAgainstRaycast:
    def test_plane_and_box(self, raster):
        s = plane_and_box()
        cam = Camera.look_at((0.3, -2.0, 0.0), (0.2, -3.5, -5.0), width=64, height=48)
        gpu, ref = raster.render(s, cam), raycast_gbuffer(s, cam)
        hit = compare(gpu, ref)
        assert set(np.unique(ref.material[hit])) == {0, 1}
        assert np.isinf(gpu.distance[0]).all()          # open water above the horizon
        assert np.all(gpu.normal[~gpu.hit] == 0)

    def test_box_from_inside_normals_face_camera(self, raster):
        box = trimesh.creation.box((4.0, 3.0, 5.0))
        s = Scene([Mesh.flat(box.vertices + [0, -5, 0], box.faces)], [Reflectance.constant(0.5)])
        cam = Camera.look_at((0.5, -5.2, 0.5), (-1.0, -5.5, -2.0), width=48, height=40)
        gpu, ref = raster.render(s, cam), raycast_gbuffer(s, cam)
        compare(gpu, ref)
        assert np.all(np.einsum("ijk,ijk->ij", ref.normal, cam.ray_directions()) < 0)

    def test_smooth_sphere_interpolated_normals(self, raster):
        sph = trimesh.creation.icosphere(2, radius=1.0)
        s = Scene([Mesh(sph.vertices + [0, -6, -4], sph.faces)], [Reflectance.constant(0.5)])
        cam = Camera.look_at((0, -5.5, 0), (0, -6, -4), width=48, height=48)
        gpu, ref = raster.render(s, cam), raycast_gbuffer(s, cam)
        hit = np.isfinite(ref.distance) & np.isfinite(gpu.distance)
        # Smooth normals vary inside triangles: every common pixel must agree.
        np.testing.assert_allclose(gpu.normal[hit], ref.normal[hit], atol=1e-4)
        np.testing.assert_allclose(gpu.distance[hit], ref.distance[hit], rtol=DIST_RTOL)

    def test_textured_and_vertex_coloured(self, raster):
        rng = np.random.default_rng(3)
        tex = rng.uniform(0.05, 0.95, (4, 5, 3))
        quad = Mesh([[-2, -5, -6], [2, -5, -6], [2, -2, -6], [-2, -2, -6]],
                    [[0, 1, 2], [0, 2, 3]], uv=[[0, 0], [2, 0], [2, 1], [0, 1]],
                    texture=tex, name="textured")
        tri = Mesh([[-1.5, -4, -3], [0, -4.5, -3.5], [-0.5, -3, -3.2]], [[0, 1, 2]],
                   vertex_rgb=[[0.9, 0.1, 0.1], [0.1, 0.8, 0.1], [0.1, 0.2, 0.9]],
                   name="coloured")
        s = Scene([quad, tri], [])
        cam = Camera.look_at((0, -3.5, 0), (0, -3.5, -6), width=64, height=48)
        gpu, ref = raster.render(s, cam), raycast_gbuffer(s, cam)
        hit = compare(gpu, ref)
        assert np.all(gpu.material[gpu.hit] == PER_PIXEL)
        np.testing.assert_allclose(gpu.sigmoid[hit], ref.sigmoid[hit], atol=COEFF_ATOL,
                                   rtol=1e-3)
        # The texture's colours do vary over the image (not a constant fill).
        assert np.ptp(ref.sigmoid[hit][:, 2]) > 1.0


    def test_mixed_modes_merged_draws(self, raster):
        """Meshes of one mode share a draw; each keeps its material / texture / colours."""
        rng = np.random.default_rng(5)
        s = plane_and_box()                     # two material meshes, one draw
        for k, x0 in enumerate((-2.5, 0.5)):    # two textures, two draws
            s.add(Mesh([[x0, -4.5, -7], [x0 + 2, -4.5, -7], [x0 + 2, -2.5, -7],
                        [x0, -2.5, -7]], [[0, 1, 2], [0, 2, 3]],
                       uv=[[0, 0], [1, 0], [1, 1], [0, 1]],
                       texture=rng.uniform(0.05, 0.95, (3 + k, 4, 3)), name=f"tex {k}"))
        for x0 in (-1.8, 1.0):                  # two vertex-coloured meshes, one draw
            s.add(Mesh([[x0, -3.9, -3.5], [x0 + 0.8, -3.9, -3.5], [x0 + 0.4, -3.1, -3.5]],
                       [[0, 1, 2]], vertex_rgb=rng.uniform(0.05, 0.95, (3, 3)),
                       name=f"coloured {x0}"))
        cam = Camera.look_at((0.0, -3.0, 0.0), (0.0, -3.6, -6.0), width=72, height=48)
        gpu, ref = raster.render(s, cam), raycast_gbuffer(s, cam)
        hit = compare(gpu, ref)
        assert set(np.unique(ref.material[hit])) == {0, 1, PER_PIXEL}
        pp = hit & (ref.material == PER_PIXEL)
        assert pp.sum() > 100
        np.testing.assert_allclose(gpu.sigmoid[pp], ref.sigmoid[pp], atol=COEFF_ATOL,
                                   rtol=1e-3)

    def test_more_vertices_than_16_bit_indices(self, raster):
        """A draw of > 65535 vertices uses 32-bit indices: a fine flat grid at y = -4."""
        n = 257                                             # 66049 vertices
        u = np.linspace(-6, 6, n)
        x, z = np.meshgrid(u, np.linspace(-12, 1, n))
        v = np.stack([x.ravel(), np.full(x.size, -4.0), z.ravel()], 1)
        idx = np.arange(n * n).reshape(n, n)
        a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
        c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
        faces = np.concatenate([np.stack([a, c, b], 1), np.stack([b, c, d], 1)])
        s = Scene([Mesh(v, faces, material=0)], [Reflectance.constant(0.5)])
        cam = Camera.look_at((0.0, -2.0, 0.0), (0.0, -3.0, -5.0), width=64, height=48)
        g = raster.render(s, cam)
        d = cam.ray_directions()
        s_exact = (-4.0 - cam.position[1]) / d[..., 1]
        p = cam.position + s_exact[..., None] * d
        inside = (d[..., 1] < 0) & (np.abs(p[..., 0]) < 5.9) & (p[..., 2] > -11.9) \
            & (p[..., 2] < 0.9)
        assert inside.sum() > 1000
        np.testing.assert_allclose(g.distance[inside], s_exact[inside], rtol=DIST_RTOL)
        np.testing.assert_allclose(g.normal[inside], np.tile([0, 1, 0], (inside.sum(), 1)),
                                   atol=NORMAL_ATOL)


@pytest.fixture(scope="module")
def rendered(raster):
    scene, cam = builtin_scene(5.0, width=320, height=180)
    return scene, cam, raster.render(scene, cam)


class TestRaycastBinning:
    """Binning triangles into pixel tiles skips only ray-triangle pairs that
    cannot meet: the G-buffer is the brute force's, bit for bit."""

    @staticmethod
    def same(a, b):
        for name in ("distance", "normal", "material", "sigmoid"):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)

    @pytest.mark.parametrize("tile", [1, 5, 16])
    def test_floor_through_the_camera_plane(self, tile):
        # The floor runs from in front of the camera to behind it (triangles
        # crossing the camera's plane); the box is partly off-screen.
        s = plane_and_box()
        cam = Camera.look_at((0.3, -3.0, -0.5), (2.5, -3.6, -4.0), width=40, height=30)
        self.same(raycast_gbuffer(s, cam, tile=tile), raycast_gbuffer(s, cam, tile=None))

    def test_inside_a_box_and_the_builtin_scene(self):
        box = trimesh.creation.box((4.0, 3.0, 5.0))
        s = Scene([Mesh.flat(box.vertices + [0, -5, 0], box.faces)], [Reflectance.constant(0.5)])
        cam = Camera.look_at((0.5, -5.2, 0.5), (-1.0, -5.5, -2.0), width=33, height=21)
        got = raycast_gbuffer(s, cam, tile=4)
        assert np.isfinite(got.distance).all()              # every ray ends on a wall
        self.same(got, raycast_gbuffer(s, cam, tile=None))
        scene, cam = builtin_scene(5.0, width=48, height=27)
        self.same(raycast_gbuffer(scene, cam), raycast_gbuffer(scene, cam, tile=None))

    def test_bad_tile(self):
        s = plane_and_box()
        cam = Camera.look_at((0.3, -2.0, 0.0), (0.2, -3.5, -5.0), width=8, height=6)
        with pytest.raises(AquaspecError, match="tile=0; accepted: a positive integer or None"):
            raycast_gbuffer(s, cam, tile=0)


class TestBuiltin:
    def test_all_24_patches_visible_and_facing(self, rendered):
        scene, cam, g = rendered
        patches = [m for m in scene.meshes if m.name.startswith("colorchecker patch")]
        dirs = cam.ray_directions()
        for p in patches:
            pix = g.material == p.material
            assert pix.sum() >= 50, f"{p.name}: {pix.sum()} pixels"
            np.testing.assert_allclose(g.normal[pix], np.tile(p.normals[0], (pix.sum(), 1)),
                                       atol=1e-5)
            assert np.all(np.einsum("ij,ij->i", g.normal[pix], dirs[pix]) < -0.95)
            np.testing.assert_allclose(g.distance[pix], 3.1, atol=0.4)

    def test_open_water_on_top_seabed_below(self, rendered):
        _, _, g = rendered
        assert np.isinf(g.distance[:40]).all()
        assert np.isfinite(g.distance[-40:]).all()
        assert np.isfinite(g.distance).sum() > 0.3 * g.distance.size

    def test_repeatable(self, rendered, raster):
        scene, cam, g = rendered
        again = raster.render(scene, cam)
        np.testing.assert_array_equal(again.distance, g.distance)
        np.testing.assert_array_equal(again.material, g.material)


class TestRenderTo:
    def test_matches_host_packing(self, raster):
        """render_to leaves the shading passes' G-buffer equal to the packed host G-buffer."""
        from aquaspec.gpu.buffers import read_texture
        from aquaspec.gpu.gbuffer import GBufferTextures, pack_gbuffer
        s = plane_and_box()
        cam = Camera.look_at((0.3, -2.0, 0.0), (0.2, -3.5, -5.0), width=40, height=30)
        ref = pack_gbuffer(raster.render(s, cam))
        dp = GBufferTextures(raster.device, 40, 30)
        raster.render_to(dp, s, cam)
        for name, arr in ref.items():
            got = read_texture(dp.device, dp.textures[name], arr.dtype, 4)
            np.testing.assert_array_equal(got, arr)
        assert dp.camera is cam
        with pytest.raises(AquaspecError, match="40x30"):
            raster.render_to(dp, s, Camera.look_at((0, -2, 0), (0, -3, -5), width=41,
                                                   height=30))


class TestErrors:
    def test_bad_scene(self, raster):
        cam = Camera.look_at((0, -2, 0), (0, -3, -5), width=8, height=8)
        with pytest.raises(AquaspecError, match="no meshes"):
            raster.render(Scene(), cam)
        s = Scene([Mesh(np.eye(3) - 3, [[0, 1, 2]], material=4)], [Reflectance.constant(0.5)])
        with pytest.raises(AquaspecError, match="material 4"):
            raster.render(s, cam)
        with pytest.raises(AquaspecError, match="Camera"):
            raster.render(plane_and_box(), "camera")

    @pytest.mark.parametrize("w,h", [(0, 10), (10, 8193)])
    def test_bad_sizes(self, w, h):
        with pytest.raises(AquaspecError, match="8192"):
            Camera.look_at((0, -2, 0), (0, -3, -5), width=w, height=h)


@pytest.mark.slow
def test_4k_plane_distances(raster):
    """3840x2160: the floor's distance in three rows against the closed form."""
    s = plane_and_box()
    s.meshes = s.meshes[:1]
    cam = Camera.look_at((0.0, -2.0, 0.0), (0.0, -3.0, -5.0), width=3840, height=2160)
    g = raster.render(s, cam)
    for row in (1200, 1700, 2159):
        j = np.arange(cam.width) + 0.5
        d = (cam.right[None] * ((j - cam.cx) / cam.fx)[:, None]
             - cam.true_up[None] * (row + 0.5 - cam.cy) / cam.fy + cam.forward[None])
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        s_exact = (-4.0 - cam.position[1]) / d[:, 1]
        inside = np.abs(cam.position[0] + s_exact * d[:, 0]) < 5.9
        np.testing.assert_allclose(g.distance[row, inside], s_exact[inside], rtol=DIST_RTOL)
