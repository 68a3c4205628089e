"""Writing images and their parameters: PNG, linear EXR/NPY, JSON sidecars.

Every file is written atomically: the bytes go to a temporary file in the
destination directory (``.<name>.<random>.part``), are flushed to disk with
``fsync``, and only then renamed over the destination with ``os.replace``,
which is atomic on POSIX and Windows within one file system. If anything
fails, the temporary file is removed, so a reader never sees a half-written
image and an old file is either intact or fully replaced.
:func:`save_image` stages *all* its files before renaming any of them, so an
error in one (say, the EXR) leaves none of the new files behind.

A bad destination (missing or unwritable directory, a directory in place of
the file, an unsupported suffix) is an :class:`AquaspecError` naming the
path; call :func:`check_writable` before rendering so no work is wasted.

Parameters are recorded twice, in the same JSON form: inside the PNG (a
``tEXt`` chunk with keyword ``aquaspec``, read back by
:func:`read_png_metadata`) or EXR header (string attribute ``aquaspec``), and
in a sidecar ``<image>.json`` beside the image (:func:`write_sidecar`), so the
parameters survive tools that strip metadata. NaN and infinity are refused in
pixels and in metadata: JSON has no NaN, and none may reach an output silently.

References
----------
.. [PNG] W3C, "Portable Network Graphics (PNG) Specification (Third
   Edition)", 2025 (chunk layout, IHDR, tEXt, CRC-32, filter type 0);
   also ISO/IEC 15948:2004.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import enum
import json
import math
import os
import secrets
import struct
import warnings
import zlib
from pathlib import Path

import numpy as np

from aquaspec.colour.display import check_finite
from aquaspec.errors import AquaspecError

#: Keyword of the PNG ``tEXt`` chunk / EXR header attribute holding the JSON.
METADATA_KEY = "aquaspec"

PNG_SUFFIXES = (".png",)
LINEAR_SUFFIXES = (".exr", ".npy")


# ---------------------------------------------------------------------------
# destinations and atomic writes
# ---------------------------------------------------------------------------

def check_writable(path, *, suffixes=None) -> Path:
    """Check that ``path`` can be written, before any rendering happens.

    Parameters
    ----------
    path : str or os.PathLike
        The output file.
    suffixes : sequence of str, optional
        Accepted file suffixes (lower case, with the dot), e.g. ``(".png",)``.

    Returns
    -------
    pathlib.Path
        ``path`` made absolute.

    Raises
    ------
    AquaspecError
        The suffix is not accepted, ``path`` is a directory, or its directory
        does not exist or cannot be written (tested by creating and removing
        a probe file, which is right even for root and network file systems,
        unlike ``os.access``).
    """
    try:
        p = Path(os.fspath(path)).expanduser().absolute()
    except TypeError as exc:
        raise AquaspecError(f"output path {path!r} is not a file path") from exc
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise AquaspecError(f"output file {str(p)!r} has suffix {p.suffix!r}; accepted: "
                            + ", ".join(suffixes))
    if p.is_dir():
        raise AquaspecError(f"output path {str(p)!r} is a directory; give a file name")
    parent = p.parent
    if not parent.exists():
        raise AquaspecError(f"output directory {str(parent)!r} does not exist; "
                            "create it first")
    if not parent.is_dir():
        raise AquaspecError(f"output directory {str(parent)!r} is not a directory")
    probe = parent / f".{p.name}.{secrets.token_hex(6)}.probe"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except OSError as exc:
        raise AquaspecError(f"output directory {str(parent)!r} is not writable "
                            f"({exc.strerror or exc}); choose another place") from exc
    os.close(fd)
    os.unlink(probe)
    return p


def _fsync_path(path, directory=False):
    flags = os.O_RDONLY | (getattr(os, "O_DIRECTORY", 0) if directory else 0)
    try:
        fd = os.open(path, flags)
    except OSError:
        if directory:       # some platforms cannot open directories; data is synced
            return
        raise
    try:
        os.fsync(fd)
    except OSError:
        if not directory:
            raise
    finally:
        os.close(fd)


class _Staged:
    """A temporary file beside ``final`` that becomes ``final`` on commit."""

    def __init__(self, final: Path):
        self.final = final
        self.tmp = final.parent / f".{final.name}.{secrets.token_hex(6)}.part"
        # O_EXCL: never write through a link or over someone else's file;
        # mode 0o666 lets the umask decide the final permissions as for open().
        os.close(os.open(self.tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))

    def discard(self):
        try:
            os.unlink(self.tmp)
        except FileNotFoundError:
            pass


def _write_atomically(jobs):
    """Write ``[(final_path, writer)]``; ``writer(tmp_path)`` fills one file.

    All files are written and synced to temporary names first; only if every
    writer succeeded are they renamed into place.
    """
    staged = []
    try:
        for final, writer in jobs:
            s = _Staged(final)
            staged.append(s)
            writer(str(s.tmp))
            _fsync_path(s.tmp)
    except BaseException:
        for s in staged:
            s.discard()
        raise
    for s in staged:
        os.replace(s.tmp, s.final)
    for parent in {s.final.parent for s in staged}:
        _fsync_path(parent, directory=True)


# ---------------------------------------------------------------------------
# metadata to JSON
# ---------------------------------------------------------------------------

def to_jsonable(value, where="metadata"):
    """``value`` as plain JSON types, refusing NaN and infinity.

    Converts NumPy scalars and arrays, tuples, paths, enums, datetimes,
    dataclasses (e.g. ``Bands``) and objects with a ``describe()`` method
    returning a dict (e.g. ``Camera``). ``where`` names the value in errors,
    e.g. ``"params['depth_m']"``.
    """
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.generic):
        return to_jsonable(value.item(), where)
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        if not math.isfinite(value):
            raise AquaspecError(f"{where} is {value!r}; NaN and infinity are not accepted "
                                "in metadata (JSON has no NaN): fix or drop the value")
        return value
    if isinstance(value, np.ndarray):
        return [to_jsonable(v, f"{where}[{i}]") for i, v in enumerate(value.tolist())] \
            if value.ndim else to_jsonable(value.item(), where)
    if isinstance(value, dict):
        out = {}
        for k, v in value.items():
            key = k.item() if isinstance(k, np.generic) else k
            if not isinstance(key, (str, int)) or isinstance(key, bool):
                raise AquaspecError(f"{where} has key {k!r}; accepted keys: strings")
            out[str(key)] = to_jsonable(v, f"{where}[{key!r}]")
        return out
    if isinstance(value, (list, tuple)):
        return [to_jsonable(v, f"{where}[{i}]") for i, v in enumerate(value)]
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, enum.Enum):
        return to_jsonable(value.value, where)
    if isinstance(value, (_dt.datetime, _dt.date)):
        return value.isoformat()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return to_jsonable(dataclasses.asdict(value), where)
    describe = getattr(value, "describe", None)
    if callable(describe):
        return to_jsonable(describe(), where)
    raise AquaspecError(f"{where} is a {type(value).__name__} ({value!r}), which cannot be "
                        "stored as JSON; accepted: numbers, strings, booleans, None, "
                        "lists, dicts, NumPy scalars and arrays")


def aquaspec_version() -> str:
    """The running aquaspec's version (``aquaspec.__version__``)."""
    from aquaspec import __version__
    return __version__


