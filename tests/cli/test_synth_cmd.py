"""`aquaspec synth`: errors on the command line, and runs killed halfway
(SIGKILL of a worker, then of the driver) then run again: no sample lost,
doubled or half-written."""

from __future__ import annotations

import csv
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from PIL import Image

from aquaspec.cli import main
from aquaspec.io.linear import read_linear
from support.synth_data import make_folder, write_config

PLAN = ('mode = "grid"\nseed = 1\nwater = ["IB", "II", "3C"]\ndepth_m = [3, 6]\nbands = 4\n')


class TestErrors:
    def test_missing_config(self, tmp_path, capsys):
        assert main(["synth", str(tmp_path / "none.toml")]) == 2
        assert "none.toml' cannot be read" in capsys.readouterr().err

    def test_zero_samples(self, tmp_path, capsys):
        make_folder(tmp_path / "data", 1)
        cfg = write_config(tmp_path / "s.toml", plan='mode = "grid"\nwater = []\n')
        assert main(["synth", str(cfg), "--no-progress"]) == 2
        assert "zero samples: [plan] water is an empty list" in capsys.readouterr().err

    def test_missing_depth(self, tmp_path, capsys):
        make_folder(tmp_path / "data", 2, missing=(0,))
        cfg = write_config(tmp_path / "s.toml")
        assert main(["synth", str(cfg)]) == 2
        assert "have no depth map: img000" in capsys.readouterr().err

    def test_bad_workers(self, tmp_path, capsys):
        with pytest.raises(SystemExit):
            main(["synth", "x.toml", "--workers", "0"])
        assert "accepted: 1 or more" in capsys.readouterr().err


def _sidecars(out):
    return sorted((out / "samples").rglob("*.png.json")) if (out / "samples").exists() else []


def _wait_for_sidecars(proc, out, n, timeout_s=240):
    deadline = time.monotonic() + timeout_s
    while len(_sidecars(out)) < n:
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < deadline, "no samples written in time"
        time.sleep(0.05)


def _worker_of(pid):
    """A pool worker (a spawned child running spawn_main, not the resource tracker)."""
    for _ in range(200):
        with open(f"/proc/{pid}/task/{pid}/children") as f:
            for child in f.read().split():
                with open(f"/proc/{child}/cmdline", "rb") as c:
                    cmd = c.read()
                if b"spawn_main" in cmd and b"resource_tracker" not in cmd:
                    return int(child)
        time.sleep(0.05)
    raise AssertionError("no worker process found")


@pytest.mark.gpu
@pytest.mark.slow
def test_killed_runs_resume_without_loss_or_duplicates(tmp_path):
    """SIGKILL a worker, then the driver of the next run, then run to the end."""
    make_folder(tmp_path / "data", 4)
    cfg = write_config(tmp_path / "s.toml", plan=PLAN)          # 4 inputs x 6 = 24 samples
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "aquaspec", "synth", str(cfg), "--no-progress", "--workers", "1"]

    def start():
        return subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                start_new_session=True)
    proc = start()
    try:
        _wait_for_sidecars(proc, out, 3)
        os.kill(_worker_of(proc.pid), signal.SIGKILL)       # a worker, mid-run
        assert proc.wait(timeout=120) == 2
        assert "a worker process died" in proc.stderr.read().decode()
        after_worker = len(_sidecars(out))
        proc = start()
        _wait_for_sidecars(proc, out, after_worker + 3)
        os.kill(proc.pid, signal.SIGKILL)                    # the driver, mid-run
        proc.wait()
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    partial = len(_sidecars(out))
    assert after_worker + 3 <= partial < 24, (after_worker, partial)
    time.sleep(1.5)                                # the orphaned worker ends (local.PARENT_POLL_S)

    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    with open(out / "manifest.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    ids = [r["sample_id"] for r in rows]
    assert len(rows) == 24 and len(set(ids)) == 24
    assert {r["status"] for r in rows} == {"done"}
    assert sorted(p.name for p in _sidecars(out)) == sorted(f"{i}.png.json" for i in ids)
    assert not list(out.rglob("*.part")) and not list(out.rglob(".*"))
    names = {p.name for p in (out / "samples").rglob("*") if p.is_file()}
    assert names == {f"{i}{ext}" for i in ids for ext in (".png", ".png.json", ".exr")}
    for r in rows:
        assert np.asarray(Image.open(out / r["png"])).shape == (48, 64, 3)
        assert np.all(np.isfinite(read_linear(out / r["linear"])))


def test_dry_run_plans_without_rendering(tmp_path, capsys):
    make_folder(tmp_path / "data", 2)
    cfg = write_config(tmp_path / "s.toml", plan=PLAN, extra='manifest = "csv"\n')
    assert main(["synth", str(cfg), "--dry-run"]) == 0
    assert "0 of 12 samples done (0 now, 0 before), 0 failed, 12 pending" in capsys.readouterr().out
    with open(tmp_path / "out" / "manifest.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 12 and {r["status"] for r in rows} == {"pending"}
    assert not (tmp_path / "out" / "samples").exists()
