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
from dataclasses import dataclass
from pathlib import Path

from aquaspec.io.sidecar import sidecar_path

SAMPLES_DIR = "samples"
FAILURES_DIR = "failures"
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
