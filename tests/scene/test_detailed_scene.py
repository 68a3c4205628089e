"""The detailed built-in scene (aquaspec.scene.detailed) and its materials."""

import numpy as np
import pytest

from aquaspec.colour.benthic import (TCS14_VALUES, TCS14_WAVELENGTH_NM, benthic_reflectance,
                                     provenance)
from aquaspec.errors import AquaspecError
from aquaspec.scene import builtin_scene
from aquaspec.scene.camera import Camera
from aquaspec.scene.mesh import Scene
from aquaspec.scene.procedural import fbm, sand_maps, tileable_noise
from aquaspec.scene.raycast import raycast_gbuffer


@pytest.fixture(scope="module")
def detailed():
    return builtin_scene(6.0, width=160, height=90, variant="detailed")


def _named(scene, word):
    return [m for m in scene.meshes if word in m.name]


class TestDetailedScene:
    def test_deterministic_and_seeded(self, detailed):
        scene, cam = detailed
        again, cam2 = builtin_scene(6.0, width=160, height=90, variant="detailed")
        assert [m.name for m in again.meshes] == [m.name for m in scene.meshes]
        for a, b in zip(scene.meshes, again.meshes):
            np.testing.assert_array_equal(a.vertices, b.vertices)
            np.testing.assert_array_equal(a.faces, b.faces)
        other, _ = builtin_scene(6.0, seed=3, width=160, height=90, variant="detailed")
        assert not np.array_equal(other.meshes[0].vertices, scene.meshes[0].vertices)
        np.testing.assert_array_equal(cam.view_matrix(), cam2.view_matrix())

    def test_what_it_holds(self, detailed):
        scene, _ = detailed
        assert len(_named(scene, "colorchecker patch")) == 24
        for word in ("seabed (rippled sand)", "seagrass", "pipe", "wreck hull plate",
                     "crevices", "coral on pipe"):
            assert _named(scene, word), word
        # Normal maps on the sand, the pipe and the plate; no per-pixel
        # materials (the fast one-material path of the G-buffer and shading).
        assert {m.name for m in scene.meshes if m.normal_map is not None} >= {
            "seabed (rippled sand)", "pipe (rust)", "pipe (fouling)"}
        assert not any(m.per_pixel for m in scene.meshes)
        assert scene.n_triangles > 2 * builtin_scene(6.0, width=16, height=9)[0].n_triangles
        assert scene.info["builtin"] == "detailed"
        assert "measured" in scene.info["reflectances"]["seagrass"]

    def test_under_water_and_camera_above_sand(self, detailed):
        scene, cam = detailed
        assert scene.bounds()[1, 1] < 0
        np.testing.assert_allclose(cam.position, [0.0, -6.0, 0.0])
        down = Camera(cam.position, (0, -1, 0), (0, 0, -1), 3, 3, 2.0, 2.0, 1.5, 1.5)
        sand = _named(scene, "seabed")
        g = raycast_gbuffer(Scene(sand, scene.materials), down)
        np.testing.assert_allclose(g.distance[1, 1], 1.5, atol=5e-3)
        # The ripples tilt the shading normal away from the geometric one.
        assert abs(g.normal[1, 1, 1]) < 0.9999

    def test_unknown_variant(self):
        with pytest.raises(AquaspecError, match="'fancy'.*classic, detailed"):
            builtin_scene(5.0, variant="fancy")


class TestProcedural:
    def test_noise_tiles_and_is_bounded(self):
        rng = np.random.default_rng(0)
        n = tileable_noise(rng, 64, 8)
        assert np.abs(n).max() <= 1.0
        # Periodic: the step across the wrap is no larger than inside.
        inner = np.abs(np.diff(n, axis=1)).max()
        assert np.abs(n[:, 0] - n[:, -1]).max() <= inner + 1e-12
        f = fbm(rng, 64, 4, 3)
        assert np.isclose(np.abs(f).max(), 1.0)

    def test_sand_ripple_spacing(self):
        rng = np.random.default_rng(1)
        _, normal, height = sand_maps(rng, (0.4, 0.35, 0.2), n=256, tile_m=1.6, ripple_m=0.16)
        spectrum = np.abs(np.fft.rfft(height - height.mean(), axis=1)).mean(axis=0)
        # 1.6 m / 0.16 m = 10 crests a tile; the crests' bending spreads it.
        assert 8 <= np.argmax(spectrum[1:]) + 1 <= 12
        assert np.all(normal[..., 2] > 0.5)
        np.testing.assert_allclose(np.linalg.norm(normal, axis=-1), 1.0, atol=1e-6)


class TestBenthicSpectra:
    def test_tcs14_table_is_colour_science_s(self):
        tcs = pytest.importorskip("colour.quality.datasets.tcs")
        sd = tcs.SDS_TCS_CIE1995["TCS14"]
        want = [sd[w] for w in TCS14_WAVELENGTH_NM]
        np.testing.assert_allclose(TCS14_VALUES, want, atol=5e-4)

    def test_leaf_green_shape_and_provenance(self):
        r = benthic_reflectance("seagrass")
        wl, v = r.wavelength_nm, r.values
        green = v[(wl >= 540) & (wl <= 560)].max()
        assert green > 2 * v[wl == 450][0] and green > 1.5 * v[wl == 670][0]
        p = provenance()
        assert p["seagrass"].startswith("measured")
        assert all("upsampling" in p[k] for k in ("sand", "rock", "coral"))
        with pytest.raises(AquaspecError, match="unknown benthic material 'mud'"):
            benthic_reflectance("mud")
