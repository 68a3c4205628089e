"""``aquaspec bench --motion``: frames of a moving camera against still frames.

A live view renders a camera that moves every frame, over a sea whose waves
move. This benchmark renders the built-in scene (built once, its seabed and
objects fixed) along a scripted camera path (:func:`camera_path`: the camera
bobs up and down by metres, turns and drifts; its depth changes by up to
:data:`MAX_DEPTH_STEP_M` per frame) with the waves advancing
``1 / FRAME_RATE_HZ`` seconds per frame, and, interleaved with it in the same
run, the same number of still frames (the first pose, the sea frozen). Each
frame is what a live view does (:meth:`aquaspec.rendering.renderer.Renderer.encode_frame`):
all the CPU work of the frame (uniforms, the light field's water table for
the camera's depth, the sun's shadow-map placement), the geometry, shading,
sun and display passes, submitted and waited for; nothing read back.

Reported (medians over the frames): the whole frame still and moving and
their ratio (the issue's line: moving / still <= 1.1), and the same frames
submitted pass by pass, which gives each pass's time still and moving. The
machine may be shared and noisy: the ratios come from one run with the two
kinds of frame interleaved, so load changes hit both alike.
"""

from __future__ import annotations

import dataclasses
import contextlib
import os
import tempfile
import time

import numpy as np

from aquaspec.cache import CACHE_ENV
from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.gpu.device import adapter_info
from aquaspec.light.caustics import DEFAULT_LOOP_FRAMES, caustic_loop
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG, surface_light
from aquaspec.medium.water import get_water
from aquaspec.rendering.api import as_waves
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import CAMERA_HEIGHT_M, builtin_scene
from aquaspec.scene.camera import Camera
from aquaspec.transport.models import DEFAULT_MS_MODEL, cone_spread_for, ms_model_name

#: Frames per second the waves' time advances by (s per frame = 1 / this).
FRAME_RATE_HZ = 30.0
#: The camera's up-and-down swing: its depth is ``d0 - A (1 - cos(2 pi i / P))``.
DEPTH_SWING_M = 1.75
DEPTH_PERIOD_FRAMES = 12
#: Largest change of depth between two frames of the path, m
#: (``A 2 sin(pi / P)``).
MAX_DEPTH_STEP_M = DEPTH_SWING_M * 2.0 * np.sin(np.pi / DEPTH_PERIOD_FRAMES)
#: Shallowest depth the path reaches, m.
MIN_PATH_DEPTH_M = 0.5
#: Water types switched to by :func:`switch_times` (the first is another type
#: than the bench's, the second the bench's own).
SWITCH_WATER = "II"
#: Band count switched to by :func:`switch_times`.
SWITCH_BANDS = 16
#: Change of the sun's elevation timed by :func:`switch_times`, degrees.
SWITCH_SUN_DEG = 10.0
#: Turns of the path: yaw and pitch swings (degrees) and their periods (frames).
YAW_SWING_DEG, YAW_PERIOD_FRAMES = 20.0, 40
PITCH_SWING_DEG, PITCH_PERIOD_FRAMES = 8.0, 28
#: Sideways and forward drift, m.
DRIFT_M = (0.4, 0.3)


def camera_path(camera: Camera, frames: int) -> list[Camera]:
    """The scripted path: ``frames`` cameras starting at ``camera``.

    Frame ``i`` rises to ``A (1 - cos(2 pi i / P))`` above the start
    (:data:`DEPTH_SWING_M`, :data:`DEPTH_PERIOD_FRAMES`; the swing shrinks so
    that the camera stays below :data:`MIN_PATH_DEPTH_M`), turns by up to
    :data:`YAW_SWING_DEG` and :data:`PITCH_SWING_DEG` and drifts by up to
    :data:`DRIFT_M` sideways and forward. The start depth must be at least
    :data:`MIN_PATH_DEPTH_M` plus a metre.
    """
    d0 = camera.depth_m
    if not d0 >= MIN_PATH_DEPTH_M + 1.0:
        raise AquaspecError(f"the motion path starts at the camera's depth {d0:g} m; "
                            f"accepted: at least {MIN_PATH_DEPTH_M + 1.0:g} m, so that it "
                            "can move up and down by metres")
    swing = min(DEPTH_SWING_M, (d0 - MIN_PATH_DEPTH_M) / 2.0)
    fwd0 = camera.forward
    yaw0 = np.arctan2(fwd0[0], -fwd0[2])
    pitch0 = np.arcsin(np.clip(fwd0[1], -1.0, 1.0))
    out = []
    for i in range(frames):
        rise = swing * (1.0 - np.cos(2.0 * np.pi * i / DEPTH_PERIOD_FRAMES))
        yaw = yaw0 + np.radians(YAW_SWING_DEG) * np.sin(2.0 * np.pi * i / YAW_PERIOD_FRAMES)
        pitch = pitch0 + np.radians(PITCH_SWING_DEG) * np.sin(
            2.0 * np.pi * i / PITCH_PERIOD_FRAMES)
        fwd = np.array([np.cos(pitch) * np.sin(yaw), np.sin(pitch), -np.cos(pitch) * np.cos(yaw)])
        drift = np.array([DRIFT_M[0] * np.sin(2.0 * np.pi * i / YAW_PERIOD_FRAMES), rise,
                          -DRIFT_M[1] * (1.0 - np.cos(2.0 * np.pi * i / PITCH_PERIOD_FRAMES))])
        out.append(Camera(camera.position + drift, fwd, camera.up, camera.width, camera.height,
                          camera.fx, camera.fy, camera.cx, camera.cy, camera.near, camera.far))
    return out


