"""`aquaspec cache info|clear`, and the cache as renders in separate processes see it."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from aquaspec import cache
from aquaspec.cli import main
from aquaspec.cli.cache_cmd import format_size


def test_info_and_clear(monkeypatch, tmp_path, capsys):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
    monkeypatch.setenv(cache.MAX_ENV, "500M")
    for name in ("caustics-1", "lightfield-tables-2"):
        cache.save_arrays(tmp_path / f"{name}.npz", {"x": np.zeros(1000)})
    (tmp_path / "mine.txt").write_text("not aquaspec's")
    size = sum(p.stat().st_size for p in tmp_path.glob("*.npz"))
    assert main(["cache", "info"]) == 0
    assert capsys.readouterr().out.splitlines() == [
        f"directory: {tmp_path}", "files: 2", f"total size: {format_size(size)}",
        "cap: 500.0 MiB (AQUASPEC_CACHE_MAX)"]
    assert main(["cache", "clear"]) == 0
    assert capsys.readouterr().out == f"removed 2 files ({format_size(size)}) from {tmp_path}\n"
    assert [p.name for p in tmp_path.iterdir()] == ["mine.txt"]
    main(["cache", "info"])
    assert "files: 0\ntotal size: 0 bytes\n" in capsys.readouterr().out


def test_info_with_caching_off(monkeypatch, capsys):
    monkeypatch.setenv(cache.CACHE_ENV, "off")
    assert main(["cache", "info"]) == 0
    assert capsys.readouterr().out.startswith("directory: none (caching is off")
    assert main(["cache", "clear"]) == 0
    assert capsys.readouterr().out == "removed 0 files (0 bytes) from caching is off\n"


@pytest.mark.parametrize("action", ["info", "clear"])
def test_a_bad_cap_is_one_line_naming_it(monkeypatch, tmp_path, capsys, action):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
    monkeypatch.setenv(cache.MAX_ENV, "1 gigabyte")
    cache.save_arrays(tmp_path / "a-1.npz", {"x": np.zeros(3)})
    assert main(["cache", action]) == 2
    err = capsys.readouterr().err
    assert err == ("aquaspec cache: error: AQUASPEC_CACHE_MAX='1 gigabyte' is not a size; "
                   "accepted: a number of bytes with an optional K, M, G or T suffix (powers "
                   "of 1024), e.g. 500M or 1G\n")
    assert (tmp_path / "a-1.npz").exists()


@pytest.mark.parametrize("n_bytes, text", [(0, "0 bytes"), (1023, "1023 bytes"),
                                           (1536, "1.5 KiB"), (139 << 20, "139.0 MiB"),
                                           (3 << 30, "3.0 GiB"), (5 << 40, "5.0 TiB")])
def test_format_size(n_bytes, text):
    assert format_size(n_bytes) == text


RENDER = ["render", "--size", "64x36", "--bands", "4"]


def _render(cache_dir, out):
    env = {**os.environ, cache.CACHE_ENV: str(cache_dir)}
    env.pop(cache.MAX_ENV, None)
    return subprocess.Popen([sys.executable, "-m", "aquaspec", *RENDER, "-o", str(out)],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _finish(*runs):
    for run in runs:
        _, err = run.communicate(timeout=600)
        assert run.returncode == 0, err


@pytest.mark.gpu
def test_renders_in_separate_processes_share_the_cache(tmp_path, device):
    """Two renders filling an empty cache at once make identical images; a
    third finds everything there and adds no file (before: each process keyed
    the light-field tables anew and wrote another file)."""
    store = tmp_path / "cache"
    first, second = _render(store, tmp_path / "a.png"), _render(store, tmp_path / "b.png")
    _finish(first, second)
    kept = sorted(p.name for p in store.iterdir())
    assert any(name.startswith("lightfield-tables-") for name in kept)
    _finish(_render(store, tmp_path / "c.png"))
    assert sorted(p.name for p in store.iterdir()) == kept
    a, b, c = (np.asarray(Image.open(tmp_path / f"{n}.png")) for n in "abc")
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a, c)
