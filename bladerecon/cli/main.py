# SPDX-License-Identifier: LGPL-2.1-or-later
"""Headless entry point: ``python3 -m bladerecon reconstruct measured.csv -o blade.step ...``.

Errors a user can cause print one line ``bladerecon: error: ...`` on stderr and exit with
status 2; input files are never written; outputs are written atomically (a failed run leaves
no half-written STEP or report behind). A command that needs a module this Python lacks
(FreeCAD, matplotlib, pyserial; numpy and scipy for any command) stops before it reads or
writes anything, in one line naming the module and the interpreter to run instead.
Progress goes to stderr, the ``--json`` summary to stdout. Set ``BLADERECON_DEBUG=1`` to see
a traceback for an internal error.
"""
from __future__ import annotations

import argparse
import importlib
import importlib.util
import json
import os
import shlex
import signal
import sys

from bladerecon import __version__
from bladerecon.core.errors import BladeReconError

__all__ = ["main", "build_parser", "needed_modules", "missing_modules", "DEFAULT_PYTHON"]


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The command-line parser; with ``command`` (a known command's name, the first word of the
    command line) only that command's module is loaded and its parser added: the same parse and
    messages for that command line, without the other commands' imports (0.03 s of `sections`,
    issue 24). Any other first word (an option, a typo) gets the full parser and its messages."""
    parser = argparse.ArgumentParser(prog="python3 -m bladerecon",
                                     description="Blade surface reconstruction from measured sections (units: mm).")
    parser.add_argument("--version", action="version", version=f"bladerecon {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for module in ((COMMAND_MODULE[command],) if command in COMMAND_MODULE else COMMAND_MODULES):
        importlib.import_module(module).add_parser(sub)
    return parser


# One module per subcommand, each with ``add_parser(sub)`` that calls
# ``set_defaults(run=function_returning_summary_dict)``; main() prints the summary with --json.
COMMAND_MODULES: tuple[str, ...] = ("bladerecon.cli.reconstruct", "bladerecon.cli.deviation", "bladerecon.cli.sections",
                                    "bladerecon.cli.plan", "bladerecon.cli.tspline", "bladerecon.cli.acquire",
                                    "bladerecon.cli.batch", "bladerecon.cli.blisk", "bladerecon.cli.repair")
# The module that adds each command (tests check it against the parsers COMMAND_MODULES add).
COMMAND_MODULE: dict[str, str] = {
    "reconstruct": "bladerecon.cli.reconstruct", "deviation": "bladerecon.cli.deviation",
    "sections": "bladerecon.cli.sections", "plan": "bladerecon.cli.plan", "tspline": "bladerecon.cli.tspline",
    "acquire": "bladerecon.cli.acquire", "simulate-instrument": "bladerecon.cli.acquire",
    "batch": "bladerecon.cli.batch", "blisk": "bladerecon.cli.blisk", "repair": "bladerecon.cli.repair"}


# The interpreter FreeCAD's Python modules are built for (Debian/Ubuntu); BLADERECON_PYTHON
# names another (tools/bladerecon runs the same one).
DEFAULT_PYTHON = "/usr/bin/python3"
# Every command: the core is numpy + scipy (the command modules import numpy at the top).
BASE_MODULES = ("numpy", "scipy")
_SHAPE_SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep", ".brp", ".fcstd")
# Debian's package names, for the hint when this Python is the right one but lacks a module.
_LABEL = {"serial": "pyserial"}    # the module ``serial`` comes in the package pyserial
_DEBIAN = {"numpy": "python3-numpy", "scipy": "python3-scipy", "matplotlib": "python3-matplotlib",
           "serial": "python3-serial", "FreeCAD": "freecad",
           "distributed": "python3-distributed"}


def _shape(path: str | None) -> bool:
    return bool(path) and os.path.splitext(path)[1].lower() in _SHAPE_SUFFIXES


def needed_modules(args: argparse.Namespace) -> list[str]:
    """The optional modules this command with these options will import (besides numpy/scipy).

    ``FreeCAD`` (with Part) for any STEP/IGES/BREP/FCStd read or written, ``matplotlib`` for
    plots (reports, section plots), ``serial`` (pyserial) for a real port.
    """
    need: list[str] = []
    command = args.command
    if command == "reconstruct":
        if args.output or args.nominal:
            need.append("FreeCAD")
        if args.report:
            need.append("matplotlib")
    elif command == "deviation":
        need.append("FreeCAD")              # the nominal is a shape (and the measured may be)
        if args.report:
            need.append("matplotlib")
    elif command == "sections":
        if _shape(args.nominal):            # cut in each section's plane; a section file needs nothing
            need.append("FreeCAD")
        if args.plots:
            need.append("matplotlib")
    elif command == "plan":
        if _shape(args.nominal) or args.check or args.surface_within:
            need.append("FreeCAD")          # cutting the nominal; --check measures against it
    elif command == "tspline":
        if args.output:
            need.append("FreeCAD")
    elif command in ("batch", "blisk"):
        if not args.scheduler or command == "blisk":   # the Dask workers read the nominal, not this one
            need.append("FreeCAD")
        need.append("matplotlib")           # lot.html's trend plot
        if args.scheduler:
            need.append("distributed")      # Dask distributed (python3-distributed)
    elif command == "repair":
        need.append("FreeCAD")              # the nominal is a shape
        if args.report:
            need.append("matplotlib")
    elif command in ("acquire", "simulate-instrument"):
        if getattr(args, "port", None):     # --replay reads a journal, --link makes a pty: no pyserial
            need.append("serial")
    return need


def _importable(name: str) -> bool:
    """``import name`` would find it (a None in sys.modules blocks an import: not importable)."""
    if name in sys.modules:
        return sys.modules[name] is not None
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def _freecad_problem() -> str | None:
    """None when FreeCAD can be imported here, else what is wrong (cheap: no import)."""
    if _importable("FreeCAD"):
        return None
    from bladerecon.fc import freecad_env

    folder = freecad_env.find_freecad_lib()
    if folder is None:
        return "no FreeCAD"
    built_for = freecad_env.freecad_python_version(folder)
    here = f"{sys.version_info.major}.{sys.version_info.minor}"
    if built_for is not None and built_for != here:
        return f"no FreeCAD it can load (the one in {folder} is built for Python {built_for}, this is {here})"
    return None


def missing_modules(modules) -> list[tuple[str, str]]:
    """``(module, problem)`` for each of ``modules`` this Python cannot import; no heavy import."""
    missing = []
    for name in modules:
        if name == "FreeCAD":
            problem = _freecad_problem()
        else:
            problem = None if _importable(name) else f"no {_LABEL.get(name, name)}"
        if problem:
            missing.append((name, problem))
    return missing


def _right_python() -> str:
    return os.environ.get("BLADERECON_PYTHON") or DEFAULT_PYTHON


def _is_this_python(path: str) -> bool:
    if os.path.abspath(path) == os.path.abspath(sys.executable):
        return True
    try:   # the same file (python3 -> python3.11), unless this one runs a venv
        return os.path.samefile(path, sys.executable) and sys.prefix == sys.base_prefix
    except OSError:
        return False


def interpreter_error(missing: list[tuple[str, str]], argv: list[str]) -> str:
    """The one line for modules this Python lacks: which, and the command line that has them."""
    names = [name for name, _ in missing]
    what = " and ".join(problem for _, problem in missing)
    python = _right_python()
    if _is_this_python(python):
        packages = " ".join(_DEBIAN.get(n, n) for n in names)
        advice = f"make deps installs it (sudo apt-get install {packages})"
    else:
        advice = f"run {python} -m bladerecon {shlex.join(argv)} (make deps installs it)"
    if "FreeCAD" in names:
        advice += "; or set FREECAD_LIB to the folder that holds FreeCAD.so"
    return f"bladerecon: error: this Python ({sys.executable}) has {what}: {advice}"


class Terminated(BaseException):
    """SIGTERM arrived: raised where the command is, so that every ``with Outputs(...)`` on the
    way out removes its temporaries (as for Ctrl-C)."""


def _on_sigterm(signum, frame) -> None:
    raise Terminated()


_STOP_LINES = {130: "bladerecon: interrupted; no output was completed",
               143: "bladerecon: terminated (SIGTERM); no output was completed"}


def _stop_now(signum: int) -> None:
    """A stop swallowed over and over (see :mod:`.stops`): the usual line, and leave."""
    code = 130 if signum == signal.SIGINT else 143
    print(_STOP_LINES[code], file=sys.stderr, flush=True)
    os._exit(code)


def main(argv: list[str] | None = None) -> int:
    as_program = argv is None
    previous = None
    resend = None
    try:
        try:
            argv = list(sys.argv[1:] if argv is None else argv)
            if _main_thread():
                from bladerecon.cli.stops import resend_swallowed
                previous = signal.signal(signal.SIGTERM, _on_sigterm)
                resend = resend_swallowed({KeyboardInterrupt: signal.SIGINT, Terminated: signal.SIGTERM},
                                          _stop_now).__enter__()
            code = _main(argv)
        # while the parser's modules load (numpy, scipy: a few tenths of a second), before any
        # work: one line and the usual status, not a traceback with status 1
        except KeyboardInterrupt:
            print(_STOP_LINES[130], file=sys.stderr)
            code = 130
        except Terminated:
            print(_STOP_LINES[143], file=sys.stderr)
            code = 143
        except BrokenPipeError:     # met while a line about another failure was printed
            _silence_stdio()
            code = _BROKEN_PIPE
    finally:
        if resend is not None:        # timers not yet fired cancelled: nothing lands after the return
            resend.__exit__(None, None, None)
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    if as_program and code in (130, 143):
        # Interrupted, temporaries already removed: leave now. FreeCAD interrupted while it reads
        # a STEP can crash in the interpreter's clean-up and turn 130 into 1.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    return code


_BROKEN_PIPE = 128 + 13     # the shell's status for a process ended by SIGPIPE


def _silence_stdio() -> None:
    """stdout and stderr onto /dev/null: a closed pipe takes no more lines, and the interpreter's
    last flush would print 'Exception ignored ... BrokenPipeError' where it still could."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    for stream in (sys.stdout, sys.stderr):
        try:
            os.dup2(devnull, stream.fileno())
        except (OSError, ValueError, AttributeError):    # not a file (a test's capture): nothing to do
            pass
    os.close(devnull)


