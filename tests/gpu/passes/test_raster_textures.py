"""Mip-mapped textures and normal maps in the geometry pass against the ray-cast reference."""

import numpy as np
import pytest

from aquaspec.colour.reflectance import Reflectance, fit_sigmoid_image
from aquaspec.gpu.passes.raster import RasterPass
from aquaspec.scene import Mesh, Scene
from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import PER_PIXEL
from aquaspec.scene.raycast import raycast_gbuffer
from aquaspec.scene.texture import height_to_normal_map

pytestmark = pytest.mark.gpu

#: float32 uv derivatives and level of detail on the GPU against float64.
COEFF_ATOL = 5e-3
NORMAL_ATOL = 2e-3


@pytest.fixture(scope="module")
def raster():
    return RasterPass()


def floor(y=-4.0, half=8.0, far=-40.0, repeats=20.0, **kwargs):
    """A floor quad from z = 1 to ``far``, uv repeating ``repeats`` times along z."""
    v = [[-half, y, 1.0], [half, y, 1.0], [half, y, far], [-half, y, far]]
    span = (1.0 - far) / repeats
    uv = [[0, 0], [2 * half / span, 0], [2 * half / span, repeats], [0, repeats]]
    return Mesh(v, [[0, 1, 2], [0, 2, 3]], uv=uv, **kwargs)


def interior(ref, gpu):
    """Hit pixels away from edges whose 3x3 neighbourhood is the same mesh in both."""
    hit = np.isfinite(ref.distance) & np.isfinite(gpu.distance)
    ok = hit.copy()
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            ok &= np.roll(hit, (di, dj), axis=(0, 1))
    ok[[0, -1], :] = False
    ok[:, [0, -1]] = False
    return ok


def ripples(n=64, texel_m=0.01, amplitude=0.004, seed=0):
    rng = np.random.default_rng(seed)
    x = np.arange(n) * texel_m
    h = amplitude * np.sin(2 * np.pi * 4 * x / (n * texel_m))[None, :] \
        + 0.3 * amplitude * rng.standard_normal((n, n))
    return height_to_normal_map(h, texel_m)


class TestMipMapping:
    def test_grazing_floor_against_raycast(self, raster):
        rng = np.random.default_rng(1)
        tex = rng.uniform(0.05, 0.95, (32, 32, 3))
        s = Scene([floor(texture=tex, name="floor")], [])
        cam = Camera.look_at((0.0, -3.0, 0.0), (0.0, -3.6, -10.0), width=96, height=64)
        gpu, ref = raster.render(s, cam), raycast_gbuffer(s, cam)
        m = interior(ref, gpu)
        assert m.sum() > 1500
        assert np.all(gpu.material[m] == PER_PIXEL)
        np.testing.assert_allclose(gpu.sigmoid[m], ref.sigmoid[m], atol=COEFF_ATOL, rtol=2e-3)

    def test_far_texels_average_to_the_top_level(self, raster):
        """A texel-sized black-and-white checker seen from far: each pixel covers
        many texels, the mip chain gives the fit of the mean colour instead of
        an aliased black or white."""
        checker = np.indices((64, 64)).sum(axis=0) % 2
        tex = np.where(checker[..., None] == 1, 0.9, 0.1) * np.ones(3)
        s = Scene([floor(texture=tex, repeats=60.0, name="floor")], [])
        cam = Camera.look_at((0.0, -3.0, 0.0), (0.0, -3.6, -10.0), width=96, height=64)
        gpu = raster.render(s, cam)
        grey = fit_sigmoid_image(np.full((1, 1, 3), 0.5))[0, 0]
        far = np.isfinite(gpu.distance) & (gpu.distance > 10.0)
        assert far.sum() > 200
        np.testing.assert_allclose(gpu.sigmoid[far], np.tile(grey, (far.sum(), 1)), atol=0.05)
        # Without mip-mapping the same pixels would be 0.1 or 0.9 texels.
        level0 = fit_sigmoid_image(np.full((1, 1, 3), 0.9))[0, 0]
        assert np.abs(level0 - grey).max() > 1.0


class TestNormalMaps:
    def test_all_modes_against_raycast(self, raster):
        nm = ripples()
        rng = np.random.default_rng(2)
        s = Scene(materials=[Reflectance.constant(0.4, "sand")])
        s.add(floor(material=0, normal_map=nm, repeats=40.0, name="nm floor"))
        s.add(Mesh([[-2.5, -3.9, -6], [-0.5, -3.9, -6], [-0.5, -2.2, -6.5], [-2.5, -2.2, -6.5]],
                   [[0, 1, 2], [0, 2, 3]], uv=[[0, 0], [1, 0], [1, 1], [0, 1]],
                   texture=rng.uniform(0.05, 0.95, (8, 8, 3)), normal_map=ripples(seed=3),
                   name="textured nm"))
        s.add(Mesh([[0.5, -3.9, -5], [2.5, -3.9, -5.5], [1.5, -2.2, -5.2]], [[0, 1, 2]],
                   uv=[[0, 0], [1.5, 0], [0.7, 1.2]],
                   vertex_rgb=[[0.9, 0.1, 0.1], [0.1, 0.8, 0.1], [0.1, 0.2, 0.9]],
                   normal_map=ripples(seed=4), name="coloured nm"))
        cam = Camera.look_at((0.0, -3.0, 0.0), (0.0, -3.5, -6.0), width=96, height=64)
        gpu, ref = raster.render(s, cam), raycast_gbuffer(s, cam)
        m = interior(ref, gpu) & (gpu.material == ref.material)
        assert m.sum() > 2000
        assert set(np.unique(ref.material[m])) == {0, PER_PIXEL}
        np.testing.assert_allclose(gpu.normal[m], ref.normal[m], atol=NORMAL_ATOL)
        # The map does tilt the normals (the floor is flat: y up everywhere).
        on_floor = m & (ref.material == 0)
        assert np.abs(ref.normal[on_floor][:, 0]).max() > 0.05
        pp = m & (ref.material == PER_PIXEL)
        np.testing.assert_allclose(gpu.sigmoid[pp], ref.sigmoid[pp], atol=COEFF_ATOL,
                                   rtol=2e-3)

    def test_back_side_normals_face_the_camera(self, raster):
        """Seen from below, the perturbed normal is turned to the camera's side."""
        s = Scene([floor(y=-2.0, material=0, normal_map=ripples())], [Reflectance.constant(0.4)])
        cam = Camera.look_at((0.0, -3.0, 0.0), (0.0, -2.5, -6.0), width=64, height=48)
        gpu, ref = raster.render(s, cam), raycast_gbuffer(s, cam)
        m = interior(ref, gpu)
        assert m.sum() > 500
        assert np.all(ref.normal[m][:, 1] < -0.5)
        np.testing.assert_allclose(gpu.normal[m], ref.normal[m], atol=NORMAL_ATOL)
