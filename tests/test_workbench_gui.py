"""The workbench loads in a real FreeCAD GUI (under Xvfb) as an addon from the user Mod folder.

A temporary HOME gets ``.local/share/FreeCAD/Mod/BladeRecon`` -> the repository (a symlink),
FreeCAD runs a script that activates the workbench, checks its toolbar, menu and command,
imports a small point file through the command's replayable path, saves screenshots and
writes a JSON result that this test asserts on.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import textwrap
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
TIMEOUT_S = 240

pytestmark = pytest.mark.skipif(
    shutil.which("xvfb-run") is None or shutil.which("freecad") is None,
    reason="needs xvfb-run and the freecad GUI executable",
)

GUI_SCRIPT = r'''
import json, os, sys, traceback
out_dir = {out_dir!r}
result = {{"steps": []}}

def step(name):
    result["steps"].append(name)

try:
    import FreeCAD, FreeCADGui
    from PySide import QtGui
    step("started")
    result["freecad_version"] = ".".join(FreeCAD.Version()[:3])
    result["workbenches"] = sorted(FreeCADGui.listWorkbenches())
    FreeCADGui.activateWorkbench("BladeReconWorkbench")
    step("activated")
    wb = FreeCADGui.activeWorkbench()
    result["active_workbench"] = type(wb).__name__
    result["bladerecon_file"] = sys.modules["bladerecon"].__file__
    mw = FreeCADGui.getMainWindow()
    bars = [b for b in mw.findChildren(QtGui.QToolBar) if b.windowTitle() == "BladeRecon"]
    result["toolbar_visible"] = any(b.isVisible() for b in bars)
    result["toolbar_actions"] = [a.text() for b in bars for a in b.actions()]
    result["menus"] = [a.text().replace("&", "") for a in mw.menuBar().actions()]
    result["commands"] = [c for c in FreeCADGui.listCommands() if c.startswith("BladeRecon")]
    result["command_icon"] = FreeCADGui.Command.get("BladeRecon_ImportPoints").getInfo()["pixmap"] \
        if hasattr(FreeCADGui, "Command") and hasattr(FreeCADGui.Command, "get") else None

    # error path: a missing file is reported in a message box, the document untouched
    import bladerecon.gui.commands as commands
    shown = []
    QtGui.QMessageBox.critical = staticmethod(lambda parent, title, text, *a: shown.append(text))
    doc = FreeCAD.newDocument("GuiTest")
    commands.import_points(os.path.join(out_dir, "missing.csv"))
    result["error_messages"] = list(shown)
    result["objects_after_error"] = len(doc.Objects)

    # the real path: transaction + FreeCADGui.doCommand, then undo and redo
    commands.import_points(os.path.join(out_dir, "points.csv"))
    step("imported")
    sections = [o for o in doc.Objects if o.TypeId == "Part::Feature"]
    result["sections"] = [o.Label for o in sections]
    result["vertex_counts"] = [len(o.Shape.Vertexes) for o in sections]
    result["undo_names"] = list(doc.UndoNames)
    doc.undo()
    result["objects_after_undo"] = len(doc.Objects)
    doc.redo()
    result["objects_after_redo"] = len(doc.Objects)

    view = FreeCADGui.ActiveDocument.ActiveView
    view.viewIsometric()
    view.fitAll()
    FreeCADGui.updateGui()
    view.saveImage(os.path.join(out_dir, "view.png"), 800, 600, "White")
    # read back from the X server: QWidget.grab() leaves the OpenGL 3D view blank
    screen = QtGui.QGuiApplication.primaryScreen()
    screen.grabWindow(mw.winId()).save(os.path.join(out_dir, "window.png"))
    step("screenshots")
except Exception:
    result["error"] = traceback.format_exc()
with open(os.path.join(out_dir, "result.json"), "w") as f:
    json.dump(result, f, indent=1)
os._exit(0)
'''


def _write_points(path: Path) -> None:
    """Five elliptic sections of 60 points each, as ``section,x,y,z`` (mm)."""
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    with open(path, "w") as f:
        f.write("section,x,y,z\n")
        for k in range(5):
            for a in t:
                f.write(f"{k},{(30 - 2 * k) * np.cos(a):.6f},{(6 + k) * np.sin(a):.6f},{20.0 * k:.6f}\n")


def _user_mod_dir(env: dict) -> Path:
    """FreeCAD's user Mod folder for this environment (versioned in FreeCAD 1.1+)."""
    default = Path(env["XDG_DATA_HOME"]) / "FreeCAD" / "Mod"
    cmd = shutil.which("freecadcmd") or shutil.which("FreeCADCmd")
    if cmd:
        code = "import FreeCAD; print('USERDIR=' + FreeCAD.getUserAppDataDir())"
        proc = subprocess.run([cmd, "-c", code], env=env, capture_output=True, text=True, timeout=120)
        for line in proc.stdout.splitlines():
            if line.startswith("USERDIR="):
                return Path(line[len("USERDIR="):]) / "Mod"
    return default


