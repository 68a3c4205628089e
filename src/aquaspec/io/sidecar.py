"""JSON sidecars: a render's parameters in ``<image>.json`` beside the image.

The sidecar repeats what the image file's own metadata holds
(:mod:`aquaspec.io.metadata`), readable by any tool and kept where a tool
strips the image's metadata.
"""

from __future__ import annotations

import json
from pathlib import Path

from aquaspec.errors import AquaspecError
from aquaspec.io.atomic import check_writable, write_atomically
from aquaspec.io.metadata import stamped


def sidecar_path(image_path) -> Path:
    """``<image>.json``: the full image name plus ``.json`` (``a.png.json``),
    so a PNG and an EXR of the same render never share a sidecar."""
    p = Path(image_path)
    return p.with_name(p.name + ".json")


def sidecar_writer(doc):
    """``writer(tmp_path)`` of the sidecar of ``doc`` (JSON-ready, e.g. from
    :func:`aquaspec.io.metadata.stamped`), indented UTF-8 JSON, for
    :func:`aquaspec.io.atomic.write_atomically`."""
    text = json.dumps(doc, ensure_ascii=False, allow_nan=False, indent=2) + "\n"

    def write(tmp):
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
    return write


def write_sidecar(image_path, params) -> Path:
    """Write ``params`` as the JSON sidecar ``<image>.json``, atomically.

    ``params`` should hold every parameter of the render (water type, light
    source, depth, camera and sensor, bands, exposure, tone map, size,
    adapter...); ``aquaspec_version`` and a UTC ``timestamp`` are added when
    absent. NumPy scalars and arrays are converted; NaN or infinity anywhere
    is an :class:`AquaspecError` naming the key.

    Returns
    -------
    pathlib.Path
        The sidecar's path.
    """
    doc = stamped(params)
    p = check_writable(sidecar_path(image_path))
    write_atomically([(p, sidecar_writer(doc))])
    return p


def read_sidecar(image_path) -> dict:
    """The parameters in ``<image>.json`` (give the image or the sidecar path)."""
    p = Path(image_path)
    if p.suffix != ".json":
        p = sidecar_path(p)
    try:
        return json.loads(p.read_text(encoding="utf-8"))
    except FileNotFoundError as exc:
        raise AquaspecError(f"no sidecar {str(p)!r}") from exc
