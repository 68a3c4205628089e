"""The live view's controls panel: Dear ImGui (``imgui-bundle``) in the same window.

:class:`ControlsPanel` draws one ImGui window over the frame with a widget
per control of :class:`aquaspec.apps.controls.ViewControls` and calls its
methods; the panel holds no physics of its own. It is drawn by wgpu-py's
``wgpu.utils.imgui.ImguiRenderer`` on the view's device into the canvas's
current texture, after the frame's present pass (``LiveView.gui``), and
takes the mouse and keys first while they are over it or in a widget (the
renderer's event handlers run before the view's and stop the event).

Sliders whose change makes a new setup (bands, sun elevation and azimuth,
wind) keep a draft while dragged and apply when released; the others apply
as they move. While a change is made on the worker thread an indeterminate
progress bar says what and for how long; the last good frame stays on screen.
Data warnings (published values missing and filled) and refusals show in
yellow at the bottom.
"""

from __future__ import annotations

from aquaspec.apps.controls import ViewControls

#: The panel's band slider range (the view accepts more: type them with --bands).
PANEL_BANDS = (3, 64)
#: The panel's width and margin, logical pixels.
PANEL_WIDTH_PX, PANEL_MARGIN_PX = 290, 8
#: Narrower windows start with the panel collapsed to its title bar (a click
#: opens it), so that it hides neither the frame nor the text in its corner.
OPEN_FROM_WIDTH_PX = 960
_WARN_RGBA = (1.0, 0.85, 0.3, 1.0)


