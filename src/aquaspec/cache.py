"""What aquaspec computes once per machine and keeps: the cache directory.

``$AQUASPEC_CACHE`` if set and not empty (``off``: keep nothing), else
``$XDG_CACHE_HOME/aquaspec`` or ``~/.cache/aquaspec``. Files are written to a
temporary name and renamed, so a reader never sees half a file; a file that
cannot be read is computed again, and a cache that cannot be written only
costs the computation next time.

Keys are made from values (:func:`stable_repr`), never from a ``repr`` that
holds a memory address, so every process finds what an earlier one kept.

The cache holds at most ``$AQUASPEC_CACHE_MAX`` bytes (:func:`max_bytes`,
default 1G): after each write the least recently used files are removed
(reading a file counts as a use), so concurrent processes may write and evict
at once; a file removed under a reader only means computing it again.
``aquaspec cache info|clear`` shows and empties it.
"""

from __future__ import annotations

import dataclasses
import enum
import functools
import hashlib
import os
import re
import tempfile
import time
import types
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
import scipy

from aquaspec.errors import AquaspecError

CACHE_ENV = "AQUASPEC_CACHE"
MAX_ENV = "AQUASPEC_CACHE_MAX"
#: The cache's size cap when ``$AQUASPEC_CACHE_MAX`` is not set.
DEFAULT_MAX = "1G"
#: Suffixes of ``$AQUASPEC_CACHE_MAX``: powers of 1024.
SIZE_UNITS = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}
#: A temporary file of an unfinished write older than this (seconds) was left
#: by a process that died while writing: eviction removes it.
STALE_PART_S = 3600.0

_PART = ".part.npz"
_SIZE = re.compile(r"\s*(\d+(?:\.\d*)?|\.\d+)\s*([KMGT]?)(?:I?B)?\s*", re.IGNORECASE)
#: A memory address in a ``repr`` (``<function f at 0x7f...>``).
_ADDRESS = re.compile(r"0x[0-9a-fA-F]{6,}")
_PLAIN = (type(None), bool, int, float, complex, str, bytes)
_MAX_NESTING = 32


