"""aquaspec's per-machine cache: where it is, and that it never half-writes or breaks a run."""

from __future__ import annotations

import dataclasses
import enum
import functools
import json
import math
import os
import re
import subprocess
import sys
import threading
import types
from pathlib import Path

import numpy as np
import pytest

from aquaspec import cache
from aquaspec.errors import AquaspecError


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


def test_an_interrupted_write_leaves_no_part_file(monkeypatch, tmp_path):
    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(np, "savez", interrupt)
    with pytest.raises(KeyboardInterrupt):
        cache.save_arrays(tmp_path / "x.npz", {"x": np.ones(2)})
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


# --- Keys from values (issue 35, item 1a) --------------------------------------------------

#: A memory address in a repr (``<function f at 0x7f...>``): never part of a key.
ADDRESS = re.compile(r"0x[0-9a-fA-F]{6,}")

#: Run in a fresh process: the keys aquaspec's caches would use for one render's
#: light-field tables and for the code of every aquaspec module, and every key part
#: that holds a memory address.
KEYS_SCRIPT = r"""
import importlib, json, pkgutil, re, sys
import numpy as np
import aquaspec
from aquaspec import cache
from aquaspec.errors import AquaspecError
from aquaspec.colour.bands import Bands
from aquaspec.medium.water import get_water
from aquaspec.transport.lightfield import bake

address = re.compile(r"0x[0-9a-fA-F]{6,}")
unstable = []
digest = cache.digest
def recording_digest(*parts):
    for p in parts:
        text = p.decode("latin-1") if isinstance(p, bytes) else str(p)
        if not isinstance(p, bytes) and address.search(text):
            unstable.append(text[:200])
    return digest(*parts)
cache.digest = recording_digest
if hasattr(cache, "stable_repr"):
    stable_repr = cache.stable_repr
    def recording_stable_repr(value):
        text = stable_repr(value)
        if address.search(text):
            unstable.append(text[:200])
        return text
    cache.stable_repr = recording_stable_repr

for info in pkgutil.walk_packages(aquaspec.__path__, "aquaspec."):
    if ".apps." in info.name or info.name.endswith("__main__"):
        continue
    importlib.import_module(info.name)
keys = {name: cache.code_key(mod) for name, mod in sorted(sys.modules.items())
        if name.startswith("aquaspec.") and getattr(mod, "__file__", None)}

class Stop(Exception):
    pass
def record(name, key, compute):
    keys[name] = key
    raise Stop
cache.cached_arrays = record
water = get_water("IB").on_bands(Bands(8))
for kw in ({}, {"phase": "hg", "g": 0.9, "sun_mu0": 0.8, "sun_fraction": np.full(8, 0.5),
                "cone_spread": True, "forward_cone_deg": 20.0}):
    try:
        bake.lightfield_tables(water, **kw)
    except Stop:
        pass
    keys["tables " + repr(sorted(kw))] = keys.pop("lightfield-tables")
print(json.dumps({"keys": keys, "unstable": unstable}))
"""


