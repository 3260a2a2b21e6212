# SPDX-License-Identifier: LGPL-2.1-or-later
"""Headless entry point: ``python3 -m bladerecon reconstruct measured.csv -o blade.step ...``.

Errors a user can cause print one line ``bladerecon: error: ...`` on stderr and exit with
status 2; input files are never written; outputs are written atomically (a failed run leaves
no half-written STEP or report behind). Progress goes to stderr, the ``--json`` summary to
stdout. Set ``BLADERECON_DEBUG=1`` to see a traceback for an internal error.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import importlib

from bladerecon import __version__
from bladerecon.core.errors import BladeReconError

__all__ = ["main", "build_parser"]


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python3 -m bladerecon",
                                     description="Blade surface reconstruction from measured sections (units: mm).")
    parser.add_argument("--version", action="version", version=f"bladerecon {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in COMMAND_MODULES:
        importlib.import_module(module).add_parser(sub)
    return parser


# One module per subcommand, each with ``add_parser(sub)`` that calls
# ``set_defaults(run=function_returning_summary_dict)``; main() prints the summary with --json.
COMMAND_MODULES: tuple[str, ...] = ("bladerecon.cli.reconstruct", "bladerecon.cli.deviation", "bladerecon.cli.sections",
                                    "bladerecon.cli.plan", "bladerecon.cli.tspline", "bladerecon.cli.acquire")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        summary = args.run(args)
        if args.command == "simulate-instrument":   # one line: a controlling script reads it at once
            print(json.dumps(summary), flush=True)
        elif getattr(args, "json", False):
            print(json.dumps(summary, indent=2 if args.command != "acquire" else None), flush=True)
        return 0
    except BladeReconError as err:
        print(f"bladerecon: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bladerecon: interrupted; no output was completed", file=sys.stderr)
        return 130
    except Exception as err:  # an internal error: one line unless debugging
        if os.environ.get("BLADERECON_DEBUG"):
            raise
        print(f"bladerecon: internal error: {type(err).__name__}: {err} "
              "(please report it; set BLADERECON_DEBUG=1 for details)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
