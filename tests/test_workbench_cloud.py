# SPDX-License-Identifier: LGPL-2.1-or-later
"""Every blade a user brings, in the workbench (issue 25): a whole-blade cloud (one block of
``x y z`` lines in metres, no section labels, shuffled) imported as a MeasuredPoints marked as a
cloud, its BladeSurface and BladeSections cut and fitted as ``reconstruct CLOUD`` /
``sections CLOUD`` do, through the path a user takes: the document objects headless (as
``tests/test_fc_objects.py``), and the real GUI under Xvfb for the import and reconstruct
commands (the harness of ``tests/test_workbench_gui.py``: the file dialog, the cloud-units dialog
and the task panel's own widgets and OK button, the report view read).

Data: the propeller of ``bladerecon.samples.propeller`` (hub fillet, tip cap; span along +x),
4000 airfoil nodes (4206 with fillet and cap), seed 3, written in metres. The referee is the
blade's closed form (``CloudBlade.truth``), never the product's own numbers; the bound is what
the command line reaches on the same file (computed here too): the workbench must agree with it
within round-off. Seed 3 is one where ``sections`` measures every automatically cut section of
this sparse cloud (on seeds 0, 2, 4, 5 it stops at "no clear LE/TE curvature peak", the
workbench with the same line: tested on seed 0).
"""
from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from fc_fixtures import require_freecad

FreeCAD, Part = require_freecad()

from bladerecon.core.errors import BladeReconError  # noqa: E402
from bladerecon.core.geometry.projection import project_points_to_surface  # noqa: E402
from bladerecon.fc import objects as bro  # noqa: E402
from bladerecon.fc.convert import from_part_surface  # noqa: E402
from bladerecon.samples.propeller import blade_cloud, propeller_blade, write_cloud  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
PLAN = REPO / "resources" / "sample" / "measured_plan.csv"
AIRFOIL_NODES, SEED = 4000, 3
#: round-off between two runs of the same path (the command in its own process, the workbench
#: in FreeCAD's): measured 1e-13 relative on the fit statistics, 4e-11 mm on the poles
REL = 1e-9
#: the CLI's surface is read back from its STEP (written with 15 significant digits)
STEP_MM = 1e-6


