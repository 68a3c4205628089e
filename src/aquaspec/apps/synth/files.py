"""Where a synth sample's files go, and whether a sample is done or failed.

Under the output folder, a sample ``ID`` has::

    samples/ID[:2]/ID.png             the display image (sRGB, 8 bit)
    samples/ID[:2]/ID.exr             linear camera RGB, float32 ([output] linear)
    samples/ID[:2]/ID_layers.exr      the image-formation layers ([output] layers)
    samples/ID[:2]/ID_valid.png       255 where the depth was valid, 0 at holes (if any)
    samples/ID[:2]/ID.png.json        the sidecar: every parameter; written last
    failures/ID.json                  the error of a sample that failed

(256 sub-folders keep a million samples at about 4000 files per folder.)
A sample is done if and only if its sidecar exists: every file is written
under a temporary name and renamed into place, the sidecar after all the
others (:func:`aquaspec.io.save.save_image`), so a sidecar vouches for the
files beside it.
"""

from __future__ import annotations

import json
import os
import socket
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from aquaspec.errors import AquaspecError
from aquaspec.io.sidecar import sidecar_path

SAMPLES_DIR = "samples"
FAILURES_DIR = "failures"
LOCK_NAME = "synth.lock"
#: Temporary files of :mod:`aquaspec.io.atomic` (``.<name>.<random>.part``).
TEMP_PATTERN = ".*.part"


@dataclass(frozen=True)
class SampleFiles:
    """The files of sample ``sample_id`` under the output folder ``root``."""

    root: Path
    sample_id: str

    @property
    def folder(self) -> Path:
        return self.root / SAMPLES_DIR / self.sample_id[:2]

    @property
    def png(self) -> Path:
        return self.folder / f"{self.sample_id}.png"

    @property
    def sidecar(self) -> Path:
        return sidecar_path(self.png)

    @property
    def linear(self) -> Path:
        return self.folder / f"{self.sample_id}.exr"

    @property
    def layers(self) -> Path:
        return self.folder / f"{self.sample_id}_layers.exr"

    @property
    def mask(self) -> Path:
        return self.folder / f"{self.sample_id}_valid.png"

    @property
    def failure(self) -> Path:
        return self.root / FAILURES_DIR / f"{self.sample_id}.json"

    def done(self) -> bool:
        return self.sidecar.is_file()

    def relative(self, path: Path) -> str:
        """``path`` relative to the output folder, with ``/``."""
        return path.relative_to(self.root).as_posix()

    def read_failure(self) -> dict | None:
        """The recorded failure (``error``, ``type``), or None."""
        try:
            return json.loads(self.failure.read_text(encoding="utf-8"))
        except (FileNotFoundError, json.JSONDecodeError):
            return None


def remove_temporaries(root: Path) -> int:
    """Remove the temporary files a killed run left under ``root``'s samples
    and failures (never counted as done); how many there were."""
    n = 0
    for sub in (SAMPLES_DIR, FAILURES_DIR):
        for p in (root / sub).rglob(TEMP_PATTERN):
            try:
                os.unlink(p)
                n += 1
            except FileNotFoundError:
                pass
    return n


@contextmanager
def folder_lock(root: Path):
    """Hold ``root``'s :data:`LOCK_NAME` while a run uses the folder: a second
    run on it (which would remove the first one's temporary files) is
    refused, naming the process. A lock left by a killed run (its process
    gone, on this machine) is taken over."""
    lock = root / LOCK_NAME
    me = {"pid": os.getpid(), "host": socket.gethostname()}
    for _ in range(2):
        try:
            fd = os.open(lock, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
        except FileExistsError:
            holder = _lock_holder(lock)
            if holder is not None and _alive(holder, me["host"]):
                raise AquaspecError(
                    f"output folder {str(root)!r} is in use by another aquaspec synth run "
                    f"(process {holder.get('pid')} on {holder.get('host')}); accepted: one run "
                    f"per folder (remove {LOCK_NAME} if that run is gone)") from None
            lock.unlink(missing_ok=True)
            continue
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(me, f)
        break
    try:
        yield
    finally:
        lock.unlink(missing_ok=True)


def _lock_holder(lock: Path) -> dict | None:
    try:
        return json.loads(lock.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def _alive(holder: dict, host: str) -> bool:
    """Whether the lock's process may still run: another machine's is taken as
    alive; on this one, whether its pid exists."""
    if holder.get("host") != host:
        return True
    try:
        os.kill(int(holder["pid"]), 0)
    except (ProcessLookupError, KeyError, TypeError, ValueError):
        return False
    except PermissionError:
        return True
    return True
