# SPDX-License-Identifier: LGPL-2.1-or-later
"""The workbench's replayable steps: the work behind each command and task panel.

Each step (``import_points``, ``reconstruct_surface``, ``compare_with_nominal``, ...) opens an
undo transaction and goes through ``FreeCADGui.doCommand``, so what it did is replayable from
the Python console. Errors a user can cause are shown as the CLI's one-line message in the
report view and a message box, never as a traceback. Commands (:mod:`bladerecon.gui.commands`)
and task panels (:mod:`bladerecon.gui.task_panels`) both call these; neither imports the other's
module for them.
"""
from __future__ import annotations

import os
import traceback
from typing import Any

import FreeCAD
import FreeCADGui

from bladerecon.core.errors import BladeReconError
from bladerecon.fc import objects

__all__ = ["import_points", "analyse_sections", "reconstruct_surface", "compare_with_nominal",
           "show_deviation_map", "set_surface_analysis", "export_step", "write_report", "show_error",
           "selected", "find_object"]

_PARAMS = "User parameter:BaseApp/Preferences/Mod/BladeRecon"
POINT_FILTER = "Measured points (*.csv *.txt *.xyz *.dat *.asc *.pts);;All files (*)"
SECTION_POINT_SIZE = 4.0


def _qt_widgets() -> Any:
    """The Qt module holding QFileDialog/QMessageBox (QtGui through FreeCAD's PySide shim)."""
    from PySide import QtGui

    if hasattr(QtGui, "QFileDialog"):
        return QtGui
    from PySide import QtWidgets

    return QtWidgets


def show_error(message: str, title: str = "BladeRecon") -> None:
    """Show ``message`` in the report view and, with the GUI up, in a message box."""
    FreeCAD.Console.PrintError(f"BladeRecon: {message}\n")
    if FreeCAD.GuiUp:
        qt = _qt_widgets()
        qt.QMessageBox.critical(FreeCADGui.getMainWindow(), title, message)


# --------------------------------------------------------------------------- selection
def selected(type_name: str | None = None) -> list:
    """Selected objects (of BladeRecon ``type_name`` if given), in selection order."""
    objs = FreeCADGui.Selection.getSelection() if FreeCAD.GuiUp else []
    return [o for o in objs if type_name is None or objects.is_type(o, type_name)]


def find_object(type_name: str) -> Any:
    """The selected object of ``type_name``, else the only one of that type in the active document."""
    sel = selected(type_name)
    if sel:
        return sel[0]
    doc = FreeCAD.ActiveDocument
    found = [o for o in doc.Objects if objects.is_type(o, type_name)] if doc is not None else []
    return found[0] if len(found) == 1 else None


def _nominal_candidates() -> list:
    """Selected objects that could be a nominal: a shape with faces that is not BladeRecon's."""
    out = []
    for o in selected():
        shape = getattr(o, "Shape", None)
        if getattr(getattr(o, "Proxy", None), "Type", None) in ("MeasuredPoints", "BladeSections", "BladeSurface"):
            continue
        if shape is not None and not shape.isNull() and shape.Faces:
            out.append(o)
    return out


def _has_surface(obj: Any) -> bool:
    shape = getattr(obj, "Shape", None)
    return obj is not None and shape is not None and not shape.isNull() and len(shape.Faces) == 1


# --------------------------------------------------------------------------- the replayable steps
def _ref(obj: Any) -> str:
    """Python expression naming ``obj`` in the console."""
    return "None" if obj is None else f"App.getDocument({obj.Document.Name!r}).getObject({obj.Name!r})"