@pytest.fixture(scope="module")
def gui_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("gui")
    home = tmp / "home"
    # a clean start: FreeCAD must find the package through the Mod folder alone
    env = {k: v for k, v in os.environ.items() if not k.startswith(("XDG_", "PYTHON", "FREECAD", "QT_QPA"))}
    env.update(
        HOME=str(home),
        XDG_DATA_HOME=str(home / ".local" / "share"),
        XDG_CONFIG_HOME=str(home / ".config"),
        XDG_CACHE_HOME=str(home / ".cache"),
        XDG_RUNTIME_DIR=str(tmp),
        QTWEBENGINE_DISABLE_SANDBOX="1",
        LC_ALL="C.UTF-8",
    )
    mod = _user_mod_dir(env)
    mod.mkdir(parents=True, exist_ok=True)
    (mod / "BladeRecon").symlink_to(REPO, target_is_directory=True)
    out = tmp / "out"
    out.mkdir()
    _write_points(out / "points.csv")
    script = tmp / "gui_check.py"
    script.write_text(textwrap.dedent(GUI_SCRIPT.format(out_dir=str(out))))
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1600x1000x24", "freecad", str(script)]
    proc = subprocess.run(cmd, env=env, cwd=str(tmp), capture_output=True, text=True, timeout=TIMEOUT_S)
    result_file = out / "result.json"
    assert result_file.exists(), f"FreeCAD wrote no result (exit {proc.returncode}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    result = json.loads(result_file.read_text())
    assert "error" not in result, result["error"]
    return result, out


def test_workbench_loads_from_user_mod_folder(gui_run):
    result, _ = gui_run
    assert "BladeReconWorkbench" in result["workbenches"]
    assert result["active_workbench"] == "BladeReconWorkbench"
    # the package came from the repository through the symlinked Mod folder
    assert Path(result["bladerecon_file"]).resolve().is_relative_to(REPO)


def test_toolbar_menu_and_command(gui_run):
    result, _ = gui_run
    assert sorted(result["commands"]) == ["BladeRecon_Acquire", "BladeRecon_ImportPoints"]
    assert result["toolbar_visible"]
    assert result["toolbar_actions"] == ["Import measured points", "Acquire from instrument"]
    assert "BladeRecon" in result["menus"]


def test_import_points_is_one_undoable_step(gui_run):
    result, _ = gui_run
    assert result["sections"] == ["0", "1", "2", "3", "4"]
    assert result["vertex_counts"] == [60] * 5
    assert result["undo_names"][:1] == ["Import measured points"]
    assert result["objects_after_undo"] == 0
    assert result["objects_after_redo"] == 6  # the group + 5 sections


def test_import_error_is_a_message_not_a_traceback(gui_run):
    result, _ = gui_run
    assert len(result["error_messages"]) == 1
    message = result["error_messages"][0]
    assert "missing.csv" in message and "Traceback" not in message
    assert result["objects_after_error"] == 0


def test_screenshots_written(gui_run):
    _, out = gui_run
    for name in ("view.png", "window.png"):
        png = out / name
        assert png.exists() and png.stat().st_size > 5000, name
