"""The GPU cone-spread pyramid (aquaspec.gpu.passes.conespread, one dispatch)
against its NumPy reference (aquaspec.transport.lightfield.conespread.spread) on random images."""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.transport.lightfield.conespread import spread
from aquaspec.errors import AquaspecError

pytestmark = pytest.mark.gpu


def reference(image, weights):
    """spread() in float64; one level (no pyramid) is U_0 = a_0 P_0."""
    if len(weights) == 1:
        return weights[0] * np.asarray(image, dtype=float)
    return spread(image, weights)


def run_pass(sp, image):
    """Upload level 0, record the pass's dispatches in one compute pass, read U_0."""
    from aquaspec.gpu.buffers import read_texture, upload_texture
    from aquaspec.gpu.dispatch import record_dispatches
    upload_texture(sp.device, sp.cone_texture, image.astype(np.float32))
    enc = sp.device.create_command_encoder()
    record_dispatches(enc, sp.dispatches())
    sp.device.queue.submit([enc.finish()])
    return read_texture(sp.device, sp.result, np.float32, 4)


def assert_spread_matches(sp, image, weights):
    got = run_pass(sp, image)
    want = reference(image.astype(np.float32), weights)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6 * np.abs(want).max())


# (width, height): the 720p and 1080p start levels, odd sizes (more rows than
# one invocation walks, conespread_pass.ROWS), thin and one texel.
SIZES = [(160, 90), (240, 135), (97, 61), (7, 5), (1, 1), (13, 1), (1, 9), (130, 3)]


@pytest.mark.parametrize("width,height", SIZES)
@pytest.mark.parametrize("levels", range(7))
def test_matches_numpy(device, width, height, levels):
    from aquaspec.gpu.passes.conespread import ConeSpreadPass
    rng = np.random.default_rng(100 * width + 10 * height + levels)
    sp = ConeSpreadPass(device, width, height, levels)
    assert len(sp.shapes) == levels + 1
    image = rng.uniform(0.0, 2.0, size=(height, width, 4))
    weights = rng.uniform(0.0, 1.0, size=levels + 1)
    sp.set_weights(weights)
    assert len(sp.dispatches()) == 1
    assert_spread_matches(sp, image, weights)


def test_new_weights_on_the_same_pipeline(device):
    """New weights (a uniform) on the same pipeline; a second run after new
    input (levels rewritten, not accumulated)."""
    from aquaspec.gpu.passes.conespread import ConeSpreadPass
    rng = np.random.default_rng(7)
    sp = ConeSpreadPass(device, 97, 61, 5)
    for trial in range(3):
        image = rng.uniform(0.0, 1.0, size=(61, 97, 4)) * rng.uniform(0.1, 10.0)
        weights = rng.uniform(0.0, 1.0, size=6)
        weights[rng.integers(0, 6)] = 0.0
        sp.set_weights(weights / weights.sum())
        pipeline = sp.dispatches()[0][0]
        if trial:
            assert pipeline is first
        first = pipeline
        assert_spread_matches(sp, image, weights / weights.sum())


def test_point_response_is_the_references(device):
    """A single bright texel near a corner (clamped taps on both sides)."""
    from aquaspec.gpu.passes.conespread import ConeSpreadPass
    sp = ConeSpreadPass(device, 33, 20, 5)
    image = np.zeros((20, 33, 4))
    image[1, 31] = [1.0, 2.0, 3.0, 4.0]
    image[19, 0] = [5.0, 0.0, 0.5, 1.0]
    weights = np.array([0.1, 0.2, 0.3, 0.2, 0.1, 0.1])
    sp.set_weights(weights)
    assert_spread_matches(sp, image, weights)


def test_most_levels(device):
    """MAX_LEVELS levels (all weights in the uniform used; the coarsest are 1x1)."""
    from aquaspec.gpu.passes.conespread import MAX_LEVELS, ConeSpreadPass
    rng = np.random.default_rng(3)
    sp = ConeSpreadPass(device, 37, 23, MAX_LEVELS)
    image = rng.uniform(0.0, 1.0, size=(23, 37, 4))
    weights = rng.uniform(0.0, 1.0, size=MAX_LEVELS + 1)
    sp.set_weights(weights)
    assert_spread_matches(sp, image, weights)
    with pytest.raises(AquaspecError, match="levels"):
        ConeSpreadPass(device, 37, 23, MAX_LEVELS + 1)


def test_bad_weights_and_order(device):
    from aquaspec.gpu.passes.conespread import ConeSpreadPass
    sp = ConeSpreadPass(device, 8, 8, 2)
    with pytest.raises(AquaspecError, match="set_weights"):
        sp.dispatches()
    with pytest.raises(AquaspecError, match="accepted: 3"):
        sp.set_weights([0.5, 0.5])


@pytest.mark.parametrize("width,height,levels", [(160, 90, 5), (97, 61, 6), (7, 5, 2),
                                                 (13, 1, 3), (20, 11, 1), (9, 4, 0)])
@pytest.mark.parametrize("nodes", [6, 4])
def test_node_images_match_numpy(device, width, height, levels, nodes):
    """The multiple-scattering spread's texels: K node images of camera RGB
    in ceil(3 K / 4) vec4, level 0's slots side by side in the cone texture;
    U_0 = spread_nodes (each node's image with its own level weights, summed)."""
    from aquaspec.transport.lightfield.conespread import spread_nodes
    from aquaspec.gpu.buffers import read_texture, upload_texture
    from aquaspec.gpu.dispatch import record_dispatches
    from aquaspec.gpu.passes.conespread import ConeSpreadPass, slots_for
    rng = np.random.default_rng(7 * width + height + levels + nodes)
    sp = ConeSpreadPass(device, width, height, levels, nodes=nodes)
    assert sp.slots == slots_for(nodes) == -(-3 * nodes // 4)
    images = rng.uniform(-1.0, 2.0, size=(height, width, nodes, 3))
    flat = np.zeros((height, width, 4 * sp.slots))
    flat[..., :3 * nodes] = images.reshape(height, width, -1)
    texels = np.concatenate([flat[..., 4 * m:4 * m + 4] for m in range(sp.slots)], axis=1)
    weights = rng.uniform(0.0, 1.0, size=(nodes, levels + 1))
    sp.set_weights(weights)
    upload_texture(device, sp.cone_texture, texels.astype(np.float32))
    enc = device.create_command_encoder()
    record_dispatches(enc, sp.dispatches())
    device.queue.submit([enc.finish()])
    got = read_texture(device, sp.result, np.float32, 4)[..., :3]
    want = spread_nodes(images.astype(np.float32), weights)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5 * np.abs(want).max())
    with pytest.raises(AquaspecError, match="node weights"):
        sp.set_weights(weights[0])
