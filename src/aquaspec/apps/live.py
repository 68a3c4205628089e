"""The live view: the render loop of ``aquaspec view``, in a window or offscreen.

:class:`LiveView` holds one :class:`aquaspec.rendering.renderer.Renderer`, the
built-in scene, the spectral setups shown so far, a
:class:`aquaspec.apps.flight.FlightController` and a
:class:`aquaspec.gpu.passes.present.PresentPass`. Each frame
(:meth:`LiveView.draw`, the draw function of a ``rendercanvas`` canvas)
moves the camera by the keys held, records the renderer's displayed frame
(:meth:`~aquaspec.rendering.renderer.Renderer.encode_frame`: geometry,
shading with the display transform, the sun when on) and the present pass
onto the canvas's current texture in one command encoder, and submits it:
the image goes from the display buffer to the window's surface on the GPU,
never through NumPy. The same object draws into a desktop window
(``rendercanvas.glfw``) and into an offscreen canvas
(``rendercanvas.offscreen``, whose context reads the presented texture back:
that is how headless runs record frames).

Frame rate: frames per second from the wall-clock time between frames
(smoothed). Per-pass milliseconds: every :data:`PROFILE_EVERY` th frame is
submitted pass by pass, each waited for (wall clock, as ``aquaspec bench
--motion`` times passes; the GPU is lavapipe on the CPU here); the others are
one submission. Both are in the window title (:meth:`LiveView.status`) and,
with :attr:`LiveView.overlay` (H toggles it), drawn over the frame's corner
by the present pass (:mod:`aquaspec.apps.overlay`).

Render scale (:mod:`aquaspec.apps.scale`): the view may render fewer pixels
than the canvas has (one :class:`~aquaspec.rendering.renderer.Renderer` per
size, made when first needed and kept; the camera's intrinsics scaled) and
the present pass stretches the image over the canvas; with a target frame
rate the scale follows the frame times.

The scene is fixed when the view starts (:mod:`aquaspec.apps.view_scene`:
the built-in scene, a mesh, or an RGB-D photograph seen from its own camera);
the camera flies within it, bounded by the surface, the seabed and the floor.
Exposure and white balance are set automatically from the first
frame and then held (plus an offset from the keys), so that frames compare.
A change of physics (the number keys, the controls panel of
:mod:`aquaspec.apps.controls`) is made on a worker thread while the frames go
on (:meth:`LiveView.request_setup`); :attr:`LiveView.gui` draws the panel.
"""

from __future__ import annotations

import dataclasses
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from aquaspec.apps.overlay import text_overlay
from aquaspec.apps.record import save_snapshot
from aquaspec.apps.scale import SCALE_LEVELS, RenderScale, scaled_size
from aquaspec.apps.settings import ViewSettings
from aquaspec.apps.view_scene import ViewScene
from aquaspec.colour.bands import Bands
from aquaspec.colour.sensors import get_sensor
from aquaspec.errors import AquaspecError
from aquaspec.gpu.passes.present import PresentPass, plain_format
from aquaspec.light.sky import surface_light
from aquaspec.light.waves import Waves
from aquaspec.medium.water import JERLOV_TYPES, get_water
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.transport.models import ms_model_name

#: Spectral setups kept for switching back (the oldest others dropped).
KEEP_SETUPS = 12
#: Every this many frames, one is submitted and timed pass by pass.
PROFILE_EVERY = 10
#: Weight of the newest frame in the smoothed frame time.
FPS_SMOOTHING = 0.2
#: Seconds between redraws of the on-screen text.
OVERLAY_EVERY_S = 0.25
#: The on-screen text's last line.
OVERLAY_HELP = ("W/A/S/D/Q/E move, drag: look, +/- speed, R reset, 1-0 water, , . EV, "
                "[ ] scale, P save, H text, Esc quit")
#: Keys that step the exposure down (,) and up (.) from the automatic one, EV.
EV_KEYS = {",": -0.5, ".": 0.5}
#: Keys that step the render scale down ([) and up (]) the ladder.
SCALE_KEYS = {"[": 1, "]": -1}
#: Keys 1-9 and 0 switch to the ten Jerlov types, clearest first.
WATER_KEYS = dict(zip("1234567890", JERLOV_TYPES))


