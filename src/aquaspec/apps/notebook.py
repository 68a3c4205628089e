"""The live view inside a Jupyter notebook: :func:`notebook_view`.

The canvas is ``rendercanvas.jupyter.RenderCanvas`` (a ``jupyter_rfb``
remote-frame-buffer widget; the ``view`` extra installs ``jupyter-rfb``),
named explicitly: ``rendercanvas.auto`` would pick its ``anywidget`` backend
in a kernel (rendercanvas 2.7). The
same :class:`aquaspec.apps.live.LiveView` that draws into the desktop window
draws into it: the frame is rendered and presented by the same passes, then
the canvas's wgpu context reads the presented texture back and the widget
sends it to the browser. The browser sends the keys and the mouse back as
``rendercanvas`` events, so W/A/S/D/Q/E, dragging, the number keys, , . [ ]
P and H work as in the window (click into the image first so it has the
keyboard). Escape closes the widget.

With ``panel=True`` (the default; needs ``imgui-bundle``) the controls panel
(:mod:`aquaspec.apps.panel`) is drawn over the frame as in the window, its
input being the widget's pointer events. Tested here: it is drawn into the
frame the widget sends; clicks on it were tried only in the window (Xvfb),
not in a browser.
"""

from __future__ import annotations

import dataclasses

from aquaspec.apps.live import LiveView
from aquaspec.apps.panel import attach_panel
from aquaspec.apps.scale import RenderScale
from aquaspec.apps.settings import ViewSettings
from aquaspec.errors import AquaspecError


def _jupyter_canvas_class():
    try:
        # deferred: jupyter_rfb (the `view` extra) pulls in ipywidgets; only notebooks need it
        from rendercanvas.jupyter import RenderCanvas
    except ImportError as exc:
        raise AquaspecError(f"the notebook view needs jupyter-rfb ({exc}); install the view "
                            "extra: pip install 'aquaspec[view]'") from None
    return RenderCanvas


def _settings(settings, options: dict) -> ViewSettings:
    fields = sorted(f.name for f in dataclasses.fields(ViewSettings))
    unknown = sorted(set(options) - set(fields))
    if unknown:
        raise AquaspecError(f"notebook_view: unknown option(s) {', '.join(unknown)}; "
                            f"accepted: {', '.join(fields)} (ViewSettings' fields), "
                            "settings, scale, max_fps, panel, progress")
    if settings is None:
        return ViewSettings(**options)
    if not isinstance(settings, ViewSettings):
        raise AquaspecError(f"notebook_view: settings={settings!r}; accepted: a ViewSettings "
                            "or None (then the keyword options make one)")
    return dataclasses.replace(settings, **options)


def notebook_view(settings: ViewSettings | None = None, *, scale: float = 1.0,
                  max_fps: float = 30.0, panel: bool = True, progress=None, **options):
    """The live view in a notebook cell; returns the widget (show it as the
    cell's last expression, or with ``IPython.display.display``).

    Parameters
    ----------
    settings : ViewSettings, optional
        The physics and image size; the keyword ``options`` (``ViewSettings``'
        fields, e.g. ``water="3C", depth_m=8, width=640, height=360``) make one
        or replace values in it.
    scale : float
        Render at ``scale`` times the widget's size (one of
        :data:`aquaspec.apps.scale.SCALE_LEVELS`), stretched to it.
    max_fps : float
        The widget's frame-rate cap (every frame is read back and sent to the
        browser, so a notebook runs slower than a window).
    panel : bool
        The controls panel over the frame (collapsed to its title bar in
        widgets narrower than 960 pixels; a click opens it).
    progress : callable, optional
        Called with short messages (e.g. ``print``).

    The widget's ``live_view`` attribute is the :class:`LiveView` (its
    ``flight``, ``pose()``, ``request_water`` ...); closing the widget stops
    the view's worker thread.
    """
    if isinstance(max_fps, bool) or not isinstance(max_fps, (int, float)) or not max_fps > 0:
        raise AquaspecError(f"notebook_view: max_fps={max_fps!r}; accepted: a number > 0")
    settings = _settings(settings, options)
    render_scale = RenderScale(scale, None)     # checked before the scene is built
    canvas_class = _jupyter_canvas_class()
    view = LiveView(settings, progress=progress)
    view.render_scale = render_scale
    view.use_scale()
    view.progressive_waves = True
    canvas = canvas_class(size=(settings.width, settings.height), title="aquaspec view",
                          update_mode="continuous", max_fps=max_fps)
    view.attach(canvas)
    if panel:
        attach_panel(view, canvas, progress or (lambda message: None))
    canvas.add_event_handler(lambda event: view.close(), "close")   # looked up on close
    canvas.live_view = view
    return canvas