def _main_thread() -> bool:
    import threading
    return threading.current_thread() is threading.main_thread()


# Commands that never load scipy's solvers: no reason to spend their start-up on them.
_LIGHT_COMMANDS = ("acquire", "simulate-instrument")
# scipy's modules the commands load on their way: scipy builds some functions from generated
# source (scipy._lib.decorator: sparse.linalg's iterative solvers), and prints that source to
# stderr for any exception in it, a Ctrl-C's or a SIGTERM's too ("Error in generated code: ...",
# then the one line; seen at 0.15 s into `deviation`, 2026-11-28)
_SCIPY_MODULES = ("scipy.sparse.linalg", "scipy.spatial", "scipy.optimize", "scipy.interpolate")
# Commands that need fewer of them: `sections` on planar sections never loads scipy.optimize or
# scipy.interpolate (0.035 s of its 0.4 s target, issue 24); where it does (a non-planar section's
# m'-theta frame, a STEP nominal) they load at that import, and neither builds generated source
# (scipy._lib.decorator serves sparse.linalg and spatial only), so holding the signals is not needed there
_SCIPY_MODULES_OF = {"sections": ("scipy.sparse.linalg", "scipy.spatial")}


def _load_scipy(command: str | None = None) -> None:
    """Load :data:`_SCIPY_MODULES` (or the command's own list, :data:`_SCIPY_MODULES_OF`) now
    (the caller holds Ctrl-C and SIGTERM, delivered after): most commands load them within their
    first second anyway."""
    import importlib

    for name in _SCIPY_MODULES_OF.get(command, _SCIPY_MODULES):
        try:
            importlib.import_module(name)
        except ImportError:           # said where the command needs it, as before
            pass


