"""``aquaspec view``: the live view in a desktop window or offscreen.

:func:`run_view` is what the command calls. In a window (``rendercanvas``'s
glfw backend, the ``view`` extra) the frames run continuously until the
window is closed (or Escape, or ``frames`` frames); the camera flies with
the keys and mouse (:mod:`aquaspec.apps.flight`) unless a flight script
drives it, and the number keys switch the water (made on a worker thread
while the frames go on). Offscreen (``rendercanvas``'s offscreen canvas; no display
needed) the same :class:`aquaspec.apps.live.LiveView` draws ``frames``
frames, the camera driven by a script (:mod:`aquaspec.apps.flight_script`)
or standing still. With ``record`` each frame is written as a PNG (offscreen:
the presented texture, as the canvas reads it back; in a window: the display
buffer, read back only for recording), optionally an MP4, and a ``run.json``
sidecar with the parameters, every frame's pose and the frame rate
(:mod:`aquaspec.apps.record`).
"""

from __future__ import annotations

import os
import time
import warnings
from pathlib import Path

import numpy as np

from aquaspec.apps.flight_script import FlightScript, Pose
from aquaspec.apps.live import PROFILE_EVERY, LiveView
from aquaspec.apps.settings import ViewSettings
from aquaspec.apps.panel import attach_panel
from aquaspec.apps.record import FrameRecorder
from aquaspec.apps.scale import RenderScale
from aquaspec.errors import AquaspecError
from aquaspec.gpu.device import adapter_info
from aquaspec.optics.flat_port import FlatPort
from aquaspec.optics.presets import get_camera_model
from aquaspec.scene.particles import parse_marine_snow

#: Environment variable that forces the offscreen canvas (rendercanvas's own).
FORCE_OFFSCREEN_ENV = "RENDERCANVAS_FORCE_OFFSCREEN"


def _window_backend():
    """rendercanvas's glfw canvas class and loop, once glfw has found a display
    (checked before anything is built: glfw aborts the process when a window
    is made without one)."""
    try:
        # deferred: glfw (the `view` extra) loads a windowing library; offscreen runs need none
        import glfw
        from rendercanvas.glfw import RenderCanvas, loop  # deferred: as glfw
    except ImportError as exc:
        raise AquaspecError(f"a window needs glfw ({exc}); install the view extra: pip install "
                            "'aquaspec[view]', or run with --offscreen") from None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        ready = glfw.init()
    if not ready:
        why = "; ".join(str(w.message) for w in caught) or "no reason given"
        raise AquaspecError(f"no window can open here (glfw: {why}); is there a display "
                            "(DISPLAY or WAYLAND_DISPLAY)? Headless: --offscreen --frames N")
    return RenderCanvas, loop


def _window_canvas(canvas_class, settings: ViewSettings):
    try:
        return canvas_class(size=(settings.width, settings.height), title="aquaspec view",
                            update_mode="continuous", max_fps=120, vsync=False)
    except Exception as exc:         # glfw raises its own error types
        raise AquaspecError(f"could not open a window ({type(exc).__name__}: {exc}); is there "
                            "a display (DISPLAY / WAYLAND_DISPLAY)? Headless: --offscreen"
                            ) from None


def _start_pose(view: LiveView) -> Pose:
    f = view.flight
    return Pose(tuple(float(v) for v in f.position), f.yaw_deg, f.pitch_deg)


def _summary(view: LiveView, walls_ms: list, mode: str) -> dict:
    """The run's frame rate and last per-pass times (JSON-ready); ``walls_ms``
    holds ``(frame index, ms, render scale)``. The rate is that of the final
    render scale; the first frame (pipelines compiled, tables built), the
    first at a new scale and the frames timed pass by pass are not the
    steady rate."""
    final = view.render_scale.scale
    steady = [ms for k, (i, ms, s) in enumerate(walls_ms)
              if i >= 1 and i % PROFILE_EVERY != 0 and s == final
              and k > 0 and walls_ms[k - 1][2] == s]
    median = float(np.median(steady)) if steady else None
    return {"mode": mode, "frames_drawn": view.frame_index,
            "slowest_second_fps": _slowest_second_fps([ms for _, ms, _ in walls_ms]),
            "render_size": [view.renderer.width, view.renderer.height],
            "render_scale": view.render_scale.scale,
            "median_frame_ms": median, "fps": None if not median else 1e3 / median,
            "pass_ms": dict(view.pass_ms), "final": view.pose()}


def _slowest_second_fps(frame_ms: list, skip_s: float = 1.0) -> float | None:
    """The fewest frames finished in any one second ending with a frame, after
    the first ``skip_s`` seconds (pipelines compiled, the automatic scale settling):
    what a user sees at the worst moment, stalls and all. None if the run
    was too short to hold a whole second after them."""
    ends = np.cumsum(np.asarray(frame_ms, dtype=float)) / 1e3
    if ends.size == 0 or ends[-1] < skip_s + 1.0:
        return None
    # For each window (t - 1 s, t] ending at a frame after skip_s + 1 s: frames in it.
    last = ends[ends >= skip_s + 1.0]
    first = np.searchsorted(ends, last - 1.0, side="right")
    counts = np.searchsorted(ends, last, side="right") - first
    return float(counts.min())


