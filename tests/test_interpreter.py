# SPDX-License-Identifier: LGPL-2.1-or-later
"""The right interpreter, or one clear line.

A Python without FreeCAD, matplotlib or pyserial must stop a command that will need them
before it writes anything, with exactly one line naming the module and the interpreter to
run instead (exit 2). The interpreter here is real: a venv made from this Python without its
site-packages, given only numpy and scipy (symlinks), so it lacks matplotlib and pyserial and
sees FreeCAD only through ``find_freecad_lib``. "No FreeCAD anywhere" is that venv with a
small wrapper that hides FreeCAD from the import system and from ``find_freecad_lib``. A bare
venv (no numpy either) checks the base line. The launcher ``tools/bladerecon`` and
``make install`` run the checkout's package from any directory.
"""
from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy
import pytest
import scipy

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "resources" / "sample"
LAUNCHER = REPO / "tools" / "bladerecon"
RIGHT = "/opt/right/bin/python3"   # BLADERECON_PYTHON in these runs: the interpreter the line names
LINE = re.compile(r"^bladerecon: error: this Python \((?P<python>[^)]+)\) has (?P<what>.+?): "
                  r"run (?P<right>\S+) -m bladerecon (?P<args>.+) \(make deps installs it\)(?P<tail>.*)$")

# Hides FreeCAD from this interpreter (imports and find_freecad_lib), then runs ``-m bladerecon``.
NO_FREECAD = r'''
import runpy, sys
class Hidden:
    def __init__(self, finder):
        self.finder = finder
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("FreeCAD", "Part", "FreeCADGui"):
            return None
        return self.finder.find_spec(name, path, target)
sys.meta_path[:] = [Hidden(f) if hasattr(f, "find_spec") else f for f in sys.meta_path]
import bladerecon.fc.freecad_env as env
env.find_freecad_lib = lambda: None
sys.argv[0] = "bladerecon"
runpy.run_module("bladerecon", run_name="__main__", alter_sys=True)
'''


def _venv(where: Path, packages=()) -> Path:
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(where)], check=True, timeout=120)
    python = where / "bin" / "python"
    site = subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True, timeout=60).stdout.strip()
    for module in packages:
        os.symlink(os.path.dirname(module.__file__), os.path.join(site, module.__name__))
    return python


@pytest.fixture(scope="module")
def lean_python(tmp_path_factory) -> Path:
    """A real interpreter with numpy and scipy only: no matplotlib, no pyserial."""
    python = _venv(tmp_path_factory.mktemp("lean") / "venv", (numpy, scipy))
    probe = ("import importlib.util as u, sys; "
             "print([m for m in ('numpy', 'scipy', 'matplotlib', 'serial') if u.find_spec(m)])")
    have = subprocess.run([str(python), "-c", probe], capture_output=True, text=True, timeout=60,
                          env=_env()).stdout.strip()
    assert have == "['numpy', 'scipy']", have
    return python


def _env(**extra) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "BLADERECON", "FREECAD"))}
    env.update({"PYTHONPATH": str(REPO), "BLADERECON_PYTHON": RIGHT, **extra})
    return env


def _run(python: Path, args: list[str], cwd: Path, hide_freecad: bool = False, **env):
    cmd = [str(python), "-c", NO_FREECAD] if hide_freecad else [str(python), "-m", "bladerecon"]
    return subprocess.run(cmd + args, cwd=str(cwd), capture_output=True, text=True, timeout=120, env=_env(**env))


def _one_line(proc, python: Path, module: str, args: list[str]) -> re.Match:
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    assert proc.stdout == ""
    lines = proc.stderr.splitlines()
    assert len(lines) == 1, proc.stderr
    m = LINE.match(lines[0])
    assert m, lines[0]
    assert m["python"] == str(python)
    assert m["what"] == f"no {module}"
    assert m["right"] == RIGHT
    assert m["args"].split() == args
    return m


MEASURED = str(SAMPLE / "measured.csv")
NOMINAL = str(SAMPLE / "nominal.step")

