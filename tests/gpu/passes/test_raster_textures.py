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

#: Beyond the envelope: the GPU's filter arithmetic against float64. The
#: normal maps are 8-bit textures whose filtered sample comes back in steps
#: of 2/255 of n (0.004 half a step); lavapipe's filter weights are coarse
#: fractions. Measured on lavapipe (2026-11-28): at most 0.0097 (coefficients)
#: and 0.0090 (normals) from the envelope.
COEFF_ATOL = 0.012
NORMAL_ATOL = 0.012
#: The GPU's level of detail is implementation-defined (lavapipe approximates
#: rho and log2 and filters "brilinearly"); its samples must lie within the
#: reference's over lod +- LOD_SLACK.
LOD_SLACK = 0.6


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


def envelope(scene, cam, name):
    """Per pixel, the lowest and highest value of G-buffer field ``name`` over
    ray-cast references with level-of-detail biases in [-LOD_SLACK, LOD_SLACK]."""
    refs = [getattr(raycast_gbuffer(scene, cam, lod_bias=b), name)
            for b in np.linspace(-LOD_SLACK, LOD_SLACK, 7)]
    return np.min(refs, axis=0), np.max(refs, axis=0)


def assert_within(got, lo, hi, atol):
    below, above = lo - atol - got, got - hi - atol
    worst = max(below.max(), above.max())
    assert worst <= 0, (f"{int(((below > 0) | (above > 0)).sum())} of {got.size} values "
                        f"outside the envelope by up to {worst:.3g}")


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
        lo, hi = envelope(s, cam, "sigmoid")
        assert_within(gpu.sigmoid[m], lo[m], hi[m], COEFF_ATOL)
        # The slack is not all: far pixels do pick coarser levels (the lod
        # spans several levels over the image and the samples differ from
        # level 0's by far more than the tolerance).
        level0 = raycast_gbuffer(s, cam, lod_bias=-20.0).sigmoid
        assert np.abs(gpu.sigmoid[m] - level0[m]).max() > 0.2

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
        lo, hi = envelope(s, cam, "normal")
        assert_within(gpu.normal[m], lo[m], hi[m], NORMAL_ATOL)
        # The map does tilt the normals (the floor is flat: y up everywhere).
        on_floor = m & (ref.material == 0)
        assert np.abs(ref.normal[on_floor][:, 0]).max() > 0.05
        pp = m & (ref.material == PER_PIXEL)
        lo, hi = envelope(s, cam, "sigmoid")
        assert_within(gpu.sigmoid[pp], lo[pp], hi[pp], COEFF_ATOL)

    def test_back_side_normals_face_the_camera(self, raster):
        """Seen from below, the perturbed normal is turned to the camera's side."""
        s = Scene([floor(y=-2.0, material=0, normal_map=ripples())], [Reflectance.constant(0.4)])
        cam = Camera.look_at((0.0, -3.0, 0.0), (0.0, -2.5, -6.0), width=64, height=48)
        gpu, ref = raster.render(s, cam), raycast_gbuffer(s, cam)
        m = interior(ref, gpu)
        assert m.sum() > 500
        assert np.all(ref.normal[m][:, 1] < -0.5)
        lo, hi = envelope(s, cam, "normal")
        assert_within(gpu.normal[m], lo[m], hi[m], NORMAL_ATOL)