class ControlsPanel:
    """The panel of one live view (module docstring).

    Parameters
    ----------
    controls : ViewControls
    """

    def __init__(self, controls: ViewControls):
        self.controls = controls
        self.renderer = None        # wgpu.utils.imgui.ImguiRenderer, made by attach()
        self._drafts: dict = {}
        #: Frames the panel has drawn.
        self.frames = 0

    def attach(self, canvas) -> None:
        """Draw the panel over every frame of the view's ``canvas`` (attached
        to the view already: its context is configured)."""
        # deferred: imgui-bundle is the `view` extra's; views without a panel need none
        from imgui_bundle import imgui
        from wgpu.utils.imgui import ImguiRenderer  # deferred: it imports imgui-bundle
        view = self.controls.view
        self.renderer = ImguiRenderer(view.device, canvas)     # its context is now current
        imgui.get_io().set_ini_filename(None)   # no imgui.ini left in the user's folder
        self.renderer.set_gui(self.draw)
        view.gui = self.renderer.render

    # ---------------------------------------------------------------- widgets
    def _combo(self, imgui, label, items, current, apply) -> None:
        labels = [str(i) for i in items]
        index = labels.index(str(current)) if str(current) in labels else 0
        changed, index = imgui.combo(label, index, labels)
        if changed and labels[index] != str(current):
            apply(items[index])

    def _on_release(self, imgui, key, value, widget, apply) -> None:
        """A slider that applies on release: the draft follows the view's value
        except while dragged."""
        draft = self._drafts.get(key, value)
        _, draft = widget(draft)
        if imgui.is_item_deactivated_after_edit():
            apply(draft)
        self._drafts[key] = draft if imgui.is_item_active() else value

    def draw(self) -> None:
        """One frame of the panel (ImGui calls; the renderer's gui function)."""
        # deferred: as attach
        from imgui_bundle import imgui
        c, view = self.controls, self.controls.view
        water, s = view.target()
        width, height = view.canvas.get_logical_size()
        imgui.set_next_window_pos((width - PANEL_WIDTH_PX - PANEL_MARGIN_PX, PANEL_MARGIN_PX),
                                  imgui.Cond_.first_use_ever)
        imgui.set_next_window_size((PANEL_WIDTH_PX, height - 2 * PANEL_MARGIN_PX),
                                   imgui.Cond_.first_use_ever)
        imgui.set_next_window_collapsed(width < OPEN_FROM_WIDTH_PX, imgui.Cond_.first_use_ever)
        imgui.begin("controls")
        imgui.push_item_width(-110)

        imgui.separator_text("water")
        self._combo(imgui, "data source", c.sources, s.water_source,
                    lambda src: c.set_water(water if water in c.waters(src) else
                                            c.waters(src)[0], src))
        self._combo(imgui, "water type", c.waters(s.water_source), water, c.set_water)
        self._combo(imgui, "ms model", c.ms_models(), s.ms_model, c.set_ms_model)
        self._combo(imgui, "phase", c.phases(), s.phase, c.set_phase)
        self._combo(imgui, "surface", c.surfaces, s.surface, c.set_surface)

        imgui.separator_text("camera")
        changed, depth = imgui.slider_float("depth", view.flight.depth_m, *c.depth_range(),
                                            "%.2f m")
        if changed:
            c.set_depth(depth)
        self._combo(imgui, "sensor", c.sensors(), s.sensor, c.set_sensor)
        self._on_release(imgui, "bands", s.bands,
                         lambda v: imgui.slider_int("bands", v, *PANEL_BANDS), c.set_bands)
        changed, ev = imgui.slider_float("EV from auto", view.ev_offset, -6.0, 6.0, "%+.1f")
        if changed:
            c.set_ev_offset(round(ev, 1))
        self._combo(imgui, "tone map", c.tonemaps(), view.tonemap, c.set_tonemap)
        self._combo(imgui, "render scale", c.scales(), view.render_scale.scale,
                    c.set_render_scale)

        imgui.separator_text("sun and waves")
        changed, on = imgui.checkbox("sun", s.has_sun)
        if changed:
            c.set_sun(on)
        self._on_release(imgui, "elevation", c.sun_elevation_deg,
                         lambda v: imgui.slider_float("elevation", v, 1.0, 90.0, "%.0f deg"),
                         lambda v: c.set_sun(True, elevation_deg=v))
        self._on_release(imgui, "azimuth", s.sun_azimuth_deg,
                         lambda v: imgui.slider_float("azimuth", v, 0.0, 360.0, "%.0f deg"),
                         lambda v: c.set_sun(s.has_sun, azimuth_deg=v))
        self._on_release(imgui, "wind", s.wind,
                         lambda v: imgui.slider_float("wind", v, 0.0, c.wind_range[1],
                                                      "%.1f m/s"),
                         lambda v: c.set_wind(0.0 if v < c.wind_range[0] else v))
        changed, on = imgui.checkbox("surface from below (window, sun)", view.surface_from_below)
        if changed:
            c.set_surface_from_below(on)
        playing = view.wave_speed > 0
        if imgui.button("pause waves" if playing else "play waves"):
            c.set_waves_playing(not playing)
        imgui.same_line()
        changed, speed = imgui.slider_float("speed", c.wave_speed, 0.1, 4.0, "%.1fx")
        if changed:
            c.set_wave_speed(speed)

        busy = c.busy()
        if busy is not None:
            what, seconds = busy
            imgui.separator()
            imgui.text_wrapped(f"{what} {seconds:.1f} s")
            imgui.progress_bar(-1.0 * imgui.get_time(), (-1.0, 0.0), "working")
        notes = c.warnings()
        if notes:
            imgui.separator_text("warnings")
            imgui.push_text_wrap_pos(0.0)
            for note in notes:
                imgui.text_colored(_WARN_RGBA, note)
            imgui.pop_text_wrap_pos()
        imgui.pop_item_width()
        imgui.end()
        self.frames += 1


def attach_panel(view, canvas, say) -> None:
    """The controls panel of ``view`` (a :class:`aquaspec.apps.live.LiveView`)
    over ``canvas``, or a note through ``say`` when imgui-bundle is missing."""
    try:
        # deferred: imgui-bundle (the `view` extra) only where a panel is drawn
        import imgui_bundle  # noqa: F401
    except ImportError as exc:
        say(f"no controls panel ({exc}); pip install 'aquaspec[view]' for it")
        return
    ControlsPanel(ViewControls(view)).attach(canvas)
