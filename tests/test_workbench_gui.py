# SPDX-License-Identifier: LGPL-2.1-or-later
"""The workbench runs for real in the FreeCAD GUI (under Xvfb) as an addon from the user Mod folder.

A temporary HOME gets ``.local/share/FreeCAD/Mod/BladeRecon`` -> the repository (a symlink).
FreeCAD runs a script that activates the workbench, imports the sample blade, reconstructs it
(through the task panel), compares it with its nominal STEP, switches on the deviation
colour map and zebra stripes, saves, closes, reopens and recomputes, and writes screenshots
and a JSON result that the tests below assert on. The statistics are compared with
``python3 -m bladerecon deviation ... --json`` run separately on the same files, and the
saved file is opened once more by a FreeCAD that cannot import BladeRecon at all.

Set ``BLADERECON_UPDATE_SCREENSHOTS=1`` to copy the screenshots into docs/screenshots/.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SAMPLE = REPO / "resources" / "sample"
TIMEOUT_S = 240
SCREENSHOTS = ("points_surface.png", "deviation_map.png", "zebra.png", "curvature.png", "deviation_points.png",
               "reopened.png")

pytestmark = pytest.mark.skipif(
    shutil.which("xvfb-run") is None or shutil.which("freecad") is None,
    reason="needs xvfb-run and the freecad GUI executable",
)

GUI_SCRIPT = r'''
import json, os, sys, time, traceback
out_dir, sample = {out_dir!r}, {sample!r}
result = {{"steps": [], "seconds": {{}}}}
t_start = time.time()

def step(name):
    result["steps"].append(name)
    result["seconds"][name] = round(time.time() - t_start, 2)

def shot(name, width=1200, height=800):
    view = FreeCADGui.ActiveDocument.ActiveView
    view.setViewDirection((-0.35, 0.75, -0.55))    # from the suction side, a little above: the twist shows
    view.fitAll()
    FreeCADGui.updateGui()
    FreeCADGui.ActiveDocument.ActiveView.saveImage(os.path.join(out_dir, name), width, height, "White")

def active(name):
    return bool(FreeCADGui.Command.get(name).isActive()) if hasattr(FreeCADGui, "Command") else None

def select(*objs):
    FreeCADGui.Selection.clearSelection()
    for o in objs:
        FreeCADGui.Selection.addSelection(o)
    FreeCADGui.updateGui()

def stats(o):
    return {{"points": o.PointCount, "max": o.Max, "min": o.Min, "mean": o.Mean, "std": o.Std, "rms": o.Rms,
            "max_abs": o.MaxAbs, "mean_abs": o.MeanAbs, "within_tolerance_pct": o.WithinTolerancePct,
            "tolerance": o.Tolerance}}

try:
    import FreeCAD, FreeCADGui, Part
    from PySide import QtGui
    step("started")
    result["freecad_version"] = ".".join(FreeCAD.Version()[:3])
    result["workbenches"] = sorted(FreeCADGui.listWorkbenches())
    FreeCADGui.activateWorkbench("BladeReconWorkbench")
    step("activated")
    result["active_workbench"] = type(FreeCADGui.activeWorkbench()).__name__
    result["bladerecon_file"] = sys.modules["bladerecon"].__file__
    mw = FreeCADGui.getMainWindow()
    bars = [b for b in mw.findChildren(QtGui.QToolBar) if b.windowTitle() == "BladeRecon"]
    result["toolbar_visible"] = any(b.isVisible() for b in bars)
    result["toolbar_actions"] = [a.text() for b in bars for a in b.actions()]
    result["menus"] = [a.text().replace("&", "") for a in mw.menuBar().actions()]
    result["commands"] = sorted(c for c in FreeCADGui.listCommands() if c.startswith("BladeRecon"))
    result["icons"] = {{c: FreeCADGui.Command.get(c).getInfo()["pixmap"] for c in result["commands"]}} \
        if hasattr(FreeCADGui, "Command") and hasattr(FreeCADGui.Command, "get") else {{}}

    import bladerecon.gui.actions as actions
    import bladerecon.gui.commands as commands
    import bladerecon.fc.objects as bro
    shown = []
    QtGui.QMessageBox.critical = staticmethod(lambda parent, title, text, *a: shown.append(text))
    doc = FreeCAD.newDocument("GuiTest")
    names = ["BladeRecon_Reconstruct", "BladeRecon_Compare", "BladeRecon_Zebra", "BladeRecon_DeviationMap",
             "BladeRecon_ExportStep", "BladeRecon_WriteReport", "BladeRecon_AnalyseSections"]
    result["active_empty"] = {{n: active(n) for n in names}}

    # a missing file: one message, no traceback, the document untouched
    actions.import_points(os.path.join(out_dir, "missing.csv"))
    result["import_error"] = list(shown)
    result["objects_after_error"] = len(doc.Objects)

    points = actions.import_points(os.path.join(sample, "measured.csv"))
    step("imported")
    result["points"] = {{"type": points.Proxy.Type, "count": points.PointCount, "sections": points.SectionCount,
                        "units": points.Units, "source": points.SourceFile, "mode": points.ViewObject.DisplayMode}}
    result["undo_names"] = list(doc.UndoNames)
    doc.undo()
    result["objects_after_undo"] = len(doc.Objects)
    doc.redo()
    result["objects_after_redo"] = len(doc.Objects)
    points = doc.getObject("MeasuredPoints")

    select(points)
    result["active_points_selected"] = {{n: active(n) for n in names}}
    from bladerecon.gui.task_panels import ReconstructPanel
    panel = ReconstructPanel(points)
    FreeCADGui.Control.showDialog(panel)
    panel.form.method.setCurrentText("auto")
    panel.accept()
    surface = panel.result
    step("reconstructed")
    sections = actions.analyse_sections(points)
    step("sections")
    result["surface"] = {{"type": surface.Proxy.Type, "u_poles": surface.UPoles, "v_poles": surface.VPoles,
                         "method": surface.MethodUsed, "fit_max": surface.FitMax, "faces": len(surface.Shape.Faces),
                         "surface_type": type(surface.Shape.Faces[0].Surface).__name__, "status": surface.Status}}
    result["sections"] = {{"names": list(sections.SectionNames), "chords": list(sections.ChordLengths),
                          "le": [tuple(v) for v in sections.LeadingEdges], "te": [tuple(v) for v in sections.TrailingEdges]}}

    # a failed recompute keeps the previous surface and marks the object
    poles_before = surface.UPoles
    area_before = surface.Shape.Area
    surface.Method = "approximate"
    surface.Tolerance = -1.0
    doc.recompute()
    result["failed"] = {{"status": surface.Status, "state": list(surface.State), "poles": surface.UPoles,
                        "same_area": abs(surface.Shape.Area - area_before) < 1e-9 * area_before,
                        "null": surface.Shape.isNull()}}
    surface.Method = "auto"
    surface.Tolerance = 0.0
    doc.recompute()
    result["recovered"] = {{"status": surface.Status, "state": list(surface.State), "poles": surface.UPoles}}

    Part.insert(os.path.join(sample, "nominal.step"), doc.Name)
    nominal = [o for o in doc.Objects if o.TypeId == "Part::Feature"][-1]
    nominal.ViewObject.Visibility = False
    shot("points_surface.png")
    step("shot_a")

    select(surface)
    result["active_surface_selected"] = {{n: active(n) for n in names}}
    select(nominal)
    result["active_nominal_selected"] = {{n: active(n) for n in names}}
    # a nominal somewhere else: the core's one-line message in a box, the failed object marked
    far = doc.addObject("Part::Feature", "FarBox")
    far.Shape = Part.makeBox(10, 10, 10, FreeCAD.Vector(5000, 5000, 5000))
    far.Shape.exportStep(os.path.join(out_dir, "far.step"))     # the same nominal for the CLI
    n_shown = len(shown)
    bad = actions.compare_with_nominal(points, far, None, "none", 0.03)
    result["far_nominal"] = {{"messages": shown[n_shown:], "status": bad.Status if bad else None,
                             "state": list(bad.State) if bad else None}}
    doc.removeObject(bad.Name)
    doc.removeObject(far.Name)
    nominal.ViewObject.Visibility = False
    analysis = actions.compare_with_nominal(points, nominal, surface, "none", 0.03)
    step("compared")
    result["stats"] = stats(analysis)
    result["analysis"] = {{"status": analysis.Status, "mode": analysis.ViewObject.DisplayMode,
                          "visible": analysis.ViewObject.Visibility, "surface_visible": surface.ViewObject.Visibility,
                          "n_dev": len(analysis.Deviations), "grid": list(analysis.SurfaceGridSize),
                          "readonly_max": analysis.getEditorMode("Max")}}
    vp = analysis.ViewObject.Proxy
    import numpy as np
    rgb = vp.surface.colours()
    sdev = np.array(analysis.SurfaceDeviations)
    redness = rgb[:, 0] - rgb[:, 2]
    order = np.argsort(np.argsort(sdev))
    rorder = np.argsort(np.argsort(redness))
    result["colour"] = {{"n": len(rgb), "distinct": int(len(np.unique(np.round(rgb, 3), axis=0))),
                        "spearman": float(np.corrcoef(order, rorder)[0, 1]),
                        "dev_range": [float(sdev.min()), float(sdev.max())]}}
    points.ViewObject.Visibility = sections.ViewObject.Visibility = False
    shot("deviation_map.png")
    step("shot_b")

    select(analysis)                                   # the toolbar command toggles the map off and on
    result["map_toggle"] = [active("BladeRecon_DeviationMap")]
    for _ in range(2):
        FreeCADGui.runCommand("BladeRecon_DeviationMap")
        FreeCADGui.updateGui()
        result["map_toggle"].append((analysis.ViewObject.Visibility, surface.ViewObject.Visibility))
    actions.show_deviation_map(analysis, "Points")
    shot("deviation_points.png")
    actions.show_deviation_map(analysis, None)
    result["map_off"] = {{"analysis_visible": analysis.ViewObject.Visibility, "surface_visible": surface.ViewObject.Visibility}}
    from bladerecon.gui.task_panels import ComparePanel
    cpanel = ComparePanel(points, nominal, surface)
    robust_at_none = cpanel.form.robust.isEnabled()
    cpanel.form.alignment.setCurrentText("rigid")
    cpanel.form.robust.setChecked(True)
    opts = cpanel.options()
    fitted = actions.compare_with_nominal(points, nominal, None, opts["alignment"], opts["tolerance"],
                                           robust=opts["robust"])
    result["robust"] = {{"enabled_at_none": robust_at_none, "option": opts["robust"], "status": fitted.Status,
                        "property": fitted.RobustFit, "weighted_out": fitted.PointsWeightedOut,
                        "rotation": fitted.RotationDeg}}
    doc.removeObject(fitted.Name)
    nominal.ViewObject.Visibility = False

    points.ViewObject.Visibility = False
    from bladerecon.gui.task_panels import SurfaceAnalysisPanel
    panel = SurfaceAnalysisPanel(surface, "Zebra")
    FreeCADGui.Control.showDialog(panel)
    panel.form.stripes.setValue(16)
    panel.accept()
    zebra_rgb = surface.ViewObject.Proxy.zebra.colours()
    view = FreeCADGui.ActiveDocument.ActiveView
    view.setViewDirection((0.6, -0.5, -0.6))         # the stripes follow the eye: colours change
    FreeCADGui.updateGui()
    result["zebra_follows_view"] = float(np.abs(surface.ViewObject.Proxy.zebra.colours() - zebra_rgb).max())
    result["zebra"] = {{"mode": surface.ViewObject.DisplayMode, "stripes": surface.ViewObject.ZebraStripes,
                       "dark": float(np.mean(zebra_rgb[:, 0] < 0.3)), "light": float(np.mean(zebra_rgb[:, 0] > 0.7))}}
    shot("zebra.png")
    step("shot_c")
    actions.set_surface_analysis(surface, "Curvature", curvature="Mean")
    result["curvature_mode"] = surface.ViewObject.DisplayMode
    shot("curvature.png")
    mean_rgb = surface.ViewObject.Proxy.curvature.colours()
    actions.set_surface_analysis(surface, "Curvature", curvature="Gaussian")
    result["gaussian_vs_mean"] = float(np.abs(surface.ViewObject.Proxy.curvature.colours() - mean_rgb).max())
    actions.set_surface_analysis(surface, "Zebra")

    # Write report: the command's error path here (the report itself: tests/test_fc_objects.py,
    # tests/test_deviation.py; its plots take a minute on a busy machine)
    n_shown = len(shown)
    result["report_error"] = [actions.write_report(analysis, os.path.join(out_dir, "no", "such", "report"))] \
        + shown[n_shown:]
    result["step_written"] = actions.export_step(surface, os.path.join(out_dir, "surface.step"))
    step("outputs")

    # replayable: the console shows the lines the commands ran; run them again in a fresh document
    console = [w for w in mw.findChildren(QtGui.QPlainTextEdit) if w.objectName() == "Python console"]
    text = console[0].toPlainText() if console else ""
    lines = [ln.lstrip(">. ").strip() for ln in text.splitlines()]
    lines = [ln for ln in lines if ln.startswith(("import bladerecon", "_br_points =", "_br_surface ="))]
    result["console_lines"] = lines
    replay = FreeCAD.newDocument("Replay")
    scope = {{"App": FreeCAD, "FreeCAD": FreeCAD}}
    for ln in lines:
        exec(ln.replace("App.getDocument('GuiTest')", "App.getDocument('Replay')"), scope)
    replay.recompute()
    again = [o for o in replay.Objects if bro.is_type(o, "BladeSurface")]
    result["replayed"] = {{"surfaces": len(again), "u_poles": again[0].UPoles if again else None,
                          "area_diff": abs(again[0].Shape.Area - surface.Shape.Area) if again else None}}
    FreeCAD.closeDocument("Replay")
    FreeCAD.setActiveDocument(doc.Name)

    actions.show_deviation_map(analysis, "Points")     # map on the points, zebra on the surface
    path = os.path.join(out_dir, "blade.FCStd")
    doc.saveAs(path)
    FreeCAD.closeDocument(doc.Name)
    step("saved")
    doc = FreeCAD.openDocument(path)
    step("reopened")
    result["reopened"] = {{"objects": sorted(o.Name for o in doc.Objects),
                          "types": sorted(getattr(o.Proxy, "Type", "") for o in doc.Objects if hasattr(o, "Proxy")),
                          "surface_mode": doc.BladeSurface.ViewObject.DisplayMode,
                          "analysis_mode": doc.DeviationAnalysis.ViewObject.DisplayMode,
                          "stats_before_recompute": stats(doc.DeviationAnalysis),
                          "n_dev": len(doc.DeviationAnalysis.Deviations),
                          "surface_faces": len(doc.BladeSurface.Shape.Faces)}}
    for o in doc.Objects:
        o.touch()
    doc.recompute()
    step("recomputed")
    result["reopened"]["stats_after_recompute"] = stats(doc.DeviationAnalysis)
    result["reopened"]["status"] = {{o.Name: o.Status for o in doc.Objects if hasattr(o, "Status")}}
    result["reopened"]["zebra_vertices"] = len(doc.BladeSurface.ViewObject.Proxy.zebra.colours())
    shot("reopened.png")
    result["messages"] = list(shown)
    step("done")
except Exception:
    result["error"] = traceback.format_exc()
with open(os.path.join(out_dir, "result.json"), "w") as f:
    json.dump(result, f, indent=1)
os._exit(0)
'''

# Opens the saved file in a FreeCAD whose Python cannot import bladerecon (no Mod folder, no PYTHONPATH).
BARE_SCRIPT = r'''
import json, sys
sys.path.append({lib!r})
import FreeCAD
doc = FreeCAD.openDocument({path!r})
try:
    import bladerecon
    importable = True
except ImportError:
    importable = False
out = {{"importable": importable, "objects": sorted(o.Name for o in doc.Objects),
       "surface_faces": len(doc.BladeSurface.Shape.Faces), "points": len(doc.MeasuredPoints.Points),
       "max": doc.DeviationAnalysis.Max, "n_dev": len(doc.DeviationAnalysis.Deviations)}}
print("RESULT=" + json.dumps(out))
'''


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


def _clean_env(home: Path, tmp: Path) -> dict:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("XDG_", "PYTHON", "FREECAD", "QT_QPA"))}
    env.update(HOME=str(home), XDG_DATA_HOME=str(home / ".local" / "share"), XDG_CONFIG_HOME=str(home / ".config"),
               XDG_CACHE_HOME=str(home / ".cache"), XDG_RUNTIME_DIR=str(tmp), QTWEBENGINE_DISABLE_SANDBOX="1",
               LC_ALL="C.UTF-8")
    return env


@pytest.fixture(scope="module")
def gui_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("gui")
    env = _clean_env(tmp / "home", tmp)
    mod = _user_mod_dir(env)
    mod.mkdir(parents=True, exist_ok=True)
    (mod / "BladeRecon").symlink_to(REPO, target_is_directory=True)
    out = tmp / "out"
    out.mkdir()
    script = tmp / "gui_check.py"
    script.write_text(textwrap.dedent(GUI_SCRIPT.format(out_dir=str(out), sample=str(SAMPLE))))
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1600x1000x24", "freecad", str(script)]
    proc = subprocess.run(cmd, env=env, cwd=str(tmp), capture_output=True, text=True, timeout=TIMEOUT_S)
    result_file = out / "result.json"
    assert result_file.exists(), f"FreeCAD wrote no result (exit {proc.returncode}):\n{proc.stdout[-3000:]}\n{proc.stderr[-3000:]}"
    result = json.loads(result_file.read_text())
    assert "error" not in result, result["error"]
    if os.environ.get("BLADERECON_UPDATE_SCREENSHOTS"):
        dest = REPO / "docs" / "screenshots"
        dest.mkdir(parents=True, exist_ok=True)
        for name in SCREENSHOTS:
            shutil.copy(out / name, dest / name)
    return result, out, tmp


@pytest.fixture(scope="module")
def cli_stats():
    proc = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", str(SAMPLE / "measured.csv"), "--nominal",
                           str(SAMPLE / "nominal.step"), "--tolerance", "0.03", "--json", "--quiet"],
                          cwd=str(REPO), capture_output=True, text=True, timeout=TIMEOUT_S,
                          env={**os.environ, "PYTHONPATH": str(REPO)})
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout)


def test_workbench_loads_with_all_commands(gui_run):
    result, _, _ = gui_run
    assert result["active_workbench"] == "BladeReconWorkbench"
    assert Path(result["bladerecon_file"]).resolve().is_relative_to(REPO)
    expected = {"BladeRecon_ImportPoints", "BladeRecon_AnalyseSections", "BladeRecon_Reconstruct", "BladeRecon_Compare",
                "BladeRecon_DeviationMap", "BladeRecon_DeviationOnPoints", "BladeRecon_Zebra", "BladeRecon_Curvature",
                "BladeRecon_ExportStep", "BladeRecon_WriteReport", "BladeRecon_Acquire", "BladeRecon_TSpline"}
    assert set(result["commands"]) == expected
    assert result["toolbar_visible"] and len(result["toolbar_actions"]) == len(expected)
    assert "BladeRecon" in result["menus"]
    icons = result["icons"]
    assert set(icons) == expected
    assert all(Path(p).is_file() and p.endswith(".svg") for p in icons.values()), icons
    assert len(set(icons.values())) == len(expected)    # every command has its own SVG


def test_commands_follow_the_selection(gui_run):
    result, _, _ = gui_run
    assert not any(result["active_empty"].values()), result["active_empty"]
    sel = result["active_points_selected"]
    assert sel["BladeRecon_Reconstruct"] and sel["BladeRecon_AnalyseSections"]
    assert not sel["BladeRecon_Zebra"] and not sel["BladeRecon_Compare"] and not sel["BladeRecon_ExportStep"]
    assert result["active_surface_selected"]["BladeRecon_Zebra"] and result["active_surface_selected"]["BladeRecon_ExportStep"]
    assert result["active_nominal_selected"]["BladeRecon_Compare"]


def test_import_is_one_undoable_step_and_errors_are_one_line(gui_run):
    result, _, _ = gui_run
    assert len(result["import_error"]) == 1
    assert "missing.csv" in result["import_error"][0] and "Traceback" not in result["import_error"][0]
    assert result["objects_after_error"] == 0
    p = result["points"]
    assert p["type"] == "MeasuredPoints" and p["count"] == 12000 and p["sections"] == 6 and p["units"] == "mm"
    assert p["mode"] == "Sections"
    assert result["undo_names"][:1] == ["Import measured points"]
    assert result["objects_after_undo"] == 0 and result["objects_after_redo"] == 1


def test_surface_and_sections(gui_run):
    result, _, _ = gui_run
    s = result["surface"]
    assert s["type"] == "BladeSurface" and s["faces"] == 1 and s["surface_type"] == "BSplineSurface"
    assert s["status"] == "ok" and s["u_poles"] > 50 and s["v_poles"] == 6
    assert s["fit_max"] < 0.02            # 2 µm noise on the sample: the fit stays within 20 µm
    sec = result["sections"]
    assert sec["names"] == ["0", "1", "2", "3", "4", "5"]
    # the sample blade's chord runs linearly from 56 mm (hub) to 52 mm (tip) (resources/sample/README.md)
    for k, chord in enumerate(sec["chords"]):
        assert abs(chord - (56.0 - 4.0 * k / 5)) < 0.05, (k, chord)
    for le, te in zip(sec["le"], sec["te"]):   # LE and TE at the two ends of each section plane
        assert abs(le[2] - te[2]) < 0.01


def test_stats_match_the_cli(gui_run, cli_stats):
    result, _, _ = gui_run
    for stats in (result["stats"], result["reopened"]["stats_before_recompute"], result["reopened"]["stats_after_recompute"]):
        for key, value in stats.items():
            assert value == pytest.approx(cli_stats[key], rel=1e-9, abs=1e-12), key
    assert result["analysis"]["n_dev"] == cli_stats["points"]
    assert 1 in result["analysis"]["readonly_max"] or "ReadOnly" in result["analysis"]["readonly_max"]


def test_deviation_colours_follow_the_deviation(gui_run):
    result, _, _ = gui_run
    a = result["analysis"]
    assert a["mode"] == "Surface" and a["visible"] and not a["surface_visible"]
    c = result["colour"]
    nu, nv = a["grid"]
    assert c["n"] == nu * nv and c["distinct"] > 100
    # blue-to-red order of the vertex colours is the order of the deviations
    assert c["spearman"] > 0.99
    assert c["dev_range"][0] < 0 < c["dev_range"][1]
    assert result["map_off"] == {"analysis_visible": False, "surface_visible": True}
    # the Compare dialog's robust box: off without an alignment; with rigid it reaches the object,
    # which fits the (unmoved, 2 µm noise) sample points with the robust fit and drops none
    rb = result["robust"]
    assert rb["enabled_at_none"] is False and rb["option"] is True and rb["property"] is True
    assert rb["status"] == "ok" and rb["weighted_out"] < 0.01 * result["stats"]["points"] and rb["rotation"] < 0.01
    # the toolbar command: enabled with the analysis selected; off (surface shown), then on again
    assert result["map_toggle"] == [True, [False, True], [True, False]]


def test_zebra_and_curvature(gui_run):
    result, _, _ = gui_run
    z = result["zebra"]
    assert z["mode"] == "Zebra" and z["stripes"] == 16
    assert z["dark"] > 0.2 and z["light"] > 0.2       # black and white bands, both present
    assert result["zebra_follows_view"] > 0.5          # recoloured when the camera turned
    assert result["curvature_mode"] == "Curvature"
    assert result["gaussian_vs_mean"] > 0.3            # a different quantity, different colours


def test_failed_recompute_keeps_the_previous_surface(gui_run):
    result, _, _ = gui_run
    f = result["failed"]
    assert f["status"].startswith("failed: ") and "Tolerance" in f["status"]
    assert "Invalid" in f["state"] and f["same_area"] and not f["null"] and f["poles"] > 50
    assert result["recovered"]["status"] == "ok" and "Invalid" not in result["recovered"]["state"]
    far = result["far_nominal"]       # through a command: the CLI's one-line message in a box
    assert len(far["messages"]) == 1 and "far from the nominal" in far["messages"][0]
    _, out, _ = gui_run
    proc = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", str(SAMPLE / "measured.csv"), "--nominal",
                           str(out / "far.step"), "--quiet"], cwd=str(REPO), capture_output=True, text=True,
                          timeout=TIMEOUT_S, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert proc.returncode == 2
    assert proc.stderr.strip() == "bladerecon: error: " + far["messages"][0]
    assert "Traceback" not in far["messages"][0] and "\n" not in far["messages"][0]
    assert far["status"].startswith("failed: ") and "Invalid" in far["state"]


def test_commands_replay_from_the_console(gui_run):
    result, _, _ = gui_run
    lines = result["console_lines"]
    assert any(ln.startswith("_br_points = bro.make_measured_points(") for ln in lines), lines
    assert any(ln.startswith("_br_surface = bro.make_blade_surface(") for ln in lines), lines
    r = result["replayed"]
    assert r["surfaces"] >= 1 and r["u_poles"] == result["surface"]["u_poles"] and r["area_diff"] < 1e-9


def test_outputs(gui_run):
    result, out, _ = gui_run
    assert result["step_written"] and (out / "surface.step").stat().st_size > 10000
    none, message = result["report_error"]
    assert none is None and "does not exist" in message and "Traceback" not in message


def test_save_close_reopen_recompute(gui_run):
    result, _, _ = gui_run
    r = result["reopened"]
    assert r["types"] == ["BladeSections", "BladeSurface", "DeviationAnalysis", "MeasuredPoints"]
    assert r["surface_faces"] == 1 and r["n_dev"] == 12000
    assert r["surface_mode"] == "Zebra" and r["analysis_mode"] == "Points"
    assert all(s == "ok" for s in r["status"].values()), r["status"]
    assert r["zebra_vertices"] > 1000
    # ~75 s on an idle 2-core machine; the bound only catches a run-away regression
    assert result["seconds"]["done"] < 180, result["seconds"]


def test_reopens_without_the_workbench(gui_run):
    _, out, tmp = gui_run
    from bladerecon.fc.freecad_env import find_freecad_lib

    env = _clean_env(tmp / "bare_home", tmp)
    script = BARE_SCRIPT.format(lib=find_freecad_lib(), path=str(out / "blade.FCStd"))
    proc = subprocess.run([sys.executable, "-c", script], env=env, cwd=str(tmp), capture_output=True, text=True,
                          timeout=TIMEOUT_S)
    line = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT=")]
    assert line, proc.stdout[-2000:] + proc.stderr[-2000:]
    r = json.loads(line[0][len("RESULT="):])
    assert not r["importable"]
    assert {"MeasuredPoints", "BladeSurface", "BladeSections", "DeviationAnalysis"} <= set(r["objects"])
    assert r["surface_faces"] == 1 and r["points"] == 12000 and r["n_dev"] == 12000 and r["max"] > 0


def test_screenshots_written(gui_run):
    _, out, _ = gui_run
    for name in SCREENSHOTS:
        png = out / name
        assert png.exists() and png.stat().st_size > 10000, name
