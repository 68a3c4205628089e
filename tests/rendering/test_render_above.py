"""render() and `aquaspec render` with the camera above the sea (issue 30)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import aquaspec
from aquaspec.cli import main
from aquaspec.errors import AquaspecError
from aquaspec.scene.camera import camera_above
from aquaspec.scene.seabed import Seabed

W, H = 24, 16


def test_render_from_above_is_the_sea_from_above_model():
    """The image is sea_from_above's radiance on the setup's flat-surface
    tables with the scene's meshes seen through the surface (water_to_hits:
    the built-in scene's rocks, chart and sand), the surface is made flat,
    and the metadata say what is not drawn."""
    from aquaspec.rendering.setup import SpectralSetup
    from aquaspec.scene.builtin import scene_for_render
    from aquaspec.shading.above_meshes import water_to_hits
    from aquaspec.shading.above_water import sea_from_above
    cam = camera_above(4.0, 40.0, width=W, height=H)
    res = aquaspec.render(water="II", camera=cam, size=(W, H), bands=4, backend="numpy",
                          seabed=Seabed(6.0, 0.3), return_radiance=True)
    assert res.params["surface"] == "flat"
    above = res.params["above_water"]
    assert above["height_m"] == 4.0 and any("above the water" in x for x in above["not_drawn"])
    assert "ray cast" in above["meshes"]
    setup = res.params  # the setup is rebuilt below from the same inputs
    from aquaspec.colour.bands import Bands
    from aquaspec.colour.sensors import get_sensor
    from aquaspec.light.sky import surface_light
    from aquaspec.medium.water import get_water
    s = SpectralSetup(get_water("II"), get_sensor("human"), surface_light("overcast"),
                      Bands(4), surface="flat", seabed=Seabed(6.0, 0.3))
    scene, _ = scene_for_render(None, 5.0, W, H, None, None)
    med = s.medium(scene.materials)
    tables = s.lightfield_tables()
    under = water_to_hits(scene, cam, tables, a=med["a"], b=med["b"], e0=med["e0"],
                          material_bands=med["material_bands"],
                          sigmoid_centers_t=med["sigmoid_centers_t"])
    assert under[0].sum() > 10
    expect = sea_from_above(cam, tables, a=med["a"], b=med["b"], e0=med["e0"], under=under)
    np.testing.assert_allclose(res.radiance, expect, rtol=1e-6)
    assert setup["seabed"]["depth_m"] == 6.0


def test_looking_straight_down_sees_no_sky_but_its_reflection():
    cam = camera_above(10.0, 90.0, width=W, height=H)
    res = aquaspec.render(water="IB", camera=cam, size=(W, H), bands=4, backend="numpy")
    assert np.all(cam.ray_directions()[..., 1] < -0.7)
    assert np.all(np.isfinite(res.linear_rgb)) and np.all(res.linear_rgb[..., 2] > 0)


@pytest.mark.parametrize("kw,match", [
    ({"ms_model": "monzon2022"}, "surface .flat. is the light field.s top boundary"),
    ({"lamps": ["rov-pair"]}, "lamps"),
    ({"camera_model": "dslr-flat-port"}, "camera model's port looks into water"),
])
def test_what_from_above_refuses(kw, match, tmp_path):
    cam = camera_above(3.0, width=W, height=H)
    with pytest.raises(AquaspecError, match=match):
        aquaspec.render(camera=cam, size=(W, H), bands=4, backend="numpy", **kw)


def test_camera_above_checks_its_angles():
    with pytest.raises(AquaspecError, match="0 \\(at the waterline\\) to 10000 m"):
        camera_above(-0.5, width=W, height=H)
    with pytest.raises(AquaspecError, match="0 \\(level\\) to 90"):
        camera_above(2.0, -5.0, width=W, height=H)
    cam = camera_above(2.0, 30.0, width=W, height=H)
    assert cam.forward[1] == pytest.approx(-0.5)


def test_cli_camera_height(tmp_path, capsys):
    out = tmp_path / "above.png"
    assert main(["render", "--camera-height", "6", "--look-down", "45", "--size", f"{W}x{H}",
                 "--bands", "4", "--backend", "numpy", "--seabed", "4,0.3",
                 "-o", str(out)]) == 0
    meta = json.loads((tmp_path / "above.png.json").read_text())
    assert meta["above_water"]["height_m"] == 6.0
    assert meta["camera"]["position_m"][1] == 6.0
    assert main(["render", "--camera-height", "6", "--rgbd", "a.png", "b.png",
                 "--intrinsics", "1,1,1,1", "-o", str(out)]) == 2
    assert "--camera-height shows the sea from above" in capsys.readouterr().err


def test_a_camera_at_the_waterline_sees_sky_above_and_water_below():
    """Half-and-half: the camera's centre on the surface. Rays going up see
    the sky in air (the same as a camera above the sea sees above its
    horizon); rays going down see the water exactly as a camera a hair under
    the surface does under the flat surface."""
    cam = camera_above(0.0, 10.0, width=W, height=H, fov_y_deg=70.0)
    res = aquaspec.render(water="IB", camera=cam, size=(W, H), bands=4, backend="numpy")
    assert "waterline" in res.params and res.params["surface"] == "flat"
    up = cam.ray_directions()[..., 1] > 0
    assert up.any() and (~up).any()
    high = camera_above(2.0, 0.0, width=W, height=H, fov_y_deg=70.0)
    sky = aquaspec.render(water="IB", camera=high, size=(W, H), bands=4, backend="numpy")
    high_up = high.ray_directions()[..., 1] > 0
    np.testing.assert_allclose(res.linear_rgb[up][0], sky.linear_rgb[high_up][0], rtol=1e-9)
    import dataclasses
    under = dataclasses.replace(cam, position=np.array([0.0, -1e-5, 0.0]))
    water = aquaspec.render(water="IB", camera=under, size=(W, H), bands=4, backend="numpy",
                            surface="flat")
    np.testing.assert_allclose(res.linear_rgb[~up], water.linear_rgb[~up], rtol=2e-3)
    assert res.linear_rgb[up].sum(axis=-1).min() > 3 * res.linear_rgb[~up].sum(axis=-1).max()


def test_a_camera_at_the_waterline_that_sees_no_water_is_refused():
    """Half-and-half needs water in the view: a camera on the surface looking
    up is refused before any shading, naming what is accepted."""
    from aquaspec.scene.camera import Camera
    cam = Camera.look_at([0.0, 0.0, 0.0], [0.0, 1.0, -0.2], width=W, height=H, fov_y_deg=40.0)
    with pytest.raises(AquaspecError, match="at the waterline sees no water.*accepted: a view "
                                            "with rays below the horizon"):
        aquaspec.render(water="IB", camera=cam, size=(W, H), bands=4, backend="numpy")


def test_a_mesh_under_the_water_is_seen_from_above(tmp_path):
    """`--mesh` with `--camera-height`: the mesh, placed in front of the
    under-water camera, is ray cast through the surface (the metadata say so)."""
    obj = tmp_path / "box.obj"
    obj.write_text("v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\n"
                   "v 1 1 1\nv -1 1 1\nf 1 3 2\nf 1 4 3\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\n"
                   "f 4 7 3\nf 4 8 7\nf 1 5 8\nf 1 8 4\nf 2 3 7\nf 2 7 6\n")
    out = tmp_path / "above.png"
    assert main(["render", "--mesh", str(obj), "--camera-height", "2", "--look-down", "50",
                 "--depth", "3", "--size", f"{W}x{H}", "--bands", "4", "--backend", "numpy",
                 "-o", str(out)]) == 0
    meta = json.loads((tmp_path / "above.png.json").read_text())
    assert "ray cast" in meta["above_water"]["meshes"]


def test_layers_from_above_are_refused_naming_the_reason():
    cam = camera_above(3.0, 40.0, width=W, height=H)
    with pytest.raises(AquaspecError, match="layers .* are of a camera under water.*accepted: "
                                            "layers=False"):
        aquaspec.render(camera=cam, size=(W, H), bands=4, backend="numpy", layers=True)
