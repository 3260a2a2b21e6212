# SPDX-License-Identifier: LGPL-2.1-or-later
"""The addon as a FreeCAD user installs it: a copy in the user Mod folder, the real GUI.

Under a temporary HOME, the folder FreeCAD itself names (``FreeCAD.getUserAppDataDir()`` +
``Mod``; 0.20 and 1.0 on Linux: ``~/.local/share/FreeCAD/Mod``, where the Addon Manager clones
addons) gets ``BladeRecon``: a *copy* of the files git tracks, as they are in the working tree.
A copy, not a symlink: FreeCAD must find everything in the installed folder (an icon or module
that is not tracked would be missing from a clone, and is missing here); not a ``git clone`` of
HEAD: the tests check the tree being worked on. Where there is no ``.git`` (the FreeCAD 1.0 root
of tools/test_freecad1.sh gets the tree without it) the tree is copied minus caches.

FreeCAD starts under Xvfb with no PYTHONPATH, activates the workbench and reports: every
BladeRecon command with its icon file (inside the installed copy), each SVG rendered by Qt at
64 px (QSvgRenderer) and each toolbar icon enabled and disabled, the Report view's text, and
a screenshot of the main window. The icon pictures are judged by pixel statistics: not a block
(a shape, not the whole square; several colours, none covering nearly all of it) and not a
striped square (rows or columns that cross the whole square with a periodic pattern). The
checks are checked too: the Zebra icon as it was (a clipPath, which Qt ignores: a striped
square), a solid square and a striped square fail them.

``BLADERECON_INSTALL_SCREENSHOT=PATH`` also copies the main-window screenshot to PATH.
"""
from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import textwrap
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
TIMEOUT_S = 240      # the whole FreeCAD run
WATCHDOG_S = 120     # inside it: the script reports what holds it, and ends FreeCAD
SIZE = 64

pytestmark = pytest.mark.skipif(
    shutil.which("xvfb-run") is None or shutil.which("freecad") is None,
    reason="needs xvfb-run and the freecad GUI executable",
)

# Controls for the icon checks: each must fail them.
BROKEN_ZEBRA = """<?xml version="1.0" encoding="UTF-8"?>
<svg xmlns="http://www.w3.org/2000/svg" width="64" height="64" viewBox="0 0 64 64">
<clipPath id="c"><path d="M 4 56 C 4 30, 30 6, 60 8 L 60 36 C 40 36, 24 48, 20 60 Z"/></clipPath>
<g clip-path="url(#c)"><rect x="0" y="0" width="64" height="64" fill="#fff"/>
<g fill="#111"><path d="M 0 14 C 20 18, 40 4, 64 6 L 64 14 C 40 12, 20 26, 0 22 Z"/><path d="M 0 30 C 20 34, 40 20, 64 22 L 64 30 C 40 28, 20 42, 0 38 Z"/><path d="M 0 46 C 20 50, 40 36, 64 38 L 64 46 C 40 44, 20 58, 0 54 Z"/></g></g>
<path d="M 4 56 C 4 30, 30 6, 60 8 L 60 36 C 40 36, 24 48, 20 60 Z" fill="none" stroke="#333" stroke-width="2"/>
</svg>
"""  # resources/icons/BladeRecon_Zebra.svg before it was redrawn
CONTROLS = {
    "control_broken_zebra": BROKEN_ZEBRA,
    "control_solid": '<svg xmlns="http://www.w3.org/2000/svg" width="64" height="64">'
                     '<rect width="64" height="64" fill="#3a5f8a"/></svg>',
    "control_inset_block": '<svg xmlns="http://www.w3.org/2000/svg" width="64" height="64">'
                           '<rect x="8" y="8" width="48" height="48" fill="#3a5f8a"/></svg>',
    "control_striped_square": '<svg xmlns="http://www.w3.org/2000/svg" width="64" height="64">'
                              '<rect width="64" height="64" fill="#eee"/>'
                              + "".join(f'<rect y="{y}" width="64" height="5" fill="#222"/>' for y in range(2, 64, 10))
                              + '<circle cx="32" cy="32" r="9" fill="#c33"/></svg>',
}

