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


def _fused_and_two_pass(shading, width, height, **settings):
    """A shading pass's fused display image and the display pass run on its
    linear output (the pass must have just run without display), same settings."""
    from aquaspec.gpu.display_pass import DisplayPass
    two_pass = DisplayPass(width, height, device=shading.device)
    two_pass.use_input(shading.rgb_buffer)
    two_pass.set_settings(**settings)
    two_pass.run()
    expected = two_pass.read()
    shading.set_display(**settings)
    shading.run(display=True)
    return shading.read_display(), expected


@pytest.fixture
def fused_and_two_pass():
    """``(fused, expected)`` display images of a shading pass (see _fused_and_two_pass)."""
    return _fused_and_two_pass
