"""What the sea surface costs a frame: ``aquaspec bench --surface``.

Frames of the same size and band count, timed in the same run, alternated,
each a whole displayed frame submitted at once and waited for (the wall
clock: a software adapter's timestamps do not bracket a pass's work):

- ``below``: the built-in scene under the index-matched surface, geometry +
  shading with the display fused (:meth:`aquaspec.rendering.renderer.Renderer.draw_frame`);
- ``below_flat``: the same view under the flat surface (its light field:
  Snell's window, the water mirrored outside it);
- ``looking_up_flat``: the built-in scene's camera turned 60 degrees up, under
  the flat surface (the window in view);
- ``waterline``: the half-and-half view, a camera on the surface looking 8
  degrees down: the water's half rendered from depth 0, the sky over the
  rays going up (:mod:`aquaspec.rendering.live_surface`'s sky pass, the
  display after it);
- ``above``: a camera 5 m above the sea looking 30 degrees down
  (:class:`aquaspec.gpu.passes.above.AbovePass`) + the display pass; the
  light field's table below the surface is uploaded once, as the medium is;
- ``above_sun_waves``: the same camera with the sun (SPECTRL2, 35 degrees,
  ahead) over a 6 m/s wind sea: the beam's scattering table, each ray
  through its wave facet, the glitter;
- ``below_sun``: the ``looking_up_flat`` view under that sun over the flat
  sea, as a live view draws it: the sun's disc through the surface
  (:mod:`aquaspec.rendering.live_surface`) added between the shading and
  the display transform; ``below_sun_plain``: the same without it;
- ``below_sun_waves``: the ``looking_up_flat`` view under that sun and sea
  as a live view draws it (:meth:`~aquaspec.rendering.renderer.Renderer.encode_frame`),
  the waves moving 1/30 s a frame: the caustics mixed from their loop (of
  :data:`LOOP_FRAMES` frames: the mix costs what the view's 48-frame loop's
  does, and the loop is built in seconds), the shading, the surface seen
  from below (:mod:`aquaspec.rendering.live_surface`: Snell's window through
  the moving facets, the sun's disc; the facets made for each frame's time
  and uploaded), the display transform after it;
- ``below_sun_waves_plain``: the same frames without the surface seen from
  below (``Renderer.surface_from_below = False``: the flat surface's light
  field only, the display fused into the shading, as live frames were before).

Each is reported with its ratio to ``below``. The machine may be shared:
compare ratios from one run.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.display import display_settings
from aquaspec.colour.sensors import get_sensor
from aquaspec.gpu.device import adapter_info
from aquaspec.gpu.passes.above import AbovePass
from aquaspec.gpu.passes.display import DisplayPass
from aquaspec.light.sky import surface_light
from aquaspec.light.wave_facets import surface_facets
from aquaspec.light.waves import Waves
from aquaspec.medium.water import get_water
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.camera import Camera, camera_above

#: The frames compared (module docstring), in the order they are run.
FRAMES = ("below", "below_flat", "looking_up_flat", "waterline", "above", "above_sun_waves",
          "below_sun", "below_sun_plain", "below_sun_waves", "below_sun_waves_plain")
#: Frames of the caustics' loop under the live frames with waves.
LOOP_FRAMES = 2
#: Wave seconds per frame of the live frames with waves.
WAVE_STEP_S = 1.0 / 30.0


def _tilted_up(camera: Camera, degrees: float) -> Camera:
    """``camera`` turned ``degrees`` up about its right axis."""
    a = np.radians(degrees)
    f = np.asarray(camera.forward) * np.cos(a) + np.asarray(camera.true_up) * np.sin(a)
    p = np.asarray(camera.position, dtype=float)
    return Camera.look_at(p, p + f, width=camera.width, height=camera.height,
                          fov_y_deg=float(np.degrees(2 * np.arctan(camera.height / 2
                                                                   / camera.fy))))


def _above_frame(below: Renderer, camera, setup, **extra):
    """A whole displayed frame of the view from above (:class:`AbovePass` +
    its display pass, settings from its first frame) on ``below``'s device, as
    a function that draws one and waits."""
    device = below.deferred.device
    above = AbovePass(device, camera.width, camera.height)
    med = setup.medium([])
    above.set_medium(setup.lightfield_tables(), a=med["a"], b=med["b"], e0=med["e0"],
                     response_weights=med["response_weights"], **extra)
    show = DisplayPass(camera.width, camera.height, device=device)
    s = display_settings(above.render(camera))
    show.set_settings(exposure_ev=s["exposure_ev"], white_balance_gains=s["white_balance_gains"],
                      matrix=s["matrix"])
    show.use_input(above.rgb_buffer)

    def draw():
        enc = device.create_command_encoder()
        above.encode(enc, camera)
        show.encode(enc)
        device.queue.submit([enc.finish()])
        below.wait()
    return draw


def _live_waves_frame(scene, camera, setup, *, plain: bool):
    """A live frame of ``camera`` under ``setup``'s sun and moving sea, if it
    has one (``plain``: without the surface seen from below), as a function
    that draws the next one (the waves :data:`WAVE_STEP_S` on) and waits."""
    r = Renderer(camera.width, camera.height, setup.bands.n)
    r.surface_from_below = not plain
    clock = {"t": 0.0}
    r.set_wave_time(0.0, frames=LOOP_FRAMES)
    r.auto_display(scene, camera, setup)

    def draw():
        clock["t"] += WAVE_STEP_S
        r.set_wave_time(clock["t"], frames=LOOP_FRAMES)
        r.draw_frame(scene, camera, setup)
    return draw


def run_surface_bench(*, width: int = 1280, height: int = 720, n_bands: int = 8,
                      frames: int = 12, warmup: int = 3, water="IB", depth_m: float = 5.0,
                      progress=None) -> dict:
    """Median wall time of each frame of :data:`FRAMES` and its ratio to ``below``."""
    say = progress or (lambda m: None)
    bands = Bands(n_bands)
    w = get_water(water)
    sensor, light = get_sensor("human"), surface_light("overcast")
    setups = {s: SpectralSetup(w, sensor, light, bands, surface=s)
              for s in ("index-matched", "flat")}
    scene, cam = builtin_scene(depth_m, width=width, height=height)
    up = _tilted_up(cam, 60.0)
    waterline = camera_above(0.0, 8.0, width=width, height=height)
    say(f"bench --surface: {width}x{height}, {n_bands} bands: compiling and first frames")
    # One renderer per frame: a renderer rebuilds its water table when the
    # camera's depth changes, which alternating views would make it do every frame.
    views = {"below": (cam, "index-matched"), "below_flat": (cam, "flat"),
             "looking_up_flat": (up, "flat"), "waterline": (waterline, "flat")}
    renderers = {}
    for name, (view, surface) in views.items():
        renderers[name] = Renderer(width, height, n_bands)
        renderers[name].auto_display(scene, view, setups[surface])
    below = renderers["below"]
    above_cam = camera_above(5.0, 30.0, width=width, height=height)
    sunny = SpectralSetup(w, sensor, surface_light("sun-sky", sun_elevation_deg=35.0,
                                                   sun_azimuth_deg=0.0), bands, surface="flat")
    draw_above = _above_frame(below, above_cam, setups["flat"])
    draw_above_sun = _above_frame(below, above_cam, sunny, sun=sunny.sun_inputs(),
                                  facets=surface_facets(Waves(6.0)))
    run = {name: (lambda r=renderers[name], v=view, s=setups[surface]:
                  r.draw_frame(scene, v, s)) for name, (view, surface) in views.items()}
    run["above"] = draw_above
    run["above_sun_waves"] = draw_above_sun
    sea = dataclasses.replace(sunny, waves=Waves(6.0))
    say("the caustic loop of a 6 m/s sea under the sun (seconds the first time, then cached)")
    for name in ("below_sun", "below_sun_plain", "below_sun_waves", "below_sun_waves_plain"):
        run[name] = _live_waves_frame(scene, up, sea if "waves" in name else sunny,
                                      plain=name.endswith("plain"))
    times = {k: [] for k in FRAMES}
    for i in range(warmup + frames):
        for name in FRAMES:
            t0 = time.perf_counter()
            run[name]()
            if i >= warmup:
                times[name].append(1e3 * (time.perf_counter() - t0))
    ms = {k: float(np.median(v)) for k, v in times.items()}
    return {"size": [width, height], "bands": n_bands, "water": w.name, "depth_m": depth_m,
            "frames": frames, "frame_wall_ms": ms,
            "ratio_to_below": {k: ms[k] / ms["below"] for k in FRAMES},
            "surface_from_below_ratio": {
                "sun": ms["below_sun"] / ms["below_sun_plain"],
                "sun_waves": ms["below_sun_waves"] / ms["below_sun_waves_plain"]},
            "adapter": adapter_info()}


def format_surface(result: dict) -> str:
    """The result as lines of text: each frame's median and its ratio."""
    w, h = result["size"]
    lines = [f"surface frames at {w}x{h}, {result['bands']} bands, Jerlov {result['water']} "
             f"(median wall ms over {result['frames']} frames; ratio to 'below'):"]
    for k in FRAMES:
        lines.append(f"  {k:21s} {result['frame_wall_ms'][k]:8.1f} ms   "
                     f"{result['ratio_to_below'][k]:.2f}")
    r = result["surface_from_below_ratio"]
    lines.append("  the surface seen from below in the live frame, over the frame without it: "
                 f"the sun's disc {r['sun']:.2f}, with waves {r['sun_waves']:.2f}")
    return "\n".join(lines)
