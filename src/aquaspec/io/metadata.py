"""A render's parameters as JSON, as every output file records them.

Parameters are recorded in the same JSON form inside the PNG (a ``tEXt``
chunk with keyword :data:`METADATA_KEY`, :mod:`aquaspec.io.png`), the EXR
header (string attribute :data:`METADATA_KEY`, :mod:`aquaspec.io.exr`), the
layers file (:mod:`aquaspec.io.layers_file`) and a sidecar ``<image>.json``
beside the image (:mod:`aquaspec.io.sidecar`), so they survive tools that
strip metadata. NaN and infinity are refused: JSON has no NaN, and none may
reach an output silently.
"""

from __future__ import annotations

import dataclasses
import datetime as _dt
import enum
import importlib.metadata
import json
import math
import os

import numpy as np

from aquaspec.errors import AquaspecError

#: Keyword of the PNG ``tEXt`` chunk / EXR header attribute holding the JSON.
METADATA_KEY = "aquaspec"


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
    """The installed aquaspec's version (its distribution's, from
    ``pyproject.toml``; ``aquaspec.__version__`` repeats it). Read from the
    package metadata, not from ``aquaspec`` itself: that package's
    namespace offers the rendering API, which the lowest layer cannot import."""
    return importlib.metadata.version("aquaspec")


def stamped(params) -> dict:
    """JSON-ready ``params`` (a dict or None) with ``aquaspec_version`` and a
    UTC ``timestamp`` added where absent."""
    if params is None:
        params = {}
    if not isinstance(params, dict):
        raise AquaspecError(f"parameters must be a dict, got {type(params).__name__}")
    out = to_jsonable(params, "params")
    out.setdefault("aquaspec_version", aquaspec_version())
    out.setdefault("timestamp",
                   _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"))
    return out


def metadata_json(obj) -> str:
    """``obj`` (JSON-ready, e.g. from :func:`stamped`) as one line of JSON,
    ASCII only, so the text fits a Latin-1 PNG ``tEXt`` chunk unchanged."""
    return json.dumps(obj, ensure_ascii=True, allow_nan=False, indent=None)