class _Timer:
    """Times one frame: whole (one submission) or pass by pass."""

    def __init__(self, renderer: Renderer, by_pass: bool):
        self.r, self.by_pass = renderer, by_pass
        self.dev = renderer.deferred.device
        self.parts: dict = {}

    def frame(self, scene, camera, setup) -> float:
        """Record, submit and wait for one frame; returns its wall time (ms)."""
        self.parts = {}
        t0 = self._last = time.perf_counter()
        self.r.draw_frame(scene, camera, setup, split=self._split if self.by_pass else None)
        return (time.perf_counter() - t0) * 1e3

    def _split(self, name, encoder):
        """Submit what ``encoder`` holds (the pass ``name``), wait, time it, and
        return a fresh encoder for the next pass."""
        self.dev.queue.submit([encoder.finish()])
        self.r.wait()
        now = time.perf_counter()
        self.parts[name] = self.parts.get(name, 0.0) + (now - self._last) * 1e3
        self._last = now
        return self.dev.create_command_encoder()


@contextlib.contextmanager
def _fresh_cache():
    """Point aquaspec's disk cache at an empty folder for the block."""
    old = os.environ.get(CACHE_ENV)
    with tempfile.TemporaryDirectory(prefix="aquaspec-bench-cache-") as tmp:
        os.environ[CACHE_ENV] = tmp
        try:
            yield
        finally:
            if old is None:
                os.environ.pop(CACHE_ENV, None)
            else:
                os.environ[CACHE_ENV] = old


def switch_times(renderer: Renderer, scene, camera, setup: SpectralSetup, settings: dict) -> dict:
    """Seconds from a change of water or band count to the first frame done.

    Each change makes a new :class:`~aquaspec.rendering.setup.SpectralSetup`
    (as a user's change does) and renders one displayed frame with it: the
    water :data:`SWITCH_WATER` with an empty disk cache (solved), the bench's
    own water, then :data:`SWITCH_WATER` again (from the disk cache); the
    band count :data:`SWITCH_BANDS` (a new renderer, solved), back to the
    bench's, and :data:`SWITCH_BANDS` again (its renderer kept, a new setup from
    the disk cache); with a sun, its elevation moved by :data:`SWITCH_SUN_DEG`
    (solved, then again from the cache).
    """
    def first_frame(r, s):
        t0 = time.perf_counter()
        if r is not renderer:
            r.set_spectral(s, scene.materials)
            r.set_display(settings)
        r.draw_frame(scene, camera, s)
        return time.perf_counter() - t0

    def new_setup(**change):
        kw = dict(water=setup.water, bands=setup.bands)
        kw.update(change)
        return dataclasses.replace(setup, **kw)

    other = get_water(SWITCH_WATER) if setup.water.name != SWITCH_WATER else get_water("IB")
    out = {"water": other.name}
    with _fresh_cache():
        out["new_water_s"] = first_frame(renderer, new_setup(water=other))
        first_frame(renderer, new_setup(water=setup.water))
        out["cached_water_s"] = first_frame(renderer, new_setup(water=other))
        bands = Bands(SWITCH_BANDS, setup.bands.lo_nm, setup.bands.hi_nm)
        w, h = renderer.width, renderer.height
        out["bands"] = SWITCH_BANDS
        # A live view keeps a renderer per band count it has shown (their
        # compiled passes), as it keeps setups: back to that count reuses it.
        other_r = Renderer(w, h, SWITCH_BANDS)
        out["new_bands_s"] = first_frame(other_r, new_setup(bands=bands))
        first_frame(renderer, setup)
        out["cached_bands_s"] = first_frame(other_r, new_setup(bands=bands))
        sun = setup.light.sun
        if sun is not None:
            # A new sun elevation: a new light field and (with waves) caustics.
            elevation = sun.elevation_deg + (SWITCH_SUN_DEG if sun.elevation_deg
                                             + SWITCH_SUN_DEG <= 90.0 else -SWITCH_SUN_DEG)
            light = surface_light("sun-sky", sun_elevation_deg=elevation,
                                  sun_azimuth_deg=sun.azimuth_deg)
            out["sun_elevation_deg"] = float(elevation)
            out["new_sun_s"] = first_frame(renderer, dataclasses.replace(setup, light=light))
            first_frame(renderer, setup)
            out["cached_sun_s"] = first_frame(renderer, dataclasses.replace(setup, light=light))
    first_frame(renderer, setup)     # leave the renderer as it was
    return out


