"""The live view's controls: what each widget of the panel changes, without a UI.

:class:`ViewControls` is the one place where the panel's widgets
(:mod:`aquaspec.apps.panel`) change a :class:`aquaspec.apps.live.LiveView`;
tests call the same methods. Two kinds of change:

- *cheap* ones apply at once, on the frame thread: the camera's depth,
  exposure offset, tone map, wave play/pause and speed, the surface seen from
  below on or off, render scale;
- *expensive* ones make a new :class:`~aquaspec.rendering.setup.SpectralSetup`
  (a water's data and light field, bands, sensor, the multiple-scattering
  model and phase function, the sun, the wind's caustics): they go through
  :meth:`~aquaspec.apps.live.LiveView.request_setup`, made on the view's
  worker thread while the last good frame stays on screen (the panel shows
  :meth:`ViewControls.busy`); a new request supersedes a pending one. The
  panel's sliders for these apply when released.

A value the view refuses (e.g. wind without a sun) leaves the view as it was
and puts the reason in the view's ``message``;
:meth:`ViewControls.set` returns False then.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from aquaspec.apps.live import LiveView
from aquaspec.apps.settings import OVERCAST_BELOW_DEG
from aquaspec.apps.scale import SCALE_LEVELS, RenderScale
from aquaspec.colour.bands import MAX_BANDS, MIN_BANDS
from aquaspec.colour.display import TONEMAPS
from aquaspec.colour.sensors import list_sensors
from aquaspec.errors import AquaspecError
from aquaspec.light.waves import WIND_RANGE
from aquaspec.medium.phase import PHASE_FUNCTIONS
from aquaspec.medium.water import SOURCES, list_waters
from aquaspec.rendering.setup import SURFACE_MODELS
from aquaspec.scene.particles import parse_marine_snow
from aquaspec.transport.models import MS_MODELS

#: Phase functions offered, with the parameters the panel gives them
#: (``tabulated`` needs a table: not offered).
PHASE_CHOICES = {"petzold": (), "ff": (), "hg": (("g", 0.92),), "isotropic": ()}
#: The sun's elevation when it is switched on without one, degrees.
DEFAULT_SUN_ON_DEG = 45.0
#: The depth control's deepest value where nothing below bounds the camera, m.
OPEN_DEPTH_LIMIT_M = 200.0


class ViewControls:
    """Every control of the panel, as methods on a live view (module docstring)."""

    def __init__(self, view: LiveView):
        self.view = view
        s = view.settings
        #: The sun's elevation kept while it is off (switching on restores it).
        self.sun_elevation_deg = s.sun_elevation_deg if s.has_sun else DEFAULT_SUN_ON_DEG
        #: Waves' speed kept while they are paused.
        self._speed = view.wave_speed or 1.0
        # (A camspec file is read once, not on every frame the panel draws.)
        self._sensors = list_sensors(s.camspec)

    # ------------------------------------------------------------ choices
    def waters(self, source: str) -> list[str]:
        """The water types of ``source`` (plus a CSV water the view started with)."""
        types = [t for s, t in list_waters() if s == source]
        start = self.view.water
        return types + [start] if start.lower().endswith(".csv") else types

    def sensors(self) -> list[str]:
        """Every built-in camera and those of the command line's ``--camspec``."""
        return list(self._sensors)

    @staticmethod
    def ms_models() -> list[str]:
        return list(MS_MODELS)

    @staticmethod
    def phases() -> list[str]:
        return [p for p in PHASE_CHOICES if p in PHASE_FUNCTIONS]

    @staticmethod
    def tonemaps() -> list[str]:
        return list(TONEMAPS)

    @staticmethod
    def scales() -> list[float]:
        return list(SCALE_LEVELS)

    surfaces = tuple(SURFACE_MODELS)
    band_range = (MIN_BANDS, MAX_BANDS)
    wind_range = WIND_RANGE
    sources = SOURCES

    # ------------------------------------------------------ expensive ones
    def set(self, water: str | None = None, **fields) -> bool:
        """Ask for ``water`` (default: the one in use or pending) with the
        settings in use or pending changed by ``fields`` (names of
        :class:`~aquaspec.apps.settings.ViewSettings`), made off the frame
        thread. False (and the reason in the view's message) if refused."""
        cur_water, cur = self.view.target()
        try:
            new = dataclasses.replace(cur, **fields)
        except (AquaspecError, TypeError, ValueError) as exc:
            self.view.message = f"not changed: {exc}"
            return False
        self.view.request_setup(cur_water if water is None else water, new)
        return True

    def set_water(self, water: str, source: str | None = None) -> bool:
        """A Jerlov type (of ``source``, default the current one) or a CSV path."""
        if source is None:
            return self.set(water)
        return self.set(water, water_source=source)

    def set_sensor(self, name: str) -> bool:
        return self.set(sensor=name)

    def set_bands(self, n: int) -> bool:
        lo, hi = self.band_range
        if isinstance(n, bool) or int(n) != n or not lo <= n <= hi:
            self.view.message = f"not changed: {n!r} bands; accepted: {lo} to {hi}"
            return False
        return self.set(bands=int(n))

    def set_surface(self, name: str) -> bool:
        """The water surface seen from below (``flat`` or ``index-matched``)."""
        return self.set(surface=name)

    def set_ms_model(self, name: str) -> bool:
        return self.set(ms_model=name)

    def set_phase(self, name: str) -> bool:
        if name not in PHASE_CHOICES:
            self.view.message = (f"not changed: phase function {name!r}; accepted: "
                                 f"{', '.join(PHASE_CHOICES)}")
            return False
        return self.set(phase=name, phase_params=PHASE_CHOICES[name])

    def set_sun(self, on: bool, elevation_deg: float | None = None,
                azimuth_deg: float | None = None) -> bool:
        """The sun on (at ``elevation_deg``, default the last one) or off (the
        overcast sky; the wind's caustics go with it)."""
        if elevation_deg is not None:
            if not (np.isfinite(elevation_deg) and OVERCAST_BELOW_DEG <= elevation_deg <= 90):
                self.view.message = (f"not changed: sun elevation {elevation_deg!r} deg; "
                                     f"accepted: {OVERCAST_BELOW_DEG:g} to 90")
                return False
            self.sun_elevation_deg = float(elevation_deg)
        fields = {"sun_elevation_deg": self.sun_elevation_deg if on else 0.0}
        if azimuth_deg is not None:
            fields["sun_azimuth_deg"] = float(azimuth_deg)
        if not on:
            fields["wind"] = 0.0
        return self.set(**fields)

    def set_wind(self, wind_m_s: float) -> bool:
        """A wind sea's caustics (0: a flat surface); it needs the sun."""
        return self.set(wind=float(wind_m_s))

    # ---------------------------------------------------------- cheap ones
    def depth_range(self) -> tuple[float, float]:
        """The depths the camera may take where it is (m): the flight's bounds
        (the floor under it included), at most :data:`OPEN_DEPTH_LIMIT_M`
        where nothing below bounds it."""
        f = self.view.flight
        lo, hi = f.depth_range_m(at=(f.position[0], f.position[2]))
        return lo, float(min(hi, max(OPEN_DEPTH_LIMIT_M, lo + 1.0)))

    def set_depth(self, depth_m: float) -> bool:
        """Move the camera straight up or down to ``depth_m`` (clamped into the
        water, above the seabed and the floor under it, as flying is)."""
        if not np.isfinite(depth_m):
            self.view.message = f"not changed: depth {depth_m!r} m; accepted: a finite number"
            return False
        f = self.view.flight
        f.set_position([f.position[0], -float(depth_m), f.position[2]])
        return True

    def set_ev_offset(self, ev: float) -> bool:
        """Stops above the automatic exposure."""
        try:
            self.view.set_ev_offset(ev)
        except AquaspecError as exc:
            self.view.message = f"not changed: {exc}"
            return False
        return True

    def set_tonemap(self, name: str) -> bool:
        if name not in TONEMAPS:
            self.view.message = f"not changed: tone map {name!r}; accepted: {', '.join(TONEMAPS)}"
            return False
        self.view.tonemap = name
        return self.set_ev_offset(self.view.ev_offset)

    def set_waves_playing(self, playing: bool) -> None:
        """Play (at the last speed) or pause the waves."""
        if self.view.wave_speed:
            self._speed = self.view.wave_speed
        self.view.wave_speed = self._speed if playing else 0.0

    def set_wave_speed(self, speed: float) -> bool:
        """Wave time per second (0 to 4); while paused it is kept for play."""
        if not (np.isfinite(speed) and 0.0 < speed <= 4.0):
            self.view.message = f"not changed: wave speed {speed!r}; accepted: above 0, up to 4"
            return False
        self._speed = float(speed)
        if self.view.wave_speed:
            self.view.wave_speed = self._speed
        return True

    @property
    def wave_speed(self) -> float:
        return self._speed

    def set_surface_from_below(self, on: bool) -> None:
        """Draw the surface seen from below (the waves' window, the sun's disc) or
        leave it out (faster frames looking up: ``aquaspec bench --surface``)."""
        self.view.surface_from_below = bool(on)

    def set_marine_snow(self, spec) -> bool:
        """Marine snow over the frames (a density per m^3, a ``--marine-snow`` spec,
        or None: none); a cheap change (the particles drift on the view's clock)."""
        try:
            self.view.marine_snow = parse_marine_snow(spec)
        except AquaspecError as exc:
            self.view.message = f"not changed: {exc}"
            return False
        return True

    def set_render_scale(self, scale: float, target_fps: float | None = None) -> bool:
        """Render ``scale`` times the window's size (the automatic scale with
        ``target_fps``)."""
        try:
            self.view.render_scale = RenderScale(scale, target_fps)
        except AquaspecError as exc:
            self.view.message = f"not changed: {exc}"
            return False
        self.view.use_scale()
        return True

    # -------------------------------------------------------------- status
    def busy(self) -> tuple[str, float] | None:
        """``(what, seconds so far)`` while a change is made off the frame thread."""
        if self.view.pending is None:
            return None
        return self.view.message or "computing ...", self.view.pending_s()

    def warnings(self) -> list[str]:
        """The data warnings of the water on screen (published values missing and
        filled, a Kd that is not published) and the view's last refusal or error."""
        water = self.view.setup.water
        out = list(water.filled)
        if water.kd_derived:
            out.append(f"{water.name} ({water.source}): Kd is derived from a and b (Kirk "
                       "1991), not published")
        if self.view.message and self.view.pending is None:
            out.append(self.view.message)
        return out
