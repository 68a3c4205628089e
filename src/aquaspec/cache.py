"""What aquaspec computes once per machine and keeps: the cache directory.

``$AQUASPEC_CACHE`` if set (``off``: keep nothing), else
``$XDG_CACHE_HOME/aquaspec`` or ``~/.cache/aquaspec``. Files are written to a
temporary name and renamed, so a reader never sees half a file; a file that
cannot be read is computed again, and a cache that cannot be written only
costs the computation next time.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np
import scipy

CACHE_ENV = "AQUASPEC_CACHE"


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


def digest(*parts) -> str:
    """A short hex key of ``parts`` (bytes, str or numbers)."""
    h = hashlib.sha256()
    for p in parts:
        b = p if isinstance(p, bytes) else repr(p).encode()
        h.update(len(b).to_bytes(8, "little"))
        h.update(b)
    return h.hexdigest()[:24]


def load_arrays(path: Path) -> dict | None:
    """The arrays of an ``.npz`` file, or None if it is missing or unreadable."""
    try:
        with np.load(path, allow_pickle=False) as z:
            return {k: z[k] for k in z.files}
    except Exception:   # (missing, truncated, not a zip, ...: all mean "compute it")
        return None


def save_arrays(path: Path, data: dict, *, compressed: bool = False) -> bool:
    """Write ``data`` to ``path`` (``.npz``, zip-deflated if ``compressed``)
    atomically; False if it could not be written."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".part.npz", dir=path.parent)
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


def cached_arrays(name: str, key: str | None, compute) -> dict:
    """``compute()`` (a dict of arrays), kept in ``<cache>/<name>-<key>.npz``
    (``key`` None, e.g. from :func:`code_digest`: computed and not kept)."""
    directory = cache_dir()
    if directory is None or key is None:
        return compute()
    path = directory / f"{name}-{key}.npz"
    found = load_arrays(path)
    if found is not None:
        return found
    data = compute()
    save_arrays(path, data)
    return data


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
    (so a changed file, or a constant set at run time, is never answered
    from an old result), with the versions of NumPy and SciPy. None when a
    module's source cannot be read (then nothing should be cached)."""
    parts = [np.__version__, scipy.__version__]
    for mod in modules:
        try:
            parts.append(Path(mod.__file__).read_bytes())
        except (OSError, TypeError, AttributeError):
            return None
        for name in sorted(vars(mod)):
            if name.isupper() and not name.startswith("_"):
                value = vars(mod)[name]
                parts.append(name)
                parts.append(np.asarray(value).tobytes() if isinstance(value, np.ndarray)
                             else repr(value))
    return digest(*parts)
