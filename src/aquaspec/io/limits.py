"""Resource limits: the size of input files and the memory a job may take.

Both are checked before the work starts, so a wrong file or an oversized
render fails in a second with the numbers, instead of minutes later (or by
the kernel's out-of-memory killer).

Files
-----
Each input format has a stated ceiling (:data:`MAX_FILE_BYTES`), far above
any real file of that kind: the camspec database is 25 KB, a spectrum CSV a
few KB, a scanned mesh tens of MB. A file over its ceiling is refused by
:func:`check_file_size` before it is parsed. ``AQUASPEC_MAX_FILE_MB`` (a
number of MB) replaces every ceiling, for the rare real file that is larger.
Text formats are read by :func:`read_text`, which also refuses binary
files (NUL bytes, or bytes that are not UTF-8) naming the file.

Memory
------
:func:`available_memory_bytes` reads ``MemAvailable`` from
``/proc/meminfo`` (Linux), else ``os.sysconf`` (available physical pages),
else gives None (unknown: nothing is refused). :func:`check_memory` refuses
an estimate above :data:`MEMORY_FRACTION` of it; the estimates themselves
belong to the code that allocates (e.g.
:func:`aquaspec.rendering.limits.render_memory_bytes`).
``AQUASPEC_MEMORY_LIMIT_MB`` replaces the available memory (a smaller budget
on a shared machine, or a larger one to override the check).
"""

from __future__ import annotations

import os

from aquaspec.errors import AquaspecError

_MB = 1024 * 1024

#: Ceiling on each input format's file size, bytes.
MAX_FILE_BYTES = {
    "csv": 50 * _MB,        # water, sensor and reflectance spectra
    "camspec": 50 * _MB,    # the camspec database (the real one is 25 KB)
    "mesh": 1024 * _MB,     # OBJ/PLY/glTF/GLB/STL/OFF (trimesh needs ~10x in memory)
    "image": 512 * _MB,     # the colour image of an RGB-D pair
    "depth": 1024 * _MB,    # its depth map (PNG, NPY, EXR)
    "script": 10 * _MB,     # a flight script (JSON keyframes; a real one is a few KB)
    "bathymetry": 512 * _MB,  # a depth grid (ASC, NPY, CSV, PNG; 4096^2 as ASC is ~150 MB)
}

#: Share of the available memory a job's estimate may take.
MEMORY_FRACTION = 0.8

_FILE_ENV = "AQUASPEC_MAX_FILE_MB"
_MEMORY_ENV = "AQUASPEC_MEMORY_LIMIT_MB"


def _env_mb(name: str):
    """A positive number of MB from environment variable ``name`` in bytes, or None."""
    text = os.environ.get(name)
    if text is None or not text.strip():
        return None
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not value > 0 or value == float("inf"):
        raise AquaspecError(f"{name}={text!r}; accepted: a positive number of MB")
    return int(value * _MB)


def format_bytes(n: float) -> str:
    """``n`` bytes as a short human-readable size (``"1.5 GB"``)."""
    for unit, size in (("GB", 1024 ** 3), ("MB", _MB), ("KB", 1024)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{int(n)} bytes"


def max_file_bytes(kind: str) -> int:
    """The size ceiling of input files of ``kind`` (a key of :data:`MAX_FILE_BYTES`)."""
    override = _env_mb(_FILE_ENV)
    return override if override is not None else MAX_FILE_BYTES[kind]


def check_file_size(path, kind: str, what: str) -> int:
    """The size of ``path`` in bytes; an error naming size and limit when it
    exceeds the ceiling of ``kind``."""
    size = os.path.getsize(path)
    limit = max_file_bytes(kind)
    if size > limit:
        raise AquaspecError(
            f"{what} {os.fspath(path)!r} is {format_bytes(size)}, above the limit of "
            f"{format_bytes(limit)} for {kind} files; is it the right file? (set "
            f"{_FILE_ENV} to raise the limit)")
    return size


def check_input_file(path, formats, what: str, kind: str):
    """``(path, suffix)`` of an input file that exists, has one of the
    suffixes ``formats`` (lower case, with the dot) and is within the size
    ceiling of ``kind``; else an error naming the file and what is accepted."""
    path = os.fspath(path)
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in formats:
        raise AquaspecError(f"{what} {path!r} has suffix {suffix!r}; accepted: "
                            f"{', '.join(formats)}")
    if not os.path.isfile(path):
        raise AquaspecError(f"{what} {path!r} does not exist")
    check_file_size(path, kind, what)
    return path, suffix


def read_text(path, kind: str, what: str, *, errors: str = "strict") -> str:
    """The text of ``path`` (UTF-8, a BOM allowed) after the size check.

    Raises
    ------
    AquaspecError
        Missing file, a file over the size ceiling of ``kind``, a binary file
        (NUL bytes) or, with ``errors="strict"``, bytes that are not UTF-8;
        the message names the file.
    """
    p = os.fspath(path)
    if not os.path.isfile(p):
        raise AquaspecError(f"{what} {p!r} does not exist")
    check_file_size(p, kind, what)
    with open(p, "rb") as f:
        data = f.read()
    if b"\x00" in data:
        at = data.index(b"\x00")
        raise AquaspecError(f"{what} {p!r} is a binary file (a NUL byte at offset {at}); "
                            "expected a text file")
    try:
        return data.decode("utf-8-sig", errors=errors)
    except UnicodeDecodeError as exc:
        raise AquaspecError(f"{what} {p!r} is not UTF-8 text (byte 0x{data[exc.start]:02x} at "
                            f"offset {exc.start}); expected a text file saved as UTF-8"
                            ) from None


def available_memory_bytes() -> int | None:
    """Memory available to a new job, bytes (None: unknown).

    ``AQUASPEC_MEMORY_LIMIT_MB`` if set, else ``MemAvailable`` of
    ``/proc/meminfo``, else available physical pages x page size.
    """
    override = _env_mb(_MEMORY_ENV)
    if override is not None:
        return override
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return int(os.sysconf("SC_AVPHYS_PAGES")) * int(os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        return None


def check_memory(estimate_bytes: float, what: str, advice: str,
                 available: int | None = None) -> None:
    """Refuse a job whose memory estimate exceeds :data:`MEMORY_FRACTION` of
    the available memory (``available``, else :func:`available_memory_bytes`).

    The message gives the estimate, the available memory and ``advice``
    (what to change).
    """
    if available is None:
        available = available_memory_bytes()
    if available is None:
        return
    budget = MEMORY_FRACTION * available
    if estimate_bytes > budget:
        raise AquaspecError(
            f"{what} needs about {format_bytes(estimate_bytes)} of memory, more than the "
            f"{format_bytes(budget)} this machine can give ({MEMORY_FRACTION:.0%} of "
            f"{format_bytes(available)} available); {advice} (or set {_MEMORY_ENV})")