GUI_SCRIPT = r'''
import json, os, sys, traceback
out_dir, icon_files = {out_dir!r}, {icon_files!r}
SIZE = {size}
result = {{}}

def finish():
    with open(os.path.join(out_dir, "result.json"), "w") as f:
        json.dump(result, f)
    os._exit(0)

def watchdog():
    """Still here after {watchdog_s} s: a modal dialog (an error box?) holds FreeCAD. Say what it shows."""
    modal = QtGui.QApplication.activeModalWidget()
    texts = [w.text() for w in (modal.findChildren(QtGui.QLabel) if modal else []) if w.text()]
    report = [w for w in FreeCADGui.getMainWindow().findChildren(QtGui.QTextEdit) if w.objectName() == "Report view"]
    result["error"] = ("the check did not finish in {watchdog_s} s; modal dialog: "
                       + repr((modal.windowTitle(), texts) if modal else None)
                       + "; Report view: " + (report[0].toPlainText()[-2000:] if report else "?"))
    FreeCADGui.getMainWindow().grab().save(os.path.join(out_dir, "main_window.png"))
    finish()

def pixels(image):
    image = image.convertToFormat(QtGui.QImage.Format_ARGB32)
    return [[image.pixel(x, y) for x in range(image.width())] for y in range(image.height())]

def svg_image(path):
    renderer = QtSvg.QSvgRenderer(path)
    image = QtGui.QImage(SIZE, SIZE, QtGui.QImage.Format_ARGB32)
    image.fill(0)
    painter = QtGui.QPainter(image)
    renderer.render(painter)
    painter.end()
    return renderer.isValid(), image

try:
    import FreeCAD, FreeCADGui
    from PySide import QtCore, QtGui
    try:
        from PySide import QtSvg
    except ImportError:
        from PySide2 import QtSvg
    QtCore.QTimer.singleShot({watchdog_s} * 1000, watchdog)   # fires inside a modal dialog's loop too
    result["freecad_version"] = ".".join(FreeCAD.Version()[:3])
    result["user_app_data"] = FreeCAD.getUserAppDataDir()
    mw = FreeCADGui.getMainWindow()
    report = [w for w in mw.findChildren(QtGui.QTextEdit) if w.objectName() == "Report view"]
    result["report_views"] = len(report)
    FreeCAD.newDocument("Installed")
    FreeCADGui.activateWorkbench("BladeReconWorkbench")
    for _ in range(5):
        FreeCADGui.updateGui()
    result["active_workbench"] = type(FreeCADGui.activeWorkbench()).__name__
    result["workbench_icon"] = FreeCADGui.getWorkbench("BladeReconWorkbench").Icon
    result["bladerecon_file"] = os.path.realpath(sys.modules["bladerecon"].__file__)
    result["commands"] = {{}}
    import bladerecon.gui.commands as commands
    for name in sorted(c for c in FreeCADGui.listCommands() if c.startswith("BladeRecon")):
        info = FreeCADGui.Command.get(name).getInfo() if hasattr(FreeCADGui, "Command") else {{}}
        result["commands"][name] = {{"pixmap": info.get("pixmap")}}
    bars = [b for b in mw.findChildren(QtGui.QToolBar) if b.windowTitle() == "BladeRecon"]
    result["toolbar_visible"] = any(b.isVisible() for b in bars)
    result["toolbar"] = {{}}
    for bar in bars:
        for action in bar.actions():
            icon = action.icon()
            result["toolbar"][action.objectName()] = {{
                "text": action.text(), "enabled": action.isEnabled(), "null_icon": icon.isNull(),
                "normal": pixels(icon.pixmap(SIZE, SIZE, QtGui.QIcon.Normal).toImage()),
                "disabled": pixels(icon.pixmap(SIZE, SIZE, QtGui.QIcon.Disabled).toImage())}}
        bar.grab().save(os.path.join(out_dir, "toolbar.png"))
    result["svg"] = {{}}
    for path in icon_files:
        valid, image = svg_image(path)
        image.save(os.path.join(out_dir, os.path.basename(path)[:-4] + ".png"))
        result["svg"][path] = {{"valid": valid, "pixels": pixels(image)}}
    for dock in mw.findChildren(QtGui.QDockWidget):     # the Report view on screen, for the record
        if dock.objectName() == "Report view":
            dock.show()
    for _ in range(5):
        FreeCADGui.updateGui()
    result["report_before_probe"] = report[0].toPlainText() if report else None
    # from the X server (a widget grab leaves the OpenGL 3D view empty); else from Qt
    shot = QtGui.QApplication.primaryScreen().grabWindow(mw.winId())
    (shot if not shot.isNull() else mw.grab()).save(os.path.join(out_dir, "main_window.png"))
    FreeCAD.Console.PrintError("bladerecon-install-probe\n")    # proof that errors arrive in that view
    for _ in range(5):
        FreeCADGui.updateGui()
    result["report_after_probe"] = report[0].toPlainText() if report else None
except Exception:
    result["error"] = traceback.format_exc()
finish()
'''


