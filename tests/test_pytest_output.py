"""What `make test` prints: skip reasons, and each distinct data warning once."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

#: Two tests that load the same gap-filled water from two places: Jerlov 3C
#: (solonenko2015) has a and Kd filled at 675 and 700 nm, two warnings.
SAMPLE = '''
from aquaspec.medium.water import load_water


def test_one():
    load_water("3C")


def test_two():
    load_water("3C")
'''


def test_each_water_data_warning_once(tmp_path):
    """(Before: one entry per test and call site, about 60 in the suite;
    here four.)"""
    (tmp_path / "test_sample.py").write_text(SAMPLE)
    # The repository's settings and the plugin its tests/conftest.py loads.
    env = {**os.environ, "PYTHONPATH": str(REPO / "tests")}
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider",
         "-p", "support.warnings_once", "-c", str(REPO / "pyproject.toml"),
         "--rootdir", str(REPO), str(tmp_path)],
        capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    shown = re.findall(r"WaterDataWarning: (.*)", done.stdout)
    assert len(shown) == 2 and len(set(shown)) == 2, done.stdout
    assert "2 passed, 2 warnings" in done.stdout


def test_make_test_shows_skip_reasons():
    recipe = re.search(r"^test:.*\n((?:\t.*\n)+)", (REPO / "Makefile").read_text(), re.M)
    assert recipe and re.search(r"pytest .*-rs", recipe.group(1)), "make test lost -rs"


def test_a_test_run_leaves_no_cache_folders(tmp_path):
    """The per-run cache and runtime folders tests/conftest.py makes in the
    temporary directory are removed when the run ends (they were 17-63 MB each
    and stayed behind)."""
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    env = {k: v for k, v in os.environ.items()
           if k not in ("AQUASPEC_CACHE", "XDG_RUNTIME_DIR")}
    env["TMPDIR"] = str(tmp)
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
         str(REPO / "tests" / "test_numerics.py"), "-k", "legendre"],
        capture_output=True, text=True, cwd=REPO, env=env, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert sorted(p.name for p in tmp.iterdir() if p.name.startswith("aquaspec-")) == []