def _run(doc: Any, title: str, lines: list[str], result: str | None = None) -> Any:
    """Run console ``lines`` in one undo transaction, recompute, report a failed object.

    ``result``: name of a variable the lines assign (e.g. the new object); returned.
    Objects that fail to recompute stay in the document, marked failed, with their reason
    in ``Status`` (shown here once).
    """
    before = {o.Name: getattr(o, "Status", None) for o in doc.Objects}
    doc.openTransaction(title)
    try:
        FreeCADGui.doCommand("import bladerecon.fc.objects as bro")
        for line in lines:
            FreeCADGui.doCommand(line)
        FreeCADGui.doCommand(f"App.getDocument({doc.Name!r}).recompute()")
    except BladeReconError as err:
        doc.abortTransaction()
        show_error(str(err))
        return None
    except Exception as err:  # a bug: one line, the traceback in the log
        doc.abortTransaction()
        FreeCAD.Console.PrintLog(traceback.format_exc())
        show_error(f"{title} failed: {type(err).__name__}: {err}")
        return None
    doc.commitTransaction()
    # newly failed in this step (an object that already failed the same way is not repeated)
    failed = [o for o in doc.Objects if str(getattr(o, "Status", "")).startswith("failed")
              and before.get(o.Name) != o.Status]
    if failed:
        show_error("; ".join(o.Status[len("failed: "):] for o in failed))
    if result is None:
        return None
    import __main__

    return getattr(__main__, result, None)


def import_points(path: str) -> Any:
    """Import ``path`` as a MeasuredPoints object into the active document (a new one if none)."""
    from bladerecon.core.io.readers import read_points

    try:
        read_points(path)  # a bad file is reported here, before the document is touched
    except BladeReconError as err:
        show_error(str(err))
        return None
    except Exception as err:  # a reader bug: say what, keep the traceback in the log only
        FreeCAD.Console.PrintLog(traceback.format_exc())
        show_error(f"cannot read {path}: {type(err).__name__}: {err}")
        return None
    doc = FreeCAD.ActiveDocument or FreeCAD.newDocument()
    obj = _run(doc, "Import measured points",
               [f"_br_points = bro.make_measured_points(App.getDocument({doc.Name!r}), {path!r})"], "_br_points")
    if obj is not None and FreeCADGui.ActiveDocument is not None:
        obj.ViewObject.PointSize = SECTION_POINT_SIZE
        FreeCADGui.SendMsgToActiveView("ViewFit")
    return obj


def analyse_sections(points_obj: Any) -> Any:
    """Add a BladeSections object (ordered sections, LE/TE) on ``points_obj``."""
    doc = points_obj.Document
    return _run(doc, "Analyse sections",
                [f"_br_sections = bro.make_blade_sections(App.getDocument({doc.Name!r}), {_ref(points_obj)})"],
                "_br_sections")


def reconstruct_surface(points_obj: Any, method: str = "auto", tolerance: float = 0.0) -> Any:
    """Add a BladeSurface reconstructed from ``points_obj`` (method, tolerance in mm; 0 = automatic)."""
    doc = points_obj.Document
    return _run(doc, "Reconstruct blade surface",
                [f"_br_surface = bro.make_blade_surface(App.getDocument({doc.Name!r}), {_ref(points_obj)}, "
                 f"method={method!r}, tolerance={float(tolerance)!r})"], "_br_surface")


def compare_with_nominal(measured: Any, nominal: Any, surface: Any = None, alignment: str = "none",
                         tolerance: float = 0.03, robust: bool = False) -> Any:
    """Add a DeviationAnalysis of ``measured`` (and ``surface``) against ``nominal``; shows its
    colour map. ``robust``: Tukey-biweight best fit (with an alignment)."""
    doc = measured.Document
    obj = _run(doc, "Compare with nominal",
               [f"_br_deviation = bro.make_deviation_analysis(App.getDocument({doc.Name!r}), {_ref(measured)}, "
                f"{_ref(nominal)}, {_ref(surface)}, alignment={alignment!r}, tolerance={float(tolerance)!r}, "
                f"robust={bool(robust)!r})"],
               "_br_deviation")
    if obj is not None and obj.Status == "ok" and FreeCAD.GuiUp:
        _view_step(doc, "Hide the nominal", [f"{_ref(nominal)}.ViewObject.Visibility = False"])
        show_deviation_map(obj, "Surface" if surface is not None else "Points")
    return obj


