"""GPU display pass (aquaspec.gpu.passes.display) against the NumPy reference."""

import numpy as np
import pytest

from aquaspec.colour import display
from aquaspec.errors import AquaspecError

pytestmark = pytest.mark.gpu

H, W = 48, 64


def _scene(seed=0):
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:H, 0:W]
    base = np.array([0.004, 0.05, 0.08])
    img = base * (0.2 + x[..., None] / W) * (0.5 + y[..., None] / H)
    img *= rng.uniform(0.7, 1.3, size=(H, W, 3))
    img[:4, :6] = [3.0, 5.0, 6.0]              # bright Snell's window
    img[20:26, 30:38] = [0.002, 0.03, 0.04]    # a grey-ish card at depth
    img[-1, -1] = 0.0
    return img


@pytest.fixture(scope="module")
def dpass(device):
    from aquaspec.gpu.passes.display import DisplayPass
    return DisplayPass(W, H, device=device)


def _compare(gpu, ref):
    # float32 on the GPU vs float64: codes may differ by one at rounding ties.
    diff = np.abs(gpu.astype(int) - ref.astype(int))
    assert diff.max() <= 1
    assert np.mean(diff == 0) > 0.99


def test_tonemap_ids_cover_the_reference_registry():
    from aquaspec.gpu.passes.display import TONEMAP_IDS
    assert set(TONEMAP_IDS) == set(display.TONEMAPS)


@pytest.mark.parametrize("tonemap", ["none", "filmic", "hable", "reinhard"])
def test_matches_numpy_reference(dpass, tonemap):
    img = _scene()
    ref, info = display.to_display(img, tonemap=tonemap)
    settings = dpass.set_from_image(img, tonemap=tonemap)
    assert settings["exposure_ev"] == info["exposure_ev"]
    dpass.upload(img)
    dpass.run()
    _compare(dpass.read(), ref)


def test_white_balance_matrix_and_manual_exposure(dpass):
    img = _scene(1)
    m = [[1.6, -0.4, -0.2], [-0.2, 1.4, -0.2], [0.0, -0.3, 1.3]]
    kw = dict(exposure=4.5, white_balance="white-patch", reference_rgb=[0.002, 0.03, 0.04],
              matrix=m)
    ref, _ = display.to_display(img, tonemap="filmic", **kw)
    dpass.set_from_image(img, tonemap="filmic", **kw)
    dpass.upload(img)
    dpass.run()
    out = dpass.read()
    _compare(out, ref)
    patch = out[21:25, 31:37].astype(int)          # the reference card comes out grey
    assert np.all(patch.max(axis=-1) - patch.min(axis=-1) <= 1)


def test_reads_a_gpu_buffer_directly(device):
    from aquaspec.gpu.buffers import create_storage_buffer
    from aquaspec.gpu.passes.display import DisplayPass
    img = _scene(2)
    rgba = np.zeros((H, W, 4), np.float32)
    rgba[..., :3] = img
    p = DisplayPass(W, H, device=device)
    p.use_input(create_storage_buffer(device, rgba))
    p.set_settings(exposure_ev=3.0, tonemap="reinhard")
    p.run()
    ref, _ = display.to_display(img, exposure=3.0, tonemap="reinhard")
    _compare(p.read(), ref)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_non_finite_input_is_refused(dpass, bad):
    img = _scene()
    img[7, 9, 2] = bad
    img[30, 1, 0] = bad
    dpass.set_settings(exposure_ev=0.0)
    dpass.upload(img)
    dpass.run()
    with pytest.raises(AquaspecError, match=r"2 pixel\(s\).*row 7, column 9"):
        dpass.read()
    # The status is reset by the next run.
    dpass.upload(_scene())
    dpass.run()
    assert dpass.read().shape == (H, W, 3)


def test_bad_settings(dpass):
    with pytest.raises(AquaspecError, match="'aces'"):
        dpass.set_settings(exposure_ev=0.0, tonemap="aces")
    with pytest.raises(AquaspecError, match="EV"):
        dpass.set_settings(exposure_ev=float("nan"))
    with pytest.raises(AquaspecError, match="shape"):
        dpass.upload(np.zeros((H + 1, W, 3)))
