"""Images and parameters shared by the output tests (tests/io): a display
image, a linear image with float32's extremes, a render's parameters with
NumPy types, and a directory listing."""

import os

import numpy as np


def display_image(h=12, w=16, dtype=np.uint8, ch=3, seed=0):
    rng = np.random.default_rng(seed)
    top = np.iinfo(dtype).max
    return rng.integers(0, top + 1, size=(h, w, ch) if ch else (h, w), dtype=dtype)


def linear_image(h=12, w=16, seed=1):
    rng = np.random.default_rng(seed)
    img = rng.lognormal(-3.0, 2.0, size=(h, w, 3))
    img[0, 0] = [1e-30, 7.5e4, 0.0]          # extremes float32 can still hold
    return img


def render_params():
    return {
        "water": "IB", "depth_m": np.float64(5.0), "n_bands": np.int64(16),
        "band_centers_nm": np.linspace(409.375, 690.625, 16),
        "camera": {"sensor": "Canon 5D Mark II", "fov_y_deg": 60.0},
        "exposure": {"mode": "auto", "ev": np.float32(3.25)},
        "tonemap": "filmic", "size": (320, 180), "adapter": None,
        "sun": True,
    }


def listing(d):
    return sorted(os.listdir(d))