def _main(argv: list[str]) -> int:
    from bladerecon.core.io.outputs import signals_held

    # Ctrl-C and SIGTERM held while the modules load and delivered after: raised inside numpy's
    # or FreeCAD's start-up they came out as an ImportError ("numpy cannot be imported", status 1)
    with signals_held():
        missing = missing_modules(BASE_MODULES)
        if missing:    # the parser itself needs numpy (the command modules import it)
            print(interpreter_error(missing, argv), file=sys.stderr)
            return 2
        parser = build_parser(argv[0] if argv else None)
    args, extra = parser.parse_known_args(argv)      # parse_args is this, then an error for the extras
    if extra:     # the full parser's message for them, its usage naming every command, as before
        with signals_held():
            parser = build_parser()
        args = parser.parse_args(argv)
    missing = missing_modules(needed_modules(args))
    if missing:    # before any output: a STEP written and then no report is worse than nothing
        print(interpreter_error(missing, argv), file=sys.stderr)
        return 2
    if args.command not in _LIGHT_COMMANDS:
        with signals_held():
            _load_scipy(args.command)
    try:
        summary = args.run(args)
        if args.command == "simulate-instrument":   # one line: a controlling script reads it at once
            print(json.dumps(summary), flush=True)
        elif getattr(args, "json", False):
            print(json.dumps(summary, indent=2 if args.command != "acquire" else None), flush=True)
        return 0
    except BladeReconError as err:      # names from the command line or a file: never raw control bytes
        from bladerecon.core.io.outputs import escaped
        print(f"bladerecon: error: {escaped(err)}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(_STOP_LINES[130], file=sys.stderr)
        return 130
    except Terminated:
        print(_STOP_LINES[143], file=sys.stderr)
        return 143
    except BrokenPipeError:
        # the reader of stdout or stderr went away (``... --json | head``): as any Unix tool, end
        # quietly with SIGPIPE's status; outputs not yet committed were removed on the way out
        _silence_stdio()
        return _BROKEN_PIPE
    except Exception as err:  # an internal error: one line unless debugging
        if os.environ.get("BLADERECON_DEBUG"):
            raise
        from bladerecon.core.io.outputs import escaped
        print(f"bladerecon: internal error: {type(err).__name__}: {escaped(err)} "
              "(please report it; set BLADERECON_DEBUG=1 for details)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