class LiveView:
    """The state and the frame of a live view (module docstring).

    Parameters
    ----------
    settings : ViewSettings
    progress : callable, optional
        Called with a short message as slow steps start.
    """

    def __init__(self, settings: ViewSettings, progress=None):
        self.settings = settings
        self._say = progress or (lambda message: None)
        s = settings
        #: The scene (or photograph), seabed and flight (:mod:`aquaspec.apps.view_scene`).
        self.view_scene = ViewScene(s, self._say)
        #: What the frames show: a :class:`~aquaspec.scene.mesh.Scene` or an
        #: RGB-D photograph's :class:`~aquaspec.scene.gbuffer.GBuffer`.
        self.scene = self.view_scene.scene
        self.seabed = self.view_scene.seabed
        self.flight = self.view_scene.flight
        self.renderer = Renderer(s.width, s.height, s.bands)
        self.device = self.renderer.deferred.device
        #: The render scale (:mod:`aquaspec.apps.scale`): fixed at 1 unless set.
        self.render_scale = RenderScale()
        self._renderers = {(s.width, s.height): self.renderer}
        self._scale_pending = None  # (size, Future of its renderer) made on the worker thread
        self._setups: dict = {}
        self.water = s.water
        self.setup = self._setup(s.water)
        self.display_settings = None
        self.present = None         # PresentPass, made when a canvas is attached
        self.canvas = self.context = None
        #: Seconds of the view's own clock (moves the waves); advanced by draw().
        self.time_s = 0.0
        self.frame_index = 0
        self.frame_ms = None        # smoothed wall time between frames
        self.pass_ms: dict = {}     # the last profiled frame's passes
        self._last = None
        self.max_frames = None      # draw() closes the canvas after this many frames
        #: A :class:`~aquaspec.apps.flight_script.FlightScript` driving the camera
        #: (frame ``i`` at its time ``i / fps``) instead of the keys; None: the keys.
        self.script = None
        self._script_t = None
        #: Called with the view after each frame is submitted (e.g. to record it).
        self.on_frame = None
        #: Moving waves: do not wait for the sea's caustic loop; frames read the
        #: part built so far (a window stays live). False: every frame exact.
        self.progressive_waves = False
        #: Draw the status text over the frame (:mod:`aquaspec.apps.overlay`).
        self.overlay = False
        #: A camera model the frames go through (``--camera-model``;
        #: :meth:`aquaspec.rendering.renderer.Renderer.set_camera_model`), or None.
        self.camera_model = None
        self._metered_green = None  # its exposure, metered by auto_exposure()
        #: Marine snow drifting on the view's clock (``--marine-snow``), or None.
        self.marine_snow = None
        #: Draw the surface seen from below where render() does (the waves' window,
        #: the sun's disc: :mod:`aquaspec.rendering.live_surface`); False: leave it out.
        self.surface_from_below = True
        #: A line of news for the status text (a water loading, an error), or None.
        self.message = None
        #: Where the P key saves frames.
        self.save_dir = Path(".")
        #: Stops of exposure above the automatic one (the , and . keys).
        self.ev_offset = 0.0
        #: The display's tone map (:data:`aquaspec.colour.display.TONEMAPS`).
        self.tonemap = "filmic"
        #: Wave time per second of wall time (0: the waves stand still).
        self.wave_speed = 1.0
        #: Called after each frame is presented, to draw over it (the controls panel).
        self.gui = None
        self._auto_display = None
        self._pending = None        # ((water, settings), Future) made on the worker thread
        self._pending_t0 = None
        self._workers = None
        self._overlay_t = None

    # ------------------------------------------------------------- physics
    def _make_setup(self, water: str, settings: ViewSettings | None = None) -> SpectralSetup:
        """A new spectral setup of ``water`` with ``settings`` (default: the view's)."""
        s = settings or self.settings
        light, waves = surface_light("overcast"), None
        if s.has_sun:
            light = surface_light("sun-sky", sun_elevation_deg=s.sun_elevation_deg,
                                  sun_azimuth_deg=s.sun_azimuth_deg)
            waves = Waves(s.wind) if s.wind > 0 else None
        return SpectralSetup(
            get_water(water, s.water_source), get_sensor(s.sensor, s.camspec), light,
            Bands(s.bands), ms_model=s.ms_model, phase=s.phase, phase_params=s.phase_params,
            cone_spread=s.cone_spread,
            surface=s.surface if ms_model_name(s.ms_model) == "lightfield" else "index-matched",
            spread_scattering=s.spread_scattering,
            seabed=self.seabed if s.ms_model == "lightfield" else None, waves=waves)

    def _setup(self, water: str) -> SpectralSetup:
        """The spectral setup of ``water`` with the view's settings (made once, on
        this thread)."""
        key = (water, self.settings)
        if key not in self._setups:
            self._say(f"water {water}: loading and solving its light field ...")
            self._setups[key] = self._make_setup(water)
        return self._setups[key]

    def _prepared_setup(self, water: str, settings: ViewSettings, camera=None,
                        display=None) -> tuple:
        """:meth:`_make_setup` with its host-side work done (the light field's
        tables, the sun's inputs and caustics, the per-band medium): what a
        worker thread runs. With ``camera`` (a new band count, a first sun) also a renderer
        of its size, its passes compiled by one frame (seconds on lavapipe),
        shown with ``display``. Returns ``(setup, renderer or None)``."""
        setup = self._make_setup(water, settings)
        setup.lightfield_tables()
        setup.sun_inputs()
        setup.medium(self.scene.materials)
        if camera is None:
            return setup, None
        return setup, self._compiled_renderer(camera, setup, display)

    def _compiled_renderer(self, camera, setup: SpectralSetup, display) -> Renderer:
        """A renderer of ``camera``'s size for ``setup`` shown with ``display``,
        its passes compiled by drawing one frame (seconds on lavapipe): what
        a worker thread makes while the frames go on."""
        # A renderer no other thread holds yet: only the device is shared.
        renderer = Renderer(camera.width, camera.height, setup.bands.n)
        renderer.set_spectral(setup, self.scene.materials)
        renderer.set_display(display)
        renderer.set_camera_model(self.camera_model, metered_green=self._metered_green)
        renderer.set_marine_snow(self.marine_snow, self.time_s)
        renderer.surface_from_below = self.surface_from_below
        if setup.waves is not None:     # (the moving sea's pass compiled here too)
            renderer.set_wave_time(self.time_s, progressive=self.progressive_waves)
        encoder = renderer.encode_frame(self.device.create_command_encoder(), self.shown(camera),
                                        camera, setup)
        self.device.queue.submit([encoder.finish()])
        renderer.wait()
        return renderer

    def _worker(self) -> ThreadPoolExecutor:
        """The thread that makes setups and renderers off the frame thread."""
        if self._workers is None:
            self._workers = ThreadPoolExecutor(max_workers=1, thread_name_prefix="aquaspec-water")
        return self._workers

    @property
    def pending(self):
        """``(water, settings)`` being made on the worker thread, or None."""
        return None if self._pending is None else self._pending[0]

    def target(self) -> tuple:
        """``(water, settings)`` the view is heading for: the pending change, else
        what it shows."""
        return self.pending or (self.water, self.settings)

    def request_water(self, water: str) -> None:
        """Switch to ``water`` (with the settings in use or pending) without
        stalling the frames (:meth:`request_setup`)."""
        self.request_setup(water, self.target()[1])

    def request_setup(self, water: str, settings: ViewSettings) -> None:
        """Show ``water`` with ``settings`` without stalling the frames: the
        setup is made on a worker thread while the last one keeps rendering,
        then taken by the next frame (:meth:`_poll_setup`); a newer request
        supersedes a pending one. Only the physics may differ from the
        view's settings (size, depth and mesh are fixed when it starts)."""
        key = (water, settings)
        if key == self.target():
            return
        if key == (self.water, self.settings) or key in self._setups:
            self._pending = None
            self._use(water, settings)
            return
        # A new band count, or a first sun (its passes compiled), is a new renderer.
        fresh = settings.bands != self.settings.bands or (settings.has_sun
                                                           and self.renderer.sun is None)
        camera = self.camera() if fresh and self.display_settings is not None else None
        self._pending = (key, self._worker().submit(self._prepared_setup, water, settings, camera,
                                                    self.display_settings))
        self._pending_t0 = time.perf_counter()
        new = [f.name for f in dataclasses.fields(settings)
               if getattr(settings, f.name) != getattr(self.settings, f.name)]
        self.message = (f"computing the light for {water} with new {', '.join(new)} ..." if new
                        else f"loading water {water} ...")

    def pending_s(self) -> float | None:
        """Seconds the pending change has been running, or None."""
        return None if self._pending is None else time.perf_counter() - self._pending_t0

    def _poll_setup(self) -> None:
        """Take a setup made on the worker thread once it is ready (a failure
        goes to :attr:`message`; the last setup stays)."""
        if not self._pending or not self._pending[1].done():
            return
        (water, settings), future = self._pending
        self._pending = None
        try:
            self._setups[(water, settings)], renderer = future.result()
        except AquaspecError as exc:
            self.message = f"water {water}: {exc}"
            return
        for key in list(self._setups)[:max(0, len(self._setups) - KEEP_SETUPS)]:
            if key != (self.water, self.settings):
                del self._setups[key]
        self.message = None
        self._use(water, settings, renderer)

    def _use(self, water: str, settings: ViewSettings, renderer=None) -> None:
        """Show ``water`` with ``settings`` (its setup made already, or made
        here); a new band count needs new renderers; ``renderer``: one made
        on the worker thread for them, replacing the others."""
        bands_changed = settings.bands != self.settings.bands
        self.settings = settings
        if renderer is not None and renderer.deferred.n_bands == settings.bands:
            self._renderers = {(renderer.width, renderer.height): renderer}
            self.use_scale(wait=True)
        elif bands_changed:
            self._renderers = {}
            self.use_scale(wait=True)
        self.set_water(water)

    def _poll_scale(self) -> None:
        """Take a new size's renderer made on the worker thread once it is ready
        (brought up to the setup and display in use; dropped if the band
        count changed meanwhile)."""
        if self._scale_pending is None or not self._scale_pending[1].done():
            return
        size, future = self._scale_pending
        self._scale_pending = None
        try:
            r = future.result()
        except AquaspecError as exc:
            self.message = f"render scale: {exc}"
            return
        if r.deferred.n_bands != self.settings.bands:
            return
        r.set_spectral(self.setup, self.scene.materials)
        r.set_display(self.display_settings)
        self._renderers[size] = r
        if scaled_size(self.settings.width, self.settings.height,
                       self.render_scale.scale) == size:
            self.renderer = r

    def save_frame(self) -> dict | None:
        """Save the current frame into :attr:`save_dir` as ``aquaspec render``
        saves an image (:func:`aquaspec.apps.record.save_snapshot`); the
        outcome goes to :attr:`message`. Returns the files written (None on error)."""
        try:
            saved = save_snapshot(self, self.save_dir)
        except AquaspecError as exc:
            self.message = f"not saved: {exc}"
            return None
        self.message = f"saved {Path(saved['png']).name}"
        self._say(f"saved {saved['png']} (+ {Path(saved['sidecar']).name}, "
                  f"{Path(saved['linear']).name})")
        return saved

    def close(self) -> None:
        """Stop the worker thread (a pending water is dropped)."""
        if self._workers is not None:
            self._workers.shutdown(wait=False, cancel_futures=True)
            self._workers = None

    def set_water(self, water: str) -> None:
        """Show ``water`` (a Jerlov type or a CSV path) on this thread; the exposure
        is kept."""
        self.setup = self._setup(water)
        self.water = water
        for r in self._renderers.values():
            r.set_spectral(self.setup, self.scene.materials)
            if self.display_settings is not None:
                r.set_display(self.display_settings)

    def camera(self):
        """The flight's camera at the current render size (intrinsics scaled)."""
        return self.flight.camera().resized(self.renderer.width, self.renderer.height)

    def shown(self, camera):
        """What a frame of ``camera``'s size shows (:meth:`ViewScene.at_size`)."""
        return self.view_scene.at_size(camera.width, camera.height)

    def use_scale(self, scale: float | None = None, *, wait: bool = False) -> None:
        """Render at :attr:`render_scale` (set to ``scale`` if given): the
        renderer of that size, made the first time (its passes compiled, the
        setup and display settings uploaded) and kept. Once frames are on
        screen a new size's renderer is made on the worker thread while the
        frames go on at the old size (:meth:`_poll_scale` takes it); before
        the first frame, or with ``wait``, it is made here."""
        if scale is not None:
            self.render_scale = RenderScale(scale, self.render_scale.target_fps)
        s = self.settings
        size = scaled_size(s.width, s.height, self.render_scale.scale)
        if size in self._renderers:
            self._scale_pending = None
        elif not wait and self.frame_index > 0 and self.display_settings is not None:
            if self._scale_pending is None or self._scale_pending[0] != size:
                camera = self.flight.camera().resized(*size)
                self._scale_pending = (size, self._worker().submit(
                    self._compiled_renderer, camera, self.setup, self.display_settings))
            return
        else:
            self._say(f"render scale {self.render_scale.scale:g}: a {size[0]}x{size[1]} "
                      "renderer ...")
            r = Renderer(*size, s.bands)
            if self.setup.bands.n == s.bands:       # (a new band count: set_water uploads)
                r.set_spectral(self.setup, self.scene.materials)
                if self.display_settings is not None:
                    r.set_display(self.display_settings)
            self._renderers[size] = r
        self.renderer = self._renderers[size]

    def auto_exposure(self) -> dict:
        """Set exposure and white balance from a frame of the current pose (plus
        :attr:`ev_offset`)."""
        self._say("automatic exposure from one linear frame ...")
        camera = self.camera()
        self.renderer.set_camera_model(self.camera_model)
        self._auto_display = self.renderer.auto_display(self.shown(camera), camera, self.setup)
        if self.renderer.live_camera is not None:
            self._metered_green = self.renderer.live_camera.metered_green
        return self.set_ev_offset(self.ev_offset)

    def set_ev_offset(self, ev: float) -> dict:
        """Expose ``ev`` stops above the automatic exposure (the , and . keys);
        returns the display settings now in use."""
        if not np.isfinite(ev):
            raise AquaspecError(f"exposure offset {ev!r} EV; accepted: a finite number")
        self.ev_offset = float(ev)
        auto = self._auto_display
        exposure = auto["exposure_ev"] + self.ev_offset
        self.display_settings = {**auto, "tonemap": self.tonemap, "exposure_ev": exposure,
                                 "exposure_scale": float(2.0 ** exposure),
                                 "exposure_offset_ev": self.ev_offset}
        for r in self._renderers.values():
            r.set_spectral(self.setup, self.scene.materials)
            r.set_display(self.display_settings)
        return self.display_settings

    # -------------------------------------------------------------- canvas
    def attach(self, canvas) -> None:
        """Draw into ``canvas`` (a ``rendercanvas`` canvas): configure its wgpu
        context on the renderer's device, route its events to the flight and
        make :meth:`draw` its draw function."""
        self.canvas = canvas
        self.context = canvas.get_wgpu_context()
        fmt = plain_format(self.context.get_preferred_format(self.device.adapter))
        try:
            self.context.configure(device=self.device, format=fmt)
        except ValueError:
            # The surface offers only the -srgb twin: the pass decodes first.
            fmt = fmt + "-srgb"
            self.context.configure(device=self.device, format=fmt)
        self.present = PresentPass(self.device, fmt)
        canvas.add_event_handler(self.handle_event, "key_down", "key_up", "pointer_down",
                                 "pointer_up", "pointer_move")
        if self.display_settings is None:
            self.auto_exposure()
        canvas.request_draw(self.draw)

    def handle_event(self, event: dict) -> None:
        """Keys and mouse to the flight; 1-9 and 0 switch the Jerlov water
        (:data:`WATER_KEYS`), , and . step the exposure (:meth:`set_ev_offset`),
        P saves the frame (:meth:`save_frame`), [ and ]
        render fewer or more pixels (:data:`SCALE_KEYS`; the automatic scale
        off), H shows or hides the on-screen text, Escape closes the canvas."""
        if event.get("event_type") == "key_down":
            if event.get("key") == "Escape":
                self.canvas.close()
                return
            if event.get("key") in ("h", "H"):
                self.overlay = not self.overlay
                self._overlay_t = None
                return
            if event.get("key") in WATER_KEYS:
                self.request_water(WATER_KEYS[event["key"]])
                return
            if event.get("key") in ("p", "P"):
                self.save_frame()
                return
            if event.get("key") in EV_KEYS and self._auto_display is not None:
                self.set_ev_offset(self.ev_offset + EV_KEYS[event["key"]])
                return
            if event.get("key") in SCALE_KEYS:
                # A chosen scale stays: the automatic control is off.
                level = int(np.clip(self.render_scale.level + SCALE_KEYS[event["key"]], 0,
                                    len(SCALE_LEVELS) - 1))
                self.render_scale = RenderScale(SCALE_LEVELS[level])
                self.use_scale()
                return
        self.flight.handle_event(event)

    def apply_script(self, frame: int) -> None:
        """Take :attr:`script`'s pose at frame ``frame`` and the parameter changes
        of the keyframes passed since the last call (water, then exposure)."""
        t = self.script.time_of(frame)
        auto = False
        for key in self.script.changes_between(self._script_t, t):
            if key.water is not None and key.water != self.water:
                self.set_water(key.water)
            auto = auto or key.auto_exposure
        self._script_t = t
        pose = self.script.pose_at(t)
        self.flight.set_position(pose.position)
        if pose.position[1] > self.flight.position[1]:
            self.message = (f"the script's camera at y = {pose.position[1]:g} m flown "
                            f"{self.flight.surface_margin_m:g} m under the surface (not above it)")
        self.flight.set_view(pose.yaw_deg, pose.pitch_deg)
        self.time_s = t
        if auto:
            self.auto_exposure()

    def _split(self, name, encoder):
        """Submit the pass ``name`` held in ``encoder``, wait, time it; a new encoder."""
        self.device.queue.submit([encoder.finish()])
        self.renderer.wait()
        now = time.perf_counter()
        self.pass_ms[name] = self.pass_ms.get(name, 0.0) + (now - self._pass_t0) * 1e3
        self._pass_t0 = now
        return self.device.create_command_encoder()

    def draw(self) -> None:
        """One frame: move, render, present onto the canvas's current texture."""
        now = time.perf_counter()
        dt = 0.0 if self._last is None else now - self._last
        if self._last is not None:
            ms = dt * 1e3
            self.frame_ms = ms if self.frame_ms is None else \
                (1 - FPS_SMOOTHING) * self.frame_ms + FPS_SMOOTHING * ms
            # (A frame timed pass by pass waited for each pass: not judged.)
            # (While a new size's renderer is made the frames are the old size's: not judged.)
            if ((self.frame_index - 1) % PROFILE_EVERY and self._scale_pending is None
                    and self.render_scale.observe(ms)):
                self.use_scale()
        self._last = now
        if self.script is not None:
            self.apply_script(self.frame_index)
        else:
            self._poll_setup()
            self._poll_scale()
            self.flight.advance(dt)
            self.time_s += dt * self.wave_speed
        profile = self.frame_index % PROFILE_EVERY == 0
        self.encode_and_submit(profile=profile)
        if self.gui is not None:
            self.gui()
            if profile:     # (the panel's own submission, timed as the passes are)
                self.renderer.wait()
                self.pass_ms["panel"] = (time.perf_counter() - self._pass_t0) * 1e3
        if self.on_frame is not None:
            self.on_frame(self)
        self.frame_index += 1
        self.canvas.set_title(self.status())
        self._update_overlay()
        if self.max_frames is not None and self.frame_index >= self.max_frames:
            self.canvas.close()

    def encode_and_submit(self, *, profile: bool = False) -> None:
        """Record and submit the current pose's frame and its presentation;
        ``profile``: pass by pass, timed into :attr:`pass_ms`."""
        if self.setup.waves is not None:
            self.renderer.set_wave_time(self.time_s, progressive=self.progressive_waves)
        camera = self.camera()
        self.renderer.set_camera_model(self.camera_model, metered_green=self._metered_green)
        self.renderer.set_marine_snow(self.marine_snow, self.time_s)
        self.renderer.surface_from_below = self.surface_from_below
        encoder = self.device.create_command_encoder()
        if profile:
            self.pass_ms = {}
            self._pass_t0 = time.perf_counter()
        encoder = self.renderer.encode_frame(encoder, self.shown(camera), camera, self.setup,
                                             split=self._split if profile else None)
        self.present.encode(encoder, self.renderer.display_buffer(),
                            (self.renderer.width, self.renderer.height),
                            self.context.get_current_texture())
        if profile:
            self._split("present", encoder)
        else:
            self.device.queue.submit([encoder.finish()])

    def status_lines(self) -> list[str]:
        """Frame rate, per-pass milliseconds, the physics and the pose, line by line."""
        fps = "-" if not self.frame_ms else f"{1e3 / self.frame_ms:.1f}"
        passes = ", ".join(f"{k} {v:.0f}" for k, v in self.pass_ms.items())
        f = self.flight
        x, _, z = f.position
        s = self.settings
        light = f"sun {s.sun_elevation_deg:g} deg" if s.has_sun else "overcast"
        rs = self.render_scale
        scale = (f"{self.renderer.width}x{self.renderer.height}"
                 + (f" (scale {rs.scale:g}{', auto' if rs.target_fps else ''})"
                    if rs.scale != 1.0 or rs.target_fps else "")
                 + ("" if self._scale_pending is None else
                    " -> {}x{} being made".format(*self._scale_pending[0])))
        return [f"{fps} fps at {scale} | Jerlov {self.water}, {s.bands} bands, {s.ms_model}, "
                f"{light}, EV {self.ev_offset:+g} from auto",
                f"ms: {passes or '-'}",
                f"depth {f.depth_m:.2f} m, x {x:.1f} z {z:.1f}, yaw {f.yaw_deg:.0f} "
                f"pitch {f.pitch_deg:.0f} | speed {f.speed_m_s:.2f} m/s",
                *([self.message] if self.message else [])]

    def status(self) -> str:
        """:meth:`status_lines` on one line, for the window title."""
        return " | ".join(["aquaspec view", *self.status_lines()])

    def _update_overlay(self) -> None:
        """Redraw the on-screen text when due (at most every :data:`OVERLAY_EVERY_S`)."""
        now = time.perf_counter()
        if self._overlay_t is not None and now - self._overlay_t < OVERLAY_EVERY_S:
            return
        self._overlay_t = now
        self.present.set_overlay(text_overlay([*self.status_lines(), OVERLAY_HELP],
                                              max_width=self.canvas.get_physical_size()[0])
                                 if self.overlay else None)

    def pose(self) -> dict:
        """The camera's pose and the view's state now (JSON-ready; sun elevation 0:
        overcast)."""
        f = self.flight
        return {"position_m": [float(v) for v in f.position], "depth_m": f.depth_m,
                "yaw_deg": f.yaw_deg, "pitch_deg": f.pitch_deg, "speed_m_s": f.speed_m_s,
                "water": self.water, "time_s": self.time_s,
                "sun_elevation_deg": self.settings.sun_elevation_deg, "bands": self.settings.bands}
