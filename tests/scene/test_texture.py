"""Mip chains, level of detail, tangent frames and normal maps (aquaspec.scene.texture)."""

import numpy as np
import pytest

from aquaspec.errors import AquaspecError
from aquaspec.scene import Mesh
from aquaspec.scene.camera import Camera
from aquaspec.scene.texture import (decode_normal_map, height_to_normal_map, mip_chain, mip_lod,
                                    perturb_normals, quad_uv_differences, sample_trilinear,
                                    vertex_tangents)


class TestMipChain:
    def test_sizes_and_means(self):
        rng = np.random.default_rng(0)
        img = rng.uniform(size=(8, 16, 3))
        levels = mip_chain(img)
        assert [lv.shape[:2] for lv in levels] == [(8, 16), (4, 8), (2, 4), (1, 2), (1, 1)]
        np.testing.assert_allclose(levels[1][1, 2], img[2:4, 4:6].mean(axis=(0, 1)))
        # A power-of-two chain keeps the mean at every level.
        for lv in levels:
            np.testing.assert_allclose(lv.mean(axis=(0, 1)), img.mean(axis=(0, 1)))

    def test_odd_sizes_drop_the_last_row_and_column(self):
        img = np.arange(5 * 3, dtype=float).reshape(5, 3, 1)
        levels = mip_chain(img)
        assert [lv.shape[:2] for lv in levels] == [(5, 3), (2, 1), (1, 1)]
        np.testing.assert_allclose(levels[1][0, 0, 0], img[0:2, 0:2].mean())

    def test_bad_shape(self):
        with pytest.raises(AquaspecError, match="expected"):
            mip_chain(np.zeros((4, 4)))


class TestLevelOfDetail:
    def test_closed_form_rule(self):
        size = (64, 128)                               # height, width
        dx = np.array([[1 / 128, 0.0], [4 / 128, 0.0], [0.0, 0.0], [1.0, 1.0]])
        dy = np.array([[0.0, 2 / 64], [0.0, 0.0], [0.0, 0.0], [0.0, 0.0]])
        np.testing.assert_allclose(mip_lod(dx, dy, size, 8), [1.0, 2.0, 0.0, 7.0])

    @pytest.mark.parametrize("k", [0, 1, 3])
    def test_frontal_plane_picks_level_k(self, k):
        """A plane facing the camera at distance D: one pixel spans D / fx metres
        at the centre, so with 2**k * fx / D texels per metre the lod is k."""
        cam = Camera.look_at((0, -5, 0), (0, -5, -1), width=64, height=48)
        dist, size = 4.0, 256
        texels_per_m = 2.0 ** k * cam.fx / dist
        span = size / texels_per_m                     # metres per uv unit
        tri = np.array([[[-1, -6, -dist], [1, -6, -dist], [-1, -4, -dist]]], float)
        tri_uv = (tri[..., [0, 1]] - [-1, -6]) / span
        rows, cols = np.array([24]), np.array([32])
        dx, dy = quad_uv_differences(tri, tri_uv, cam, rows, cols)
        lod = mip_lod(dx, dy, (size, size), 9)
        assert lod[0] == pytest.approx(k, abs=1e-3)

    def test_trilinear_mixes_neighbouring_levels(self):
        levels = [np.full((4, 4, 1), 1.0), np.full((2, 2, 1), 3.0), np.full((1, 1, 1), 7.0)]
        uv = np.array([[0.3, 0.6]] * 4)
        got = sample_trilinear(levels, uv, np.array([0.0, 0.25, 1.5, 5.0]))[:, 0]
        np.testing.assert_allclose(got, [1.0, 1.5, 5.0, 7.0])


def _plane_mesh(u_axis, v_axis, uv_scale=(1.0, 1.0), mirror=False):
    """A quad in the plane spanned by ``u_axis`` and ``v_axis``, uv along them."""
    a, b = np.asarray(u_axis, float), np.asarray(v_axis, float)
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    v = corners[:, :1] * a + corners[:, 1:] * b + [0, -5, 0]
    uv = corners * uv_scale
    if mirror:
        uv[:, 0] = -uv[:, 0]
    return v, np.array([[0, 1, 2], [0, 2, 3]]), uv


