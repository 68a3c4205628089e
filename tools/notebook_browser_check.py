"""Check docs/live-view.ipynb in a real browser: headless Chromium through Selenium.

The notebook widget (``aquaspec.apps.notebook.notebook_view``: rendercanvas's
jupyter backend, a ``jupyter_rfb`` frame buffer) is tested without a browser
in ``tests/apps/test_notebook.py``; this script runs the example notebook in
Jupyter Notebook 7 in headless Chromium and checks what only a browser shows:

1. the widget cell's output is a 640x360 image within four minutes;
2. the frames keep arriving with a still camera (the image changes within
   five seconds: the waves' clock and the text's frame rate move it);
3. a click into the image and W held for 3 s fly the camera forward (the
   pose cell, run afterwards, gives a z below the start's);
4. a click on the controls panel's collapse arrow opens the panel (the
   screenshot is saved for a person to look at).

It needs what CI does not install: Debian ``chromium`` and
``chromium-driver``, and ``pip install notebook selenium`` beside the
``view`` extra. Screenshots go to OUTDIR. Exit status 0 when 1-3 hold.

Usage::

    python tools/notebook_browser_check.py OUTDIR
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "live-view.ipynb"
PORT, TOKEN = 8899, "aquaspec-check"
WIDGET_WAIT_S = 240


def _shift_enter(drv):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.keys import Keys
    ActionChains(drv).key_down(Keys.SHIFT).send_keys(Keys.ENTER).key_up(Keys.SHIFT).perform()


def _run_cell(drv, index):
    from selenium.webdriver.common.by import By
    drv.find_elements(By.CSS_SELECTOR, ".jp-Cell")[index].click()
    time.sleep(1)
    _shift_enter(drv)


def _widget_image(drv):
    from selenium.webdriver.common.by import By
    t0 = time.time()
    while time.time() - t0 < WIDGET_WAIT_S:
        imgs = drv.find_elements(By.CSS_SELECTOR, ".jp-OutputArea img")
        if imgs and imgs[0].size["width"] > 100:
            return imgs[0], time.time() - t0
        time.sleep(2)
    raise SystemExit(f"no widget image within {WIDGET_WAIT_S} s")


def _pose(drv) -> dict:
    """The dict the pose cell printed (its repr, read back as JSON)."""
    from selenium.webdriver.common.by import By
    for out in reversed(drv.find_elements(By.CSS_SELECTOR, ".jp-OutputArea-output")):
        text = out.text.strip()
        if text.startswith("{'position_m'"):
            return json.loads(text.replace("'", '"'))
    raise SystemExit("the pose cell printed no pose")


def main(outdir: str) -> int:
    from selenium import webdriver
    from selenium.webdriver.common.action_chains import ActionChains
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    shutil.copy(NOTEBOOK, out / NOTEBOOK.name)
    env = {**os.environ, "XDG_RUNTIME_DIR": os.environ.get("XDG_RUNTIME_DIR", "/tmp")}
    server = subprocess.Popen(
        [sys.executable, "-m", "jupyter", "notebook", "--no-browser", f"--port={PORT}",
         f"--IdentityProvider.token={TOKEN}", "--allow-root", f"--ServerApp.root_dir={out}"],
        env=env, stdout=open(out / "server.log", "w"), stderr=subprocess.STDOUT)
    opts = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--window-size=1400,1000", "--disable-gpu"):
        opts.add_argument(arg)
    opts.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    drv = webdriver.Chrome(service=webdriver.ChromeService(shutil.which("chromedriver")),
                           options=opts)
    try:
        time.sleep(6)
        drv.get(f"http://127.0.0.1:{PORT}/notebooks/{NOTEBOOK.name}?token={TOKEN}")
        time.sleep(15)
        _run_cell(drv, 0)                       # the title (markdown)
        _shift_enter(drv)                       # the widget
        img, waited = _widget_image(drv)
        print(f"1. widget image {img.size['width']}x{img.size['height']} after {waited:.0f} s")
        time.sleep(20)                          # the exposure and the first frames
        drv.save_screenshot(str(out / "1-widget.png"))
        digests = []
        for _ in range(5):
            digests.append(hashlib.md5(img.get_attribute("src").encode()).hexdigest())
            time.sleep(1)
        moving = len(set(digests)) > 1
        print(f"2. frames arriving with a still camera: {len(set(digests))} different in 5 s")
        _run_cell(drv, 3)
        time.sleep(8)
        start = _pose(drv)
        drv.execute_script("arguments[0].scrollIntoView({block: 'center'})", img)
        time.sleep(1)
        ActionChains(drv).move_to_element_with_offset(img, -150, 0).click().perform()
        time.sleep(1)
        ActionChains(drv).key_down("w").perform()
        time.sleep(3)
        ActionChains(drv).key_up("w").perform()
        time.sleep(3)
        drv.save_screenshot(str(out / "2-flown.png"))
        _run_cell(drv, 3)
        time.sleep(8)
        flown = _pose(drv)
        dz = flown["position_m"][2] - start["position_m"][2]
        print(f"3. W held 3 s: z {start['position_m'][2]:.2f} -> {flown['position_m'][2]:.2f} m")
        # The panel starts collapsed in a widget narrower than 960 px; its arrow
        # is 31 px right of and 163 px above the image's centre at 640x360.
        drv.execute_script("arguments[0].scrollIntoView({block: 'center'})", img)
        time.sleep(1)
        ActionChains(drv).move_to_element_with_offset(img, 31, -163).click().perform()
        time.sleep(4)
        drv.save_screenshot(str(out / "3-panel.png"))
        print(f"4. panel clicked open: see {out / '3-panel.png'}")
    finally:
        drv.quit()
        server.terminate()
    return 0 if (moving and dz < -1.0) else 1


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    raise SystemExit(main(sys.argv[1]))
