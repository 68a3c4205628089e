"""Shared fixtures: the camspec file (read from ../shared, never copied)."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

import pytest

# Each distinct data warning once in the warnings summary, not once per test.
pytest_plugins = ["support.warnings_once"]

# What aquaspec caches per machine goes to a directory of this test run, CLI
# subprocesses included, not to the user's cache; the directories this run made
# are removed when it ends.
_MADE = {}
for _var, _prefix in (("XDG_RUNTIME_DIR", "aquaspec-xdg-"), ("AQUASPEC_CACHE", "aquaspec-cache-")):
    if _var not in os.environ:
        os.environ[_var] = _MADE[_var] = tempfile.mkdtemp(prefix=_prefix)


def pytest_sessionfinish(session, exitstatus):
    for path in _MADE.values():
        shutil.rmtree(path, ignore_errors=True)

REPO = Path(__file__).resolve().parents[1]
CAMSPEC = REPO.parent / "shared" / "data" / "camspec_database.txt"


@pytest.fixture(scope="session")
def camspec_path():
    """Path of the camspec database; skips (naming the file) where ../shared is absent."""
    if not CAMSPEC.is_file():
        pytest.skip(f"camera database not found: {CAMSPEC} (it is not shipped with aquaspec)")
    return CAMSPEC


@pytest.fixture(scope="session")
def device():
    """The shared wgpu device; skips (with the reason) where no adapter is available."""
    from aquaspec.errors import GPUUnavailableError
    from aquaspec.gpu.device import get_device
    try:
        return get_device()[1]
    except GPUUnavailableError as exc:
        pytest.skip(f"no wgpu adapter: {exc}")


def _fused_and_two_pass(shading, width, height, **settings):
    """A shading pass's fused display image and the display pass run on its
    linear output (the pass must have just run without display), same settings."""
    from aquaspec.gpu.passes.display import DisplayPass
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


def _lightfield_gbuffer(kind, depth):
    """G-buffer of the light-field tests: ``"builtin"`` (the built-in scene at
    96x54) or ``"up"`` (the validation board seen looking up at 40 degrees,
    64x48: the board, open water and Snell's window)."""
    from aquaspec.scene.camera import Camera
    from aquaspec.gpu.passes.raster import RasterPass
    if kind == "builtin":
        from aquaspec.scene.builtin import builtin_scene
        scene, cam = builtin_scene(depth, width=96, height=54)
    else:
        from aquaspec.validation.scenes import board_scene
        scene, _ = board_scene(depth, width=64, height=48)
        cam = Camera.look_at([0, -depth, 1.0], [0, -depth + 2.5, -3.0], width=64, height=48,
                             fov_y_deg=90)
    return RasterPass().render(scene, cam)


@pytest.fixture
def lightfield_gbuffer():
    """``gbuffer_of(kind, depth)`` for the light-field tests (see _lightfield_gbuffer)."""
    return _lightfield_gbuffer