def _keys_in_a_fresh_process():
    env = {**os.environ, "XDG_RUNTIME_DIR": os.environ.get("XDG_RUNTIME_DIR", "/tmp")}
    env.pop("PYTHONHASHSEED", None)      # each process its own hash seed, as for a user
    out = subprocess.run([sys.executable, "-c", KEYS_SCRIPT], env=env, capture_output=True,
                         text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def test_keys_are_the_same_in_every_process():
    """The keys of the code of every module, and of the light field's tables,
    come out the same in two fresh processes, and no part holds an address
    (before: a phase dict holding a function and the ambient models' lambdas
    gave the tables a new key, and a new file, in each process)."""
    first, second = _keys_in_a_fresh_process(), _keys_in_a_fresh_process()
    assert first["unstable"] == []
    assert len(first["keys"]) > 50 and "tables []" in first["keys"]
    missing = [name for name, key in first["keys"].items() if key is None]
    assert missing == []
    differ = [name for name in first["keys"] if first["keys"][name] != second["keys"][name]]
    assert differ == []


class TestStableRepr:
    def test_plain_values_are_their_repr(self):
        for value in (1, 2.5, -0.0, "a'b", None, True, b"x", 1 + 2j, Path("/a/b")):
            assert cache.stable_repr(value) == repr(value)

    def test_functions_and_classes_by_qualified_name(self):
        assert cache.stable_repr(math.sqrt) == "math.sqrt"
        assert cache.stable_repr(cache.digest) == "aquaspec.cache.digest"
        assert cache.stable_repr(Path) == "pathlib.Path"
        assert cache.stable_repr(lambda x: x) == (
            f"{__name__}.TestStableRepr.test_functions_and_classes_by_qualified_name"
            ".<locals>.<lambda>")
        assert cache.stable_repr(functools.partial(max, 1, key=abs)) == \
            "functools.partial(builtins.max, (1,), {'key': builtins.abs})"
        assert cache.stable_repr(Path("/x").exists).startswith("PosixPath('/x').exists")

    def test_containers_element_by_element(self):
        assert cache.stable_repr({"f": cache.digest, "n": (1,)}) == \
            "{'f': aquaspec.cache.digest, 'n': (1,)}"
        # Equal dicts and sets give one description, whatever their order.
        assert cache.stable_repr({"b": 1, "a": 2}) == cache.stable_repr({"a": 2, "b": 1})
        assert cache.stable_repr({"z", "y", "x"}) == "{'x', 'y', 'z'}"
        assert cache.stable_repr(frozenset()) == "frozenset()"
        assert cache.stable_repr([1, [2]]) != cache.stable_repr([1, (2,)])

    def test_arrays_by_dtype_shape_and_content(self):
        a = np.arange(6.0)
        assert cache.stable_repr(a) == cache.stable_repr(a.copy())
        assert cache.stable_repr(a) != cache.stable_repr(a.reshape(2, 3))
        assert cache.stable_repr(a) != cache.stable_repr(a.astype(np.float32))
        assert cache.stable_repr(a[::2]) == cache.stable_repr(np.array([0.0, 2.0, 4.0]))
        objects = np.array([cache.digest, None], dtype=object)
        assert not ADDRESS.search(cache.stable_repr(objects))

    def test_enums_and_dataclasses_by_their_fields(self):
        class Kind(enum.IntEnum):
            A = 1

        @dataclasses.dataclass(frozen=True)
        class Point:
            x: float
            f: object

        assert cache.stable_repr(Kind.A).endswith("Kind.A")
        assert cache.stable_repr(Point(1.0, math.sqrt)).endswith("Point(x=1.0, f=math.sqrt)")

    def test_objects_with_an_address_described_by_their_state(self):
        class Thing:
            def __init__(self):
                self.g = 0.9
                self.f = math.sqrt

        assert ADDRESS.search(repr(Thing()))
        text = cache.stable_repr(Thing())
        assert not ADDRESS.search(text) and text == cache.stable_repr(Thing())
        assert text.endswith("Thing(f=math.sqrt, g=0.9)")

    def test_no_stable_description_is_an_error_and_no_key(self):
        with pytest.raises(cache.UnstableKeyError, match="lock"):
            cache.stable_repr(threading.Lock())
        module = types.ModuleType("made_up")
        module.__file__ = cache.__file__
        assert cache.code_key(module) is not None
        module.LOCK = threading.Lock()
        assert cache.code_key(module) is None


# --- The size cap (issue 35, item 1b) ------------------------------------------------------

class TestSizes:
    @pytest.mark.parametrize("text, expected", [
        ("123", 123), ("500M", 500 << 20), ("1G", 1 << 30), ("1.5g", 3 << 29),
        ("2kB", 2048), ("1GiB", 1 << 30), (" 0 ", 0), ("2T", 2 << 40)])
    def test_read(self, text, expected):
        assert cache.parse_size(text) == expected

    @pytest.mark.parametrize("text", ["", "lots", "-1", "1X", "1 G B", "0x10", "1e9"])
    def test_refused(self, text):
        with pytest.raises(ValueError):
            cache.parse_size(text)

    def test_the_cap_from_the_environment(self, monkeypatch):
        monkeypatch.delenv(cache.MAX_ENV, raising=False)
        assert cache.max_bytes() == 1 << 30
        monkeypatch.setenv(cache.MAX_ENV, "")
        assert cache.max_bytes() == 1 << 30
        monkeypatch.setenv(cache.MAX_ENV, "500M")
        assert cache.max_bytes() == 500 << 20

    def test_a_bad_cap_is_an_error_before_the_work(self, monkeypatch, tmp_path):
        monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
        monkeypatch.setenv(cache.MAX_ENV, "lots")
        with pytest.raises(AquaspecError, match=r"^AQUASPEC_CACHE_MAX='lots' is not a size; "
                           r"accepted: .*500M or 1G$"):
            cache.cached_arrays("thing", "k", lambda: pytest.fail("computed"))
        # With caching off, the cap is not asked for.
        monkeypatch.setenv(cache.CACHE_ENV, "off")
        assert cache.cached_arrays("thing", "k", lambda: {"x": np.ones(1)})["x"] == 1


def _entry(directory, name, used_s, n_bytes=4000):
    """A cache file of about ``n_bytes`` last used at ``used_s`` (seconds since the epoch)."""
    path = directory / f"{name}.npz"
    assert cache.save_arrays(path, {"x": np.zeros(n_bytes // 8)})
    os.utime(path, (used_s, used_s))
    return path


class TestEviction:
    def test_least_recently_used_go_first_and_reads_count(self, monkeypatch, tmp_path):
        a, b = _entry(tmp_path, "a-1", 1000), _entry(tmp_path, "b-1", 2000)
        size = a.stat().st_size
        assert cache.load_arrays(a) is not None          # a is used now: b is the oldest
        assert a.stat().st_mtime > 2000 and b.stat().st_mtime == 2000
        monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
        monkeypatch.setenv(cache.MAX_ENV, str(2 * size + 100))
        cache.cached_arrays("c", "1", lambda: {"x": np.zeros(500)})
        assert sorted(p.name for p in tmp_path.iterdir()) == ["a-1.npz", "c-1.npz"]

    def test_under_the_cap_nothing_goes(self, tmp_path):
        paths = [_entry(tmp_path, f"e-{i}", 1000 + i) for i in range(3)]
        sizes = [p.stat().st_size for p in paths]
        assert cache.evict(tmp_path, sum(sizes)) == 0
        assert cache.evict(tmp_path, sum(sizes) - 1) == sizes[0]
        assert [p.exists() for p in paths] == [False, True, True]
        assert cache.evict(tmp_path, 0) == sizes[1] + sizes[2]
        assert list(tmp_path.iterdir()) == []

    def test_stale_temporaries_go_and_fresh_ones_stay(self, tmp_path):
        old, new = tmp_path / "x.npz.1.part.npz", tmp_path / "y.npz.2.part.npz"
        for p in (old, new):
            p.write_bytes(b"partial")
        os.utime(old, (1000, 1000))
        cache.evict(tmp_path, 10 ** 9)
        assert not old.exists() and new.exists()

    def test_files_vanishing_meanwhile_are_no_error(self, monkeypatch, tmp_path):
        real = _entry(tmp_path, "r-1", 2000)
        size = real.stat().st_size
        ghost = cache.CacheFile(tmp_path / "gone-1.npz", 10 ** 6, 1)     # listed, then removed
        monkeypatch.setattr(cache, "cache_files", lambda d: [
            ghost, cache.CacheFile(real, size, 2 * 10 ** 12)])
        assert cache.evict(tmp_path, 0) == size
        assert not real.exists()
        monkeypatch.undo()
        assert cache.load_arrays(ghost.path) is None

    def test_only_aquaspecs_files_count_and_are_cleared(self, monkeypatch, tmp_path):
        mine = [_entry(tmp_path, "a-1", 1000), tmp_path / "b-1.npz.x.part.npz"]
        mine[1].write_bytes(b"part")
        (tmp_path / "reference").mkdir()
        mine.append(_entry(tmp_path / "reference", "0123", 1000))
        others = [tmp_path / "notes.txt", tmp_path / "reference" / "x.png",
                  tmp_path / "a" / "b" / "deep.npz"]
        for p in others:
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_bytes(b"not aquaspec's")
        monkeypatch.setenv(cache.CACHE_ENV, str(tmp_path))
        monkeypatch.setenv(cache.MAX_ENV, "1M")
        info = cache.usage()
        assert (info.directory, info.files, info.cap_bytes) == (tmp_path, 3, 1 << 20)
        assert info.size_bytes == sum(p.stat().st_size for p in mine)
        assert cache.clear() == (3, info.size_bytes)
        assert not any(p.exists() for p in mine) and all(p.exists() for p in others)
        monkeypatch.setenv(cache.CACHE_ENV, "off")
        assert cache.clear() == (0, 0) and cache.usage().directory is None


#: Run in a fresh process: fill the cache in ``sys.argv[1]`` (cap 60 000 bytes)
#: with 30 entries of about 8 KB, half of their keys shared with the other
#: process, each checked when it comes back; "ok" at the end.
FILL_SCRIPT = r"""
import os, sys
import numpy as np
from aquaspec import cache
from aquaspec.errors import AquaspecError
os.environ[cache.CACHE_ENV] = sys.argv[1]
os.environ[cache.MAX_ENV] = "60000"
for i in range(30):
    key = f"{i}" if i % 2 else f"{i}-{sys.argv[2]}"
    for _ in range(2):
        out = cache.cached_arrays("fill", key, lambda: {"x": np.full(1000, float(i))})
        assert out["x"].shape == (1000,) and (out["x"] == i).all(), (i, out["x"])
print("ok")
"""


def test_two_processes_writing_and_evicting_at_once(tmp_path):
    """Both processes get every value right, no temporary is left, and the
    cache ends under its cap."""
    runs = [subprocess.Popen([sys.executable, "-c", FILL_SCRIPT, str(tmp_path), name],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            for name in ("p", "q")]
    outs = [run.communicate(timeout=300) for run in runs]
    assert [(run.returncode, out) for run, (out, _) in zip(runs, outs)] == [(0, "ok\n")] * 2, \
        [err for _, err in outs]
    files = cache.cache_files(tmp_path)
    assert files and not any(f.unfinished for f in files)
    assert sum(f.size_bytes for f in files) <= 60000
