"""Linear images: camera RGB (H, W, 3) as float32 EXR, or NPY.

The format follows the suffix: ``.exr`` (channels R, G, B, ZIP compression,
the parameters as JSON in the header attribute ``aquaspec``) or ``.npy``
(pixels only; the sidecar carries the parameters). When ``.exr`` is asked
but the ``OpenEXR`` module is missing, the image is written as ``.npy``
beside it, with a :class:`UserWarning` ("EXR, NPY if EXR is unavailable").
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.io import exr
from aquaspec.io.atomic import check_writable, write_atomically
from aquaspec.io.finite import check_finite
from aquaspec.io.metadata import stamped

LINEAR_SUFFIXES = (".exr", ".npy")


def _linear_pixels(rgb) -> np.ndarray:
    try:
        arr = np.asarray(rgb, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise AquaspecError(f"linear image must be a numeric array, got "
                            f"{type(rgb).__name__}") from exc
    if arr.ndim != 3 or arr.shape[2] != 3 or 0 in arr.shape:
        raise AquaspecError(f"linear image has shape {arr.shape}; accepted: "
                            "(height, width, 3) linear RGB")
    check_finite(arr, "linear image")
    with np.errstate(over="ignore"):   # reported by the check below
        out = arr.astype(np.float32)
    check_finite(out, "linear image as float32 (values beyond 3.4e38)")
    return out


def plan_linear(path, rgb, meta):
    """``(final_path, writer, info)`` of a linear image for
    :func:`aquaspec.io.atomic.write_atomically` (``info`` as
    :func:`write_linear` returns it); EXR falls back to NPY. The pixels
    and the destination are checked here, before anything is written."""
    p = check_writable(path, suffixes=LINEAR_SUFFIXES)
    pixels = _linear_pixels(rgb)
    info = {"requested_path": str(p), "path": str(p), "format": p.suffix.lower()[1:],
            "dtype": "float32", "warning": None}
    if info["format"] == "exr" and exr.openexr() is None:
        p = check_writable(p.with_suffix(".npy"))
        info.update(path=str(p), format="npy",
                    warning=(f"the OpenEXR module is not installed, so the linear image "
                             f"was written as NPY to {str(p)!r} instead of "
                             f"{info['requested_path']!r}; pip install openexr for EXR"))
        warnings.warn(info["warning"], UserWarning, stacklevel=3)

    if info["format"] == "exr":
        # An (H, W, 3) array under "RGB" becomes the channels R, G, B.
        write = exr.exr_writer({"RGB": pixels}, meta)
    else:
        def write(tmp):
            with open(tmp, "wb") as f:     # a file object: np.save(name) adds ".npy"
                np.save(f, pixels, allow_pickle=False)
    return p, write, info


def write_linear(path, rgb, metadata=None) -> dict:
    """Write linear RGB (H, W, 3) as float32 EXR or NPY, atomically.

    The format follows the suffix (see the module docstring); the EXR keeps
    ``metadata`` in its header. Non-finite values, and values that overflow
    float32, are refused.

    Returns
    -------
    dict
        ``path`` (written), ``requested_path``, ``format`` (``"exr"`` or
        ``"npy"``), ``dtype``, ``warning`` (None or the fallback notice).
    """
    p, write, info = plan_linear(path, rgb, stamped(metadata))
    write_atomically([(p, write)])
    return info


def read_linear(path) -> np.ndarray:
    """Read back an (H, W, 3) float32 image written by :func:`write_linear`."""
    p = Path(path)
    if p.suffix.lower() == ".npy":
        return np.load(p, allow_pickle=False)
    if p.suffix.lower() != ".exr":
        raise AquaspecError(f"linear image {str(p)!r}; accepted suffixes: .exr, .npy")
    ch, _ = exr.read_exr_channels(p, "RGB")
    return np.stack([ch[c] for c in "RGB"], axis=-1).astype(np.float32)
