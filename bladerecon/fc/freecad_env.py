# SPDX-License-Identifier: LGPL-2.1-or-later
"""Find and import FreeCAD + Part from a plain Python interpreter.

FreeCAD's Python modules (``FreeCAD.so``, ``Part.so``) live in a ``lib`` folder that is not
on ``sys.path`` of the system Python. :func:`import_freecad` looks for it in this order:

1. ``FREECAD_LIB`` (one folder, or several separated by ``os.pathsep``);
2. the folder of an already importable ``FreeCAD`` (inside the FreeCAD GUI, or a conda env);
3. the usual install places (Debian/Ubuntu, Fedora, /usr/local, /opt, conda prefixes,
   ``$FREECAD_HOME/lib``, macOS app bundle, Windows program folders).

Importing FreeCAD must never write to stdout: the CLI's ``--json`` output goes there.
:func:`stdout_to_stderr` sends file descriptor 1 to stderr around any call into FreeCAD
or OpenCASCADE that might print (C++ code writes to the descriptor, not to ``sys.stdout``).
"""
from __future__ import annotations

import contextlib
import glob
import os
import re
import sys
from types import ModuleType
from typing import Iterator

from bladerecon.core.errors import BladeReconError

__all__ = ["import_freecad", "find_freecad_lib", "candidate_lib_dirs", "stdout_to_stderr", "freecad_python_version"]

INSTALL_HINT = (
    "install FreeCAD (Debian/Ubuntu: sudo apt-get install freecad) "
    "or set FREECAD_LIB to the folder that holds FreeCAD.so"
)

_MODULE_NAMES = ("FreeCAD.so", "FreeCAD.pyd", "FreeCAD.dylib")


def _env_dirs(name: str) -> list[str]:
    value = os.environ.get(name, "")
    return [d for d in value.split(os.pathsep) if d]


def candidate_lib_dirs() -> list[str]:
    """Folders that may hold FreeCAD's Python module, most specific first."""
    dirs = list(_env_dirs("FREECAD_LIB"))
    for home in _env_dirs("FREECAD_HOME"):
        dirs += [os.path.join(home, "lib"), os.path.join(home, "bin")]
    prefixes = [os.environ.get("CONDA_PREFIX", ""), sys.prefix, sys.base_prefix]
    for prefix in filter(None, prefixes):
        dirs += [os.path.join(prefix, "lib"), os.path.join(prefix, "Library", "bin")]
    dirs += [
        "/usr/lib/freecad-python3/lib",
        "/usr/lib/freecad-daily-python3/lib",
        "/usr/lib/freecad/lib",
        "/usr/lib64/freecad/lib",
        "/usr/local/lib/freecad/lib",
        "/usr/local/lib/freecad-python3/lib",
        "/usr/share/freecad/lib",
        "/usr/local/share/freecad/lib",
        "/opt/freecad/lib",
        "/snap/freecad/current/usr/lib/freecad/lib",
        "/Applications/FreeCAD.app/Contents/Resources/lib",
        os.path.expanduser("~/miniconda3/lib"),
        os.path.expanduser("~/anaconda3/lib"),
        os.path.expanduser("~/miniforge3/lib"),
    ]
    dirs += sorted(glob.glob("/opt/freecad*/lib")) + sorted(glob.glob("/usr/lib/freecad*/lib"))
    for program_files in filter(None, [os.environ.get("ProgramFiles"), os.environ.get("ProgramW6432")]):
        dirs += sorted(glob.glob(os.path.join(program_files, "FreeCAD*", "bin")))
    seen: set[str] = set()
    unique = []
    for d in dirs:
        key = os.path.normcase(os.path.abspath(d))
        if key not in seen:
            seen.add(key)
            unique.append(d)
    return unique


def _holds_freecad(folder: str) -> bool:
    return any(os.path.isfile(os.path.join(folder, name)) for name in _MODULE_NAMES)


def find_freecad_lib() -> str | None:
    """The first candidate folder that holds ``FreeCAD.so`` (or ``.pyd``), else None."""
    for folder in candidate_lib_dirs():
        if _holds_freecad(folder):
            return folder
    return None


def freecad_python_version(folder: str) -> str | None:
    """The Python version ("3.11") FreeCAD's module in ``folder`` is linked against, else None.

    Reads the small ``FreeCAD.so``/``.pyd`` for the name of the Python library it needs
    (``libpython3.11.so.1.0``, ``python311.dll``): cheap, and nothing is loaded. None when the
    name is not there (a statically linked or unusual build): then only an import can tell.
    """
    for name in _MODULE_NAMES:
        path = os.path.join(folder, name)
        try:
            with open(path, "rb") as f:
                data = f.read(8 << 20)
        except OSError:
            continue
        found = re.search(rb"libpython(3\.\d+)", data)
        if found:
            return found.group(1).decode()
        found = re.search(rb"python3(\d+)\.dll", data, re.IGNORECASE)
        if found:
            return "3." + found.group(1).decode()
        return None
    return None


@contextlib.contextmanager
def stdout_to_stderr() -> Iterator[None]:
    """Redirect file descriptor 1 (and ``sys.stdout``) to stderr for the duration.

    Keeps stdout clean for ``--json`` output while FreeCAD or OpenCASCADE may print
    banners or transfer statistics from C++.
    """
    try:
        sys.stdout.flush()
        out_fd = sys.stdout.fileno()
        err_fd = sys.stderr.fileno()
    except (AttributeError, OSError, ValueError):
        yield  # no real descriptors (e.g. inside the FreeCAD GUI console): nothing to guard
        return
    saved = os.dup(out_fd)
    try:
        os.dup2(err_fd, out_fd)
        yield
    finally:
        try:
            sys.stdout.flush()
        finally:
            os.dup2(saved, out_fd)
            os.close(saved)


def _import_modules() -> tuple[ModuleType, ModuleType]:
    # Ctrl-C and SIGTERM held until FreeCAD is loaded: raised inside FreeCAD's start-up (which
    # runs Python code) they came out as an empty ImportError, and the command blamed the
    # install ("cannot load it", exit 2) instead of ending with 130/143 (seen on FreeCAD 1.0
    # under load, 2026-11-27)
    from bladerecon.core.io.outputs import signals_held

    with signals_held(), stdout_to_stderr():
        import FreeCAD  # noqa: N813  (FreeCAD's own module name)
        import Part
    return FreeCAD, Part


def import_freecad() -> tuple[ModuleType, ModuleType]:
    """Return the ``(FreeCAD, Part)`` modules, adding FreeCAD's lib folder to ``sys.path``.

    Raises :class:`BladeReconError` with a one-line hint when FreeCAD cannot be found or
    cannot be loaded by this interpreter.
    """
    if "FreeCAD" in sys.modules and "Part" in sys.modules:
        return sys.modules["FreeCAD"], sys.modules["Part"]
    for folder in reversed(_env_dirs("FREECAD_LIB")):
        if folder not in sys.path:
            sys.path.insert(0, folder)
    try:
        return _import_modules()
    except ImportError:
        pass
    folder = find_freecad_lib()
    if folder is None:
        raise BladeReconError(f"FreeCAD not found: {INSTALL_HINT}")
    if folder not in sys.path:
        sys.path.append(folder)
    try:
        return _import_modules()
    except ImportError as err:
        detail = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise BladeReconError(
            f"FreeCAD found in {folder} but this Python ({sys.executable}, "
            f"{sys.version_info.major}.{sys.version_info.minor}) cannot load it ({detail}): "
            f"run the Python FreeCAD was built for (e.g. /usr/bin/python3) or {INSTALL_HINT}"
        ) from None
