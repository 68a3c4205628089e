"""The image-formation layers' file: EXR or NPZ, float32, with the parameters.

What the layers are and how they are computed is
:mod:`aquaspec.rendering.layers`; this module names them and reads and
writes them. ``.exr``: float32, ZIP; the colour layers as ``backscatter.R``
... ``transmission.B``, the channel ``range_m``, the parameters as JSON in
the header attribute ``aquaspec``. ``.npz``: one float32 array per layer and
``aquaspec``, the parameters as JSON. Non-finite values are refused and
nothing is written.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.io import exr
from aquaspec.io.atomic import check_writable, write_atomically
from aquaspec.io.metadata import METADATA_KEY, metadata_json, stamped

#: The colour layers, (H, W, 3) each, in file order; ``range_m`` (H, W) follows.
COLOUR_LAYERS = ("backscatter", "direct", "surface", "albedo", "transmission")
#: Every layer name.
LAYER_NAMES = COLOUR_LAYERS + ("range_m",)
#: Accepted file suffixes of :func:`write_layers`.
LAYER_SUFFIXES = (".exr", ".npz")


def _checked(layers) -> dict:
    """The layers as float32, checked for names, shapes and finiteness."""
    missing = [k for k in LAYER_NAMES if k not in layers]
    if missing:
        raise AquaspecError(f"layers lack {missing}; accepted: a dict with {list(LAYER_NAMES)}")
    out = {}
    shape = None
    for k in LAYER_NAMES:
        with np.errstate(over="ignore"):
            arr = np.asarray(layers[k], dtype=np.float32)
        want = 3 if k in COLOUR_LAYERS else 2
        if arr.ndim != want or (want == 3 and arr.shape[2] != 3):
            raise AquaspecError(f"layer {k!r} has shape {arr.shape}; accepted: "
                                + ("(height, width, 3)" if want == 3 else "(height, width)"))
        if shape is None:
            shape = arr.shape[:2]
        elif arr.shape[:2] != shape:
            raise AquaspecError(f"layer {k!r} is {arr.shape[:2]}; the others are {shape}")
        if not np.all(np.isfinite(arr)):
            raise AquaspecError(f"layer {k!r} has NaN or infinite values (or values beyond "
                                "float32); nothing was written")
        out[k] = arr
    return out


def check_layers_path(path):
    """The layers' output path (a ``Path``), refused before any work if its
    suffix is not one of :data:`LAYER_SUFFIXES`, its directory cannot be
    written, or it is an EXR without the OpenEXR module."""
    p = check_writable(path, suffixes=LAYER_SUFFIXES)
    if p.suffix.lower() == ".exr" and exr.openexr() is None:
        raise AquaspecError(f"writing {str(p)!r} needs the OpenEXR module (pip install "
                            "openexr); or give a .npz path")
    return p


def plan_layers(path, layers, metadata: dict):
    """``(final_path, writer)`` of :func:`write_layers` for a staged, atomic write
    (:func:`aquaspec.io.save.save_image` writes it with the other files);
    ``metadata`` is serialised when the file is written."""
    p = check_layers_path(path)
    arrays = _checked(layers)
    if p.suffix.lower() == ".exr":
        channels = {f"{k}.{c}": np.ascontiguousarray(arrays[k][..., i])
                    for k in COLOUR_LAYERS for i, c in enumerate("RGB")}
        channels["range_m"] = arrays["range_m"]
        write = exr.exr_writer(channels, metadata)
    else:
        def write(tmp):
            with open(tmp, "wb") as f:     # a file object: np.savez(name) adds ".npz"
                np.savez_compressed(f, **arrays,
                                    **{METADATA_KEY: np.array(metadata_json(metadata))})
    return p, write


def write_layers(path, layers, metadata=None) -> Path:
    """Write ``layers`` (:data:`LAYER_NAMES`, e.g. ``RenderResult.layers``) to
    ``path``, atomically, as the module docstring describes;
    ``aquaspec_version`` and a UTC ``timestamp`` are added to ``metadata``."""
    p, write = plan_layers(path, layers, stamped(metadata))
    write_atomically([(p, write)])
    return p


def read_layers(path) -> tuple[dict, dict]:
    """``(layers, metadata)`` of a file written by :func:`write_layers`."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in LAYER_SUFFIXES:
        raise AquaspecError(f"layers file {str(p)!r}; accepted suffixes: "
                            + ", ".join(LAYER_SUFFIXES))
    if not p.is_file():
        raise AquaspecError(f"no layers file {str(p)!r}")
    if suffix == ".npz":
        with np.load(p, allow_pickle=False) as z:
            missing = [k for k in LAYER_NAMES + (METADATA_KEY,) if k not in z.files]
            if missing:
                raise AquaspecError(f"{str(p)!r} lacks {missing}; has {sorted(z.files)}")
            return ({k: z[k] for k in LAYER_NAMES}, json.loads(str(z[METADATA_KEY])))
    ch, header = exr.read_exr_channels(
        p, [f"{k}.{c}" for k in COLOUR_LAYERS for c in "RGB"] + ["range_m"])
    layers = {k: np.stack([ch[f"{k}.{c}"] for c in "RGB"], axis=-1) for k in COLOUR_LAYERS}
    layers["range_m"] = ch["range_m"]
    meta = header.get(METADATA_KEY)
    return layers, (json.loads(meta) if meta else {})
