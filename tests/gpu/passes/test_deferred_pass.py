"""The GPU deferred pass against its NumPy reference, shade_gbuffer.

G-buffers are built analytically (tests/support/analytic_gbuffers.py: ray-plane
and ray-box intersections per pixel), so neither side's geometry comes from
code under test.
"""

import numpy as np
import pytest

from aquaspec.transport import monzon2022 as model
from aquaspec.scene.camera import Camera
from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import snell_window_cos
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer
from aquaspec.shading.shade import shade_gbuffer

from support.analytic_gbuffers import (ATOL_FRACTION, H, PASSES, RTOL, SCENES, W, assert_matches,
                                       comparable, deferred_pass, gbuffer_textures, medium,
                                       run_gpu, scene_box, scene_seabed, scene_up)

pytestmark = pytest.mark.gpu


# ------------------------------------------------------------------- tests
class TestDeferredMatchesReference:
    @pytest.mark.parametrize("n", [3, 8, 31])
    @pytest.mark.parametrize("water", ["I", "IB", "3C"])
    @pytest.mark.parametrize("scene", list(SCENES))
    def test_camera_rgb(self, device, scene, water, n):
        gb = SCENES[scene]()
        med = medium(water, n)
        ref = shade_gbuffer(gb, **med)["camera_rgb"]
        gpu = run_gpu(device, gb, med, n).read_rgb()
        assert gpu.shape == (H, W, 3) and gpu.dtype == np.float32
        assert np.all(ref > 0)
        assert_matches(gpu, ref, comparable(gb))

    @pytest.mark.parametrize("n", [1, 2, 3, 4, 7, 10, 13, 16, 17, 18, 22])
    def test_band_counts_around_whole_material_vec4s(self, device, n):
        # From GROUPED_MIN_BANDS bands the loop takes four bands at a time,
        # then the rest (aquaspec.gpu.materials); below, a loop over each
        # vec4's bands in a loop over the vec4s (one partial vec4 alone
        # below 4 bands): every remainder 0-3 on both sides.
        gb = scene_seabed()
        med = medium("IB", n)
        ref = shade_gbuffer(gb, **med)["camera_rgb"]
        assert_matches(run_gpu(device, gb, med, n).read_rgb(), ref, comparable(gb))

    @pytest.mark.parametrize("n", [7, 31])
    def test_many_materials_in_a_storage_buffer(self, device, n):
        # Over 64 KiB of material table (4096 vec4) it moves to a storage
        # buffer: 2100 materials, drawn at random for the box scene's pixels.
        from aquaspec.gpu.passes.deferred import DeferredPass
        from aquaspec.gpu.materials import UNIFORM_VEC4
        gb = scene_box()
        n_mat = 2100
        assert n_mat * -(-n // 4) > UNIFORM_VEC4
        rng = np.random.default_rng(n)
        mat = gb.material.copy()
        own = gb.hit & (mat != PER_PIXEL)
        mat[own] = rng.integers(0, n_mat, size=int(own.sum()))
        gb = GBuffer(gb.camera, gb.distance, gb.normal, mat, gb.sigmoid,
                     materials=[f"m{i}" for i in range(n_mat)])
        med = medium("3C", n)
        med["material_bands"] = rng.uniform(0.02, 0.9, size=(n_mat, n))
        ref = shade_gbuffer(gb, **med)["camera_rgb"]
        p = DeferredPass(W, H, n, device=device)
        p.gbuffer.upload(gb)
        p.set_medium(**med)
        assert not p.materials.in_uniform
        p.run()
        assert_matches(p.read_rgb(), ref, comparable(gb))
        # Back to a small table: the uniform buffer again, same pass.
        med = medium("3C", n)
        gb2 = scene_box()
        p.gbuffer.upload(gb2)
        p.set_medium(**med)
        assert p.materials.in_uniform
        p.run()
        assert_matches(p.read_rgb(), shade_gbuffer(gb2, **med)["camera_rgb"], comparable(gb2))

    @pytest.mark.parametrize("water", ["I", "3C"])
    @pytest.mark.parametrize("scene", ["seabed", "up"])
    def test_open_water_table(self, device, scene, water):
        """Four-pixel groups that see only open water are shaded from the
        open-water table (interpolated in v_y): they must match the reference
        as the band loop does, and the table must really be used."""
        from aquaspec.gpu.passes.deferred import open_water_table
        gb = SCENES[scene]()
        n = 8
        med = medium(water, n)
        ref = shade_gbuffer(gb, **med)["camera_rgb"]
        p = run_gpu(device, gb, med, n)
        table = p.read_rgb()
        p.use_open_table = False
        p.run()
        loop = p.read_rgb()
        p.use_open_table = True
        assert_matches(table, ref, comparable(gb))
        assert_matches(loop, ref, comparable(gb))
        changed = np.any(table != loop, axis=-1)
        v_y = gb.camera.ray_directions()[..., 1]
        to_surface = np.where(v_y > 0, gb.camera.depth_m / np.where(v_y > 0, v_y, 1), np.inf)
        seen = gb.hit & (gb.distance <= to_surface)    # surfaces the shading sees
        assert changed.sum() > 100 and not np.any(changed & seen)
        # The table itself against the per-band model at v_y between its samples.
        t = open_water_table(med["a"], med["b"], med["kd"], med["e0"], med["response_weights"],
                             gb.camera.depth_m, size=4096)
        assert t.shape == (4096, 2, 4) and np.all(np.isfinite(t))

    @pytest.mark.parametrize("n", [3, 8])
    @pytest.mark.parametrize("scene", ["seabed", "box"])
    def test_without_per_pixel_materials(self, device, scene, n):
        """A G-buffer with no per-pixel material runs the pipeline that never
        reads the sigmoid texture; it must shade the same."""
        gb = SCENES[scene]()
        gb.material[gb.material == PER_PIXEL] = 0
        med = medium("IB", n)
        p = run_gpu(device, gb, med, n)
        assert not p.gbuffer.per_pixel
        assert_matches(p.read_rgb(), shade_gbuffer(gb, **med)["camera_rgb"], comparable(gb))

    def test_per_pixel_material_in_single_material_gbuffer_is_reported(self, device):
        """PER_PIXEL in a G-buffer declared without per-pixel materials is an error, not rho = 0."""
        from aquaspec.gpu.buffers import upload_texture
        from aquaspec.gpu.gbuffer import pack_gbuffer
        gb = scene_box()
        p = deferred_pass(device, 3)
        p.set_medium(**medium("IB", 3))
        p.gbuffer.use_textures(gb.camera, per_pixel=False)
        upload_texture(device, p.gbuffer.textures["surface"], pack_gbuffer(gb)["surface"])
        p.run()
        with pytest.raises(AquaspecError, match="material index"):
            p.read_rgb()
        p.gbuffer.upload(gb)   # leave valid contents behind

    def test_scenes_cover_every_branch(self):
        """The scenes exercise hits, open water, the window, the black surface
        outside it and a hit beyond the surface; otherwise the match above
        would prove less."""
        cos_c = snell_window_cos()
        seen = set()
        for make in SCENES.values():
            gb = make()
            v_y = gb.camera.ray_directions()[..., 1]
            to_surface = np.where(v_y > 0, gb.camera.depth_m / np.where(v_y > 0, v_y, 1), np.inf)
            hit = gb.hit & (gb.distance <= to_surface)
            seen |= {name for name, m in [
                ("hit", hit), ("per-pixel", hit & (gb.material == PER_PIXEL)),
                ("material", hit & (gb.material != PER_PIXEL)),
                ("open-down", ~gb.hit & (v_y <= 0)),
                ("window", ~hit & (v_y > cos_c)),
                ("outside-window", ~hit & (v_y > 0) & (v_y < cos_c)),
                ("beyond-surface", gb.hit & ~hit)] if m.any()}
        assert seen == {"hit", "per-pixel", "material", "open-down", "window",
                        "outside-window", "beyond-surface"}

    @pytest.mark.parametrize("ambient", ["uniform", "cosine"])
    def test_ambient_models(self, device, ambient):
        gb = scene_up()           # the plate faces down: the two models differ most
        med = medium("IB", 8, ambient=ambient)
        ref = shade_gbuffer(gb, **med)["camera_rgb"]
        assert_matches(run_gpu(device, gb, med, 8).read_rgb(), ref, comparable(gb))

    def test_k_crossing_zero(self, device):
        """k = c - Kd v_y passes through 0 and below it across the image."""
        gb = scene_up()
        n = 8
        med = medium("I", n)
        c = med["a"] + med["b"]
        med["kd"] = c / 0.8      # k = 0 at v_y = 0.8, k < 0 above
        v_y = gb.camera.ray_directions()[..., 1]
        assert v_y.min() < 0.8 < v_y.max()
        ref = shade_gbuffer(gb, **med)["camera_rgb"]
        assert_matches(run_gpu(device, gb, med, n).read_rgb(), ref, comparable(gb))

    def test_radiance_debug_mode(self, device):
        gb = scene_box()
        med = medium("IB", 8)
        ref = shade_gbuffer(gb, **med, return_radiance=True)
        p = run_gpu(device, gb, med, 8, debug=True)
        mask = comparable(gb)
        rad = p.read_radiance()
        assert rad.shape == (H, W, 8)
        np.testing.assert_allclose(rad[mask], ref["radiance"][mask], rtol=RTOL,
                                   atol=ATOL_FRACTION * ref["radiance"].max())
        assert_matches(p.read_rgb(), ref["camera_rgb"], mask)

    def test_read_radiance_needs_debug_mode(self, device):
        p = run_gpu(device, scene_box(), medium("IB", 3), 3)
        with pytest.raises(AquaspecError, match="debug_radiance"):
            p.read_radiance()


class TestGpuResidentInputs:
    def test_external_textures(self, device):
        """A raster pass hands over its own textures in the documented layout."""
        from aquaspec.gpu.gbuffer import pack_gbuffer
        gb = scene_seabed()
        med = medium("3C", 8)
        tex = gbuffer_textures(device, pack_gbuffer(gb))
        p = deferred_pass(device, 8)
        p.set_medium(**med)
        p.gbuffer.use_textures(gb.camera, **tex)
        try:
            p.run()
            gpu = p.read_rgb()
        finally:
            # Restore the pass's own textures for the other tests sharing it.
            from aquaspec.gpu.passes.deferred import DeferredPass
            PASSES.pop((8, False))
            PASSES[(8, False)] = DeferredPass(W, H, 8, device=device)
        ref = shade_gbuffer(gb, **med)["camera_rgb"]
        assert_matches(gpu, ref, comparable(gb))

    def test_written_in_place(self, device):
        """Writing the pass's own gbuffer_textures (as a raster pass does) works."""
        from aquaspec.gpu.buffers import upload_texture
        from aquaspec.gpu.gbuffer import pack_gbuffer
        gb = scene_box()
        med = medium("IB", 3)
        p = deferred_pass(device, 3)
        p.set_medium(**med)
        for k, v in pack_gbuffer(gb).items():
            upload_texture(device, p.gbuffer.textures[k], v)
        p.gbuffer.set_camera(gb.camera)
        p.run()
        assert_matches(p.read_rgb(), shade_gbuffer(gb, **med)["camera_rgb"], comparable(gb))

    def test_upload_packs_the_documented_layout(self, device):
        """GBufferTextures.upload writes the layout of aquaspec.gpu.gbuffer's docstring (distance, n_y, material)."""
        from aquaspec.gpu.buffers import read_texture
        gb = scene_seabed()
        p = deferred_pass(device, 3)
        p.gbuffer.upload(gb)
        surface = read_texture(device, p.gbuffer.textures["surface"], np.uint32, 4)
        np.testing.assert_array_equal(surface[..., 0].view(np.float32),
                                      np.where(gb.hit, gb.distance, -1.0).astype(np.float32))
        np.testing.assert_array_equal(surface[..., 1].view(np.float32),
                                      gb.normal[..., 1].astype(np.float32))
        np.testing.assert_array_equal(surface[..., 3], gb.material)
        assert p.gbuffer.per_pixel == bool(np.any(gb.hit & (gb.material == PER_PIXEL)))

    def test_bad_material_index_is_reported(self, device):
        from aquaspec.gpu.buffers import upload_texture
        from aquaspec.gpu.gbuffer import pack_gbuffer
        gb = scene_box()
        packed = pack_gbuffer(gb)
        packed["surface"][gb.hit & (gb.material == 0), 3] = 7
        p = deferred_pass(device, 3)
        p.set_medium(**medium("IB", 3))
        upload_texture(device, p.gbuffer.textures["surface"], packed["surface"])
        p.gbuffer.set_camera(gb.camera)
        p.run()
        with pytest.raises(AquaspecError, match="material index"):
            p.read_rgb()
        p.gbuffer.upload(gb)   # leave valid contents behind

    def test_wrong_texture(self, device):
        from aquaspec.gpu.gbuffer import pack_gbuffer
        gb = scene_box()
        p = deferred_pass(device, 3)
        packed = pack_gbuffer(gb)
        small = gbuffer_textures(device, {"surface": packed["surface"][:10, :10]})
        with pytest.raises(AquaspecError, match="surface texture is 10x10"):
            p.gbuffer.use_textures(gb.camera, **small)
        swapped = gbuffer_textures(device, {"sigmoid": packed["sigmoid"]})
        with pytest.raises(AquaspecError, match="rgba32uint"):
            p.gbuffer.use_textures(gb.camera, surface=swapped["sigmoid"])
        with pytest.raises(AquaspecError, match="unknown G-buffer texture"):
            p.gbuffer.use_textures(gb.camera, depth=swapped["sigmoid"])


class TestDeferredInputErrors:
    def test_band_count_mismatch(self, device):
        p = deferred_pass(device, 3)
        with pytest.raises(AquaspecError, match="created for 3"):
            p.set_medium(**medium("IB", 8))

    def test_size_mismatch(self, device):
        p = deferred_pass(device, 3)
        cam = Camera.look_at((0, -5, 0), (0, -5, 1), width=W + 1, height=H)
        gb = GBuffer(cam, np.full((H, W + 1), np.inf), np.zeros((H, W + 1, 3)),
                     np.zeros((H, W + 1)), np.zeros((H, W + 1, 3)))
        with pytest.raises(AquaspecError, match="created for"):
            p.gbuffer.upload(gb)

    def test_camera_above_water(self, device):
        p = deferred_pass(device, 3)
        cam = Camera.look_at((0, 1, 0), (0, -5, 1), width=W, height=H)
        with pytest.raises(AquaspecError, match="above the water"):
            p.gbuffer.set_camera(cam)

    def test_ambient_ids_cover_the_model(self):
        from aquaspec.gpu.passes.deferred import AMBIENT_MODEL_IDS
        assert set(AMBIENT_MODEL_IDS) == set(model.AMBIENT_MODELS)

    def test_bad_band_count(self, device):
        from aquaspec.gpu.passes.deferred import DeferredPass
        with pytest.raises(AquaspecError, match="n_bands"):
            DeferredPass(W, H, 0, device=device)


class TestFusedDisplay:
    """encode(display=True): shading and the display transform in one pass."""

    @pytest.mark.parametrize("tonemap", ["filmic", "none"])
    @pytest.mark.parametrize("scene", ["seabed", "up"])
    def test_equals_display_pass_of_linear_output(self, device, scene, tonemap,
                                                  fused_and_two_pass):
        from aquaspec.colour import display
        gb = SCENES[scene]()
        n = 8
        med = medium("IB", n)
        p = run_gpu(device, gb, med, n)
        linear = p.read_rgb()
        settings = display.display_settings(linear, white_balance="grey-world")
        kw = dict(exposure_ev=settings["exposure_ev"],
                  white_balance_gains=settings["white_balance_gains"], tonemap=tonemap)
        fused, expected = fused_and_two_pass(p, W, H, **kw)
        assert fused.shape == (H, W, 3) and fused.dtype == np.uint8
        # Same f32 arithmetic, but the compiler may fuse operations
        # differently in the two shaders: codes may differ by one at ties.
        diff = np.abs(fused.astype(int) - expected.astype(int))
        assert diff.max() <= 1 and np.mean(diff == 0) > 0.99
        assert len(np.unique(fused.reshape(-1, 3), axis=0)) > 50   # a real picture
        # And against the float64 NumPy chain, shading included.
        ref, _ = display.to_display(shade_gbuffer(gb, **med)["camera_rgb"],
                                    exposure=settings["exposure_ev"],
                                    white_balance="grey-world", tonemap=tonemap)
        m = comparable(gb)
        assert np.abs(fused.astype(int) - ref.astype(int))[m].max() <= 1
        with pytest.raises(AquaspecError, match="display image"):
            p.read_rgb()

    def test_non_finite_pixels_are_refused(self, device):
        """Values that overflow float32 after exposure: the fused pass says where."""
        gb = scene_seabed()
        n = 3
        med = medium("I", n)
        med["e0"] = med["e0"] * 1e36
        p = deferred_pass(device, n)
        p.gbuffer.upload(gb)
        p.set_medium(**med)
        p.set_display(exposure_ev=20.0)
        p.run(display=True)
        with pytest.raises(AquaspecError, match=r"non-finite .* first is at \(row"):
            p.read_display()

    def test_needs_settings_and_a_display_run(self, device):
        from aquaspec.gpu.passes.deferred import DeferredPass
        p = DeferredPass(W, H, 3, device=device)
        p.gbuffer.upload(scene_box())
        p.set_medium(**medium("IB", 3))
        with pytest.raises(AquaspecError, match="set_display"):
            p.run(display=True)
        p.run()
        with pytest.raises(AquaspecError, match="display=True"):
            p.read_display()
        with pytest.raises(AquaspecError, match="unknown tone map 'aces'"):
            p.set_display(exposure_ev=0.0, tonemap="aces")
