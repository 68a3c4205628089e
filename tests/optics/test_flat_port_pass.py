"""The GPU flat port pass against its NumPy twin (aquaspec.optics.remap.port_image).

A smooth analytic image and a tilted plane's G-buffer (the depth lookup and
its iteration exercised), open water, and no G-buffer (the central mapping); float32 on
the GPU against float64: the coordinates agree to about 1e-4 pixel, so the
images agree to the image's gradient times that.
"""

from __future__ import annotations

import numpy as np
import pytest

from aquaspec.optics.presets import CAMERA_MODELS
from aquaspec.colour.reflectance import Reflectance
from aquaspec.optics.remap import Intrinsics, axial_depth, port_image, water_intrinsics
from aquaspec.scene.camera import Camera
from aquaspec.scene.gbuffer import GBuffer

pytestmark = pytest.mark.gpu

W, H = 320, 180
F = 90.0 / np.tan(np.radians(30.0))
SENSOR = Intrinsics(W, H, F, F, W / 2, H / 2)
PORT = CAMERA_MODELS["dslr-flat-port"].port
WAVELENGTHS = (600.0, 530.0, 470.0)
#: float32 against float64 on an image whose values change by at most ~0.05 per
#: pixel (measured: 9e-7 at most, 2026-11-28).
TOL = 1e-5


def _scene(water):
    """An image, and the ray distances of a plane tilted up and away (1 m at
    the bottom, 4 m near the top) as a G-buffer of the render in water."""
    tx, ty = water.tangents()
    img = np.stack([0.5 + 0.4 * np.sin(9 * tx + 2 * ty), 0.5 + 0.4 * np.cos(7 * ty - 3 * tx),
                    0.5 + 0.3 * np.sin(5 * (tx + ty))], axis=-1)
    dist = 1.0 / np.maximum(0.05, 0.3 + 0.6 * ty) * np.sqrt(1 + tx ** 2 + ty ** 2)
    return img, dist


def _gbuffer(device, water, dist):
    from aquaspec.gpu.gbuffer import GBufferTextures
    cam = Camera([0.0, -5.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], water.width,
                 water.height, water.fx, water.fy, water.cx, water.cy)
    h, w = dist.shape
    gb = GBuffer(cam, dist, np.zeros((h, w, 3)), np.zeros((h, w), np.uint32),
                 np.zeros((h, w, 3)), [Reflectance("grey", np.array([400.0, 700.0]),
                                                   np.array([0.5, 0.5]))])
    tex = GBufferTextures(device, w, h)
    tex.upload(gb)
    return tex


@pytest.mark.parametrize("with_depth", [True, False])
def test_gpu_port_image_matches_numpy(device, with_depth):
    from aquaspec.gpu.passes.flat_port import FlatPortPass
    water = water_intrinsics(SENSOR, PORT, WAVELENGTHS, 0.3)
    img, dist = _scene(water)
    if not with_depth:
        dist = np.full(dist.shape, np.inf)
    p = FlatPortPass(SENSOR, water, device=device)
    p.set_port(PORT, WAVELENGTHS)
    p.upload(img)
    p.use_gbuffer(_gbuffer(device, water, dist))
    p.run()
    gpu = p.read()
    z = axial_depth(dist, water)
    rho = np.hypot(*SENSOR.tangents())[..., None]
    ref = (port_image(img, WAVELENGTHS, PORT, SENSOR, water, z)
           * PORT.radiance_factor(rho, WAVELENGTHS))
    diff = np.abs(gpu - ref)
    # A nearest-pixel depth lookup may fall on the other side of a rounding
    # tie in float32: allow a handful of such pixels, none elsewhere.
    assert np.mean(diff > TOL) < 2e-3, np.sort(diff.ravel())[-10:]
    assert np.percentile(diff, 99.9) < TOL
    # The port does move the image, and the depth matters (by up to 0.03 here).
    assert np.abs(ref / PORT.radiance_factor(rho, WAVELENGTHS) - img).max() > 0.1
    if with_depth:
        central = (port_image(img, WAVELENGTHS, PORT, SENSOR, water, None)
                   * PORT.radiance_factor(rho, WAVELENGTHS))
        assert np.abs(ref - central).max() > 100 * TOL
        p.use_gbuffer(None)                     # no G-buffer: the central mapping
        p.run()
        np.testing.assert_allclose(p.read(), central, atol=TOL)
