"""Reading numeric spectra from CSV files with a header row.

One reader for every spectrum a user gives as a file: water
(``wavelength_nm,a,b[,Kd]``, :func:`aquaspec.medium.water.water_from_csv`),
sensors (``wavelength_nm,r,g,b``, :func:`aquaspec.colour.sensors.sensor_from_csv`)
and reflectances (``wavelength_nm,reflectance``,
:func:`aquaspec.colour.reflectance.reflectance_from_csv`). Errors name the
file, line and column; a binary file, or one over the size ceiling of
:mod:`aquaspec.io.limits`, is refused before parsing.
"""

from __future__ import annotations

import csv
import io
import numpy as np

from aquaspec.errors import AquaspecError
from aquaspec.io.limits import read_text


def _number(text, path, line, column):
    try:
        v = float(text)
    except ValueError:
        raise AquaspecError(f"{path}: line {line}, column {column!r}: {text!r} is not a "
                            "number") from None
    if not np.isfinite(v):
        raise AquaspecError(f"{path}: line {line}, column {column!r}: {text!r} is not a "
                            "finite number")
    return v


def read_csv_columns(path, required, optional=(), *, what="spectrum"):
    """Read numeric columns from a CSV with a header row.

    Returns a dict of column -> ndarray. Errors name the file, line and
    column. Wavelengths (the first required column) must strictly ascend.
    """
    text = read_text(path, "csv", f"{what} file")
    try:
        rows = [r for r in csv.reader(io.StringIO(text)) if r and any(c.strip() for c in r)
                and not r[0].lstrip().startswith("#")]
    except csv.Error as exc:
        raise AquaspecError(f"{path}: not a readable CSV ({exc})") from None
    if not rows:
        raise AquaspecError(f"{path}: empty file; expected a header "
                            f"{','.join(required + tuple(optional))} and rows of numbers")
    header = [h.strip() for h in rows[0]]
    lower = [h.lower() for h in header]
    missing = [c for c in required if c.lower() not in lower]
    if missing:
        raise AquaspecError(f"{path}: missing column(s) {', '.join(missing)}; found "
                            f"{', '.join(header) or 'none'}; expected "
                            f"{','.join(required + tuple(optional))}")
    cols = {c: lower.index(c.lower()) for c in required + tuple(optional) if c.lower() in lower}
    out = {c: [] for c in cols}
    for k, row in enumerate(rows[1:], start=2):
        for c, idx in cols.items():
            if idx >= len(row):
                raise AquaspecError(f"{path}: line {k} has no value for column {c!r}")
            out[c].append(_number(row[idx].strip(), path, k, c))
    if len(rows) < 3:
        raise AquaspecError(f"{path}: need at least two rows of data")
    arrays = {c: np.asarray(v) for c, v in out.items()}
    wl = arrays[required[0]]
    if np.any(np.diff(wl) <= 0):
        i = int(np.argmax(np.diff(wl) <= 0))
        raise AquaspecError(f"{path}: wavelengths must strictly ascend; {wl[i + 1]:g} nm "
                            f"follows {wl[i]:g} nm (line {i + 3})")
    return arrays