def cache_dir() -> Path | None:
    """The cache directory (None: caching is off)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return None if env.lower() == "off" else Path(env)
    base = os.environ.get("XDG_CACHE_HOME")
    if not base:
        try:
            base = str(Path.home() / ".cache")
        except RuntimeError:    # no home directory to be found: no cache
            return None
    return Path(base) / "aquaspec"


# --- Keys ----------------------------------------------------------------------------------

class UnstableKeyError(TypeError):
    """A value with no description that is the same in every process."""


def stable_repr(value) -> str:
    """A description of ``value`` that is the same in every process.

    ``repr`` for plain values (numbers, strings, bytes, None, paths, ...);
    containers element by element (dict items and set elements sorted, so
    neither insertion order nor hash randomisation changes it); arrays by
    dtype, shape and a hash of their content; functions, classes and methods
    by qualified name; enum members by name; dataclasses field by field; any
    other object whose ``repr`` holds a memory address by its type and its
    attributes.

    Raises
    ------
    UnstableKeyError
        For a value with no such description (an address in its ``repr`` and
        no attributes, or nesting deeper than 32).
    """
    return _stable(value, 0)


def _stable(value, depth: int) -> str:
    if depth > _MAX_NESTING:
        raise UnstableKeyError(f"value nested deeper than {_MAX_NESTING} levels: "
                               f"{type(value).__qualname__}")
    inner = functools.partial(_stable, depth=depth + 1)
    if isinstance(value, enum.Enum):
        return f"{_qualified(type(value))}.{value.name}"
    if type(value) in _PLAIN:
        return repr(value)
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            content = inner(value.tolist())
        else:
            content = hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest()
        return f"array(dtype={value.dtype.str!r}, shape={value.shape}, content={content})"
    if isinstance(value, (list, tuple)):
        items = [inner(v) for v in value]
        if isinstance(value, list):
            return "[" + ", ".join(items) + "]"
        return "(" + ", ".join(items) + ("," if len(items) == 1 else "") + ")"
    if isinstance(value, dict):
        items = sorted(f"{inner(k)}: {inner(v)}" for k, v in value.items())
        return "{" + ", ".join(items) + "}"
    if isinstance(value, (set, frozenset)):
        items = sorted(inner(v) for v in value)
        if not items:
            return f"{type(value).__name__}()"
        text = "{" + ", ".join(items) + "}"
        return text if isinstance(value, set) else f"frozenset({text})"
    if isinstance(value, (type, types.FunctionType, types.BuiltinFunctionType)):
        owner = getattr(value, "__self__", None)
        if owner is not None and not isinstance(owner, (type, types.ModuleType)):
            return f"{inner(owner)}.{value.__name__}"     # a bound built-in method
        return _qualified(value)
    if isinstance(value, types.MethodType):
        return f"{inner(value.__self__)}.{value.__name__}"
    if isinstance(value, functools.partial):
        return (f"functools.partial({inner(value.func)}, {inner(value.args)}, "
                f"{inner(value.keywords)})")
    if dataclasses.is_dataclass(value):
        fields = ", ".join(f"{f.name}={inner(getattr(value, f.name))}"
                           for f in dataclasses.fields(value))
        return f"{_qualified(type(value))}({fields})"
    text = repr(value)
    if not _ADDRESS.search(text):
        return text
    state = getattr(value, "__dict__", None)
    if not state:
        raise UnstableKeyError(f"no stable description of {text[:80]} (its repr holds a "
                               "memory address and it has no attributes)")
    fields = ", ".join(f"{name}={inner(state[name])}" for name in sorted(state))
    return f"{_qualified(type(value))}({fields})"


def _qualified(obj) -> str:
    return f"{getattr(obj, '__module__', None) or '?'}.{obj.__qualname__}"


def digest(*parts) -> str:
    """A short hex key of ``parts`` (bytes as they are, anything else by
    :func:`stable_repr`)."""
    h = hashlib.sha256()
    for p in parts:
        b = p if isinstance(p, bytes) else stable_repr(p).encode()
        h.update(len(b).to_bytes(8, "little"))
        h.update(b)
    return h.hexdigest()[:24]


def package_version(distribution: str) -> str:
    """The installed version of a package (``"unknown"`` if it is not
    installed), for keys of results computed from its data."""
    try:
        return version(distribution)
    except PackageNotFoundError:
        return "unknown"


def code_digest(modules, *parts) -> str | None:
    """A cache key of ``parts`` and of the code of ``modules`` (:func:`code_key`);
    None when that code cannot be read (then nothing should be cached)."""
    code = code_key(*modules)
    return None if code is None else digest(code, *parts)


def code_key(*modules) -> str | None:
    """A key of the code behind a cached result: the source files of
    ``modules`` and the values of their module-level UPPERCASE constants
    (:func:`stable_repr`: so a changed file, or a constant set at run time, is
    never answered from an old result), with the versions of NumPy and SciPy.
    None when a module's source cannot be read or a constant has no stable
    description (then nothing should be cached)."""
    parts = [np.__version__, scipy.__version__]
    for mod in modules:
        try:
            parts.append(Path(mod.__file__).read_bytes())
        except (OSError, TypeError, AttributeError):
            return None
        for name in sorted(vars(mod)):
            if name.isupper() and not name.startswith("_"):
                try:
                    parts += [name, stable_repr(vars(mod)[name])]
                except UnstableKeyError:
                    return None
    return digest(*parts)


# --- Files ---------------------------------------------------------------------------------

def load_arrays(path: Path) -> dict | None:
    """The arrays of an ``.npz`` file, or None if it is missing or unreadable.
    Reading it marks it as used (its times set to now), for :func:`evict`."""
    try:
        with np.load(path, allow_pickle=False) as z:
            found = {k: z[k] for k in z.files}
    except Exception:   # (missing, truncated, not a zip, ...: all mean "compute it")
        return None
    try:
        os.utime(path)
    except OSError:     # removed meanwhile, or a read-only cache: still a result
        pass
    return found


def save_arrays(path: Path, data: dict, *, compressed: bool = False) -> bool:
    """Write ``data`` to ``path`` (``.npz``, zip-deflated if ``compressed``)
    atomically; False if it could not be written. Interrupted (Ctrl-C), it
    leaves no temporary file behind."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=_PART, dir=path.parent)
    except OSError:
        return False
    os.close(fd)
    try:
        (np.savez_compressed if compressed else np.savez)(tmp, **data)
        os.replace(tmp, path)
        return True
    except OSError:
        Path(tmp).unlink(missing_ok=True)
        return False
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def cached_arrays(name: str, key: str | None, compute) -> dict:
    """``compute()`` (a dict of arrays), kept in ``<cache>/<name>-<key>.npz``
    (``key`` None, e.g. from :func:`code_digest`: computed and not kept);
    after writing, the cache is brought under its cap (:func:`evict`)."""
    directory = cache_dir()
    if directory is None or key is None:
        return compute()
    cap = max_bytes()       # a bad $AQUASPEC_CACHE_MAX is an error before the work
    path = directory / f"{name}-{key}.npz"
    found = load_arrays(path)
    if found is not None:
        return found
    data = compute()
    if save_arrays(path, data):
        evict(directory, cap)
    return data


