"""``synth()``: a data set from a configuration, resumable, locally or on Ray.

The steps: read the configuration
(:func:`aquaspec.apps.synth.config.load_config`), find the inputs
(:func:`aquaspec.apps.synth.inputs.discover`), check the plan's values and
make its samples (:mod:`aquaspec.apps.synth.plan`), prepare the output
folder (temporary files of a killed run removed), leave out the samples
done (and, unless ``retry_failed``, those that failed), render the rest in
work units of one group each on the local pool
(:mod:`aquaspec.apps.synth.local`) or Ray (:mod:`aquaspec.apps.synth.on_ray`)
with a progress bar, and write the manifest and summary
(:mod:`aquaspec.apps.synth.manifest`).
"""

from __future__ import annotations

import sys
import time
from dataclasses import replace
from pathlib import Path

from aquaspec.apps.synth.config import SynthConfig, load_config
from aquaspec.apps.synth.files import SampleFiles, folder_lock, remove_temporaries
from aquaspec.apps.synth.inputs import discover
from aquaspec.apps.synth.local import run_local
from aquaspec.apps.synth.manifest import (check_formats, manifest_rows, write_manifest,
                                          write_summary)
from aquaspec.apps.synth.on_ray import run_ray
from aquaspec.apps.synth.plan import check_values, chunks, plan_samples
from aquaspec.errors import AquaspecError
from aquaspec.io.atomic import check_writable

#: Failures listed in the summary (all are in the manifest).
SUMMARY_FAILURES = 50


def synth(config, *, output=None, layers: bool | None = None, workers: int | None = None,
          ray=False, retry_failed: bool = False, progress: bool = True,
          dry_run: bool = False) -> dict:
    """Render the data set of ``config``; returns the run's summary.

    Parameters
    ----------
    config : path or SynthConfig
        The TOML configuration (:mod:`aquaspec.apps.synth.config`).
    output : path, optional
        Overrides the configuration's output folder.
    layers : bool, optional
        Overrides ``[output] layers``.
    workers : int, optional
        Worker processes of the local pool (default 1), or Ray actors
        (default: one per GPU of the cluster, else per CPU).
    ray : False, True or str
        False: the local pool. True: a Ray started on this machine for the
        run; ``"auto"`` or ``"HOST:PORT"``: that Ray cluster.
    retry_failed : bool
        Render again the samples whose failure was recorded by an earlier run
        (otherwise they are left as failed).
    progress : bool
        Show a progress bar (rate and time left) on stderr.
    dry_run : bool
        Plan only: write the manifest (samples done, failed or pending as
        the folder has them) and the summary, render nothing.

    Returns
    -------
    dict
        The summary also written to ``summary.json``: counts (``planned``,
        ``done``, ``failed``, ``pending``, ``rendered``, ``skipped_done``,
        ``skipped_failed``), ``seconds``, ``samples_per_second``, the
        executor, the manifest's files and the failures.
    """
    t_start = time.perf_counter()
    cfg = config if isinstance(config, SynthConfig) else load_config(config, output=output,
                                                                      layers=layers)
    check_formats(cfg.output.manifest)
    pairs, missing = discover(cfg.inputs)
    check_values(cfg)
    samples = plan_samples(cfg, pairs)
    root = _prepare_output(Path(cfg.output.folder))
    with folder_lock(root):
        return _run(_with_folder(cfg, root), samples, pairs, missing, workers=workers,
                    ray=ray, retry_failed=retry_failed, progress=progress, t_start=t_start,
                    dry_run=dry_run)