def run_motion_bench(*, size=(1280, 720), bands: int = 8, frames: int = 36, warmup: int = 3,
                     water="IB", depth_m: float = 5.0, sensor="human", ms_model: str | None = None,
                     phase: str = "petzold", cone_spread: bool | None = None,
                     spread_scattering: str = "single", light: str = "overcast",
                     sun_elevation_deg: float = 60.0, sun_azimuth_deg: float | None = None,
                     sun_shadow_map: int | None = None, waves=None, progress=None) -> dict:
    """Time still and moving frames of the built-in scene in one run (module docstring).

    The parameters are those of :func:`aquaspec.apps.bench.run_bench` for one
    image ``size`` and one band count; ``depth_m`` is the path's start (and
    deepest) camera depth. Returns a JSON-ready dict.
    """
    say = progress or (lambda m: None)
    if frames < DEPTH_PERIOD_FRAMES:
        raise AquaspecError(f"--frames {frames} is too few for the motion path; accepted: at "
                            f"least {DEPTH_PERIOD_FRAMES} (one up-and-down swing)")
    width, height = size
    ms_model = ms_model_name(DEFAULT_MS_MODEL if ms_model is None else ms_model)
    light_obj = surface_light(light, sun_elevation_deg=sun_elevation_deg,
                              sun_azimuth_deg=DEFAULT_SUN_AZIMUTH_DEG if sun_azimuth_deg is None
                              else sun_azimuth_deg)
    waves = as_waves(waves)
    if waves is not None and light_obj.sun is None:
        raise AquaspecError(f"waves focus the sun's beam into caustics: they need "
                            f"light='sun-sky', not {light!r}")
    scene, camera = builtin_scene(depth_m, width=width, height=height)
    path = camera_path(camera, warmup + frames)
    setup = SpectralSetup(get_water(water), get_sensor(sensor), light_obj, Bands(bands),
                          ms_model=ms_model, phase=phase,
                          cone_spread=cone_spread_for(ms_model, cone_spread),
                          spread_scattering=spread_scattering, waves=waves,
                          seabed=scene.seabed if ms_model == "lightfield" else None)
    still, moving = Renderer(width, height, bands), Renderer(width, height, bands)
    for r in (still, moving):
        if sun_shadow_map is not None:
            r.sun_map_size = sun_shadow_map
    loop_s = None
    if waves is not None:
        # Both kinds of frame read the sea's caustic loop; the still frames
        # stay at t = 0. (The loop is built, or read from the cache, here.)
        say(f"the caustic loop of a {waves.wind_speed:g} m/s sea under the sun (built once "
            "per sea state and sun, then cached; minutes the first time) ...")
        still.set_wave_time(0.0)
        moving.set_wave_time(0.0)
        t0 = time.perf_counter()
        step = max(1, DEFAULT_LOOP_FRAMES // 8)
        caustic_loop(waves, light_obj.sun.elevation_deg, light_obj.sun.azimuth_deg,
                     n_water=light_obj.sun.n_water,
                     progress=lambda done, total: say(f"  caustic loop: {done}/{total} frames")
                     if done == total or done % step == 0 else None)
        loop_s = time.perf_counter() - t0
        say(f"caustic loop ready in {loop_s:.1f} s")
    t0 = time.perf_counter()
    settings = still.auto_display(scene, camera, setup)
    moving.set_spectral(setup, scene.materials)
    moving.set_display(settings)
    say(f"{width}x{height}, {bands} bands, {ms_model}: ready in "
        f"{time.perf_counter() - t0:.2f} s; path depths {min(c.depth_m for c in path):.2f}-"
        f"{max(c.depth_m for c in path):.2f} m, up to {MAX_DEPTH_STEP_M:.2f} m per frame")
    result = {}
    for by_pass in (False, True):
        timers = {"still": _Timer(still, by_pass), "moving": _Timer(moving, by_pass)}
        walls = {"still": [], "moving": []}
        parts = {"still": [], "moving": []}
        for i in range(warmup + frames):
            # Interleaved, so that a change of load hits both kinds alike.
            if waves is not None:
                moving.set_wave_time(i / FRAME_RATE_HZ)
            for kind, cam in (("still", camera), ("moving", path[i])):
                ms = timers[kind].frame(scene, cam, setup)
                if i >= warmup:
                    walls[kind].append(ms)
                    parts[kind].append(timers[kind].parts)
        key = "per_pass" if by_pass else "frame"
        med = {k: float(np.median(v)) for k, v in walls.items()}
        entry = {"still_ms": med["still"], "moving_ms": med["moving"],
                 "moving_over_still": med["moving"] / med["still"]}
        if by_pass:
            names = list(parts["moving"][0])
            entry["passes"] = {n: {k: float(np.median([p[n] for p in parts[k]]))
                                   for k in ("still", "moving")} for n in names}
        result[key] = entry
        say(f"{'pass by pass' if by_pass else 'whole frame'}: still {med['still']:.1f} ms, "
            f"moving {med['moving']:.1f} ms: moving / still = {entry['moving_over_still']:.3f}")
    say("changes of water, band count and sun ...")
    # (A new sun's caustics: the still map at t = 0, not a new loop.)
    still.set_wave_time(None)
    switch = switch_times(still, scene, camera, setup, settings)
    return {"adapter": adapter_info(), "width": width, "height": height, "bands": bands,
            "frames": frames, "warmup": warmup, "ms_model": ms_model,
            "water": setup.water.describe(), "light": light_obj.describe(),
            "path": {"start_depth_m": float(camera.depth_m),
                     "depths_m": [float(c.depth_m) for c in path],
                     "max_depth_step_m": float(MAX_DEPTH_STEP_M),
                     "seabed_depth_m": None if scene.seabed is None
                     else float(scene.seabed.depth_m),
                     "wave_seconds_per_frame": 1.0 / FRAME_RATE_HZ},
            "waves": None if waves is None else {**waves.describe(),
                                                 "caustic_loop_ready_s": loop_s},
            **result, "switch": switch}


def format_motion(result: dict) -> str:
    """The motion benchmark as text: the two frames, their ratio, each pass."""
    f, p = result["frame"], result["per_pass"]
    lines = [f"adapter: {result['adapter'].get('description') or result['adapter']}",
             f"{result['width']}x{result['height']}, {result['bands']} bands, "
             f"{result['ms_model']}; median of {result['frames']} frames of each kind, "
             "interleaved",
             f"camera path: depth {min(result['path']['depths_m']):.2f}-"
             f"{max(result['path']['depths_m']):.2f} m, up to "
             f"{result['path']['max_depth_step_m']:.2f} m per frame",
             *([] if not result.get("waves") else [
                 f"waves: {result['waves']['wind_speed_m_s']:g} m/s, advancing "
                 f"{result['path']['wave_seconds_per_frame']:.4f} s per frame (caustic loop "
                 f"ready in {result['waves']['caustic_loop_ready_s']:.1f} s)"]),
             f"whole frame: still {f['still_ms']:.1f} ms ({1e3 / f['still_ms']:.1f} fps), "
             f"moving {f['moving_ms']:.1f} ms ({1e3 / f['moving_ms']:.1f} fps): "
             f"moving / still = {f['moving_over_still']:.3f}",
             "pass by pass (each submitted and waited for):",
             f"  {'pass':<16} {'still':>8} {'moving':>8}  (ms)"]
    for name, t in p["passes"].items():
        lines.append(f"  {name:<16} {t['still']:8.2f} {t['moving']:8.2f}")
    lines.append(f"  {'sum':<16} {p['still_ms']:8.2f} {p['moving_ms']:8.2f}  "
                 f"moving / still = {p['moving_over_still']:.3f}")
    sw = result["switch"]
    lines.append(f"first frame after a change (s): water {sw['water']} {sw['new_water_s']:.2f} "
                 f"new, {sw['cached_water_s']:.2f} cached; "
                 f"{sw['bands']} bands {sw['new_bands_s']:.2f} new, {sw['cached_bands_s']:.2f} "
                 "cached"
                 + ("" if "new_sun_s" not in sw else
                    f"; sun at {sw['sun_elevation_deg']:g} deg {sw['new_sun_s']:.2f} new, "
                    f"{sw['cached_sun_s']:.2f} cached"))
    return "\n".join(lines)
