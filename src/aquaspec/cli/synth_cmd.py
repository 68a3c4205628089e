"""``aquaspec synth``: an underwater data set from RGB-D images, resumable, locally or on Ray."""

from __future__ import annotations

import argparse
import sys


def _workers(text) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"{text!r} workers; accepted: 1 or more")
    return n


def register(sub):
    p = sub.add_parser(
        "synth", help="a data set from RGB-D images: a sampling plan over waters, depths, "
                      "cameras and light; resumable; local processes or a Ray cluster",
        description="Render every sample of the plan in CONFIG.toml (inputs, plan, render, "
                    "output; see docs/synth.md): per sample a PNG, a linear EXR, optionally "
                    "the image-formation layers, and a JSON sidecar written last; then a "
                    "manifest (CSV, Parquet) of every sample and a summary.json. Samples "
                    "done are skipped on a rerun, so a killed run goes on where it stopped; "
                    "failed ones are recorded with their error and rendered again with "
                    "--retry-failed.",
        epilog="example: aquaspec synth data.toml --workers 2 --layers")
    p.add_argument("config", metavar="CONFIG.toml", help="the data set's configuration")
    p.add_argument("-o", "--output", metavar="DIR",
                   help="output folder (default: the config's [output] folder)")
    p.add_argument("--workers", type=_workers, default=None, metavar="N",
                   help="worker processes of the local pool (default 1), or Ray actors "
                        "(default: one per GPU of the cluster, else one per CPU)")
    p.add_argument("--ray", nargs="?", const=True, default=False, metavar="ADDRESS",
                   help="run on Ray (pip install 'aquaspec[synth]'): no ADDRESS starts one "
                        "on this machine for the run, 'auto' joins this machine's cluster, "
                        "HOST:PORT a head node; outputs are those of the local pool")
    p.add_argument("--layers", action=argparse.BooleanOptionalAction, default=None,
                   help="write the image-formation layers of each sample (EXR) (default: "
                        "the config's [output] layers)")
    p.add_argument("--retry-failed", action="store_true",
                   help="render again the samples an earlier run recorded as failed")
    p.add_argument("--dry-run", action="store_true",
                   help="plan only: write the manifest (each sample done, failed or pending) "
                        "and the summary, render nothing")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run, command="synth")


def run(args):
    # deferred: the synth package loads the renderer (wgpu and every GPU pass)
    from aquaspec.apps.synth import synth
    summary = synth(args.config, output=args.output, layers=args.layers,
                    workers=args.workers, ray=args.ray, retry_failed=args.retry_failed,
                    progress=not args.no_progress, dry_run=args.dry_run)
    rate = summary["samples_per_second"]
    print(f"{summary['done']} of {summary['planned']} samples done "
          f"({summary['rendered']} now, {summary['skipped_done']} before), "
          f"{summary['failed']} failed, {summary['pending']} pending"
          + (f"; {rate:.2f} samples/s" if rate else "")
          + f"; manifest and summary in {summary['output']}")
    for failure in summary["failures"][:5]:
        print(f"aquaspec synth: failed {failure['sample_id']}: {failure['error']}",
              file=sys.stderr)
    if args.dry_run:
        return 0
    return 0 if summary["failed"] == 0 and summary["pending"] == 0 else 1
