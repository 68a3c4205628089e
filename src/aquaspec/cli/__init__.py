"""The ``aquaspec`` command line: a thin layer over the Python API.

One module per command; each has ``register(subparsers)`` adding its parser
and a ``run(args)`` that calls importable functions. Errors the user can fix
are one line on stderr with exit status 2; Ctrl-C is "aquaspec: interrupted"
with status 130 (128 + SIGINT, the shell's convention), and every file is
written atomically, so an interrupted command leaves nothing half-written.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings

from aquaspec.cli.common import Parser
from aquaspec.errors import AquaspecError, GPUUnavailableError

#: Exit status after Ctrl-C: 128 + SIGINT.
EXIT_INTERRUPTED = 130

COMMANDS = ("list", "spectra", "colour", "render", "view", "synth", "bench", "validate",
            "cache")

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
    parser = Parser(
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
    try:
        return _main(argv)
    except KeyboardInterrupt:
        print("aquaspec: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


def _main(argv) -> int:
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
