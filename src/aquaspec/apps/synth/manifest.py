"""The run's manifest (CSV and Parquet) and summary (JSON).

The manifest has one row per planned sample, in plan order, whatever ran
when: its id, ``status`` (``done``, ``failed``, ``pending``), the error of a
failed one, its input (``kind`` ``rgbd`` with image, depth and intrinsics, or
``mesh``), every plan parameter, the seed, the
image size, the depth holes (count and rule), the exposure applied and the
files written (relative to the output folder; empty when not written). A
done sample's row is its sidecar's ``synth`` entry, so a manifest rebuilt
after a killed run is the one an uninterrupted run writes, byte for byte
(:data:`COLUMNS` fixes the columns, their order and their Parquet types).

The summary (``summary.json``) holds the counts, the run's time and rate,
the executor and the failures' errors; it is the one output that differs
from run to run.
"""

from __future__ import annotations

import csv
import io
import json

from aquaspec.apps.synth.files import SampleFiles
from aquaspec.apps.synth.plan import Sample
from aquaspec.errors import AquaspecError
from aquaspec.io.atomic import write_file_atomically
from aquaspec.io.sidecar import sidecar_writer

#: The manifest's columns and their types (``str``, ``float``, ``int``).
COLUMNS = (
    ("sample_id", "str"), ("status", "str"), ("error", "str"),
    ("input", "str"), ("kind", "str"), ("image", "str"), ("depth", "str"), ("mesh", "str"),
    ("fx", "float"), ("fy", "float"), ("cx", "float"), ("cy", "float"),
    ("water", "str"), ("source", "str"), ("depth_m", "float"), ("sensor", "str"),
    ("bands", "int"), ("light", "str"), ("sun_elevation_deg", "float"),
    ("sun_azimuth_deg", "float"), ("wind_m_s", "float"), ("exposure", "str"),
    ("white_balance", "str"), ("seed", "int"), ("width", "int"), ("height", "int"),
    ("depth_holes", "int"), ("holes", "str"), ("exposure_ev", "float"),
    ("png", "str"), ("linear", "str"), ("layers", "str"), ("mask", "str"), ("sidecar", "str"))
MANIFEST_NAME = "manifest"
SUMMARY_NAME = "summary.json"


def manifest_rows(samples: list[Sample], root, seed: int, records: dict) -> list[dict]:
    """The manifest's rows: ``records`` (this run's, by sample id) where there
    is one, else what the output folder holds (sidecar, failure record)."""
    return [_row(s, root, seed, records.get(s.sample_id)) for s in samples]


def _row(sample: Sample, root, seed: int, record: dict | None) -> dict:
    files = SampleFiles(root, sample.sample_id)
    synth, error = None, None
    if record is not None and record["status"] == "done":
        synth = record["synth"]
    elif files.done():
        synth = _sidecar_synth(files)
    elif record is not None:
        error = record["error"]
    else:
        error = (files.read_failure() or {}).get("error")
    if synth is not None:
        row = {**{k: v for k, v in synth.items() if k != "files"}, **synth["files"],
               "status": "done", "error": None}
    else:
        row = {"sample_id": sample.sample_id, **sample.pair.describe(), **sample.params,
               "seed": seed, "status": "failed" if error else "pending", "error": error}
    if row.get("exposure") is not None:
        row["exposure"] = str(row["exposure"])
    return {name: row.get(name) for name, _ in COLUMNS}


def _sidecar_synth(files: SampleFiles) -> dict:
    with open(files.sidecar, encoding="utf-8") as f:
        return json.load(f)["synth"]


def csv_text(rows: list[dict]) -> str:
    """The manifest as CSV text (empty cells for None; numbers as Python writes them)."""
    buf = io.StringIO()
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow([name for name, _ in COLUMNS])
    for row in rows:
        writer.writerow(["" if row[name] is None else row[name] for name, _ in COLUMNS])
    return buf.getvalue()


def write_manifest(root, rows: list[dict], formats) -> dict:
    """Write ``manifest.csv`` and/or ``manifest.parquet`` under ``root``
    (atomically); their paths by format."""
    out = {}
    if "csv" in formats:
        text = csv_text(rows)

        def write_csv(tmp):
            with open(tmp, "w", encoding="utf-8", newline="") as f:
                f.write(text)
        out["csv"] = str(write_file_atomically(root / f"{MANIFEST_NAME}.csv", write_csv))
    if "parquet" in formats:
        table = _arrow_table(rows)
        # deferred: pyarrow is the optional synth extra (checked by check_formats)
        import pyarrow.parquet as pq
        out["parquet"] = str(write_file_atomically(root / f"{MANIFEST_NAME}.parquet",
                                                   lambda tmp: pq.write_table(table, tmp)))
    return out


def _arrow_table(rows):
    # deferred: pyarrow is the optional synth extra (checked by check_formats)
    import pyarrow as pa
    types = {"str": pa.string(), "float": pa.float64(), "int": pa.int64()}
    schema = pa.schema([(name, types[kind]) for name, kind in COLUMNS])
    return pa.Table.from_pylist(rows, schema=schema)


def check_formats(formats) -> None:
    """Refuse, before any work, a Parquet manifest without pyarrow."""
    if "parquet" in formats:
        try:
            # deferred: pyarrow is the optional synth extra
            import pyarrow  # noqa: F401
        except ImportError as exc:
            raise AquaspecError("[output] manifest 'parquet' needs pyarrow: pip install "
                                "'aquaspec[synth]', or manifest = ['csv']") from exc


def write_summary(root, summary: dict):
    """Write ``summary.json`` under ``root`` (atomically); its path."""
    return write_file_atomically(root / SUMMARY_NAME, sidecar_writer(summary))
