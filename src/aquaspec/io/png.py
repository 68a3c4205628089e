"""PNG files of display images, with the render's parameters in a ``tEXt`` chunk.

8-bit images and 16-bit grey go through Pillow; 16-bit RGB(A), which Pillow
cannot write, is written directly (:func:`png_writer`). The parameters are
stored as JSON under the keyword :data:`aquaspec.io.metadata.METADATA_KEY`
and read back by :func:`read_png_metadata`.

References
----------
.. [PNG] W3C, "Portable Network Graphics (PNG) Specification (Third
   Edition)", 2025 (chunk layout, IHDR, tEXt, CRC-32, filter type 0);
   also ISO/IEC 15948:2004.
"""

from __future__ import annotations

import json
import struct
import zlib
from pathlib import Path

import numpy as np
from PIL import Image, PngImagePlugin, UnidentifiedImageError

from aquaspec.errors import AquaspecError
from aquaspec.io.atomic import check_writable, write_atomically, write_file_atomically
from aquaspec.io.metadata import METADATA_KEY, metadata_json, stamped

PNG_SUFFIXES = (".png",)


def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return (struct.pack(">I", len(data)) + kind + data
            + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


def _write_png16_rgb(path, image, text):
    """16-bit RGB(A) PNG written directly, as Pillow cannot write 48/64-bit PNG.

    [PNG]: colour type 2 (RGB) or 6 (RGBA), bit depth 16, big-endian samples,
    every scanline with filter type 0 (None), one zlib stream in IDAT.
    """
    h, w, ch = image.shape
    rows = np.ascontiguousarray(image, dtype=">u2").view(np.uint8).reshape(h, w * ch * 2)
    raw = np.concatenate([np.zeros((h, 1), np.uint8), rows], axis=1).tobytes()
    ihdr = struct.pack(">IIBBBBB", w, h, 16, 2 if ch == 3 else 6, 0, 0, 0)
    data = (b"\x89PNG\r\n\x1a\n"
            + _png_chunk(b"IHDR", ihdr)
            + _png_chunk(b"tEXt", METADATA_KEY.encode("latin-1") + b"\0"
                         + text.encode("latin-1"))
            + _png_chunk(b"IDAT", zlib.compress(raw, 6))
            + _png_chunk(b"IEND", b""))
    with open(path, "wb") as f:
        f.write(data)


def png_writer(image, text: str):
    """``writer(tmp_path)`` of a PNG of ``image`` (uint8 or uint16; (H, W),
    (H, W, 3) or (H, W, 4)) with ``text`` (JSON, :func:`aquaspec.io.metadata.metadata_json`)
    in its ``tEXt`` chunk, for :func:`aquaspec.io.atomic.write_atomically`;
    a bad image is refused here, before anything is written."""
    arr = np.asarray(image)
    if arr.dtype not in (np.uint8, np.uint16):
        raise AquaspecError(f"PNG image has dtype {arr.dtype}; accepted: uint8 or uint16 "
                            "(convert linear values with aquaspec.colour.display.to_display)")
    if not (arr.ndim == 2 or (arr.ndim == 3 and arr.shape[2] in (3, 4))):
        raise AquaspecError(f"PNG image has shape {arr.shape}; accepted: (height, width), "
                            "(height, width, 3) or (height, width, 4)")
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise AquaspecError(f"PNG image has shape {arr.shape}; it has no pixels")
    if arr.dtype == np.uint16 and arr.ndim == 3:
        return lambda tmp: _write_png16_rgb(tmp, arr, text)

    def write(tmp):
        info = PngImagePlugin.PngInfo()
        info.add_text(METADATA_KEY, text)
        # Pillow maps 2-D uint16 to mode "I;16" (16-bit grey PNG).
        Image.fromarray(np.ascontiguousarray(arr)).save(tmp, format="PNG", pnginfo=info)

    return write


def write_png(path, image, metadata=None) -> Path:
    """Write a PNG atomically, with ``metadata`` as JSON in a ``tEXt`` chunk.

    Parameters
    ----------
    path : str or os.PathLike
        Destination ending in ``.png``.
    image : ndarray, uint8 or uint16, shape (H, W), (H, W, 3) or (H, W, 4)
        Display-encoded pixels (e.g. from :func:`aquaspec.colour.display.to_display`).
    metadata : dict, optional
        Parameters, stored under the keyword ``"aquaspec"`` with
        ``aquaspec_version`` and ``timestamp`` added (see
        :func:`aquaspec.io.metadata.to_jsonable` for accepted types; NaN is refused).

    Returns
    -------
    pathlib.Path
        The absolute path written.
    """
    p = check_writable(path, suffixes=PNG_SUFFIXES)
    writer = png_writer(image, metadata_json(stamped(metadata)))
    write_atomically([(p, writer)])
    return p


def read_png_metadata(path) -> dict:
    """The ``aquaspec`` JSON embedded in a PNG by :func:`write_png`."""
    p = Path(path)
    try:
        with Image.open(p) as im:
            if im.format != "PNG":
                raise AquaspecError(f"{str(p)!r} is a {im.format} image, not a PNG")
            im.load()   # text chunks after the image data are read by load()
            text = im.text.get(METADATA_KEY)
    except (FileNotFoundError, UnidentifiedImageError) as exc:
        raise AquaspecError(f"cannot read PNG {str(p)!r}: {exc}") from exc
    if text is None:
        raise AquaspecError(f"PNG {str(p)!r} has no {METADATA_KEY!r} text chunk; "
                            "it was not written by aquaspec")
    return json.loads(text)


def write_figure(path, fig, dpi: int = 100) -> Path:
    """Save a matplotlib figure as a PNG, atomically, and close it (also when
    saving fails): the plots of validate, bench, spectra and Tyler's check."""
    import matplotlib.pyplot as plt  # deferred: matplotlib takes 0.3 s to import; only figures need it
    try:
        return write_file_atomically(path, lambda tmp: fig.savefig(tmp, format="png", dpi=dpi))
    finally:
        plt.close(fig)
