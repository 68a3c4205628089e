"""The water surface seen from below in a render: surface="flat" (the real
interface: Snell's window, the water mirrored outside it) against
"index-matched" (no interface, the validation's setting)."""

from __future__ import annotations

import numpy as np
import pytest

import aquaspec
from aquaspec.errors import AquaspecError
from aquaspec.medium.interface import snell_window_cos
from aquaspec.scene.camera import Camera
from aquaspec.colour.reflectance import Reflectance
from aquaspec.scene.mesh import Mesh, Scene

W, H = 96, 96


def _up_camera(depth_m=5.0):
    """Straight up from ``depth_m``, 120 degrees across: the window (97 degrees) fits."""
    p = np.array([0.0, -depth_m, 0.0])
    return Camera.look_at(p, p + [0.0, 1.0, 0.0], width=W, height=H, fov_y_deg=120.0,
                          up=(0.0, 0.0, -1.0))


def _open_water(cam) -> Scene:
    """Nothing in view: one small grey square far below the camera."""
    y = cam.position[1] - 20.0
    quad = Mesh(np.array([[-1.0, y, -1.0], [1.0, y, -1.0], [1.0, y, 1.0], [-1.0, y, 1.0]]),
                np.array([[0, 2, 1], [0, 3, 2]]), np.tile([0.0, 1.0, 0.0], (4, 1)), 0)
    return Scene(meshes=[quad], materials=[Reflectance.constant(0.2)], camera=cam)


def _render(surface, backend):
    cam = _up_camera()
    res = aquaspec.render(water="IB", depth_m=5.0, bands=6, scene=_open_water(cam),
                          camera=cam, surface=surface, backend=backend, size=(W, H))
    v_y = cam.ray_directions()[..., 1]
    return res.linear_rgb.sum(axis=-1), v_y, res


@pytest.mark.gpu
def test_snells_window_from_below():
    """Looking up in open water at 5 m: with the flat surface the sky is inside
    the window (v_y above cos 48.8 deg) and the water, mirrored, much dimmer
    outside it; the index-matched surface shows no edge. The GPU and the NumPy
    reference agree on both; the sidecar names the surface."""
    edge = snell_window_cos()
    ratios = {}
    for surface in ("flat", "index-matched"):
        gpu, v_y, res = _render(surface, "gpu")
        ref, _, _ = _render(surface, "numpy")
        np.testing.assert_allclose(gpu, ref, rtol=2e-2)
        inside = gpu[(v_y > edge + 0.03) & (v_y < edge + 0.08)].mean()
        outside = gpu[(v_y < edge - 0.03) & (v_y > edge - 0.08)].mean()
        ratios[surface] = inside / outside
        assert res.params["surface"] == surface
    assert ratios["flat"] > 3.0
    assert ratios["index-matched"] < 1.3


def test_an_unknown_surface_is_refused():
    with pytest.raises(AquaspecError, match="surface 'wavy'; accepted: index-matched, flat"):
        aquaspec.render(surface="wavy", size=(16, 16), backend="numpy")


def test_the_flat_surface_needs_the_light_field():
    """The seeds' model has no top boundary to change: refused, not ignored."""
    with pytest.raises(AquaspecError, match="surface 'flat' is the light field's top"):
        aquaspec.render(surface="flat", ms_model="monzon2022", size=(16, 16), backend="numpy")

