"""`aquaspec view` in a real window: Xvfb, the real entry point, keys from xdotool.

The command runs as a user runs it (``python -m aquaspec view``, a separate
process) in a glfw window on a virtual X server; xdotool focuses the window
and holds W (through the XTEST extension, as a keyboard does), then presses
Escape, which closes it. The run's sidecar (``--record``) says where the
camera went. Skipped, naming what is missing, where Xvfb or xdotool is not
installed (``make setup`` installs them as root) or no X server starts.
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

pytestmark = pytest.mark.gpu

#: Seconds to wait for the server, the window, and the command to finish.
SERVER_WAIT_S, WINDOW_WAIT_S, EXIT_WAIT_S = 10, 240, 120
#: Seconds W is held down.
HOLD_S = 2.0


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


def test_w_key_flies_the_camera_forward(x_display, tmp_path):
    out = tmp_path / "run"
    env = {**os.environ, "DISPLAY": x_display}
    env.pop("RENDERCANVAS_FORCE_OFFSCREEN", None)
    # --frames: a cap, so that the window closes even if Escape is lost.
    view = subprocess.Popen([sys.executable, "-m", "aquaspec", "view", "--size", "160x90",
                             "--bands", "3", "--frames", "5000", "--record", str(out)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        found = _xdotool(x_display, "search", "--sync", "--name", "^aquaspec view",
                         timeout=WINDOW_WAIT_S)
        assert found.returncode == 0, f"no window appeared: {found.stderr}"
        window = found.stdout.split()[0]
        # Let a few frames run, then hold W.
        time.sleep(1.0)
        focus = _xdotool(x_display, "windowfocus", "--sync", window)
        assert focus.returncode == 0, focus.stderr
        _xdotool(x_display, "keydown", "w")
        time.sleep(HOLD_S)
        _xdotool(x_display, "keyup", "w")
        time.sleep(0.5)
        _xdotool(x_display, "key", "Escape")
        stdout, stderr = view.communicate(timeout=EXIT_WAIT_S)
    finally:
        if view.poll() is None:
            view.kill()
            view.communicate()
    assert view.returncode == 0, stderr[-3000:]
    run = json.loads((out / "run.json").read_text())
    assert run["mode"] == "window"
    assert run["frames_drawn"] < 5000, "Escape did not close the window"
    poses = np.array([f["position_m"] for f in run["frames"]])
    # The built-in camera looks along -z, 10 degrees down: W moves it that way.
    start, end = poses[0], poses[-1]
    travelled = end - start
    assert travelled[2] < -0.3, f"the camera did not fly forward: {start} -> {end}"
    assert abs(travelled[0]) < 1e-6
    assert travelled[1] < 0                      # forward is slightly downward
    # It moved while the window drew: the frames' poses change in between.
    assert len({tuple(p) for p in poses}) > 2
    assert "frames (window)" in stdout