def _stamped(params) -> dict:
    """JSON-ready params with ``aquaspec_version`` and UTC ``timestamp`` added."""
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise AquaspecError(f"parameters must be a dict, got {type(params).__name__}")
    out = to_jsonable(params, "params")
    out.setdefault("aquaspec_version", aquaspec_version())
    out.setdefault("timestamp",
                   _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"))
    return out


def _dumps(obj) -> str:
    # ASCII only, so the text fits a Latin-1 PNG tEXt chunk unchanged.
    return json.dumps(obj, ensure_ascii=True, allow_nan=False, indent=None)


# ---------------------------------------------------------------------------
# PNG
# ---------------------------------------------------------------------------

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


def _png_writer(image, text):
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
        from PIL import Image, PngImagePlugin
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
        ``aquaspec_version`` and ``timestamp`` added (see :func:`to_jsonable`
        for accepted types; NaN is refused).

    Returns
    -------
    pathlib.Path
        The absolute path written.
    """
    p = check_writable(path, suffixes=PNG_SUFFIXES)
    writer = _png_writer(image, _dumps(_stamped(metadata)))
    _write_atomically([(p, writer)])
    return p


def read_png_metadata(path) -> dict:
    """The ``aquaspec`` JSON embedded in a PNG by :func:`write_png`."""
    from PIL import Image, UnidentifiedImageError
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


# ---------------------------------------------------------------------------
# linear images: EXR or NPY
# ---------------------------------------------------------------------------

def _openexr():
    """The ``OpenEXR`` module, or None when it is not installed."""
    try:
        import OpenEXR
    except ImportError:
        return None
    return OpenEXR


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


def exr_writer(channels: dict, meta):
    """``writer(tmp_path)`` of a float32 scanline EXR (ZIP) with ``channels``
    ({name: pixels}) and ``meta`` as JSON in the header attribute
    :data:`METADATA_KEY`, serialised when the file is written."""
    exr = _openexr()

    def write(tmp):
        header = {"compression": exr.ZIP_COMPRESSION, "type": exr.scanlineimage,
                  METADATA_KEY: _dumps(meta)}
        with exr.File(header, channels) as f:
            f.write(tmp)
    return write


def read_exr_channels(path, names) -> tuple[dict, dict]:
    """``({name: pixels}, header)`` of the EXR at ``path``; an
    :class:`AquaspecError` names the channels it lacks."""
    p = Path(path)
    exr = _openexr()
    if exr is None:
        raise AquaspecError(f"reading {str(p)!r} needs the OpenEXR module: pip install openexr")
    with exr.File(str(p), separate_channels=True) as f:
        ch = f.channels()
        missing = [c for c in names if c not in ch]
        if missing:
            raise AquaspecError(f"EXR {str(p)!r} lacks channels {missing}; has {sorted(ch)}")
        return {c: np.asarray(ch[c].pixels) for c in names}, dict(f.header())


def _plan_linear(path, rgb, meta):
    """``(final_path, writer, info)`` for a linear image; EXR falls back to NPY."""
    p = check_writable(path, suffixes=LINEAR_SUFFIXES)
    pixels = _linear_pixels(rgb)
    info = {"requested_path": str(p), "path": str(p), "format": p.suffix.lower()[1:],
            "dtype": "float32", "warning": None}
    exr = _openexr() if info["format"] == "exr" else None
    if info["format"] == "exr" and exr is None:
        p = check_writable(p.with_suffix(".npy"))
        info.update(path=str(p), format="npy",
                    warning=(f"the OpenEXR module is not installed, so the linear image "
                             f"was written as NPY to {str(p)!r} instead of "
                             f"{info['requested_path']!r}; pip install openexr for EXR"))
        warnings.warn(info["warning"], UserWarning, stacklevel=3)

    if info["format"] == "exr":
        # An (H, W, 3) array under "RGB" becomes the channels R, G, B.
        write = exr_writer({"RGB": pixels}, meta)
    else:
        def write(tmp):
            with open(tmp, "wb") as f:     # a file object: np.save(name) adds ".npy"
                np.save(f, pixels, allow_pickle=False)
    return p, write, info


def write_linear(path, rgb, metadata=None) -> dict:
    """Write linear RGB (H, W, 3) as float32 EXR or NPY, atomically.

    The format follows the suffix: ``.exr`` (channels R, G, B, ZIP
    compression, ``metadata`` as JSON in the header attribute ``aquaspec``)
    or ``.npy`` (pixels only; the sidecar carries the parameters). When
    ``.exr`` is asked but the ``OpenEXR`` module is missing, the image is
    written as ``.npy`` beside it, with a :class:`UserWarning` and the reason
    in the returned ``warning`` ("EXR, NPY if EXR is unavailable").
    Non-finite values, and values that overflow float32, are refused.

    Returns
    -------
    dict
        ``path`` (written), ``requested_path``, ``format`` (``"exr"`` or
        ``"npy"``), ``dtype``, ``warning`` (None or the fallback notice).
    """
    p, write, info = _plan_linear(path, rgb, _stamped(metadata))
    _write_atomically([(p, write)])
    return info


def read_linear(path) -> np.ndarray:
    """Read back an (H, W, 3) float32 image written by :func:`write_linear`."""
    p = Path(path)
    if p.suffix.lower() == ".npy":
        return np.load(p, allow_pickle=False)
    if p.suffix.lower() != ".exr":
        raise AquaspecError(f"linear image {str(p)!r}; accepted suffixes: .exr, .npy")
    ch, _ = read_exr_channels(p, "RGB")
    return np.stack([ch[c] for c in "RGB"], axis=-1).astype(np.float32)


# ---------------------------------------------------------------------------
# sidecar and the whole set
# ---------------------------------------------------------------------------

def sidecar_path(image_path) -> Path:
    """``<image>.json``: the full image name plus ``.json`` (``a.png.json``),
    so a PNG and an EXR of the same render never share a sidecar."""
    p = Path(image_path)
    return p.with_name(p.name + ".json")


def _sidecar_writer(doc):
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
    doc = _stamped(params)
    p = check_writable(sidecar_path(image_path))
    _write_atomically([(p, _sidecar_writer(doc))])
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


def save_image(path, display_image, linear_rgb=None, params=None, *, linear_path=None,
               layers=None, layers_path=None) -> dict:
    """Write the PNG, its sidecar and optionally the linear image, all or none.

    Parameters
    ----------
    path : str or os.PathLike
        The PNG (``.png``); the sidecar is ``<path>.json``.
    display_image : ndarray, uint8 or uint16
        Display pixels (from :func:`aquaspec.colour.display.to_display`).
    linear_rgb : ndarray (H, W, 3), optional
        Linear camera RGB; written only when ``linear_path`` is given.
    params : dict, optional
        Every parameter of the render; stored in the sidecar, the PNG and the
        EXR header, with ``files`` (names of what was written),
        ``aquaspec_version`` and ``timestamp`` added.
    linear_path : str or os.PathLike, optional
        ``.exr`` or ``.npy`` destination for ``linear_rgb`` (EXR falls back
        to NPY as in :func:`write_linear`).
    layers : dict, optional
        Image-formation layers (``RenderResult.layers``); written only when
        ``layers_path`` is given.
    layers_path : str or os.PathLike, optional
        ``.exr`` or ``.npz`` destination for ``layers``
        (:func:`aquaspec.rendering.layers.write_layers`).

    Returns
    -------
    dict
        ``png``, ``sidecar``, ``linear``, ``layers`` (paths as str, None when
        not written), ``linear_format``, ``warnings`` (list of str).

    Notes
    -----
    Every file is staged under a temporary name and synced before any is
    renamed into place, so an error while writing any of them leaves no new
    file behind.
    """
    png = check_writable(path, suffixes=PNG_SUFFIXES)
    side = check_writable(sidecar_path(png))
    if linear_path is not None and linear_rgb is None:
        raise AquaspecError(f"linear_path={str(linear_path)!r} was given without linear_rgb")
    if layers_path is not None and layers is None:
        raise AquaspecError(f"layers_path={str(layers_path)!r} was given without layers "
                            "(render with layers=True)")
    doc = _stamped(params)
    jobs, result = [], {"png": str(png), "sidecar": str(side), "linear": None,
                        "layers": None, "linear_format": None, "warnings": []}
    if linear_path is not None:
        lin, lin_write, lin_info = _plan_linear(linear_path, linear_rgb, doc)
        result.update(linear=str(lin), linear_format=lin_info["format"])
        if lin_info["warning"]:
            result["warnings"].append(lin_info["warning"])
        jobs.append((lin, lin_write))
    if layers_path is not None:
        from aquaspec.rendering.layers import plan_layers
        lay, lay_write = plan_layers(layers_path, layers, doc)
        result["layers"] = str(lay)
        jobs.append((lay, lay_write))
    doc["files"] = {"png": png.name, "sidecar": side.name,
                    "linear": None if result["linear"] is None else Path(result["linear"]).name}
    if result["layers"] is not None:
        doc["files"]["layers"] = Path(result["layers"]).name
    if result["warnings"]:
        doc["warnings"] = list(result["warnings"])
    jobs.append((png, _png_writer(display_image, _dumps(doc))))
    jobs.append((side, _sidecar_writer(doc)))
    _write_atomically(jobs)
    return result


def write_file_atomically(path, writer) -> Path:
    """Write one file through ``writer(tmp_path)``, then rename it to ``path``.

    Nothing is left at ``path`` (or beside it) if ``writer`` fails.
    """
    final = check_writable(path)
    _write_atomically([(final, writer)])
    return final
