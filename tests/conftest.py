"""Shared fixtures: the camspec file (read from ../shared, never copied)."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest

os.environ.setdefault("XDG_RUNTIME_DIR", tempfile.mkdtemp(prefix="aquaspec-xdg-"))

REPO = Path(__file__).resolve().parents[1]
CAMSPEC = REPO.parent / "shared" / "data" / "camspec_database.txt"


@pytest.fixture(scope="session")
def camspec_path():
    """Path of the camspec database; skips (naming the file) where ../shared is absent."""
    if not CAMSPEC.is_file():
        pytest.skip(f"camera database not found: {CAMSPEC} (it is not shipped with aquaspec)")
    return CAMSPEC
