"""`aquaspec view` in a real window: Xvfb, the real entry point, keys from xdotool.

The command runs as a user runs it (``python -m aquaspec view``, a separate
process) in a glfw window on a virtual X server; xdotool focuses the window
and presses keys (through the XTEST extension, as a keyboard does): Q and W
fly, 7 switches the water, Escape closes the window. The run's sidecar and
frames (``--record``) say where the camera went and what it saw. Skipped,
naming what is missing, where Xvfb or xdotool is not installed (``make
setup`` installs them as root) or no X server starts.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

pytestmark = pytest.mark.gpu

#: Seconds to wait for the server, the window, and the command to finish.
SERVER_WAIT_S, WINDOW_WAIT_S, EXIT_WAIT_S = 10, 240, 120
#: Seconds a movement key is held down, and given to a new water's loading.
HOLD_S, WATER_WAIT_S = 2.0, 8.0


@pytest.fixture()
def x_display():
    """A fresh Xvfb display (its name, e.g. ":5"); the server is stopped after."""
    for tool in ("Xvfb", "xdotool"):
        if shutil.which(tool) is None:
            pytest.skip(f"{tool} is not installed (Debian packages xvfb, xdotool; "
                        "`make setup` installs them as root)")
    read_fd, write_fd = os.pipe()
    server = subprocess.Popen(["Xvfb", "-displayfd", str(write_fd), "-screen", "0",
                               "800x600x24", "-nolisten", "tcp"],
                              pass_fds=(write_fd,), stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE)
    os.close(write_fd)
    try:
        with os.fdopen(read_fd) as f:
            import select  # deferred: only this fixture waits on a pipe
            ready, _, _ = select.select([f], [], [], SERVER_WAIT_S)
            number = f.readline().strip() if ready else ""
        if not number:
            server.kill()
            err = server.communicate(timeout=5)[1].decode(errors="replace")[-500:]
            pytest.skip(f"Xvfb did not start within {SERVER_WAIT_S} s: {err}")
        yield f":{number}"
    finally:
        server.terminate()
        try:
            server.wait(timeout=10)
        except subprocess.TimeoutExpired:
            server.kill()


def _xdotool(display, *args, timeout=30):
    return subprocess.run(["xdotool", *args], env={**os.environ, "DISPLAY": display},
                          capture_output=True, text=True, timeout=timeout)


def _hold(display, key, seconds):
    _xdotool(display, "keydown", key)
    time.sleep(seconds)
    _xdotool(display, "keyup", key)
    time.sleep(0.5)


def _run_view(display, args, act):
    """Run ``python -m aquaspec view ARGS`` in a window on ``display``: wait for
    its window, ``act(window)`` (xdotool calls), press Escape, wait for the
    command to end; asserts it ended well and returns ``(stdout, stderr)``."""
    env = {**os.environ, "DISPLAY": display}
    env.pop("RENDERCANVAS_FORCE_OFFSCREEN", None)
    view = subprocess.Popen([sys.executable, "-m", "aquaspec", "view", *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        found = _xdotool(display, "search", "--sync", "--name", "^aquaspec view",
                         timeout=WINDOW_WAIT_S)
        assert found.returncode == 0, f"no window appeared: {found.stderr}"
        window = found.stdout.split()[0]
        time.sleep(1.0)                                   # a few frames first
        act(window)
        _xdotool(display, "key", "Escape")
        stdout, stderr = view.communicate(timeout=EXIT_WAIT_S)
    finally:
        if view.poll() is None:
            view.kill()
            view.communicate()
    assert view.returncode == 0, stderr[-3000:]
    return stdout, stderr


def _ratio(png, num, den, rows=0.2):
    """Mean of channel ``num`` over mean of channel ``den`` in the top ``rows``
    of a frame: open water (the camera looks 10 degrees down), the background."""
    a = np.asarray(Image.open(png)).astype(float)
    top = a[:max(1, int(a.shape[0] * rows))]
    return top[..., num].mean() / top[..., den].mean()


def test_keys_fly_the_camera_and_change_the_water(x_display, tmp_path):
    """Q descends (the background turns bluer: red is absorbed faster), W flies
    forward, 7 switches to Jerlov 3C (greener: less blue for the green), Escape
    closes the window."""
    out = tmp_path / "run"

    def act(window):
        focus = _xdotool(x_display, "windowfocus", "--sync", window)
        assert focus.returncode == 0, focus.stderr
        _hold(x_display, "q", HOLD_S)
        _hold(x_display, "w", HOLD_S)
        _xdotool(x_display, "key", "7")
        time.sleep(WATER_WAIT_S)

    # --frames: a cap, so that the window closes even if Escape is lost.
    # (The index-matched surface: under the flat one the shallow view's red is 0 and the
    # blue-to-red ratio below is not defined.)
    stdout, _ = _run_view(x_display, ["--size", "160x90", "--bands", "6", "--depth", "1.5",
                                      "--surface", "index-matched",
                                      "--frames", "5000", "--record", str(out)], act)
    run = json.loads((out / "run.json").read_text())
    assert run["mode"] == "window"
    assert run["frames_drawn"] < 5000, "Escape did not close the window"
    frames = run["frames"]
    poses = np.array([f["position_m"] for f in frames])
    waters = [f["water"] for f in frames]
    # Q first: straight down from the start, stopped above the sand.
    assert waters[0] == "IB" and waters[-1] == "3C", sorted(set(waters))
    start = [i for i in range(len(frames)) if np.allclose(poses[i, [0, 2]], poses[0, [0, 2]])]
    low = start[-1]
    assert poses[low, 1] < poses[0, 1] - 0.5, "Q did not take the camera down"
    # Deeper, the open water above the horizon is bluer (red absorbed faster).
    assert _ratio(out / frames[low]["file"], 2, 0) > _ratio(out / frames[0]["file"], 2, 0)
    # W: along the view (-z, 10 degrees down, or along the sand); x never changes.
    assert poses[:, 2].min() < poses[low, 2] - 0.5, "W did not fly the camera forward"
    assert np.ptp(poses[:, 0]) < 1e-9
    # 7: Jerlov 3C from the same pose, the exposure held: the frame turns greener.
    first_3c = waters.index("3C")
    np.testing.assert_array_equal(poses[first_3c], poses[first_3c - 1])
    assert waters[first_3c - 1] == "IB"
    assert (_ratio(out / frames[first_3c]["file"], 2, 1, rows=1.0)
            < _ratio(out / frames[first_3c - 1]["file"], 2, 1, rows=1.0))
    assert "frames (window)" in stdout


#: Where the panel's "sun" checkbox is, from the panel's top-left corner (logical
#: pixels, ImGui's default font and style: read off docs/images/live-view-panel.png).
SUN_CHECKBOX_FROM_PANEL = (17, 359)


def test_a_click_on_the_panel_turns_the_sun_on(x_display, tmp_path):
    """The controls panel is in the window the command opens: a click on its sun
    checkbox turns the sun on (made on the worker thread; the frames go on) and
    the frames turn brighter, the exposure held; the click does not turn the
    camera."""
    pytest.importorskip("imgui_bundle")
    from aquaspec.apps.panel import PANEL_MARGIN_PX, PANEL_WIDTH_PX
    out = tmp_path / "run"
    w, h = 960, 540                          # (narrower windows start with it collapsed)

    def act(window):
        x = w - PANEL_WIDTH_PX - PANEL_MARGIN_PX + SUN_CHECKBOX_FROM_PANEL[0]
        y = PANEL_MARGIN_PX + SUN_CHECKBOX_FROM_PANEL[1]
        _xdotool(x_display, "mousemove", "--window", window, str(x), str(y))
        time.sleep(1.0)                                   # hovered: the panel takes the mouse
        _xdotool(x_display, "click", "1")
        time.sleep(WATER_WAIT_S)

    _, stderr = _run_view(x_display, ["--size", f"{w}x{h}", "--scale", "0.25", "--bands", "3",
                                      "--frames", "5000", "--record", str(out)], act)
    assert "no controls panel" not in stderr
    frames = json.loads((out / "run.json").read_text())["frames"]
    suns = [f["sun_elevation_deg"] for f in frames]
    assert suns[0] == 0 and suns[-1] > 0, "the click did not turn the sun on"
    first_sun = next(i for i, e in enumerate(suns) if e > 0)
    assert first_sun > 0

    def mean(i):
        return np.asarray(Image.open(out / frames[i]["file"])).astype(float).mean()
    assert mean(first_sun) > 1.05 * mean(first_sun - 1)
    assert {f["yaw_deg"] for f in frames} == {frames[0]["yaw_deg"]}
    assert {f["pitch_deg"] for f in frames} == {frames[0]["pitch_deg"]}