def run_view(settings: ViewSettings, *, offscreen: bool = False, script=None,
             frames: int | None = None, record=None, mp4: bool = False, save_dir=".",
             scale: float = 1.0, target_fps: float | None = None, panel: bool = True,
             progress=None, camera_model=None, marine_snow=None) -> dict:
    """Run the live view; returns the run's summary (frame rate, final pose).

    Parameters
    ----------
    settings : ViewSettings
    offscreen : bool
        Draw into ``rendercanvas``'s offscreen canvas (needs ``frames``); also
        when the environment sets :data:`FORCE_OFFSCREEN_ENV` to 1, true or yes.
    script : path, optional
        A flight script driving the camera and the parameters.
    frames : int, optional
        Stop after this many frames (a window: None runs until it is closed).
    record : path, optional
        Folder for the PNG frames, ``run.json`` and, with ``mp4``, the video.
    save_dir : path
        Where the P key saves the current frame (PNG, sidecar, linear EXR).
    scale, target_fps : float
        Render at ``scale`` times the window's size (one of
        :data:`aquaspec.apps.scale.SCALE_LEVELS`), stretched to it; with
        ``target_fps`` (a window only, and not while recording) the scale
        follows the frame rate (:class:`aquaspec.apps.scale.RenderScale`).
    panel : bool
        In a window: the controls panel (:mod:`aquaspec.apps.panel`, needs
        ``imgui-bundle``; without it the view runs with the keys alone and says so).
    progress : callable, optional
        Called with short messages.
    camera_model : str or CameraModel, optional
        The frames through a real camera's port and noisy sensor
        (:mod:`aquaspec.rendering.live_camera`; no depth of field live).
    marine_snow : None, a density per m^3, "DENSITY[,SEED][,...]" or MarineSnow
        Particles drifting with the current on the view's clock
        (:class:`aquaspec.rendering.marine_snow.LiveSnow`; the fixed blur, no depth of field).
    """
    say = progress or (lambda message: None)
    # rendercanvas's own switch (for tests and CI): offscreen, whatever is asked.
    offscreen = offscreen or os.environ.get(FORCE_OFFSCREEN_ENV, "").lower() in ("1", "true",
                                                                                 "yes")
    if frames is not None and (isinstance(frames, bool) or not isinstance(frames, int)
                               or frames < 1):
        raise AquaspecError(f"--frames {frames!r}; accepted: a whole number >= 1")
    if offscreen and frames is None:
        raise AquaspecError("--offscreen needs --frames N (there is no window to close)")
    if not Path(save_dir).is_dir():
        raise AquaspecError(f"--save-dir {str(save_dir)!r} is not an existing folder")
    if mp4 and record is None:
        raise AquaspecError("--mp4 needs --record OUTDIR (the video goes there)")
    if target_fps is not None and (offscreen or record is not None):
        raise AquaspecError("--target-fps changes the render size with the frame rate: for a "
                            "window that is not recording (recorded frames keep one size)")
    render_scale = RenderScale(scale, target_fps)     # checked before the scene is built
    camera_model = get_camera_model(camera_model)    # (and the camera model)
    marine_snow = parse_marine_snow(marine_snow)     # (and the marine snow)
    if camera_model is not None and settings.rgbd is not None \
            and isinstance(camera_model.port, FlatPort):
        raise AquaspecError("--camera-model with a flat port needs a render made for it; an "
                            "RGB-D photograph has its own view; accepted: a dome port")
    window = None if offscreen else _window_backend()
    view = LiveView(settings, progress=say)
    view.camera_model = camera_model
    view.marine_snow = marine_snow
    view.save_dir = Path(save_dir)
    view.render_scale = render_scale
    view.use_scale()
    if script is not None:
        view.script = FlightScript.load(script, _start_pose(view))
        view.apply_script(0)
    fps = view.script.fps if view.script is not None else 30.0
    recorder = None if record is None else FrameRecorder(record, fps=fps, mp4=mp4)
    walls_ms: list = []
    mode = "offscreen" if offscreen else "window"
    try:
        if offscreen:
            # deferred: rendercanvas's canvases are needed only when a view runs
            from rendercanvas.offscreen import RenderCanvas
            canvas = RenderCanvas(size=(settings.width, settings.height))
            view.attach(canvas)
            for i in range(frames):
                t0 = time.perf_counter()
                image = np.asarray(canvas.draw())
                walls_ms.append((i, (time.perf_counter() - t0) * 1e3, view.render_scale.scale))
                if recorder is not None:
                    recorder.add(image, view.pose())
                say(f"frame {i + 1}/{frames}: {view.status()}")
            canvas.close()
        else:
            canvas_class, loop = window
            canvas = _window_canvas(canvas_class, settings)
            view.max_frames = frames
            view.progressive_waves = True
            view.overlay = True
            last = [None]

            def after_frame(v):
                now = time.perf_counter()
                if last[0] is not None:
                    walls_ms.append((v.frame_index, (now - last[0]) * 1e3,
                                     v.render_scale.scale))
                last[0] = now
                if recorder is not None:
                    recorder.add(v.renderer.read_display(), v.pose())

            view.on_frame = after_frame
            view.attach(canvas)
            if panel:
                attach_panel(view, canvas, say)
            say("window open: W/A/S/D/Q/E move, drag to look, +/- speed, R reset, 1-0 water "
                "(Jerlov I ... 9C), P save the frame, H text, Esc quit")
            loop.run()
    except BaseException:
        if recorder is not None:
            recorder.discard()
        raise
    finally:
        view.close()
    summary = _summary(view, walls_ms, mode)
    if recorder is not None:
        recorder.close({"command": "view", "settings": settings.describe(), **summary,
                        "image_source": "presented texture (offscreen canvas)" if offscreen
                        else "display buffer (read back for recording)",
                        "script": None if view.script is None else view.script.doc,
                        "display": view.display_settings, "adapter": adapter_info()})
    return summary
