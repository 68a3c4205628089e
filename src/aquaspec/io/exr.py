"""OpenEXR files: float32 channels with the render's parameters in the header.

The ``OpenEXR`` module is optional (``pip install openexr``): :func:`openexr`
says whether it is there, and callers fall back (linear images to NPY,
:mod:`aquaspec.io.linear`) or refuse with a message that names it
(:mod:`aquaspec.io.layers_file`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.io.metadata import METADATA_KEY, metadata_json


def openexr():
    """The ``OpenEXR`` module, or None when it is not installed."""
    try:
        import OpenEXR  # deferred: an optional dependency, looked for only when an EXR is asked
    except ImportError:
        return None
    return OpenEXR


def exr_writer(channels: dict, meta):
    """``writer(tmp_path)`` of a float32 scanline EXR (ZIP) with ``channels``
    ({name: pixels}) and ``meta`` as JSON in the header attribute
    :data:`aquaspec.io.metadata.METADATA_KEY`, serialised when the file is written."""
    exr = openexr()

    def write(tmp):
        header = {"compression": exr.ZIP_COMPRESSION, "type": exr.scanlineimage,
                  METADATA_KEY: metadata_json(meta)}
        with exr.File(header, channels) as f:
            f.write(tmp)
    return write


def read_exr_channels(path, names) -> tuple[dict, dict]:
    """``({name: pixels}, header)`` of the EXR at ``path``; an
    :class:`AquaspecError` names the channels it lacks."""
    p = Path(path)
    exr = openexr()
    if exr is None:
        raise AquaspecError(f"reading {str(p)!r} needs the OpenEXR module: pip install openexr")
    with exr.File(str(p), separate_channels=True) as f:
        ch = f.channels()
        missing = [c for c in names if c not in ch]
        if missing:
            raise AquaspecError(f"EXR {str(p)!r} lacks channels {missing}; has {sorted(ch)}")
        return {c: np.asarray(ch[c].pixels) for c in names}, dict(f.header())
