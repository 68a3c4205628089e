"""What detail costs a frame: ``aquaspec bench --detail``.

Issue 32 asks that a frame with textures, normal maps and particles take at
most 1.3 times the plain frame (1280x720, 8 bands). This bench times, in one
run, whole displayed frames of the built-in scene
(:meth:`aquaspec.rendering.renderer.Renderer.draw_frame`: geometry, shading,
display, submitted and waited for; what a live view draws):

- ``plain``: the classic built-in scene, no particles (the display fused
  into the shading pass);
- ``particles``: the same with marine snow (:mod:`aquaspec.rendering.marine_snow`;
  the particles drifting 1/30 s per frame, so their positions, light and
  discs are redone every frame as in a live view: lit by the light field
  alone, on the GPU, :mod:`aquaspec.gpu.passes.snow_field`; the splat after
  the geometry, composed by the light field's shading pass in its fused
  display, :meth:`aquaspec.gpu.passes.lightfield.LightfieldPass.set_snow`);
- ``detailed`` / ``detailed_particles``: a detailed scene's frames, without
  and with the particles, when given (a callable making ``(scene, camera)``;
  ``bench --detail`` gives :func:`detailed_builtin`, the textured,
  normal-mapped built-in scene).

The frames are alternated, their wall-clock medians compared (the machine
may be shared: compare ratios from one run). The host's path of the
particles (positions, light and discs in NumPy, what a frame with the sun
or lamps computes) is timed alone beside (``particles_host_ms``).
"""

from __future__ import annotations

import time

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.light.sky import surface_light
from aquaspec.medium.water import get_water
from aquaspec.rendering.marine_snow import frame_splats, particle_light
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene
from aquaspec.scene.particles import parse_marine_snow

#: The marine snow the bench draws by default: 200 particles per m^3 within 4 m.
DEFAULT_SNOW = "200,1"
#: Seconds of drift between the particles' frames (a 30 fps view).
FRAME_DT_S = 1.0 / 30.0


def run_detail_bench(*, width: int = 1280, height: int = 720, n_bands: int = 8,
                     frames: int = 20, warmup: int = 3, water="IB", depth_m: float = 5.0,
                     light: str = "overcast", marine_snow=DEFAULT_SNOW, detailed_scene=None,
                     progress=None) -> dict:
    """Time the frames of the module docstring; returns a JSON-ready dict with
    each frame's median ``*_ms`` and its ``*_ratio`` to ``plain``.
    ``detailed_scene``: None, or a function ``(depth_m, width, height) -> (scene, camera)``."""
    say = progress or (lambda m: None)
    snow = parse_marine_snow(marine_snow)
    scene, camera = builtin_scene(depth_m, width=width, height=height, variant="classic")
    scenes = {"plain": scene}
    if detailed_scene is not None:
        scenes["detailed"] = detailed_scene(depth_m, width, height)[0]
    setup = SpectralSetup(get_water(water), get_sensor("human"), surface_light(light),
                          Bands(n_bands))
    r = Renderer(width, height, n_bands)
    say(f"detail bench: {width}x{height}, {n_bands} bands, marine snow {snow.density_per_m3:g} "
        f"per m^3 ({snow.count} particles in the cube)")
    r.auto_display(scene, camera, setup)
    frames_of = {}
    for name, sc in scenes.items():
        frames_of[name] = (sc, False)
        frames_of[f"{name}_particles" if name != "plain" else "particles"] = (sc, True)
    times = {k: [] for k in frames_of}
    t_snow = 0.0
    for f in range(warmup + frames):
        t_snow += FRAME_DT_S
        for name, (sc, with_snow) in frames_of.items():
            r.set_marine_snow(snow if with_snow else None, t_snow)
            t0 = time.perf_counter()
            r.draw_frame(sc, camera, setup)
            if f >= warmup:
                times[name].append(1e3 * (time.perf_counter() - t0))
    passes = {k: _passes_ms(r, sc, camera, setup, snow if with_snow else None, t_snow,
                            max(3, frames // 4)) for k, (sc, with_snow) in frames_of.items()}
    r.set_marine_snow(snow, t_snow)
    r.draw_frame(scene, camera, setup)
    drawn = r.snow.drawn
    host = []
    light_of = particle_light(setup, camera, snow)
    for f in range(max(3, frames // 2)):
        t0 = time.perf_counter()
        frame_splats(snow, light_of, camera, f * FRAME_DT_S)
        host.append(1e3 * (time.perf_counter() - t0))
    ms = {k: float(np.median(v)) for k, v in times.items()}
    row = {"width": width, "height": height, "bands": n_bands, "frames": frames,
           "marine_snow": snow.describe(), "particles_drawn": int(drawn),
           "detailed_scene": detailed_scene is not None,
           **{f"{k}_ms": v for k, v in ms.items()},
           **{f"{k}_ratio": v / ms["plain"] for k, v in ms.items() if k != "plain"},
           "particles_host_ms": float(np.median(host)), "passes_ms": passes,
           "timing": "wall clock around submit + wait, whole frames alternated, medians"}
    say(format_detail(row))
    return row


def _passes_ms(r: Renderer, scene, camera, setup, snow, time_s, frames: int) -> dict:
    """Median milliseconds of each pass of a frame (each submitted and waited for
    alone: their sum exceeds the whole frame's time)."""
    out = {}
    dev = r.deferred.device
    for _ in range(frames):
        r.set_marine_snow(snow, time_s)
        stamp = [time.perf_counter()]

        def split(name, encoder):
            dev.queue.submit([encoder.finish()])
            r.wait()
            now = time.perf_counter()
            out.setdefault(name, []).append(1e3 * (now - stamp[0]))
            stamp[0] = now
            return dev.create_command_encoder()

        r.draw_frame(scene, camera, setup, split=split)
    return {k: float(np.median(v)) for k, v in out.items()}


def detailed_builtin(depth_m: float, width: int, height: int):
    """The detailed built-in scene (textures, normal maps; issue 32 items 1-2) and its camera."""
    return builtin_scene(depth_m, width=width, height=height, variant="detailed")


def format_detail(row: dict) -> str:
    """A bench result in words."""
    parts = [f"{k[:-6]} {row[k[:-6] + '_ms']:.1f} ms ({row[k]:.2f}x)"
             for k in row if k.endswith("_ratio")]
    return (f"{row['width']}x{row['height']} n={row['bands']}: plain frame "
            f"{row['plain_ms']:.1f} ms; " + "; ".join(parts)
            + f"; {row['particles_drawn']} particles drawn, their host path (with a sun "
            f"or lamps) {row['particles_host_ms']:.1f} ms"
            + ("" if row["detailed_scene"] else " (no detailed scene timed)")
            + "; passes (ms, each waited for): " + "; ".join(
                f"{frame}: " + ", ".join(f"{k} {v:.0f}" for k, v in p.items())
                for frame, p in row["passes_ms"].items()))
