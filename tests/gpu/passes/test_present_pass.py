"""The present pass (aquaspec.gpu.passes.present): the display buffer onto a texture.

The texture is read back here, in the test only; the live view never does.
"""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.errors import AquaspecError

pytestmark = pytest.mark.gpu


def _target(device, width, height, fmt="rgba8unorm"):
    import wgpu  # deferred: the GPU tests import wgpu only when they run
    return device.create_texture(size=(width, height, 1), format=fmt,
                                 usage=wgpu.TextureUsage.RENDER_ATTACHMENT
                                 | wgpu.TextureUsage.COPY_SRC)


def _present_and_read(device, ppass, source, image_size, target):
    enc = device.create_command_encoder()
    ppass.encode(enc, source, image_size, target)
    device.queue.submit([enc.finish()])
    w, h = target.size[0], target.size[1]
    raw = device.queue.read_texture({"texture": target, "origin": (0, 0, 0), "mip_level": 0},
                                    {"offset": 0, "bytes_per_row": w * 4, "rows_per_image": h},
                                    (w, h, 1))
    return np.frombuffer(raw, np.uint8).reshape(h, w, 4)


def _packed(rgb):
    """(H, W, 3) uint8 -> the display buffer's u32 words (alpha 255)."""
    r, g, b = (rgb[..., i].astype(np.uint32) for i in range(3))
    return (r | g << 8 | b << 16 | np.uint32(255) << 24).ravel()


@pytest.fixture(scope="module")
def pattern():
    # Every byte value on each channel, at odd sizes (rows not multiples of 4 or 8).
    h, w = 37, 61
    rng = np.random.default_rng(3)
    rgb = rng.integers(0, 256, size=(h, w, 3), dtype=np.uint8)
    rgb.reshape(-1, 3)[:256] = np.arange(256, dtype=np.uint8)[:, None]
    return rgb


def test_an_image_is_copied_exactly(device, pattern):
    from aquaspec.gpu.buffers import create_storage_buffer
    from aquaspec.gpu.passes.present import PresentPass
    h, w, _ = pattern.shape
    source = create_storage_buffer(device, _packed(pattern))
    out = _present_and_read(device, PresentPass(device, "rgba8unorm"), source, (w, h),
                            _target(device, w, h))
    np.testing.assert_array_equal(out[..., :3], pattern)
    assert np.all(out[..., 3] == 255)


def test_bgra_target_gets_the_same_colours(device, pattern):
    from aquaspec.gpu.buffers import create_storage_buffer
    from aquaspec.gpu.passes.present import PresentPass
    h, w, _ = pattern.shape
    source = create_storage_buffer(device, _packed(pattern))
    out = _present_and_read(device, PresentPass(device, "bgra8unorm"), source, (w, h),
                            _target(device, w, h, "bgra8unorm"))
    np.testing.assert_array_equal(out[..., 2::-1], pattern)     # stored B, G, R


def test_a_larger_target_repeats_pixels(device, pattern):
    from aquaspec.gpu.buffers import create_storage_buffer
    from aquaspec.gpu.passes.present import PresentPass
    h, w, _ = pattern.shape
    source = create_storage_buffer(device, _packed(pattern))
    out = _present_and_read(device, PresentPass(device, "rgba8unorm"), source, (w, h),
                            _target(device, 2 * w, 3 * h))
    np.testing.assert_array_equal(out[..., :3], pattern.repeat(3, axis=0).repeat(2, axis=1))


def test_srgb_target_decodes_so_the_bytes_come_back(device, pattern):
    from aquaspec.gpu.buffers import create_storage_buffer
    from aquaspec.gpu.passes.present import PresentPass
    h, w, _ = pattern.shape
    source = create_storage_buffer(device, _packed(pattern))
    out = _present_and_read(device, PresentPass(device, "rgba8unorm-srgb"), source, (w, h),
                            _target(device, w, h, "rgba8unorm-srgb"))
    # Decoded in f32, encoded again by the hardware: rounding may move a code by one.
    assert np.abs(out[..., :3].astype(int) - pattern).max() <= 1


def test_a_rendered_frame_matches_read_display(device):
    """The renderer's own frame (built-in scene, light field, display fused):
    presented, it is read_display() byte for byte."""
    from aquaspec.apps.live import LiveView, ViewSettings
    from aquaspec.gpu.passes.present import PresentPass
    w, h = 72, 40
    view = LiveView(ViewSettings(width=w, height=h, bands=4))
    view.auto_exposure()
    r = view.renderer
    enc = r.encode_frame(device.create_command_encoder(), view.scene, view.flight.camera(),
                         view.setup)
    device.queue.submit([enc.finish()])
    assert view.device is device
    out = _present_and_read(device, PresentPass(device, "rgba8unorm"), r.display_buffer(),
                            (w, h), _target(device, w, h))
    expected = r.read_display()
    assert expected.std() > 5                   # a real image, not a flat one
    np.testing.assert_array_equal(out[..., :3], expected)


def test_overlay_covers_the_corner_mixed_by_its_alpha(device, pattern):
    from aquaspec.gpu.buffers import create_storage_buffer
    from aquaspec.gpu.passes.present import PresentPass
    h, w, _ = pattern.shape
    source = create_storage_buffer(device, _packed(pattern))
    ppass = PresentPass(device, "rgba8unorm")
    over = np.zeros((9, 20, 4), np.uint8)
    over[..., :3] = (200, 10, 90)
    over[:, :10, 3] = 255          # opaque left half, transparent right half
    over[4, 12, 3] = 128           # one half-covered pixel
    ppass.set_overlay(over)
    out = _present_and_read(device, ppass, source, (w, h), _target(device, w, h))[..., :3]
    np.testing.assert_array_equal(out[:9, :10], over[:, :10, :3])
    expected = pattern.copy()
    expected[:9, :10] = over[:, :10, :3]
    mixed = pattern[4, 12] + (over[4, 12, :3].astype(float) - pattern[4, 12]) * 128 / 255
    assert np.abs(out[4, 12].astype(float) - mixed).max() <= 1
    expected[4, 12] = out[4, 12]
    np.testing.assert_array_equal(out, expected)          # nothing else touched
    ppass.set_overlay(None)
    out = _present_and_read(device, ppass, source, (w, h), _target(device, w, h))[..., :3]
    np.testing.assert_array_equal(out, pattern)


def test_bad_format_and_small_buffer_are_refused(device):
    from aquaspec.gpu.buffers import create_storage_buffer
    from aquaspec.gpu.passes.present import PresentPass
    with pytest.raises(AquaspecError, match="accepted: bgra8unorm"):
        PresentPass(device, "rgba16float")
    ppass = PresentPass(device, "rgba8unorm")
    enc = device.create_command_encoder()
    with pytest.raises(AquaspecError, match="needs 4096"):
        ppass.encode(enc, create_storage_buffer(device, 64), (32, 32), _target(device, 32, 32))
    with pytest.raises(AquaspecError, match="made for 'rgba8unorm'"):
        ppass.encode(enc, create_storage_buffer(device, 4096), (32, 32),
                     _target(device, 32, 32, "bgra8unorm"))
    with pytest.raises(AquaspecError, match=r"accepted: uint8 \(height, width, 4\)"):
        ppass.set_overlay(np.zeros((4, 4, 3), np.uint8))
