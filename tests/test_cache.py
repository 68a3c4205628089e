"""aquaspec's per-machine cache: where it is, and that it never half-writes or breaks a run."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from aquaspec import cache


def test_where(monkeypatch, tmp_path):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path / "mine"))
    assert cache.cache_dir() == tmp_path / "mine"
    monkeypatch.setenv(cache.CACHE_ENV, "OFF")
    assert cache.cache_dir() is None
    monkeypatch.delenv(cache.CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache.cache_dir() == tmp_path / "xdg" / "aquaspec"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache.cache_dir() == tmp_path / "home" / ".cache" / "aquaspec"


def test_computed_once_then_read(monkeypatch, tmp_path):
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
    calls = []

    def compute():
        calls.append(1)
        return {"x": np.arange(5.0)}

    a = cache.cached_arrays("thing", "k1", compute)
    b = cache.cached_arrays("thing", "k1", compute)
    np.testing.assert_array_equal(a["x"], b["x"])
    assert len(calls) == 1
    assert [p.name for p in tmp_path.iterdir()] == ["thing-k1.npz"]
    cache.cached_arrays("thing", "k2", compute)
    assert len(calls) == 2


def test_an_unwritable_cache_only_costs_the_computation(monkeypatch, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("a file where the cache directory would be")
    monkeypatch.setenv(cache.CACHE_ENV, str(blocker / "sub"))
    out = cache.cached_arrays("thing", "k", lambda: {"x": np.ones(3)})
    np.testing.assert_array_equal(out["x"], np.ones(3))


def test_a_failed_write_leaves_no_part_file(monkeypatch, tmp_path):
    def fail(*args, **kwargs):
        raise OSError("disk full")
    monkeypatch.setattr(np, "savez", fail)
    assert not cache.save_arrays(tmp_path / "x.npz", {"x": np.ones(2)})
    assert list(tmp_path.iterdir()) == []


def test_digest_tells_parts_apart():
    assert cache.digest(b"ab", b"c") != cache.digest(b"a", b"bc")
    assert cache.digest(1.0, "x") == cache.digest(1.0, "x")
    assert cache.digest(1.0) != cache.digest(1.0000001)


@pytest.mark.parametrize("content", [b"", b"not a zip", b"PK\x03\x04broken"])
def test_damaged_files_read_as_missing(tmp_path, content):
    path = Path(tmp_path) / "x.npz"
    path.write_bytes(content)
    assert cache.load_arrays(path) is None
