"""Frames of a live view: a camera that moves every frame through a fixed scene
(Renderer.encode_frame, render_scene in sequence) against per-camera renders."""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest

from aquaspec.apps.motion import camera_path
from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import load_water
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.camera import camera_depth

pytestmark = pytest.mark.gpu

W, H, N = 96, 54, 5


@pytest.fixture(scope="module")
def scene_and_path():
    scene, cam = builtin_scene(5.0, width=W, height=H)
    return scene, camera_path(cam, 6)


def setup_for(scene, water="IB", light="overcast", **kw):
    return SpectralSetup(load_water(water), get_sensor("human"), surface_light(light), Bands(N),
                         ms_model="lightfield", seabed=scene.seabed, **kw)


@pytest.mark.parametrize("light", ["overcast", "sun-sky"])
def test_moving_camera_equals_a_render_per_camera(light, scene_and_path):
    """One renderer following the path (its light-field water table rebuilt for
    each camera depth) gives each frame exactly as a renderer made for that
    camera alone (whose compile the light-field pass tests hold against the
    NumPy twin)."""
    scene, path = scene_and_path
    setup = setup_for(scene, light=light)
    moving = Renderer(W, H, N)
    depths = []
    for cam in path[:4]:
        got = moving.render_scene(scene, cam, setup)
        depths.append(moving.lightfield.water.key[0])
        ref = Renderer(W, H, N).render_scene(scene, cam, setup)
        scale = np.abs(ref).max()
        np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-7 * scale)
    assert depths == pytest.approx([camera_depth(c) for c in path[:4]])
    # The path moves by metres: the frames really differ.
    assert max(abs(np.diff(depths))) > 0.5


@pytest.mark.parametrize("model,light", [("lightfield", "overcast"),
                                         ("lightfield", "sun-sky"), ("seeds", "sun-sky")])
def test_encode_frame_is_the_displayed_render(model, light, scene_and_path):
    """encode_frame's 8-bit image (through draw_frame) is render_scene's linear
    image through the display transform with the same settings (within one
    step): the display fused into the shading, or (the seeds' model with the
    sun) a display pass after it."""
    from aquaspec.gpu.passes.display import DisplayPass
    scene, path = scene_and_path
    setup = setup_for(scene, light=light)
    if model == "seeds":
        setup = SpectralSetup(setup.water, setup.sensor, setup.light, setup.bands,
                              ms_model="seeds")
    r = Renderer(W, H, N)
    settings = r.auto_display(scene, path[0], setup)
    for cam in path[1:3]:
        r.draw_frame(scene, cam, setup)
        shown = r.read_display()
        lin = Renderer(W, H, N).render_scene(scene, cam, setup)
        disp = DisplayPass(W, H, device=r.deferred.device)
        disp.set_settings(exposure_ev=settings["exposure_ev"],
                          white_balance_gains=settings["white_balance_gains"],
                          matrix=settings["matrix"], tonemap=settings["tonemap"])
        disp.upload(lin)
        disp.run()
        diff = np.abs(shown.astype(int) - disp.read().astype(int))
        assert diff.max() <= 1


def test_encode_frame_needs_display_settings(scene_and_path):
    scene, path = scene_and_path
    r = Renderer(W, H, N)
    enc = r.deferred.device.create_command_encoder()
    with pytest.raises(AquaspecError, match="display settings"):
        r.encode_frame(enc, scene, path[0], setup_for(scene))
    with pytest.raises(AquaspecError, match="no frame yet"):
        r.read_display()


def test_a_new_setup_is_uploaded_even_at_a_reused_address(scene_and_path):
    """The renderer keeps the setup it uploaded alive, so that no new setup can
    take its id() (it once compared ids only: a setup made after the previous
    one was freed could get its address and not be uploaded); and switching
    setups back and forth gives each one's image."""
    scene, path = scene_and_path
    r = Renderer(W, H, N)
    s = setup_for(scene, "IB")
    alive = weakref.ref(s)
    first = r.render_scene(scene, path[0], s)
    del s
    gc.collect()
    assert alive() is not None
    for water in ("3C", "IB", "3C"):
        s = setup_for(scene, water)
        got = r.render_scene(scene, path[0], s)
        ref = Renderer(W, H, N).render_scene(scene, path[0], s)
        np.testing.assert_allclose(got, ref, rtol=1e-5, atol=1e-7 * np.abs(ref).max())
        del s
        gc.collect()
    assert not np.allclose(got, first, rtol=0.05)


def _displayed(device, settings, linear):
    from aquaspec.gpu.passes.display import DisplayPass
    disp = DisplayPass(W, H, device=device)
    disp.set_settings(exposure_ev=settings["exposure_ev"],
                      white_balance_gains=settings["white_balance_gains"],
                      matrix=settings["matrix"], tonemap=settings["tonemap"])
    disp.upload(linear)
    disp.run()
    return disp.read().astype(int)


def test_a_gbuffer_seen_from_a_moved_camera(scene_and_path):
    """A G-buffer made elsewhere (here ray cast in NumPy; an RGB-D photograph in
    the live view) as a frame's source: uploaded once, then shown from its
    camera moved 1.5 m deeper, its frame is render_gbuffer's image of the
    G-buffer with that camera through the display transform; a scene frame in
    between does not leave stale textures; a turned camera is refused."""
    import dataclasses
    from aquaspec.scene.raycast import raycast_gbuffer
    scene, path = scene_and_path
    gb = raycast_gbuffer(scene, path[0])
    setup = setup_for(scene)
    r = Renderer(W, H, N)
    settings = r.auto_display(gb, gb.camera, setup)
    deeper = dataclasses.replace(gb.camera, position=gb.camera.position - [0.0, 1.5, 0.0])
    shown = []
    for cam in (gb.camera, deeper):
        r.draw_frame(gb, cam, setup)
        shown.append(r.read_display().astype(int))
        lin = Renderer(W, H, N).render_gbuffer(dataclasses.replace(gb, camera=cam), setup)
        assert np.abs(shown[-1] - _displayed(r.deferred.device, settings, lin)).max() <= 1
    # Deeper in Jerlov IB the frame is darker and bluer: the move is seen.
    assert shown[1].mean() < shown[0].mean() - 2
    r.draw_frame(scene, path[2], setup)
    r.draw_frame(gb, deeper, setup)
    assert np.abs(r.read_display().astype(int) - shown[1]).max() <= 1
    turned = dataclasses.replace(gb.camera, forward=path[2].forward)
    enc = r.deferred.device.create_command_encoder()
    with pytest.raises(AquaspecError, match="its own rays"):
        r.encode_frame(enc, gb, turned, setup)
