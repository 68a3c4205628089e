"""Atomic file writes: a reader never sees a half-written file.

Every file is written atomically: the bytes go to a temporary file in the
destination directory (``.<name>.<random>.part``), are flushed to disk with
``fsync``, and only then renamed over the destination with ``os.replace``,
which is atomic on POSIX and Windows within one file system. If anything
fails, the temporary file is removed, so a reader never sees a half-written
file and an old file is either intact or fully replaced.
:func:`write_atomically` stages *all* its files before renaming any of them,
so an error in one leaves none of the new files behind
(:func:`aquaspec.io.save.save_image` writes an image's set that way).

A bad destination (missing or unwritable directory, a directory in place of
the file, an unsupported suffix) is an :class:`AquaspecError` naming the
path; call :func:`check_writable` before rendering so no work is wasted.
"""

from __future__ import annotations

import os
import secrets
from pathlib import Path

from aquaspec.errors import AquaspecError


def check_writable(path, *, suffixes=None) -> Path:
    """Check that ``path`` can be written, before any rendering happens.

    Parameters
    ----------
    path : str or os.PathLike
        The output file.
    suffixes : sequence of str, optional
        Accepted file suffixes (lower case, with the dot), e.g. ``(".png",)``.

    Returns
    -------
    pathlib.Path
        ``path`` made absolute.

    Raises
    ------
    AquaspecError
        The suffix is not accepted, ``path`` is a directory, or its directory
        does not exist or cannot be written (tested by creating and removing
        a probe file, which is right even for root and network file systems,
        unlike ``os.access``).
    """
    try:
        p = Path(os.fspath(path)).expanduser().absolute()
    except TypeError as exc:
        raise AquaspecError(f"output path {path!r} is not a file path") from exc
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise AquaspecError(f"output file {str(p)!r} has suffix {p.suffix!r}; accepted: "
                            + ", ".join(suffixes))
    if p.is_dir():
        raise AquaspecError(f"output path {str(p)!r} is a directory; give a file name")
    parent = p.parent
    if not parent.exists():
        raise AquaspecError(f"output directory {str(parent)!r} does not exist; "
                            "create it first")
    if not parent.is_dir():
        raise AquaspecError(f"output directory {str(parent)!r} is not a directory")
    probe = parent / f".{p.name}.{secrets.token_hex(6)}.probe"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as exc:
        raise AquaspecError(f"output directory {str(parent)!r} is not writable "
                            f"({exc.strerror or exc}); choose another place") from exc
    os.close(fd)
    os.unlink(probe)
    return p


def _fsync_path(path, directory=False):
    flags = os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0)
    try:
        fd = os.open(path, flags)
    except OSError:
        if directory:       # some platforms cannot open directories; data is synced
            return
        raise
    try:
        os.fsync(fd)
    except OSError:
        if not directory:
            raise
    finally:
        os.close(fd)


class _Staged:
    """A temporary file beside ``final`` that becomes ``final`` on commit."""

    def __init__(self, final: Path):
        self.final = final
        self.tmp = final.parent / f".{final.name}.{secrets.token_hex(6)}.part"
        # O_EXCL: never write through a link or over someone else's file;
        # mode 0o666 lets the umask decide the final permissions as for open().
        os.close(os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))

    def discard(self):
        try:
            os.unlink(self.tmp)
        except FileNotFoundError:
            pass


def write_atomically(jobs) -> None:
    """Write ``[(final_path, writer)]``, all or none; ``writer(tmp_path)`` fills one file.

    All files are written and synced to temporary names first; only if every
    writer succeeded are they renamed into place (``final_path`` as returned
    by :func:`check_writable`).
    """
    staged = []
    try:
        for final, writer in jobs:
            s = _Staged(final)
            staged.append(s)
            writer(str(s.tmp))
            _fsync_path(s.tmp)
    except BaseException:
        for s in staged:
            s.discard()
        raise
    for s in staged:
        os.replace(s.tmp, s.final)
    for parent in {s.final.parent for s in staged}:
        _fsync_path(parent, directory=True)


def write_file_atomically(path, writer) -> Path:
    """Write one file through ``writer(tmp_path)``, then rename it to ``path``.

    Nothing is left at ``path`` (or beside it) if ``writer`` fails.
    """
    final = check_writable(path)
    write_atomically([(final, writer)])
    return final