# (command line, the module it lacks, the outputs it must not leave behind)
LACKS_MATPLOTLIB_OR_SERIAL = [
    (["reconstruct", MEASURED, "-o", "blade.step", "--report", "report"], "matplotlib", ["blade.step", "report"]),
    (["reconstruct", MEASURED, "--report", "report", "--json"], "matplotlib", ["report"]),
    (["deviation", MEASURED, "--nominal", NOMINAL, "--csv", "dev.csv", "--report", "report"], "matplotlib",
     ["dev.csv", "report"]),
    (["sections", MEASURED, "--plots", "plots"], "matplotlib", ["plots"]),
    (["acquire", "--port", "loop://", "-o", "acquired.csv", "--journal", "acquired.journal"], "pyserial",
     ["acquired.csv", "acquired.journal"]),
    (["simulate-instrument", "--port", "loop://", "--clean", "clean.csv"], "pyserial", ["clean.csv"]),
]

LACKS_FREECAD = [
    (["reconstruct", MEASURED, "-o", "blade.step"], ["blade.step"]),
    (["reconstruct", MEASURED, "--nominal", NOMINAL, "--json"], []),
    (["deviation", MEASURED, "--nominal", NOMINAL, "--csv", "dev.csv"], ["dev.csv"]),
    (["sections", MEASURED, "--nominal", NOMINAL], []),
    (["plan", NOMINAL, "--heights", "5,10", "-o", "plan.csv"], ["plan.csv"]),
    (["tspline", MEASURED, "--tolerance", "0.05", "-o", "patches.step"], ["patches.step"]),
]


def _id(case) -> str:
    return "-".join(a.lstrip("-") for a in case[0] if not a.startswith("/"))


@pytest.mark.parametrize("args,module,outputs", LACKS_MATPLOTLIB_OR_SERIAL, ids=[_id(c) for c in LACKS_MATPLOTLIB_OR_SERIAL])
def test_a_missing_module_is_one_line_before_any_output(lean_python, tmp_path, args, module, outputs):
    proc = _run(lean_python, args, tmp_path)
    _one_line(proc, lean_python, module, args)
    assert not [p for p in outputs if (tmp_path / p).exists()]
    assert os.listdir(tmp_path) == []          # no default journal or half-written file either


@pytest.mark.parametrize("args,outputs", LACKS_FREECAD, ids=[_id(c) for c in LACKS_FREECAD])
def test_no_freecad_is_one_line_naming_freecad_lib(lean_python, tmp_path, args, outputs):
    proc = _run(lean_python, args, tmp_path, hide_freecad=True)
    m = _one_line(proc, lean_python, "FreeCAD", args)
    assert m["tail"] == "; or set FREECAD_LIB to the folder that holds FreeCAD.so"
    assert not [p for p in outputs if (tmp_path / p).exists()]
    assert os.listdir(tmp_path) == []


def test_several_missing_modules_are_named_in_the_one_line(lean_python, tmp_path):
    args = ["reconstruct", MEASURED, "-o", "blade.step", "--report", "report"]
    proc = _run(lean_python, args, tmp_path, hide_freecad=True)
    m = _one_line(proc, lean_python, "FreeCAD and no matplotlib", args)
    assert "FREECAD_LIB" in m["tail"]
    assert os.listdir(tmp_path) == []


def test_without_numpy_every_command_is_one_line(tmp_path):
    bare = _venv(tmp_path / "bare")
    work = tmp_path / "work"
    work.mkdir()
    for args in (["reconstruct", MEASURED, "--json"], ["acquire", "--replay", "x.journal", "-o", "x.csv"]):
        proc = _run(bare, args, work)
        _one_line(proc, bare, "numpy and no scipy", args)
    assert os.listdir(work) == []


def test_commands_that_need_none_of_them_still_run(lean_python, tmp_path):
    """The checks are per option: no -o/--nominal/--report/--plots, no module asked for."""
    for args in (["reconstruct", MEASURED, "--json", "--quiet"], ["sections", MEASURED, "--json", "--quiet"]):
        proc = _run(lean_python, args, tmp_path)
        assert proc.returncode == 0, proc.stderr
        assert proc.stdout.lstrip().startswith(("{", "["))