class TestTangents:
    def test_plane_closed_form(self):
        # A tilted plane: u along a, v along b (not orthogonal, not unit).
        a, b = np.array([2.0, 0.0, 0.0]), np.array([0.5, 1.0, -1.0])
        v, f, uv = _plane_mesh(a, b, uv_scale=(3.0, 0.5))
        n = np.cross(a, b) / np.linalg.norm(np.cross(a, b))
        t = vertex_tangents(v, f, np.tile(n, (4, 1)), uv)
        np.testing.assert_allclose(t[:, :3], np.tile(a / 2.0, (4, 1)), atol=1e-12)
        np.testing.assert_allclose(t[:, 3], 1.0)
        # cross(N, T) has a positive component along dP/dv.
        assert np.all(np.cross(n, t[:, :3]) @ b > 0)

    def test_mirrored_uv_flips_handedness(self):
        v, f, uv = _plane_mesh([1.0, 0, 0], [0, 0, -1.0], mirror=True)
        t = vertex_tangents(v, f, np.tile([0, 1.0, 0], (4, 1)), uv)
        np.testing.assert_allclose(t[:, :3], np.tile([-1.0, 0, 0], (4, 1)), atol=1e-12)
        np.testing.assert_allclose(t[:, 3], -1.0)

    def test_degenerate_uv_gives_orthogonal_unit_tangent(self):
        v, f, _ = _plane_mesh([1.0, 0, 0], [0, 0, -1.0])
        n = np.tile([0, 1.0, 0], (4, 1))
        t = vertex_tangents(v, f, n, np.zeros((4, 2)))
        np.testing.assert_allclose(np.linalg.norm(t[:, :3], axis=1), 1.0)
        np.testing.assert_allclose(np.einsum("ij,ij->i", t[:, :3], n), 0.0, atol=1e-12)

    def test_mesh_tangents_need_uv(self):
        m = Mesh(np.eye(3) - 3, [[0, 1, 2]])
        with pytest.raises(AquaspecError, match="no uv"):
            m.tangents()


class TestNormalMaps:
    def test_flat_map_keeps_the_normal_and_tilts_along_the_tangent(self):
        n = np.array([[0, 1.0, 0]] * 2)
        t = np.array([[1.0, 0, 0, 1.0], [1.0, 0, 0, -1.0]])
        np.testing.assert_allclose(perturb_normals(n, t, [[0, 0, 1]] * 2), n)
        s = np.sin(0.3)
        got = perturb_normals(n, t, [[s, 0, np.cos(0.3)], [0, s, np.cos(0.3)]])
        np.testing.assert_allclose(got[0], [s, np.cos(0.3), 0], atol=1e-12)
        # B = w * cross(N, T) = -(0, 0, -1) for w = -1.
        np.testing.assert_allclose(got[1], [0, np.cos(0.3), s], atol=1e-12)

    def test_height_field_closed_form(self):
        # h = A sin(2 pi x / L) along u: the normal tilts by atan(dh/du).
        n_tex, L, A = 64, 0.5, 0.01
        x = (np.arange(n_tex) + 0.5) * L / n_tex
        h = np.tile(A * np.sin(2 * np.pi * x / L), (8, 1))
        nm = height_to_normal_map(h, L / n_tex)
        slope = A * 2 * np.pi / L * np.cos(2 * np.pi * x / L)
        np.testing.assert_allclose(-nm[0, :, 0] / nm[0, :, 2], slope, rtol=0.01, atol=1e-4)
        np.testing.assert_allclose(nm[..., 1], 0.0, atol=1e-12)

    def test_decode_and_errors(self):
        img = np.array([[[128, 128, 255], [255, 128, 128]]], np.uint8)
        nm = decode_normal_map(img)
        np.testing.assert_allclose(nm[0, 0], [0, 0, 1], atol=0.01)
        np.testing.assert_allclose(nm[0, 1], [1, 0, 0], atol=0.01)
        with pytest.raises(AquaspecError, match="values outside"):
            decode_normal_map(np.full((2, 2, 3), 2.0))
        with pytest.raises(AquaspecError, match="normal map but no uv"):
            Mesh(np.eye(3) - 3, [[0, 1, 2]], normal_map=np.tile([0, 0, 1.0], (2, 2, 1)))
        with pytest.raises(AquaspecError, match="z >= 0"):
            Mesh(np.eye(3) - 3, [[0, 1, 2]], uv=np.zeros((3, 2)),
                 normal_map=np.tile([0, 0, -1.0], (2, 2, 1)))

    def test_texture_mips_are_fitted_from_averaged_rgb(self):
        tex = np.zeros((2, 2, 3), np.float32)
        tex[0, 0] = tex[1, 1] = (0.8, 0.2, 0.1)
        tex[0, 1] = tex[1, 0] = (0.1, 0.3, 0.6)
        m = Mesh(np.eye(3) - 3, [[0, 1, 2]], uv=np.zeros((3, 2)), texture=tex)
        from aquaspec.colour.reflectance import fit_sigmoid_image
        mips = m.texture_mips()
        assert [lv.shape for lv in mips] == [(2, 2, 3), (1, 1, 3)]
        want = fit_sigmoid_image(tex.mean(axis=(0, 1), keepdims=True))
        np.testing.assert_allclose(mips[1], want, rtol=1e-5, atol=1e-5)
        # Not the mean of the coefficients (the sigmoid is non-linear).
        assert np.abs(mips[0].mean(axis=(0, 1)) - mips[1][0, 0]).max() > 1e-2