def _clean_env(home: Path, tmp: Path) -> dict:
    """No PYTHONPATH, no FreeCAD or XDG settings of the caller: FreeCAD finds the addon or not."""
    env = {k: v for k, v in os.environ.items() if not k.startswith(("XDG_", "PYTHON", "FREECAD", "QT_QPA"))}
    env.update(HOME=str(home), XDG_RUNTIME_DIR=str(tmp), QTWEBENGINE_DISABLE_SANDBOX="1", LC_ALL="C.UTF-8")
    return env


def _user_mod_dir(env: dict) -> Path:
    """The Mod folder FreeCAD reads for this HOME, as FreeCAD itself says."""
    cmd = shutil.which("freecadcmd") or shutil.which("FreeCADCmd")
    assert cmd, "no freecadcmd beside freecad"
    code = "import FreeCAD; print('USERDIR=' + FreeCAD.getUserAppDataDir())"
    proc = subprocess.run([cmd, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    for line in proc.stdout.splitlines():
        if line.startswith("USERDIR="):
            return Path(line[len("USERDIR="):]) / "Mod"
    raise AssertionError(f"freecadcmd named no user folder:\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}")


def _files_to_install() -> list[str]:
    """What a clone would hold: git's tracked files as they are in the working tree."""
    if (REPO / ".git").exists() and shutil.which("git"):
        out = subprocess.run(["git", "-C", str(REPO), "ls-files", "-z"], capture_output=True, check=True,
                             timeout=60).stdout.decode()
        return [f for f in out.split("\0") if f and (REPO / f).is_file()]   # not the ones deleted here
    skip = {".git", ".cache", "__pycache__", ".pytest_cache", "demo_out"}
    files = []
    for root, dirs, names in os.walk(REPO):
        dirs[:] = [d for d in dirs if d not in skip]
        files += [os.path.relpath(os.path.join(root, n), REPO) for n in names if not n.endswith(".pyc")]
    return files


def _install(dest: Path) -> int:
    files = _files_to_install()
    for rel in files:
        target = dest / rel
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(REPO / rel, target)
    return len(files)


@pytest.fixture(scope="module")
def installed(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("install")
    home = tmp / "home"
    home.mkdir()
    env = _clean_env(home, tmp)
    mod = _user_mod_dir(env)
    addon = mod / "BladeRecon"
    addon.mkdir(parents=True)
    copied = _install(addon)
    controls = tmp / "controls"
    controls.mkdir()
    for name, text in CONTROLS.items():
        (controls / f"{name}.svg").write_text(text)
    icons = sorted(str(p) for p in (addon / "resources" / "icons").glob("*.svg"))
    out = tmp / "out"
    out.mkdir()
    script = tmp / "install_check.py"
    script.write_text(textwrap.dedent(GUI_SCRIPT.format(
        out_dir=str(out), icon_files=icons + sorted(str(p) for p in controls.glob("*.svg")), size=SIZE,
        watchdog_s=WATCHDOG_S)))
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1600x1000x24", "freecad", str(script)]
    # its own process group: on a timeout, FreeCAD and Xvfb end with xvfb-run
    proc = subprocess.Popen(cmd, env=env, cwd=str(tmp), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    try:
        stdout, stderr = proc.communicate(timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        stdout, stderr = proc.communicate()
    log = stdout + stderr
    result_file = out / "result.json"
    assert result_file.exists(), f"FreeCAD wrote no result (exit {proc.returncode}):\n{log[-5000:]}"
    result = json.loads(result_file.read_text())
    assert "error" not in result, result["error"]
    if os.environ.get("BLADERECON_INSTALL_SCREENSHOT"):
        shutil.copy(out / "main_window.png", os.environ["BLADERECON_INSTALL_SCREENSHOT"])
    return {"result": result, "home": home, "mod": mod, "addon": addon, "copied": copied, "out": out,
            "controls": controls, "log": log}


# ---- pixel statistics -------------------------------------------------------------------------

def _channels(pixels) -> tuple[np.ndarray, np.ndarray]:
    argb = np.asarray(pixels, dtype=np.uint32)
    alpha = (argb >> 24) & 255
    rgb = np.stack([(argb >> 16) & 255, (argb >> 8) & 255, argb & 255], axis=-1).astype(float)
    return alpha, rgb


def _periodic(line: np.ndarray) -> bool:
    """A line with a repeating light/dark pattern: its autocorrelation peaks again at lag 3..32."""
    x = line - line.mean()
    if x.std() < 20:
        return False
    ac = np.correlate(x, x, "full")[len(x) - 1:] / (x @ x)
    return bool(ac[3:33].max() > 0.5)


def icon_problems(pixels) -> list[str]:
    """What is wrong with an icon picture (ARGB rows), by pixel statistics; [] when it is fine."""
    alpha, rgb = _channels(pixels)
    opaque = alpha >= 128
    problems = []
    if opaque.mean() < 0.03:
        return [f"almost nothing drawn ({opaque.mean():.1%} of the square)"]
    k = 4
    corners = np.mean([opaque[:k, :k].mean(), opaque[:k, -k:].mean(), opaque[-k:, :k].mean(), opaque[-k:, -k:].mean()])
    full_rows = (opaque.mean(axis=1) > 0.97).mean()
    full_cols = (opaque.mean(axis=0) > 0.97).mean()
    if corners > 0.5 and max(full_rows, full_cols) > 0.5:
        problems.append(f"fills its square (corners {corners:.0%} opaque, {full_rows:.0%} of rows edge to edge)")
    quantised = (rgb[opaque] // 32).astype(int) @ np.array([64, 8, 1])
    _, counts = np.unique(quantised, return_counts=True)
    share = counts / counts.sum()
    colours = int((share >= 0.01).sum())
    if colours < 3:
        problems.append(f"a block: {colours} colour(s) cover 99 % of it")
    if share.max() > 0.85:
        problems.append(f"a block: one colour covers {share.max():.0%}")
    lum = rgb @ np.array([0.299, 0.587, 0.114])
    rows = [lum[i] for i in range(lum.shape[0]) if opaque[i].all()]
    cols = [lum[:, j] for j in range(lum.shape[1]) if opaque[:, j].all()]
    periodic = max(sum(map(_periodic, rows)), sum(map(_periodic, cols)))
    if periodic >= 0.25 * SIZE:
        problems.append(f"a striped square: {periodic} lines cross it edge to edge with a periodic pattern")
    return problems


def disabled_difference(normal, disabled) -> dict:
    """How the disabled picture differs from the normal one: colour change where either is
    drawn; saturation, contrast (luminance spread) and lightness of what is drawn."""
    a_n, rgb_n = _channels(normal)
    a_d, rgb_d = _channels(disabled)
    drawn = (a_n >= 128) | (a_d >= 128)
    change = np.abs(rgb_n * a_n[..., None] / 255.0 - rgb_d * a_d[..., None] / 255.0).max(axis=-1)

    def looks(alpha, rgb):
        shown = alpha >= 128
        lum = (rgb @ np.array([0.299, 0.587, 0.114]))[shown]
        return {"saturation": float((rgb.max(axis=-1) - rgb.min(axis=-1))[shown].mean()),
                "contrast": float(lum.std()), "lightness": float(lum.mean())}

    return {"mean_change": float(change[drawn].mean()), "normal": looks(a_n, rgb_n), "disabled": looks(a_d, rgb_d)}


# ---- tests ------------------------------------------------------------------------------------

EXPECTED = {"BladeRecon_ImportPoints", "BladeRecon_AnalyseSections", "BladeRecon_Reconstruct", "BladeRecon_Compare",
            "BladeRecon_DeviationMap", "BladeRecon_DeviationOnPoints", "BladeRecon_Zebra", "BladeRecon_Curvature",
            "BladeRecon_ExportStep", "BladeRecon_WriteReport", "BladeRecon_Acquire", "BladeRecon_TSpline",
            "BladeRecon_Repair"}


def test_freecad_reads_the_user_mod_folder_under_home(installed):
    r = installed["result"]
    mod = installed["mod"]
    assert Path(r["user_app_data"]) / "Mod" == mod
    assert mod.resolve().is_relative_to(installed["home"].resolve())
    if r["freecad_version"].startswith(("0.20", "0.21", "1.0")):     # 1.1 and later: versioned folders
        assert mod == installed["home"] / ".local" / "share" / "FreeCAD" / "Mod"
    assert installed["copied"] > 100 and not (installed["addon"] / ".git").exists()


def test_the_workbench_runs_from_the_installed_copy(installed):
    r = installed["result"]
    assert r["active_workbench"] == "BladeReconWorkbench"
    addon = installed["addon"].resolve()
    assert Path(r["bladerecon_file"]).is_relative_to(addon), r["bladerecon_file"]
    assert Path(r["workbench_icon"]).resolve().is_relative_to(addon)


def test_every_command_is_registered_with_its_icon_file(installed):
    r = installed["result"]
    assert set(r["commands"]) == EXPECTED
    addon = installed["addon"].resolve()
    for name, c in r["commands"].items():
        pixmap = Path(c["pixmap"])
        assert pixmap.suffix == ".svg" and pixmap.is_file(), (name, c)
        assert pixmap.resolve().is_relative_to(addon), (name, c)
    assert len({c["pixmap"] for c in r["commands"].values()}) == len(EXPECTED)   # each its own
    assert r["toolbar_visible"] and set(r["toolbar"]) == EXPECTED
    assert not [n for n, t in r["toolbar"].items() if t["null_icon"]]


def test_the_toolbar_shows_the_svg_files(installed):
    """What FreeCAD put on each button is the command's SVG, not a placeholder."""
    r = installed["result"]
    for name, t in r["toolbar"].items():
        svg = r["svg"][r["commands"][name]["pixmap"]]["pixels"]
        a_t, rgb_t = _channels(t["normal"])
        a_s, rgb_s = _channels(svg)
        assert a_t.shape == a_s.shape, name
        diff = np.abs(rgb_t * a_t[..., None] / 255.0 - rgb_s * a_s[..., None] / 255.0).mean()
        assert diff < 8, (name, diff)


def test_every_icon_renders_as_a_picture(installed):
    r = installed["result"]
    icons = {Path(p).name: s for p, s in r["svg"].items() if Path(p).parent.name == "icons"}
    assert len(icons) >= len(EXPECTED) + 1                     # the commands' and the workbench's
    bad = {name: icon_problems(s["pixels"]) for name, s in icons.items()}
    assert not {n: p for n, p in bad.items() if p} and all(s["valid"] for s in icons.values()), bad


def test_the_icon_checks_catch_a_block_and_a_striped_square(installed):
    r = installed["result"]
    controls = {Path(p).stem: s for p, s in r["svg"].items() if Path(p).parent == installed["controls"]}
    assert set(controls) == set(CONTROLS)
    problems = {name: icon_problems(s["pixels"]) for name, s in controls.items()}
    assert all(problems.values()), problems
    broken = " ".join(problems["control_broken_zebra"])
    assert "fills its square" in broken and "striped square" in broken, broken
    assert "striped square" in " ".join(problems["control_striped_square"])
    assert "a block" in " ".join(problems["control_solid"]) and "a block" in " ".join(problems["control_inset_block"])


def test_a_disabled_command_looks_disabled(installed):
    """Qt greys the icon of a disabled action by itself: less colour, less contrast, visibly changed."""
    r = installed["result"]
    assert not r["toolbar"]["BladeRecon_Zebra"]["enabled"]      # no surface selected: greyed on screen
    for name, t in r["toolbar"].items():
        d = disabled_difference(t["normal"], t["disabled"])
        n, g = d["normal"], d["disabled"]
        assert d["mean_change"] > 20, (name, d)                  # of 255, on average over the picture
        assert g["saturation"] < 3 and g["contrast"] < 0.85 * n["contrast"], (name, d)
        assert g["lightness"] > n["lightness"] + 15, (name, d)


def test_no_error_in_the_report_view(installed):
    r = installed["result"]
    assert r["report_views"] == 1
    assert "bladerecon-install-probe" in r["report_after_probe"]     # messages do arrive there
    text = r["report_before_probe"]
    bad = [ln for ln in text.splitlines() if any(w in ln for w in ("Traceback", "Error", "error", "Exception"))]
    assert not bad, text[-3000:]
    assert "Traceback" not in installed["log"], installed["log"][-3000:]


def test_a_screenshot_of_the_main_window(installed):
    shot = installed["out"] / "main_window.png"
    assert shot.is_file() and shot.stat().st_size > 10_000
