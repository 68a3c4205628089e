"""aquaspec's per-machine cache: where it is, and that it never half-writes or breaks a run."""

from __future__ import annotations

import types
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
    # No key (code that cannot be read, cache.code_digest): computed each time, never kept.
    cache.cached_arrays("thing", None, compute)
    cache.cached_arrays("thing", None, compute)
    assert len(calls) == 4 and len(list(tmp_path.iterdir())) == 2
    assert cache.code_digest([types.ModuleType("made_up")], 1) is None
    assert cache.code_digest([cache], 1) != cache.code_digest([cache], 2)


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


def test_code_key_follows_source_and_constants(monkeypatch):
    import types

    from aquaspec.transport.lightfield import compiled as lfc
    key = cache.code_key(lfc)
    assert key is not None and key == cache.code_key(lfc)
    monkeypatch.setattr(lfc, "ALS_SWEEPS", lfc.ALS_SWEEPS + 1)
    assert cache.code_key(lfc) != key
    # A module without a source file: nothing to key on.
    assert cache.code_key(types.ModuleType("made_up")) is None


def test_lightfield_tables_kept(monkeypatch, tmp_path):
    from aquaspec.transport.lightfield import bake as lightfield
    from aquaspec.transport.lightfield import cone
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import get_water
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
    water = get_water("II").on_bands(Bands(4))
    kw = dict(phase="hg", g=0.9, n_depth=8, n_mu=9)
    first = lightfield.lightfield_tables(water, **kw).to_arrays()
    assert len(list(tmp_path.glob("lightfield-tables-*.npz"))) == 1
    computed = lightfield.bake_tables
    monkeypatch.setattr(lightfield, "bake_tables",
                        lambda *a, **k: pytest.fail("computed again"))
    again = lightfield.lightfield_tables(water, **kw).to_arrays()
    assert again.keys() == first.keys()
    for name in first:
        assert again[name].dtype == first[name].dtype
        np.testing.assert_array_equal(again[name], first[name])
    # Other arguments, or another constant of the code, are another entry.
    monkeypatch.setattr(lightfield, "bake_tables", computed)
    other = lightfield.lightfield_tables(water, **{**kw, "g": 0.8}).to_arrays()
    assert not np.array_equal(other["irradiance_per_e0"], first["irradiance_per_e0"])
    monkeypatch.setattr(cone, "CONE_OFFSET_SAMPLES", cone.CONE_OFFSET_SAMPLES + 1)
    lightfield.lightfield_tables(water, **kw)
    assert len(list(tmp_path.glob("lightfield-tables-*.npz"))) == 3


def test_irradiance_factors_kept(monkeypatch, tmp_path):
    from aquaspec.transport.lightfield import bake as lightfield
    from aquaspec.transport.lightfield import compiled as lfc
    from aquaspec.colour.bands import Bands
    from aquaspec.medium.water import get_water
    monkeypatch.setenv(cache.CACHE_ENV, "off")
    tables = lightfield.lightfield_tables(get_water("IB").on_bands(Bands(12)), n_depth=16,
                                          n_mu=17)
    direct = lfc.choose_irradiance_factors(tables)
    monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
    first = lfc.choose_irradiance_factors(tables)
    second = lfc.choose_irradiance_factors(tables)
    for fac in (first, second):
        np.testing.assert_array_equal(fac["coef"], direct["coef"])
        np.testing.assert_array_equal(fac["basis"], direct["basis"])
        assert fac["max_error"] == direct["max_error"]
        assert isinstance(fac["rms_error"], float)
    # The ranks tried are part of the key.
    monkeypatch.setattr(lfc, "IRRADIANCE_RANKS", (8,))
    assert lfc.choose_irradiance_factors(tables)["coef"].shape[1] == 10
