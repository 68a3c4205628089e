"""The marine-snow pass (aquaspec.gpu.passes.particles) against its NumPy reference."""

import numpy as np
import pytest

from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import PER_PIXEL, GBuffer
from aquaspec.shading.particles import composite, splat_image

pytestmark = pytest.mark.gpu

W, H = 160, 90
#: The accumulation sums f32 (the weights f32, NumPy float64); as a fraction
#: of the image's largest value.
ATOL_FRACTION = 1e-5


def _surface(device, dist):
    from aquaspec.gpu.gbuffer import GBufferTextures
    h, w = dist.shape
    cam = Camera.look_at([0, -5, 0], [0, -5, -1], width=w, height=h)
    gb = GBufferTextures(device, w, h)
    gb.upload(GBuffer(cam, dist, np.tile([0.0, 0.0, 1.0], (h, w, 1)),
                      np.full((h, w), PER_PIXEL, np.uint32), np.zeros((h, w, 3))))
    return gb.textures["surface"]


def _records(n, seed=2, w=W, h=H):
    rng = np.random.default_rng(seed)
    rec = np.zeros((n, 8), np.float32)
    rec[:, 0], rec[:, 1] = rng.uniform(-5, w + 5, n), rng.uniform(-5, h + 5, n)
    rec[:, 2] = rng.uniform(0.5, 12.0, n)
    rec[:, 3] = rng.uniform(0.2, 4.0, n)
    rec[:, 4:7] = rng.uniform(0.0, 3.0, (n, 3)) * 1e-3     # small camera RGB: the scale matters
    rec[:, 4] -= 1.5e-3                     # camera RGB can be negative (red in blue water)
    rec[:, 7] = rng.uniform(0.0, 1.0, n) * np.pi * rec[:, 2] ** 2
    return rec


class TestParticlePass:
    # (150: rows of the splat's buffer padded to 160 pixels before the copy into a texture.)
    @pytest.mark.parametrize("W", [W, 150])
    def test_splat_and_compose_match_numpy(self, device, W):
        from aquaspec.gpu.buffers import create_storage_buffer, read_buffer
        from aquaspec.gpu.passes.particles import ParticlePass
        dist = np.full((H, W), np.inf, np.float32)
        dist[:, :80] = 2.0                  # half the image a wall 2 m away
        dist[60:, 80:] = 0.5
        rec = _records(300, w=W)
        image = np.random.default_rng(5).uniform(0, 2e-3, (H, W, 4)).astype(np.float32)
        buf = create_storage_buffer(device, image)
        p = ParticlePass(device, W, H)
        p.set_splats(rec)
        enc = device.create_command_encoder()
        p.encode(enc, _surface(device, dist), buf)
        device.queue.submit([enc.finish()])
        acc_gpu = p.read_accumulated()
        out_gpu = read_buffer(device, buf, np.float32, (H, W, 4))[..., :3]
        acc = splat_image(rec, dist)
        out = composite(image[..., :3], acc)
        assert (acc[..., 3] > 0).mean() > 0.5 and np.any(acc[:, :80, 3] == 0)
        for k in range(4):
            np.testing.assert_allclose(acc_gpu[..., k], acc[..., k],
                                       atol=ATOL_FRACTION * np.abs(acc[..., k]).max())
        np.testing.assert_allclose(out_gpu, out, atol=ATOL_FRACTION * out.max())

    def test_a_pile_of_discs_adds_up(self, device):
        """5000 opaque discs on one spot (a coverage of about 5000 on its
        pixels, invocations adding to the same pixels at once) sum as NumPy's."""
        from aquaspec.gpu.passes.particles import ParticlePass
        dist = np.full((H, W), np.inf, np.float32)
        rec = np.zeros((5000, 8), np.float32)
        rec[:, 0], rec[:, 1], rec[:, 2], rec[:, 3] = 80.3, 45.6, 3.0, 1.0
        rec[:, 4:7] = np.linspace(0.1, 1.0, 5000)[:, None] * [1.0, 0.5, 0.25]
        rec[:, 7] = np.pi * 9.0
        p = ParticlePass(device, W, H)
        p.set_splats(rec)
        enc = device.create_command_encoder()
        p.encode_splat(enc, _surface(device, dist))
        device.queue.submit([enc.finish()])
        acc = splat_image(rec, dist)
        got = p.read_accumulated()
        assert acc[..., 3].max() > 4000
        # The coverage adds 5000 equal f32 terms (the same sum in any order):
        # within 1e-4, where one disc lost would be 2e-4; the light's terms
        # differ, f32 rounding of 5000 of them within 1e-3.
        np.testing.assert_allclose(got[..., 3], acc[..., 3], rtol=1e-4, atol=1e-6)
        np.testing.assert_allclose(got[..., :3], acc[..., :3], rtol=1e-3,
                                   atol=ATOL_FRACTION * np.abs(acc).max())

    def test_no_particles_leaves_the_image(self, device):
        from aquaspec.gpu.buffers import create_storage_buffer, read_buffer
        from aquaspec.gpu.passes.particles import ParticlePass
        p = ParticlePass(device, W, H)
        image = np.random.default_rng(1).random((H, W, 4)).astype(np.float32)
        buf = create_storage_buffer(device, image)
        surface = _surface(device, np.full((H, W), np.inf, np.float32))
        p.set_splats(_records(50))
        enc = device.create_command_encoder()
        p.encode_splat(enc, surface)
        device.queue.submit([enc.finish()])
        p.set_splats(np.zeros((0, 8), np.float32))
        enc = device.create_command_encoder()
        p.encode(enc, surface, buf)
        device.queue.submit([enc.finish()])
        np.testing.assert_array_equal(read_buffer(device, buf, np.float32, (H, W, 4)), image)

    def test_bad_records(self, device):
        from aquaspec.errors import AquaspecError
        from aquaspec.gpu.passes.particles import ParticlePass
        with pytest.raises(AquaspecError, match="accepted"):
            ParticlePass(device, W, H).set_splats(np.zeros((3, 5)))