def _cli(*argv, cwd=REPO):
    return subprocess.run([sys.executable, "-m", "bladerecon", *map(str, argv)], cwd=cwd, capture_output=True,
                          text=True, timeout=300,
                          env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin", "HOME": str(cwd)})


def _cli_inproc(*argv):
    """``main(argv)`` in this process: (exit status, stdout, stderr)."""
    from bladerecon.cli.main import main

    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        rc = main([str(a) for a in argv])
    return rc, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """The cloud file (metres), the blade, and what the command line makes of it."""
    tmp = tmp_path_factory.mktemp("cloud")
    blade = propeller_blade()
    P, _ = blade_cloud(blade, AIRFOIL_NODES, seed=SEED)
    cloud = tmp / "propeller.xyz"
    write_cloud(str(cloud), P)
    step = tmp / "cli.step"
    run = _cli("reconstruct", cloud, "--cloud-scale", "1000", "-o", step, "--json", "--quiet", cwd=tmp)
    assert run.returncode == 0, run.stderr
    rc, out, err = _cli_inproc("sections", cloud, "--cloud-scale", "1000", "--json", "--quiet")
    assert rc == 0, err
    mm = np.loadtxt(cloud) * 1000.0             # what is read: the file's numbers in mm
    np.savetxt(tmp / "nodes_mm.xyz", mm, fmt="%.17g")     # the same points for ``deviation`` (no --cloud-scale)
    return {"tmp": tmp, "blade": blade, "cloud": cloud, "step": step, "cli": json.loads(run.stdout),
            "cli_sections": json.loads(out), "mm": mm}


@pytest.fixture(scope="module")
def chain(data):
    doc = FreeCAD.newDocument("CloudObjects")
    points = bro.make_measured_points(doc, str(data["cloud"]), cloud_scale=1000.0)
    surface = bro.make_blade_surface(doc, points)
    sections = bro.make_blade_sections(doc, points)
    doc.recompute()
    yield doc, points, surface, sections
    FreeCAD.closeDocument(doc.Name)


def _truth(blade, slicing: dict) -> np.ndarray:
    """True points (15 x 300, dense on the round edges) between the end sections' planes."""
    axis, pos = np.array(slicing["axis"]), np.array(slicing["positions_mm"])
    a0, a1 = blade.airfoil_range()
    h = np.sort((pos[[0, -1]] * float(axis @ blade.span_axis) - a0) / (a1 - a0))
    return blade.truth(max(h[0], 0.0), min(h[1], 1.0), n_span=15, n_profile=300)


def _close(a, b, path="") -> list:
    """Where two JSON values differ beyond round-off (REL)."""
    if isinstance(a, dict) and isinstance(b, dict):
        if set(a) != set(b):
            return [f"{path}: keys {sorted(set(a) ^ set(b))}"]
        return [d for k in a for d in _close(a[k], b[k], f"{path}.{k}")]
    if isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            return [f"{path}: {len(a)} vs {len(b)} items"]
        return [d for k, (x, y) in enumerate(zip(a, b)) for d in _close(x, y, f"{path}[{k}]")]
    if isinstance(a, float) and isinstance(b, (int, float)) and not isinstance(b, bool):
        return [] if a == pytest.approx(b, rel=REL, abs=1e-12) else [f"{path}: {a!r} vs {b!r}"]
    return [] if a == b else [f"{path}: {a!r} vs {b!r}"]


def _distances_to_truth(face_surface, blade, slicing) -> np.ndarray:
    return project_points_to_surface(from_part_surface(face_surface), _truth(blade, slicing)).distance


# --------------------------------------------------------------------------- headless document objects
def test_a_cloud_imports_as_a_cloud_in_mm(data, chain):
    _, points, _, _ = chain
    n = len(data["mm"])
    assert points.Status == "ok" and points.Cloud and points.CloudScale == 1000.0
    assert points.PointCount == n and points.SectionCount == 0 and list(points.SectionNames) == []
    assert points.getEditorMode("Cloud") == ["ReadOnly"] and points.getEditorMode("CloudScale") == []
    # the points in mm, as the command reads them (the file's numbers times 1000)
    np.testing.assert_array_equal(bro._array(points.Points), data["mm"])
    assert len(points.Shape.Vertexes) == n


def test_cloud_scale_changes_the_points(data):
    doc = FreeCAD.newDocument("CloudScale")
    try:
        points = bro.make_measured_points(doc, str(data["cloud"]))           # default 1: as in the file
        doc.recompute()
        np.testing.assert_allclose(bro._array(points.Points), data["mm"] / 1000.0, rtol=1e-15)
        points.CloudScale = 1000.0
        doc.recompute()
        assert points.Status == "ok"
        np.testing.assert_array_equal(bro._array(points.Points), data["mm"])
        points.CloudScale = 0.0
        doc.recompute()
        assert "Invalid" in points.State
        assert points.Status.startswith("failed: ") and "CloudScale 0: give a positive factor" in points.Status
        np.testing.assert_array_equal(bro._array(points.Points), data["mm"])      # the last good points kept
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_surface_is_the_command_lines(data, chain):
    """The BladeSurface on the cloud takes the command's path: the same sections, method, fit to
    the cloud and statistics on the cloud's nodes, within round-off; the true surface as near."""
    _, _, surface, _ = chain
    cli = data["cli"]
    assert surface.Status == "ok", surface.Status
    assert surface.FitMax == pytest.approx(cli["fit"]["max"], rel=REL)
    assert surface.FitRms == pytest.approx(cli["fit"]["rms"], rel=REL)
    assert (surface.UPoles, surface.VPoles) == (cli["surface"]["u_poles"], cli["surface"]["v_poles"])
    assert surface.MethodUsed == cli["surface"]["method"]
    assert surface.MethodReason == cli["slicing"]["method_reason"]
    got = json.loads(surface.SlicingJson)
    assert _close(got["slicing"], cli["slicing"]) == []
    assert _close(got["cloud_fit"], cli["surface"]["cloud_fit"]) == []
    # against the true blade: the workbench's surface and the command's STEP at the same distance
    cli_face = Part.read(str(data["step"])).Faces[0].Surface
    d_wb = _distances_to_truth(surface.Shape.Faces[0].Surface, data["blade"], cli["slicing"])
    d_cli = _distances_to_truth(cli_face, data["blade"], cli["slicing"])
    assert np.abs(d_wb - d_cli).max() <= STEP_MM, np.abs(d_wb - d_cli).max()
    # issue 25's figure holds on this sparse cloud too (measured 0.0962 max, 0.0035 mean)
    assert d_wb.max() <= 0.1 and d_wb.mean() <= 0.01, (d_wb.max(), d_wb.mean())


def test_slicing_says_what_was_chosen_and_why(data, chain):
    _, _, surface, _ = chain
    cli = data["cli"]["slicing"]
    lines = list(surface.Slicing)
    assert surface.getEditorMode("Slicing") == ["ReadOnly"]
    text = "\n".join(lines)
    assert lines[0].startswith("span axis: x (") and cli["axis_reason"] in lines[0]
    lo, hi = cli["airfoil_span_mm"]
    assert f"span: {lo:.2f} to {hi:.2f} mm" in text
    assert f"kind: auto-planes ({cli['kind_reason']})" in text
    assert f"sections: {cli['sections']} (" in text and f"slab width: {cli['slab_mm']:.2f} mm" in text
    assert f"method: {cli['method_reason']}" in text
    assert "fit to the cloud: the surface through the" in text and "coordinates times 1000" in text


def test_sections_are_the_command_lines(data, chain):
    _, _, _, sections = chain
    cli = data["cli_sections"]
    assert sections.Status == "ok", sections.Status
    assert len(sections.SectionNames) == len(cli) == data["cli"]["slicing"]["sections"]
    for prop, key in (("ChordLengths", "chord"), ("StaggerDeg", "stagger_deg"), ("MaxThickness", "max_thickness"),
                      ("LERadius", "le_radius"), ("TERadius", "te_radius")):
        want = np.array([np.nan if c[key] is None else c[key] for c in cli], float)
        np.testing.assert_allclose(getattr(sections, prop), want, rtol=REL, atol=1e-12, err_msg=prop)
    assert sections.LERule == cli[0]["le_rule"]
    assert json.loads(sections.SlicingJson)["slicing"]["positions_mm"] == pytest.approx(
        data["cli"]["slicing"]["positions_mm"], rel=REL)
    assert json.loads(sections.SlicingJson)["cloud_fit"] is None


def test_cloud_choices_reach_the_cut_and_bad_ones_are_one_line(data, chain):
    """The Cloud properties are the command's options: given, they are used and said so; a bad
    one fails the recompute in one line naming the property, the previous result kept."""
    doc, points, _, _ = chain
    sections = bro.make_blade_sections(doc, points, "Chosen", blade_kind="axial", span_axis="x", span_range="60:150",
                                       sections=6)
    doc.recompute()
    try:
        got = json.loads(sections.SlicingJson)["slicing"]
        assert sections.Status == "ok", sections.Status
        assert got["airfoil_span_mm"] == [60.0, 150.0] and got["sections"] == 6 and got["axis"] == [1.0, 0.0, 0.0]
        assert got["kind_reason"] == "axial requested" and got["span_reason"]["method"] == "--span-range"
        assert all(60.0 <= p <= 150.0 for p in got["positions_mm"])
        chords = list(sections.ChordLengths)
        for prop, value, says in (("CloudSections", 1, "CloudSections 1: give 2 to 200"),
                                  ("CloudSpanRange", "150:60", "CloudSpanRange '150:60': give A:B with A < B (mm)"),
                                  ("CloudSpanRange", "300:400", "CloudSpanRange 300:400 mm lies outside the cloud")):
            old = getattr(sections, prop)
            setattr(sections, prop, value)
            doc.recompute()
            assert "Invalid" in sections.State
            assert sections.Status.startswith("failed: ") and says in sections.Status, sections.Status
            assert "\n" not in sections.Status and "Traceback" not in sections.Status
            assert list(sections.ChordLengths) == chords
            setattr(sections, prop, old)
        with pytest.raises(BladeReconError, match="CloudBladeKind 'sideways'"):
            bro.make_blade_surface(doc, points, blade_kind="sideways")
    finally:
        doc.removeObject(sections.Name)


def test_sections_the_command_cannot_measure_fail_with_its_line(data, tmp_path):
    """Seed 0: ``sections`` stops at a section without a clear LE/TE; the workbench says the same
    line, as the failure of the object."""
    P, _ = blade_cloud(data["blade"], AIRFOIL_NODES, seed=0)
    cloud = tmp_path / "seed0.xyz"
    write_cloud(str(cloud), P)
    rc, _, err = _cli_inproc("sections", cloud, "--cloud-scale", "1000", "--quiet")
    assert rc == 2
    said = err.strip().splitlines()[-1].removeprefix("bladerecon: error: ")
    doc = FreeCAD.newDocument("CloudSeed0")
    try:
        sections = bro.make_blade_sections(doc, bro.make_measured_points(doc, str(cloud), cloud_scale=1000.0))
        doc.recompute()
        assert "Invalid" in sections.State
        assert sections.Status == f"failed: {said}", (sections.Status, said)
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_deviation_of_the_cloud_is_the_command_lines(data, chain):
    """A DeviationAnalysis of the cloud against the command's STEP: the statistics of
    ``deviation`` on the same points (written in mm, every digit kept), fillet and cap nodes
    included (the crop is ``--crop-to-nominal``'s, not the workbench's)."""
    doc, points, _, _ = chain
    mm = data["tmp"] / "nodes_mm.xyz"
    run = _cli("deviation", mm, "--nominal", data["step"], "--tolerance", "0.05", "--json", "--quiet", cwd=data["tmp"])
    assert run.returncode == 0, run.stderr
    cli = json.loads(run.stdout)
    nominal = doc.addObject("Part::Feature", "CliStep")
    nominal.Shape = Part.read(str(data["step"]))
    analysis = bro.make_deviation_analysis(doc, points, nominal, tolerance=0.05)
    doc.recompute()
    try:
        assert analysis.Status == "ok", analysis.Status
        for key, value in bro.DeviationAnalysis.stats(analysis).items():
            assert value == pytest.approx(cli[key], rel=REL, abs=1e-12), key
    finally:
        doc.removeObject(analysis.Name)
        doc.removeObject(nominal.Name)


def test_compensated_deviation_of_the_cloud_is_the_command_lines(data):
    """ProbeRadius on a cloud in a Deviation analysis: the points moved along the nominal's
    normals, as ``deviation CLOUD --probe-radius`` moves them."""
    mm = data["tmp"] / "nodes_mm.xyz"
    run = _cli("deviation", mm, "--nominal", data["step"], "--tolerance", "0.05", "--probe-radius", "0.05", "--json",
               "--quiet", cwd=data["tmp"])
    assert run.returncode == 0, run.stderr
    cli = json.loads(run.stdout)
    assert cli["compensation"]["normals"] == "nominal"
    doc = FreeCAD.newDocument("CloudProbe")
    try:
        points = bro.make_measured_points(doc, str(data["cloud"]), cloud_scale=1000.0)
        points.ProbeRadius = 0.05
        nominal = doc.addObject("Part::Feature", "CliStep")
        nominal.Shape = Part.read(str(data["step"]))
        analysis = bro.make_deviation_analysis(doc, points, nominal, tolerance=0.05)
        doc.recompute()
        assert analysis.Status == "ok", analysis.Status
        for key, value in bro.DeviationAnalysis.stats(analysis).items():
            assert value == pytest.approx(cli[key], rel=REL, abs=1e-12), key
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_a_structured_file_is_unchanged(tmp_path):
    """Measured sections import as before: sections, no cloud, the Cloud choices refused on them."""
    doc = FreeCAD.newDocument("Structured")
    try:
        points = bro.make_measured_points(doc, str(PLAN))
        surface = bro.make_blade_surface(doc, points)
        doc.recompute()
        assert points.Status == "ok" and not points.Cloud and points.SectionCount == 6 and points.PointCount == 390
        assert points.getEditorMode("CloudScale") == ["Hidden"]
        assert surface.Status == "ok" and surface.VPoles == 6 and list(surface.Slicing) == [] and surface.SlicingJson == ""
        surface.CloudSections = 8
        doc.recompute()
        assert "Invalid" in surface.State
        assert "CloudSections applies to a whole-blade cloud" in surface.Status and "6 measured sections" in surface.Status
        with pytest.raises(BladeReconError, match="applies to an unordered cloud"):
            bro.make_measured_points(doc, str(PLAN), "Scaled", cloud_scale=1000.0)
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_a_small_cloud_is_refused_as_the_command_refuses_it(data, tmp_path):
    small = tmp_path / "small.xyz"
    np.savetxt(small, data["mm"][:1500] / 1000.0)
    doc = FreeCAD.newDocument("Small")
    try:
        with pytest.raises(BladeReconError) as err:
            bro.make_measured_points(doc, str(small), cloud_scale=1000.0)
        assert len(doc.Objects) == 0
    finally:
        FreeCAD.closeDocument(doc.Name)
    said = str(err.value)
    assert "\n" not in said and said.startswith(f"{small}: 1500 points with no section labels") and "at least 2000" in said
    rc, _, cli_err = _cli_inproc("sections", small, "--cloud-scale", "1000", "--quiet")
    assert rc == 2 and cli_err.strip() == f"bladerecon: error: {said}"


def test_saved_and_reopened_cloud_recomputes(data, tmp_path):
    doc = FreeCAD.newDocument("CloudSave")
    points = bro.make_measured_points(doc, str(data["cloud"]), cloud_scale=1000.0)
    sections = bro.make_blade_sections(doc, points)
    doc.recompute()
    path = tmp_path / "cloud.FCStd"
    names = points.Name, sections.Name
    doc.saveAs(str(path))
    FreeCAD.closeDocument(doc.Name)
    doc = FreeCAD.openDocument(str(path))
    try:
        points, sections = (doc.getObject(n) for n in names)
        assert points.Cloud and points.CloudScale == 1000.0 and sections.CloudRotorAxis == "z"
        chords = list(sections.ChordLengths)
        for o in doc.Objects:
            o.touch()
        doc.recompute()
        assert points.Status == "ok" and sections.Status == "ok"
        np.testing.assert_array_equal(bro._array(points.Points), data["mm"])      # not scaled twice
        assert list(sections.ChordLengths) == chords
    finally:
        FreeCAD.closeDocument(doc.Name)


# --------------------------------------------------------------------------- the real GUI
GUI_FLOW = r'''
with part("setup"):
    FreeCADGui.activateWorkbench("BladeReconWorkbench")
    doc = FreeCAD.newDocument("CloudGui")
    def kind(o):
        return getattr(getattr(o, "Proxy", None), "Type", "")

with part("import cloud"):
    rep = Report()
    asked = {}
    def units(d):
        asked["label"] = d.labelText()
        asked["proposed"] = d.doubleValue()
        d.setDoubleValue(1000.0)
        d.accept()
    units.kind = W.QInputDialog
    seen = run("BladeRecon_ImportPoints", [choose(CONFIG["cloud"]), units], timing="import cloud")
    points = [o for o in doc.Objects if kind(o) == "MeasuredPoints"][0]
    result["import"] = {"dialogs": seen, "asked": asked, "cloud": points.Cloud, "scale": points.CloudScale,
                        "count": points.PointCount, "sections": points.SectionCount, "report": rep.new(),
                        "undo": list(doc.UndoNames)[:1], "first": list(points.Points[0]),
                        "mode": points.ViewObject.DisplayMode}

with part("reconstruct"):
    select(points)
    rep = Report()
    run("BladeRecon_Reconstruct")
    show_tasks()
    result["panel"] = {"source": task_widget("source").text(), "cloud_visible": task_widget("cloud").isVisible(),
                       "kinds": [task_widget("bladeKind").itemText(i) for i in range(task_widget("bladeKind").count())],
                       "axes": [task_widget("spanAxis").itemText(i) for i in range(task_widget("spanAxis").count())],
                       "rotor": task_widget("rotorAxis").currentText(), "sections": task_widget("sections").text(),
                       "clipped": clipped_texts()}
    grab_window("panel_reconstruct_cloud.png")
    task_widget("method").setCurrentText("auto")
    task_widget("bladeKind").setCurrentText("auto")
    task_widget("spanRange").setText("")
    click_ok(timing="reconstruct cloud (task panel OK to surface shown)")
    surface = [o for o in doc.Objects if kind(o) == "BladeSurface"][0]
    surface.Shape.exportBrep(os.path.join(OUT, "surface.brep"))
    result["surface"] = {"status": surface.Status, "fit_max": surface.FitMax, "fit_rms": surface.FitRms,
                         "method": surface.MethodUsed, "reason": surface.MethodReason, "slicing": list(surface.Slicing),
                         "json": surface.SlicingJson, "poles": [surface.UPoles, surface.VPoles],
                         "kind": surface.CloudBladeKind, "undo": list(doc.UndoNames)[:1], "report": rep.new()}
    FreeCADGui.runCommand("Std_Undo"); pump()
    result["after_undo"] = len([o for o in doc.Objects if kind(o) == "BladeSurface"])
    FreeCADGui.runCommand("Std_Redo"); pump()
    result["after_redo"] = len([o for o in doc.Objects if kind(o) == "BladeSurface"])
    select()
    shot("cloud_surface.png")

with part("sections"):
    select(points)
    run("BladeRecon_AnalyseSections", timing="analyse sections of the cloud")
    sections = [o for o in doc.Objects if kind(o) == "BladeSections"][0]
    result["sections"] = {"status": sections.Status, "chords": list(sections.ChordLengths),
                          "slicing": list(sections.Slicing)}

with part("bad choice"):
    surface = [o for o in doc.Objects if kind(o) == "BladeSurface"][0]
    area = surface.Shape.Area
    surface.CloudSections = 1
    rep = Report()
    select()
    FreeCADGui.runCommand("Std_Refresh")
    pump(0.5)
    result["bad_choice"] = {"status": surface.Status, "state": list(surface.State), "report": rep.new(),
                            "same_area": abs(surface.Shape.Area - area) < 1e-9 * area}

with part("small cloud"):
    rep = Report()
    n = len(doc.Objects)
    seen = run("BladeRecon_ImportPoints", [choose(CONFIG["small"]), press("OK")])
    result["small"] = {"dialogs": seen, "report": rep.new(), "added": len(doc.Objects) - n}

result["report_view"] = report_view()
with open(os.path.join(OUT, "result.json"), "w") as f:
    json.dump(result, f, indent=1, default=str)
os._exit(0)
'''

needs_gui = pytest.mark.skipif(shutil.which("xvfb-run") is None or shutil.which("freecad") is None,
                               reason="needs xvfb-run and the freecad GUI executable")


@pytest.fixture(scope="module")
def gui(data, tmp_path_factory):
    from test_workbench_gui import run_gui

    tmp = tmp_path_factory.mktemp("cloud_gui")
    small = tmp / "small_cloud.xyz"
    np.savetxt(small, data["mm"][:1500] / 1000.0)
    result, out = run_gui(tmp, GUI_FLOW, {"cloud": str(data["cloud"]), "small": str(small)})
    return result, out, small


def _ok(result, *parts):
    for p in parts:
        assert p not in result["errors"], result["errors"][p]


@needs_gui
@pytest.mark.timeout(600)
def test_gui_import_asks_the_units_of_a_cloud(data, gui):
    result, _, _ = gui
    _ok(result, "setup", "import cloud")
    imp = result["import"]
    assert [d["class"] for d in imp["dialogs"]] == ["QFileDialog", "QInputDialog"]
    assert "with no section labels" in imp["asked"]["label"] and "metres: 1000" in imp["asked"]["label"]
    assert imp["asked"]["proposed"] == 1000.0          # a cloud 0.2 units across: metres proposed
    assert imp["cloud"] and imp["scale"] == 1000.0 and imp["count"] == len(data["mm"]) and imp["sections"] == 0
    assert imp["first"] == list(data["mm"][0]) and imp["mode"] == "Sections"
    assert imp["undo"] == ["Import measured points"]
    assert "a whole-blade cloud of" in imp["report"] and "Traceback" not in imp["report"]


@needs_gui
@pytest.mark.timeout(600)
def test_gui_reconstruct_is_the_command_lines(data, gui):
    """The task panel shows the cloud's choices; OK makes the command line's surface (within
    round-off), one undo step, with the slicing said."""
    result, out, _ = gui
    _ok(result, "reconstruct")
    panel = result["panel"]
    assert panel["cloud_visible"] and "a whole-blade cloud, coordinates times 1000" in panel["source"]
    assert panel["kinds"] == ["auto", "axial", "radial"] and panel["axes"] == ["auto", "x", "y", "z", "-x", "-y", "-z"]
    assert panel["rotor"] == "z" and panel["sections"] == "auto" and panel["clipped"] == [], panel
    s, cli = result["surface"], data["cli"]
    assert s["status"] == "ok" and s["kind"] == "auto" and s["undo"] == ["Reconstruct blade surface"]
    assert result["after_undo"] == 0 and result["after_redo"] == 1
    assert s["fit_max"] == pytest.approx(cli["fit"]["max"], rel=REL)
    assert s["fit_rms"] == pytest.approx(cli["fit"]["rms"], rel=REL)
    assert s["method"] == cli["surface"]["method"] and s["reason"] == cli["slicing"]["method_reason"]
    assert _close(json.loads(s["json"])["slicing"], cli["slicing"]) == []
    assert any(line.startswith("kind: auto-planes") for line in s["slicing"])
    face = Part.read(str(out / "surface.brep")).Faces[0].Surface
    cli_face = Part.read(str(data["step"])).Faces[0].Surface
    d_gui = _distances_to_truth(face, data["blade"], cli["slicing"])
    d_cli = _distances_to_truth(cli_face, data["blade"], cli["slicing"])
    assert np.abs(d_gui - d_cli).max() <= STEP_MM and d_gui.max() <= 0.1, (d_gui.max(), d_cli.max())
    assert "Traceback" not in s["report"]


@needs_gui
@pytest.mark.timeout(600)
def test_gui_sections_of_the_cloud(data, gui):
    result, _, _ = gui
    _ok(result, "sections")
    s = result["sections"]
    assert s["status"] == "ok" and any(line.startswith("slab width") for line in s["slicing"])
    np.testing.assert_allclose(s["chords"], [c["chord"] for c in data["cli_sections"]], rtol=REL)


@needs_gui
@pytest.mark.timeout(600)
def test_gui_errors_are_one_line(gui):
    result, _, small = gui
    _ok(result, "bad choice", "small cloud")
    b = result["bad_choice"]
    assert b["status"] == "failed: CloudSections 1: give 2 to 200" and "Invalid" in b["state"] and b["same_area"]
    assert sum("CloudSections 1" in ln for ln in b["report"].splitlines()) == 1, b["report"]
    sm = result["small"]
    assert sm["added"] == 0 and sm["dialogs"][1]["class"] == "QMessageBox"
    assert sm["dialogs"][1]["text"].startswith(f"{small}: 1500 points with no section labels")
    assert sum("1500 points" in ln for ln in sm["report"].splitlines()) == 1, sm["report"]
    assert result["errors"] == {}, list(result["errors"])
    assert "Traceback" not in result["report_view"] and "Failed to load UI file" not in result["report_view"]
