"""Tiny RGB-D data sets and configurations for the ``aquaspec synth`` tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

WIDTH, HEIGHT = 64, 48
#: Pinhole intrinsics of the test images (about 60 degrees across).
INTRINSICS = (55.0, 55.0, 32.0, 24.0)


def rgb_image(seed: int, width=WIDTH, height=HEIGHT) -> np.ndarray:
    """A smooth colourful uint8 image (few distinct colours, quick to fit)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:height, 0:width]
    base = rng.uniform(40, 200, size=3)
    ramp = np.stack([x / width, y / height, (x + y) / (width + height)], axis=-1)
    img = base + 80 * (ramp - 0.5) * rng.uniform(0.5, 1.0, size=3)
    return np.clip(np.round(img / 16) * 16, 0, 255).astype(np.uint8)


def depth_mm(seed: int, width=WIDTH, height=HEIGHT) -> np.ndarray:
    """A tilted floor and a box: z-depth in millimetres, uint16, 1.2-4 m."""
    rng = np.random.default_rng(seed + 1000)
    y, x = np.mgrid[0:height, 0:width]
    z = 4000 - 2500 * (y / height) + rng.uniform(-200, 200)
    box = (abs(x - width / 2) < width / 6) & (abs(y - height / 2) < height / 5)
    z = np.where(box, z - 600, z)
    return np.round(z).astype(np.uint16)


def make_folder(root: Path, n: int, *, holes: dict | None = None, missing=(),
                mismatched=()) -> Path:
    """``root`` with ``rgb/`` and ``depth/`` of ``n`` pairs ``img000`` ...:
    ``holes`` maps a pair's index to how many of its depth pixels are 0,
    ``missing`` names indices without a depth map, ``mismatched`` indices
    whose depth map is a pixel narrower."""
    (root / "rgb").mkdir(parents=True, exist_ok=True)
    (root / "depth").mkdir(parents=True, exist_ok=True)
    for i in range(n):
        name = f"img{i:03d}"
        Image.fromarray(rgb_image(i)).save(root / "rgb" / f"{name}.png")
        if i in missing:
            continue
        d = depth_mm(i)
        if i in mismatched:
            d = d[:, :-1]
        if holes and i in holes:
            flat = d.reshape(-1)
            flat[np.random.default_rng(i).choice(flat.size, holes[i], replace=False)] = 0
        Image.fromarray(d).save(root / "depth" / f"{name}.png")
    return root


def write_config(path: Path, *, inputs: str = "data", output: str = "out",
                 plan: str | None = None, extra: str = "") -> Path:
    """A synth TOML at ``path`` over the folder ``inputs`` (relative to it)."""
    plan = plan if plan is not None else (
        'mode = "random"\nseed = 3\nsamples_per_input = 2\nwater = ["IB", "3C"]\n'
        'depth_m = {min = 2, max = 8}\nbands = 4\nlight = ["overcast", "sun-sky"]\n'
        'sun_elevation_deg = {min = 40, max = 70}\n')
    path.write_text(
        f'[inputs]\nfolder = "{inputs}"\nintrinsics = {list(INTRINSICS)}\n\n'
        f"[plan]\n{plan}\n"
        f'[output]\nfolder = "{output}"\n' + extra, encoding="utf-8")
    return path