def _run(cfg: SynthConfig, samples, pairs, missing, *, workers, ray, retry_failed, progress,
         t_start, dry_run) -> dict:
    """:func:`synth` once the output folder is ready and held."""
    root = Path(cfg.output.folder)
    temporaries = remove_temporaries(root)
    done, failed, todo = [], [], []
    for s in samples:
        files = SampleFiles(root, s.sample_id)
        if files.done():
            done.append(s)
        elif files.failure.is_file() and not retry_failed:
            failed.append(s)
        else:
            todo.append(s)
    before = {"skipped_done": len(done), "skipped_failed": len(failed), "inputs": len(pairs),
              "inputs_without_depth": missing, "temporary_files_removed": temporaries}
    records: dict = {}
    t0 = time.perf_counter()
    executor = {"kind": "ray" if ray else "local"}
    try:
        if dry_run:
            executor = {"kind": "none (dry run)"}
        else:
            executor = _execute(cfg, todo, workers, ray, records, progress)
    finally:
        # Also when the run is interrupted: the manifest says what is done.
        summary = _finish(cfg, root, samples, records, before, executor,
                          seconds=time.perf_counter() - t0,
                          total_seconds=time.perf_counter() - t_start)
    return summary


def _finish(cfg, root, samples, records, before: dict, executor: dict, *, seconds,
            total_seconds) -> dict:
    """Write the manifest and the summary (``before``: what the run found
    done or failed, its inputs); the summary."""
    rows = manifest_rows(samples, root, cfg.plan.seed, records)
    manifest = write_manifest(root, rows, cfg.output.manifest)
    counts = {status: sum(r["status"] == status for r in rows)
              for status in ("done", "failed", "pending")}
    rendered = sum(r["status"] == "done" for r in records.values())
    summary = {
        "config": None if cfg.path is None else str(cfg.path),
        "output": str(root), "planned": len(samples), **counts,
        "rendered": rendered, "failed_now": len(records) - rendered, **before,
        "seconds": seconds, "total_seconds": total_seconds,
        "samples_per_second": len(records) / seconds if records and seconds > 0 else None,
        "sample_seconds": sum(r["seconds"] for r in records.values()),
        "executor": executor, "manifest": manifest,
        "failures": [{"sample_id": r["sample_id"], "error": r["error"]}
                     for r in rows if r["status"] == "failed"][:SUMMARY_FAILURES],
    }
    write_summary(root, summary)
    return summary


def _prepare_output(root: Path) -> Path:
    """The output folder, made if needed and checked writable (absolute)."""
    root = root.expanduser().absolute()
    try:
        root.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AquaspecError(f"output folder {str(root)!r} cannot be made "
                            f"({exc.strerror or exc}); accepted: a folder that can be "
                            "written") from exc
    check_writable(root / "summary.json")
    return root


def _with_folder(cfg: SynthConfig, root: Path) -> SynthConfig:
    return replace(cfg, output=replace(cfg.output, folder=root))


def _execute(cfg, todo, workers, ray, records: dict, progress: bool) -> dict:
    """Render ``todo``, filling ``records`` by sample id; what ran it."""
    n_workers = 1 if workers is None and not ray else workers
    units = chunks(todo, n_workers or 2)
    bar = _progress_bar(len(todo), progress)

    def on_records(batch):
        for r in batch:
            records[r["sample_id"]] = r
        bar.update(len(batch))
        failed = sum(r["status"] == "failed" for r in records.values())
        if failed:
            bar.set_postfix(failed=failed)
    try:
        if ray:
            used = run_ray(cfg, units, n_workers, None if ray is True else str(ray), on_records)
            return {"kind": "ray", **used}
        run_local(cfg, units, n_workers, on_records)
        return {"kind": "local", "workers": n_workers}
    finally:
        bar.close()


def _progress_bar(total: int, show: bool):
    try:
        # deferred: tqdm is the optional synth extra; without it there is no bar
        from tqdm import tqdm
    except ImportError:
        show = False
    if not show:
        return _NoBar()
    return tqdm(total=total, unit="sample", desc="aquaspec synth", file=sys.stderr,
                dynamic_ncols=True, smoothing=0.1)


class _NoBar:
    def update(self, n):
        pass

    def set_postfix(self, **kwargs):
        pass

    def close(self):
        pass