# --- Size: the cap, eviction, info and clearing ---------------------------------------------

def parse_size(text: str) -> int:
    """Bytes from ``"1073741824"``, ``"500M"``, ``"1.5G"`` (K, M, G, T: powers
    of 1024; a trailing ``B`` or ``iB`` is allowed)."""
    match = _SIZE.fullmatch(text)
    if match is None:
        raise ValueError(text)
    return int(float(match.group(1)) * SIZE_UNITS[match.group(2).upper()])


def max_bytes() -> int:
    """The cache's size cap in bytes: ``$AQUASPEC_CACHE_MAX`` (empty or unset:
    :data:`DEFAULT_MAX`)."""
    raw = os.environ.get(MAX_ENV) or DEFAULT_MAX
    try:
        return parse_size(raw)
    except ValueError:
        raise AquaspecError(f"{MAX_ENV}={raw!r} is not a size; accepted: a number of bytes "
                            "with an optional K, M, G or T suffix (powers of 1024), "
                            "e.g. 500M or 1G") from None


@dataclasses.dataclass(frozen=True)
class CacheFile:
    """One of aquaspec's files in the cache directory."""

    path: Path
    size_bytes: int
    #: When it was last written or read (``st_mtime_ns``).
    used_ns: int

    @property
    def unfinished(self) -> bool:
        """A temporary file of a write not (yet) finished."""
        return self.path.name.endswith(_PART)


def cache_files(directory: Path) -> list[CacheFile]:
    """aquaspec's files in ``directory``: the ``.npz`` files in it and in its
    folders (the validation's ``reference``), with the temporaries of
    unfinished writes; a file removed while listing is left out."""
    found = []
    for path in [*Path(directory).glob("*.npz"), *Path(directory).glob("*/*.npz")]:
        try:
            st = path.stat()
        except OSError:
            continue
        found.append(CacheFile(path, st.st_size, st.st_mtime_ns))
    return found


def _remove(path: Path) -> bool:
    try:
        path.unlink()
        return True
    except OSError:     # removed by another process first, or not ours to remove
        return False


def evict(directory: Path, cap_bytes: int) -> int:
    """Remove the least recently used files of ``directory`` until the rest
    hold at most ``cap_bytes`` (the newest too, if it alone is larger), and
    temporaries older than :data:`STALE_PART_S`; the bytes removed. Safe
    while other processes read, write and evict: a file that vanishes is
    skipped, and files only ever appear whole (written under another name)."""
    files = cache_files(directory)
    stale_ns = time.time_ns() - int(STALE_PART_S * 1e9)
    removed = sum(f.size_bytes for f in files
                  if f.unfinished and f.used_ns < stale_ns and _remove(f.path))
    done = sorted((f for f in files if not f.unfinished), key=lambda f: (f.used_ns, f.path))
    total = sum(f.size_bytes for f in done)
    for f in done:
        if total <= cap_bytes:
            break
        total -= f.size_bytes
        if _remove(f.path):
            removed += f.size_bytes
    return removed


@dataclasses.dataclass(frozen=True)
class CacheUsage:
    """What the cache holds (:func:`usage`)."""

    #: None: caching is off (``AQUASPEC_CACHE=off`` or no home directory).
    directory: Path | None
    files: int
    size_bytes: int
    cap_bytes: int


def usage() -> CacheUsage:
    """The cache's directory, its number of files and their size, and its cap."""
    cap = max_bytes()
    directory = cache_dir()
    files = [] if directory is None else cache_files(directory)
    return CacheUsage(directory, len(files), sum(f.size_bytes for f in files), cap)


def clear() -> tuple[int, int]:
    """Remove aquaspec's files from the cache directory (:func:`cache_files`;
    nothing else there); ``(files, bytes)`` removed."""
    directory = cache_dir()
    if directory is None:
        return 0, 0
    gone = [f for f in cache_files(directory) if _remove(f.path)]
    return len(gone), sum(f.size_bytes for f in gone)
