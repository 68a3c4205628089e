"""The ``aquaspec`` command line: a thin layer over the Python API.

One module per command; each has ``register(subparsers)`` adding its parser
and a ``run(args)`` that calls importable functions.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from aquaspec.errors import AquaspecError, GPUUnavailableError

COMMANDS = ("list", "spectra", "colour", "render", "view", "bench", "validate")

DESCRIPTION = """\
aquaspec renders underwater scenes spectrally: light is carried in n
wavelength bands through real water (Jerlov types, or your own a, b, Kd
spectra) and turned into RGB by a real camera's response curves.

Start with:
  aquaspec list waters                      which water types exist
  aquaspec colour --water IB --depth 5      what colour is that water?
  aquaspec render --water IB --depth 5 -o x.png
"""


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="aquaspec", description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        try:
            mod = importlib.import_module(f".{name}_cmd", __name__)
        except ModuleNotFoundError as exc:
            if exc.name and exc.name.endswith(f"{name}_cmd"):
                continue
            raise
        mod.register(sub)
    return parser


def _show_warning(message, category, filename, lineno, file=None, line=None):
    print(f"aquaspec: warning: {message}", file=file or sys.stderr)


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 2
    warnings.simplefilter("default")
    warnings.showwarning = _show_warning
    try:
        return int(args.func(args) or 0)
    except (AquaspecError, GPUUnavailableError, FileNotFoundError) as exc:
        print(f"aquaspec {args.command}: error: {exc}", file=sys.stderr)
        return 2