def show_deviation_map(analysis: Any, target: str | None = "Surface") -> None:
    """Show the deviation colour map on the ``"Surface"`` or the ``"Points"``; ``None`` hides it.

    Only visibility and display mode change (nothing is recomputed); the object under the
    map is hidden so the two do not overlap.
    """
    lines = [f"_br_map = {_ref(analysis)}"]
    if target is None:
        lines += ["_br_map.ViewObject.Visibility = False"]
        for link in ("Surface", "Measured"):
            if getattr(analysis, link) is not None:
                lines.append(f"_br_map.{link}.ViewObject.Visibility = True")
    else:
        under = analysis.Surface if target == "Surface" else analysis.Measured
        if under is None:
            show_error(f"{analysis.Label} has no {'surface' if target == 'Surface' else 'points'} to colour: "
                       "link one in its properties")
            return
        lines += [f"_br_map.ViewObject.DisplayMode = {target!r}", "_br_map.ViewObject.Visibility = True",
                  f"_br_map.{'Surface' if target == 'Surface' else 'Measured'}.ViewObject.Visibility = False"]
    _view_step(analysis.Document, "Deviation colour map", lines)


def set_surface_analysis(surface: Any, mode: str | None, stripes: int | None = None, direction: str | None = None,
                         curvature: str | None = None) -> None:
    """Zebra (``mode="Zebra"``), curvature (``"Curvature"``) or plain (``None``) display of a BladeSurface.

    ``stripes``, ``direction`` (span, x, y) and ``curvature`` (Mean, Gaussian) set the view
    properties first; only colours are recomputed, never the surface.
    """
    lines = [f"_br_view = {_ref(surface)}.ViewObject"]
    if stripes is not None:
        lines.append(f"_br_view.ZebraStripes = {int(stripes)}")
    if direction is not None:
        lines.append(f"_br_view.ZebraDirection = {direction!r}")
    if curvature is not None:
        lines.append(f"_br_view.CurvatureKind = {curvature!r}")
    lines.append(f"_br_view.DisplayMode = {mode or 'Flat Lines'!r}")
    lines.append("_br_view.Visibility = True")
    _view_step(surface.Document, "Surface analysis", lines)


def _view_step(doc: Any, title: str, lines: list[str]) -> None:
    """View-only changes: replayable through doCommand, no recompute."""
    try:
        for line in lines:
            FreeCADGui.doCommand(line)
    except Exception as err:
        FreeCAD.Console.PrintLog(traceback.format_exc())
        show_error(f"{title} failed: {type(err).__name__}: {err}")


def export_step(surface: Any, path: str) -> bool:
    """Write the surface's face to ``path`` (STEP, mm). True on success."""
    try:
        FreeCADGui.doCommand("import bladerecon.fc.objects as bro")
        FreeCADGui.doCommand(f"bro.export_step({_ref(surface)}, {path!r})")
    except BladeReconError as err:
        show_error(str(err))
        return False
    FreeCAD.Console.PrintMessage(f"BladeRecon: wrote {path}\n")
    return True


def write_report(analysis: Any, folder: str) -> dict | None:
    """Write the deviation report (report.html, plots, deviations.csv, summary.json) into ``folder``."""
    try:
        FreeCADGui.doCommand("import bladerecon.report.deviation as br_report")
        FreeCADGui.doCommand(f"_br_report = br_report.write_analysis_report({_ref(analysis)}, {folder!r})")
    except BladeReconError as err:
        show_error(str(err))
        return None
    except Exception as err:
        FreeCAD.Console.PrintLog(traceback.format_exc())
        show_error(f"report failed: {type(err).__name__}: {err}")
        return None
    FreeCAD.Console.PrintMessage(f"BladeRecon: report in {folder}\n")
    import __main__

    return getattr(__main__, "_br_report", None)


# --------------------------------------------------------------------------- commands
