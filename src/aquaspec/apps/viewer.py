"""The interactive viewer: the built-in scene with live controls.

A matplotlib window (any interactive backend: Qt, Tk, GTK, macOS) with
sliders for depth, number of bands, exposure, the sun (elevation 0 is an
overcast sky; above it the SPECTRL2 sun and sky with the refracted beam, its
shadows and god rays) and the wind (0 is a flat surface; above it the wind
sea's caustics, :mod:`aquaspec.light.caustics`, a few seconds for each new sea or
sun), and choices of water type, sensor and multiple-scattering model (the
seeds' formula or the light field). Every change re-renders the frame on the GPU through one
:class:`aquaspec.rendering.renderer.Renderer`, which is rebuilt only when the band
count changes, so a new depth or water costs one frame. The scene is built
for the deepest depth asked for so far (the camera 1.5 m above the sand);
a shallower depth raises the camera in it, so the light field (whose lower
boundary is the sand) is not solved again. Waters, sensors and
spectral setups are kept once made: going back to a water neither reloads
it (nor repeats its data warnings) nor re-uploads its tables.

:class:`Viewer` does not open a window by itself (it takes a matplotlib
figure), so it can be driven and tested headless.
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from aquaspec.colour.bands import Bands
from aquaspec.colour.display import to_display
from aquaspec.colour.sensors import builtin_sensors, get_sensor, load_camspec
from aquaspec.errors import AquaspecError
from aquaspec.light.waves import WIND_RANGE, Waves
from aquaspec.light.sky import DEFAULT_SUN_AZIMUTH_DEG, surface_light
from aquaspec.medium.water import JERLOV_TYPES, load_water
from aquaspec.rendering.appearance import check_ms_model
from aquaspec.rendering.renderer import Renderer
from aquaspec.rendering.setup import SpectralSetup
from aquaspec.scene.builtin import builtin_scene
from aquaspec.transport.models import DEFAULT_MS_MODEL, MS_MODELS


class Viewer:
    """State and rendering of the interactive view.

    Parameters
    ----------
    width, height : int
        Frame size in pixels.
    water, depth_m, bands, sensor, exposure, ms_model, cone_spread : initial settings
        ``exposure`` is ``"auto"`` or EV; ``ms_model`` a key of
        :data:`aquaspec.transport.models.MS_MODELS`; ``cone_spread`` (light field only;
        None: on) spreads the forward cone's light over the image (cone 40
        degrees); ``spread_scattering`` ("single" or "multiple") how.
    sun_elevation_deg, sun_azimuth_deg : float
        The sun (elevation 0: an overcast sky, no sun).
    wind : float
        Wind speed in m/s of the sea whose caustics the sun makes (0: flat).
    camspec : path, optional
        Makes the cameras of a camspec file selectable.
    """

    def __init__(self, width=640, height=360, *, water="IB", depth_m=5.0, bands=8,
                 sensor="human", exposure="auto", ms_model=DEFAULT_MS_MODEL, cone_spread=None,
                 camspec=None, spread_scattering="single", sun_elevation_deg=0.0,
                 sun_azimuth_deg=DEFAULT_SUN_AZIMUTH_DEG, wind=0.0):
        self.width, self.height = width, height
        self.camspec = camspec
        self.state = {"water": water, "depth_m": float(depth_m), "bands": int(bands),
                      "sensor": sensor, "exposure": exposure,
                      "ms_model": check_ms_model(ms_model),
                      # (the light field's default: spread; see models.cone_spread_for)
                      "cone_spread": True if cone_spread is None else bool(cone_spread),
                      "sun_elevation": float(sun_elevation_deg),
                      "sun_azimuth": float(sun_azimuth_deg), "wind": float(wind)}
        self._check_sun(self.state)
        if spread_scattering not in ("single", "multiple"):
            raise AquaspecError(f"spread_scattering={spread_scattering!r}; accepted: "
                                "'single', 'multiple'")
        self.spread_scattering = spread_scattering
        self._waters, self._sensors, self._setups = {}, {}, {}
        self._renderer = None
        self._renderers = {}
        self._scene_depth = None
        self.last_frame_ms = None
        self.image = None
        self.linear = None

    def sensors(self) -> list[str]:
        names = list(builtin_sensors())
        if self.camspec:
            names += list(load_camspec(self.camspec))
        return names

    def update(self, **changes) -> np.ndarray:
        """Apply setting changes and render; returns the display image (H, W, 3) uint8."""
        unknown = set(changes) - set(self.state)
        if unknown:
            raise AquaspecError(f"unknown viewer setting(s) {sorted(unknown)}; accepted: "
                                f"{', '.join(self.state)}")
        if "ms_model" in changes:
            changes["ms_model"] = check_ms_model(changes["ms_model"])
        self._check_sun({**self.state, **changes})
        self.state.update(changes)
        s = self.state
        t0 = time.perf_counter()
        if self._renderer is None or self._renderer.deferred.n_bands != s["bands"]:
            # One renderer per band count shown (its compiled passes kept).
            if s["bands"] not in self._renderers:
                if len(self._renderers) >= self.MAX_RENDERERS:
                    self._renderers.pop(next(iter(self._renderers)))
                self._renderers[s["bands"]] = Renderer(self.width, self.height, s["bands"])
            self._renderer = self._renderers[s["bands"]]
        if self._scene_depth is None or s["depth_m"] > self._scene_depth:
            # A scene whose camera stands 1.5 m above the sand at this depth;
            # shallower views raise the camera in it (no new light field).
            self._scene, self._scene_camera = builtin_scene(s["depth_m"], width=self.width,
                                                            height=self.height)
            self._scene_depth = s["depth_m"]
        self._camera = dataclasses.replace(
            self._scene_camera, position=self._scene_camera.position
            + [0.0, self._scene_depth - s["depth_m"], 0.0])
        setup = self._setup(s["water"], s["sensor"], s["bands"], s["ms_model"],
                            s["cone_spread"] and s["ms_model"] == "lightfield",
                            self._scene.seabed if s["ms_model"] == "lightfield" else None,
                            sun=self._sun_key(s))
        sensor = setup.sensor
        # The exposure acts on the linear image: changing only it re-renders nothing.
        if self.linear is None or set(changes) - {"exposure"}:
            self.linear = self._renderer.render_scene(self._scene, self._camera, setup)
        self.image, _ = to_display(self.linear, exposure=s["exposure"],
                                   matrix=sensor.srgb_matrix())
        self.last_frame_ms = (time.perf_counter() - t0) * 1e3
        return self.image

    @staticmethod
    def _check_sun(state) -> None:
        e, w = state["sun_elevation"], state["wind"]
        if not (np.isfinite(e) and 0.0 <= e <= 90.0):
            raise AquaspecError(f"sun elevation {e!r} deg; accepted: 0 (no sun) to 90")
        if not (np.isfinite(state["sun_azimuth"])):
            raise AquaspecError(f"sun azimuth {state['sun_azimuth']!r} deg; accepted: a "
                                "finite angle")
        if not (np.isfinite(w) and (w == 0 or WIND_RANGE[0] <= w <= WIND_RANGE[1])):
            raise AquaspecError(f"wind {w!r} m/s; accepted: 0 (a flat surface) or "
                                f"{WIND_RANGE[0]} to {WIND_RANGE[1]}")

    @staticmethod
    def _sun_key(s):
        """(elevation, azimuth, wind) of the sun the settings ask for, or None."""
        if s["sun_elevation"] < 1.0:       # below 1 degree: an overcast sky
            return None
        return (round(s["sun_elevation"], 1), round(s["sun_azimuth"], 1),
                round(s["wind"], 1) if s["wind"] > 0 else 0.0)

    #: Renderers kept, one per band count (each about 100 MB at 1280x720).
    MAX_RENDERERS = 3

    #: Spectral setups kept (each may hold a sea's caustic map, about 11 MB).
    MAX_SETUPS = 16

    def _setup(self, water, sensor, bands, ms_model, spread=False, seabed=None,
               sun=None) -> SpectralSetup:
        """The spectral setup of these settings, made once (the renderer
        re-uploads the medium only when the setup object changes); ``seabed``
        the built-in scene's (the light field's lower boundary, per depth);
        ``sun`` (elevation, azimuth, wind) or None for an overcast sky."""
        key = (water, sensor, bands, ms_model, bool(spread),
               None if seabed is None else float(seabed.depth_m), sun)
        if key not in self._setups:
            if len(self._setups) >= self.MAX_SETUPS:
                self._setups.pop(next(iter(self._setups)))
            if water not in self._waters:
                self._waters[water] = load_water(water)
            if sensor not in self._sensors:
                self._sensors[sensor] = get_sensor(sensor, self.camspec)
            light, waves = surface_light("overcast"), None
            if sun is not None:
                light = surface_light("sun-sky", sun_elevation_deg=sun[0],
                                      sun_azimuth_deg=sun[1])
                if sun[2] > 0:
                    waves = Waves(sun[2])
            self._setups[key] = SpectralSetup(self._waters[water], self._sensors[sensor],
                                              light, Bands(bands),
                                              ms_model=ms_model, cone_spread=bool(spread),
                                              spread_scattering=self.spread_scattering
                                              if spread else "single", seabed=seabed,
                                              waves=waves)
        return self._setups[key]

    def title(self) -> str:
        s = self.state
        model = "light field" if s["ms_model"] == "lightfield" else "seeds' model"
        if s["ms_model"] == "lightfield" and s["cone_spread"]:
            model += " + cone spread"
            if self.spread_scattering == "multiple":
                model += " (multiple)"
        sun = self._sun_key(s)
        light = "overcast" if sun is None else (
            f"sun {sun[0]:g}/{sun[1]:g} deg" + (f", wind {sun[2]:g} m/s" if sun[2] else ""))
        return (f"Jerlov {s['water']}, {s['depth_m']:.1f} m, {s['bands']} bands, "
                f"{s['sensor']}, {model}, {light}, {self.last_frame_ms:.0f} ms")

    def attach(self, fig):
        """Build the image and the controls in a matplotlib figure."""
        # deferred: matplotlib takes 0.3 s to import; only a window needs it
        from matplotlib.widgets import CheckButtons, RadioButtons, Slider
        self.update()
        ax = fig.add_axes([0.22, 0.31, 0.76, 0.66])
        ax.set_axis_off()
        self._im = ax.imshow(self.image)
        self._ax = ax
        ax.set_title(self.title(), fontsize=9)
        self.controls = {
            "depth": Slider(fig.add_axes([0.45, 0.26, 0.45, 0.025]), "depth (m)", 0.0, 40.0,
                            valinit=self.state["depth_m"]),
            "bands": Slider(fig.add_axes([0.45, 0.22, 0.45, 0.025]), "bands", 3, 64,
                            valinit=self.state["bands"], valstep=1),
            "exposure": Slider(fig.add_axes([0.45, 0.18, 0.45, 0.025]), "EV (0 = auto)", -6, 6,
                               valinit=0.0),
            "sun_elevation": Slider(fig.add_axes([0.45, 0.14, 0.45, 0.025]),
                                    "sun elevation (0 = overcast)", 0.0, 90.0,
                                    valinit=self.state["sun_elevation"], valstep=1.0),
            "sun_azimuth": Slider(fig.add_axes([0.45, 0.10, 0.45, 0.025]), "sun azimuth",
                                  0.0, 360.0, valinit=self.state["sun_azimuth"] % 360.0,
                                  valstep=5.0),
            "wind": Slider(fig.add_axes([0.45, 0.06, 0.45, 0.025]),
                           "wind m/s (0 = flat; caustics)", 0.0, 10.0,
                           valinit=self.state["wind"], valstep=0.5),
            "water": RadioButtons(fig.add_axes([0.01, 0.45, 0.12, 0.5]), JERLOV_TYPES,
                                  active=JERLOV_TYPES.index(self.state["water"])),
            "sensor": RadioButtons(fig.add_axes([0.01, 0.12, 0.19, 0.28]), self.sensors()[:12],
                                   active=0),
            "ms_model": RadioButtons(fig.add_axes([0.01, 0.01, 0.19, 0.09]), list(MS_MODELS),
                                     active=list(MS_MODELS).index(self.state["ms_model"])),
            "cone_spread": CheckButtons(fig.add_axes([0.22, 0.01, 0.12, 0.05]), ["cone spread"],
                                        [self.state["cone_spread"]]),
        }
        c = self.controls
        c["depth"].on_changed(lambda v: self._changed(depth_m=float(v)))
        c["bands"].on_changed(lambda v: self._changed(bands=int(v)))
        c["exposure"].on_changed(lambda v: self._changed(exposure="auto" if v == 0 else float(v)))
        c["sun_elevation"].on_changed(lambda v: self._changed(sun_elevation=float(v)))
        c["sun_azimuth"].on_changed(lambda v: self._changed(sun_azimuth=float(v)))
        c["wind"].on_changed(lambda v: self._changed(wind=float(v)))
        c["water"].on_clicked(lambda label: self._changed(water=label))
        c["sensor"].on_clicked(lambda label: self._changed(sensor=label))
        c["ms_model"].on_clicked(lambda label: self._changed(ms_model=label))
        c["cone_spread"].on_clicked(
            lambda label: self._changed(cone_spread=not self.state["cone_spread"]))
        return self

    def _changed(self, **changes):
        try:
            self.update(**changes)
        except AquaspecError as exc:
            self._ax.set_title(f"error: {exc}", fontsize=8, color="red")
        else:
            self._im.set_data(self.image)
            self._ax.set_title(self.title(), fontsize=9, color="black")
        self._ax.figure.canvas.draw_idle()


def run_viewer(**kwargs) -> None:
    """Open the interactive window (needs a display and a GUI backend)."""
    import matplotlib  # deferred: matplotlib takes 0.3 s to import; only a window needs it
    import matplotlib.pyplot as plt  # deferred: as matplotlib
    if matplotlib.get_backend().lower() in ("agg", "pdf", "svg", "ps", "template"):
        raise AquaspecError(
            f"matplotlib's backend {matplotlib.get_backend()!r} cannot open a window; run on a "
            "machine with a display, install a GUI toolkit (e.g. pip install PySide6), or set "
            "MPLBACKEND=QtAgg / TkAgg")
    fig = plt.figure(figsize=(11, 6))
    fig.canvas.manager.set_window_title("aquaspec view")
    Viewer(**kwargs).attach(fig)
    plt.show()