def test_the_right_python_is_told_to_install(lean_python, tmp_path):
    """When this Python is the one BLADERECON_PYTHON names, the line says what to install."""
    args = ["sections", MEASURED, "--plots", "plots"]
    proc = _run(lean_python, args, tmp_path, BLADERECON_PYTHON=str(lean_python))
    assert proc.returncode == 2
    assert proc.stderr.splitlines() == [
        f"bladerecon: error: this Python ({lean_python}) has no matplotlib: "
        "make deps installs it (sudo apt-get install python3-matplotlib)"]


def test_the_launcher_runs_the_checkout_from_any_directory(tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "BLADERECON"))}
    env["BLADERECON_PYTHON"] = sys.executable
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    link_dir = tmp_path / "bin"
    link_dir.mkdir()
    (link_dir / "bladerecon").symlink_to(LAUNCHER)           # what make install puts on PATH
    for cmd in ([str(LAUNCHER)], [str(link_dir / "bladerecon")],
                ["bladerecon"]):                              # found on PATH, run through the symlink
        proc = subprocess.run(cmd + ["sections", MEASURED, "--json", "--quiet"], cwd=str(elsewhere),
                              capture_output=True, text=True, timeout=120,
                              env={**env, "PATH": f"{link_dir}{os.pathsep}{env.get('PATH', '')}"})
        assert proc.returncode == 0, (cmd, proc.stderr)
        assert proc.stdout.lstrip().startswith("[")
    assert os.listdir(elsewhere) == []


def test_the_launcher_runs_bladerecon_python(lean_python, tmp_path):
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "BLADERECON"))}
    proc = subprocess.run([str(LAUNCHER), "sections", MEASURED, "--plots", "plots"], cwd=str(tmp_path),
                          capture_output=True, text=True, timeout=120, env={**env, "BLADERECON_PYTHON": str(lean_python)})
    assert proc.returncode == 2
    assert proc.stderr.startswith(f"bladerecon: error: this Python ({lean_python}) has no matplotlib: ")
    missing = subprocess.run([str(LAUNCHER), "--version"], capture_output=True, text=True, timeout=60,
                             env={**env, "BLADERECON_PYTHON": str(tmp_path / "no-such-python")})
    assert missing.returncode == 2
    assert missing.stderr.splitlines() == [
        f"bladerecon: error: no Python at {tmp_path / 'no-such-python'} (BLADERECON_PYTHON): "
        "set BLADERECON_PYTHON to the Python FreeCAD was built for, or unset it for /usr/bin/python3"]


@pytest.mark.skipif(shutil.which("make") is None, reason="needs make")
def test_make_install_puts_the_launcher_on_path(tmp_path):
    prefix = tmp_path / "prefix"
    env = {k: v for k, v in os.environ.items() if not k.startswith(("PYTHON", "BLADERECON", "MAKE"))}
    proc = subprocess.run(["make", "-s", "-C", str(REPO), "install", f"PREFIX={prefix}"], capture_output=True,
                          text=True, timeout=120, env=env)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    installed = prefix / "bin" / "bladerecon"
    assert installed.is_symlink() and installed.resolve() == LAUNCHER.resolve()
    assert str(installed) in proc.stdout                       # it says where
    assert "not on your PATH" in proc.stdout                   # and that this prefix is not on PATH
    version = subprocess.run(["bladerecon", "--version"], cwd=str(tmp_path), capture_output=True, text=True,
                             timeout=60, env={**env, "BLADERECON_PYTHON": sys.executable,
                                              "PATH": f"{installed.parent}{os.pathsep}{env.get('PATH', '')}"})
    assert version.returncode == 0, version.stderr
    assert version.stdout.startswith("bladerecon ")
    again = subprocess.run(["make", "-s", "-C", str(REPO), "install", f"PREFIX={prefix}"], capture_output=True,
                           text=True, timeout=120, env=env)
    assert again.returncode == 0, again.stderr                 # a second install replaces the link
