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

__all__ = ["import_points", "ask_cloud_scale", "import_nominal", "analyse_sections", "reconstruct_surface",
           "compare_with_nominal", "show_deviation_map", "map_state", "set_surface_analysis", "export_step",
           "write_report", "show_error", "off_the_gui_thread", "Cancelled", "selected", "find_object"]

_PARAMS = "User parameter:BaseApp/Preferences/Mod/BladeRecon"
POINT_FILTER = "Measured points (*.csv *.txt *.xyz *.dat *.asc *.pts *.ply *.pcd);;All files (*)"
SECTION_POINT_SIZE = 4.0


def _qt_widgets() -> Any:
    """The Qt module holding QFileDialog/QMessageBox (QtGui through FreeCAD's PySide shim)."""
    from PySide import QtGui

    if hasattr(QtGui, "QFileDialog"):
        return QtGui
    from PySide import QtWidgets

    return QtWidgets


def show_error(message: str, title: str = "BladeRecon", log: bool = True) -> None:
    """Show ``message`` in the report view (unless ``log`` is False: already said there) and,
    with the GUI up, in a message box."""
    if log:
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


def _run(doc: Any, title: str, lines: list[str], result: str | None = None, then: Any = None,
         before_recompute: Any = None) -> Any:
    """Run console ``lines`` in one undo transaction, recompute, report a failed object.

    ``result``: name of a variable the lines assign (e.g. the new object); returned.
    ``then(obj)``: console lines to run in the same transaction once ``obj`` recomputed fine
    (showing it: undo takes them back with the object).
    ``before_recompute(obj)``: called (not replayed) just before the recompute, e.g. to hand
    ``obj`` a result measured off the GUI thread.
    A new object that fails on its first recompute is not left in the document: the
    transaction is undone and the reason, already in the report view once (the object said
    it), is shown in a message box. An existing object that fails keeps its previous result,
    marked failed, with the reason in ``Status``.
    """
    import __main__

    before = {o.Name: getattr(o, "Status", None) for o in doc.Objects}
    doc.openTransaction(title)
    try:
        FreeCADGui.doCommand("import bladerecon.fc.objects as bro")
        for line in lines:
            FreeCADGui.doCommand(line)
        if before_recompute is not None and result is not None and getattr(__main__, result, None) is not None:
            before_recompute(getattr(__main__, result))
        FreeCADGui.doCommand(f"App.getDocument({doc.Name!r}).recompute()")
        failed = [o for o in doc.Objects if str(getattr(o, "Status", "")).startswith("failed")
                  and before.get(o.Name, "new") != o.Status]
        new_failed = [o for o in failed if o.Name not in before]
        reasons = "; ".join(o.Status[len("failed: "):] for o in failed)
        if new_failed:
            doc.abortTransaction()
            show_error(reasons, log=False)
            return None
        obj = getattr(__main__, result, None) if result is not None else None
        if then is not None and obj is not None:
            for line in then(obj):
                FreeCADGui.doCommand(line)
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
    if failed:
        show_error(reasons, log=False)
    return getattr(__main__, result, None) if result is not None else None


def _view_step(doc: Any, title: str, lines: list[str]) -> None:
    """View-only changes: replayable through doCommand, one undo step, no recompute."""
    doc.openTransaction(title)
    try:
        for line in lines:
            FreeCADGui.doCommand(line)
    except Exception as err:
        doc.abortTransaction()
        FreeCAD.Console.PrintLog(traceback.format_exc())
        show_error(f"{title} failed: {type(err).__name__}: {err}")
        return
    doc.commitTransaction()


def import_points(path: str, cloud_scale: float | None = None) -> Any:
    """Import ``path`` as a MeasuredPoints object into the active document (a new one if none).

    A file with fewer than 2 sections imports (its sections can be analysed) with a warning:
    it cannot make a surface. A file with no section structure is a whole-blade cloud (its
    sections are cut automatically), its coordinates times ``cloud_scale`` (None: asked in a
    dialog with the GUI up, else 1); one too small to cut is refused in the command line's line.
    """
    from bladerecon.core.io.readers import read_points

    try:
        # a bad file is reported here, before the document is touched
        ps = read_points(path, require_sections=False)
        if not ps.structured:
            from bladerecon.core.sections.whole_cloud import check_cloud_size

            check_cloud_size(path, len(ps.points))
    except BladeReconError as err:
        show_error(str(err))
        return None
    except Exception as err:  # a reader bug: say what, keep the traceback in the log only
        FreeCAD.Console.PrintLog(traceback.format_exc())
        show_error(f"cannot read {path}: {type(err).__name__}: {err}")
        return None
    scale = ""
    if not ps.structured:
        if cloud_scale is None:
            cloud_scale = ask_cloud_scale(path, ps.points) if FreeCAD.GuiUp else 1.0
            if cloud_scale is None:
                return None
        scale = f", cloud_scale={float(cloud_scale)!r}"
    doc = FreeCAD.ActiveDocument or FreeCAD.newDocument()
    obj = _run(doc, "Import measured points",
               [f"_br_points = bro.make_measured_points(App.getDocument({doc.Name!r}), {path!r}{scale})"], "_br_points")
    if obj is not None and not ps.structured:
        FreeCAD.Console.PrintMessage(
            f"BladeRecon: {os.path.basename(path)}: a whole-blade cloud of {len(ps.points)} points (coordinates "
            f"times {float(cloud_scale):g}): Reconstruct and Analyse sections cut its sections automatically\n")
    elif obj is not None and len(ps.section_names) < 2:
        FreeCAD.Console.PrintWarning(
            f"BladeRecon: {os.path.basename(path)}: {len(ps.section_names)} section only: a surface needs at "
            "least 2 sections (Reconstruct cannot run on it)\n")
    if obj is not None and FreeCADGui.ActiveDocument is not None:
        obj.ViewObject.PointSize = SECTION_POINT_SIZE
        FreeCADGui.SendMsgToActiveView("ViewFit")
    return obj


def ask_cloud_scale(path: str, points: Any) -> float | None:
    """The unit factor of a cloud (its coordinates times it are mm), asked in a dialog that shows
    the cloud's extent; proposed: 1000 when the cloud is under 2 units across (metres), else the
    last one given or 1. None when the user cancels."""
    import numpy as np

    params = FreeCAD.ParamGet(_PARAMS)
    ext = np.ptp(np.asarray(points, float), axis=0)
    proposed = 1000.0 if float(np.linalg.norm(ext)) < 2.0 else params.GetFloat("CloudScale", 1.0) or 1.0
    qt = _qt_widgets()
    text = (f"{os.path.basename(path)}: {len(points)} points with no section labels, a whole-blade cloud "
            f"(its sections are cut automatically).\nExtent {ext[0]:.4g} x {ext[1]:.4g} x {ext[2]:.4g} in the "
            "file's units.\n\nMultiply the coordinates by (mm: 1, metres: 1000, inches: 25.4):")
    scale, ok = qt.QInputDialog.getDouble(FreeCADGui.getMainWindow(), "Cloud units", text, proposed, 1e-6, 1e9, 6)
    if not ok:
        return None
    params.SetFloat("CloudScale", scale)
    return float(scale)


def import_nominal(path: str) -> Any:
    """Import a nominal blade (STEP, IGES, BREP) as one Part feature labelled by its file name."""
    doc = FreeCAD.ActiveDocument or FreeCAD.newDocument()
    stem = os.path.splitext(os.path.basename(path))[0]
    return _run(doc, "Import nominal",
                ["import Part",
                 f"_br_nominal = App.getDocument({doc.Name!r}).addObject('Part::Feature', 'Nominal')",
                 f"_br_nominal.Shape = Part.read({path!r})",
                 f"_br_nominal.Label = {stem!r}"], "_br_nominal")


def analyse_sections(points_obj: Any) -> Any:
    """Add a BladeSections object (ordered sections, LE/TE) on ``points_obj``."""
    doc = points_obj.Document
    return _run(doc, "Analyse sections",
                [f"_br_sections = bro.make_blade_sections(App.getDocument({doc.Name!r}), {_ref(points_obj)})"],
                "_br_sections")


def reconstruct_surface(points_obj: Any, method: str = "auto", tolerance: float = 0.0, **cloud: Any) -> Any:
    """Add a BladeSurface reconstructed from ``points_obj`` (method, tolerance in mm; 0 = automatic).
    ``cloud``: the choices for a whole-blade cloud (``blade_kind``, ``span_axis``, ``span_range``,
    ``sections``, ``rotor_axis`` of :func:`bladerecon.fc.objects.make_blade_surface`)."""
    doc = points_obj.Document
    extra = "".join(f", {k}={v!r}" for k, v in cloud.items())
    return _run(doc, "Reconstruct blade surface",
                [f"_br_surface = bro.make_blade_surface(App.getDocument({doc.Name!r}), {_ref(points_obj)}, "
                 f"method={method!r}, tolerance={float(tolerance)!r}{extra})"], "_br_surface")


def compare_with_nominal(measured: Any, nominal: Any, surface: Any = None, alignment: str = "none",
                         tolerance: float = 0.03, robust: bool = False) -> Any:
    """Add a DeviationAnalysis of ``measured`` (and ``surface``) against ``nominal`` and show its
    colour map, all one undo step. ``robust``: Tukey-biweight best fit (with an alignment).

    The measurement runs first, off the GUI thread under FreeCAD's progress bar (Esc cancels:
    the document is left as it was); then one transaction adds the object, whose recompute
    stores that result (the console line replays it in the foreground). The nominal is hidden
    (it lies on the measured surface); deleting the analysis shows it again.
    """
    import time

    doc = measured.Document
    t0 = time.time()
    ready = _measure_off_the_gui_thread(measured, nominal, surface, alignment, tolerance, robust)
    if ready is False:
        return None

    def show(analysis: Any) -> list[str]:
        lines = []
        if FreeCAD.GuiUp and nominal.ViewObject is not None and nominal.ViewObject.Visibility:
            lines += [f"_br_deviation.ViewObject.HiddenByCompare = [{nominal.Name!r}]",
                      f"{_ref(nominal)}.ViewObject.Visibility = False"]
        if FreeCAD.GuiUp and analysis.Status == "ok":
            lines += _map_lines(analysis, "Surface" if surface is not None else "Points", "_br_deviation")
        return lines

    def hand_over(analysis: Any) -> None:
        if ready is not None:
            analysis.Proxy.precomputed = ready

    obj = _run(doc, "Compare with nominal",
               [f"_br_deviation = bro.make_deviation_analysis(App.getDocument({doc.Name!r}), {_ref(measured)}, "
                f"{_ref(nominal)}, {_ref(surface)}, alignment={alignment!r}, tolerance={float(tolerance)!r}, "
                f"robust={bool(robust)!r})"],
               "_br_deviation", then=show, before_recompute=hand_over)
    if obj is not None:
        FreeCAD.Console.PrintLog(f"BladeRecon: compare took {time.time() - t0:.2f} s\n")
    return obj


def _measure_off_the_gui_thread(measured: Any, nominal: Any, surface: Any, alignment: str, tolerance: float,
                                robust: bool) -> Any:
    """``(key, DeviationMeasurement or its BladeReconError)`` measured in a worker thread; None
    when the inputs cannot make a job (the recompute then says why, as from the console);
    False when the user cancelled (said in one line)."""
    try:
        job = objects.deviation_job(measured, nominal, surface, alignment, float(tolerance), bool(robust),
                                    copy_shape=True)
    except BladeReconError:
        return None
    try:
        outcome = off_the_gui_thread(f"Comparing {measured.Label} with {nominal.Label}",
                                     lambda: objects.measure_job(job))
    except Cancelled:
        FreeCAD.Console.PrintWarning("BladeRecon: compare cancelled; the document is as it was "
                                     "(previous results kept)\n")
        return False
    except BladeReconError as err:
        outcome = err
    except Exception:   # a bug: the recompute runs it again in the foreground and says it in one line
        FreeCAD.Console.PrintLog(traceback.format_exc())
        return None
    return job.key, outcome


# --------------------------------------------------------------------------- colour maps
def map_state(analysis: Any) -> str | None:
    """Where the deviation map of ``analysis`` is shown: ``"Surface"``, ``"Points"`` or None."""
    vobj = analysis.ViewObject
    proxy = getattr(vobj, "Proxy", None)
    if proxy is not None and hasattr(proxy, "surface_showing_me") and proxy.surface_showing_me() is not None:
        return "Surface"
    if vobj.Visibility and vobj.DisplayMode == "Points":
        return "Points"
    return None


def _covering(analysis: Any) -> list:
    """What would be drawn over a map: the measured points and their section curves."""
    measured = analysis.Measured
    if measured is None:
        return []
    return [measured] + [o for o in measured.Document.Objects
                         if objects.is_type(o, "BladeSections") and o.Points == measured]


def _map_lines(analysis: Any, target: str | None, ref: str | None = None) -> list[str]:
    """Console lines that put the map of ``analysis`` on ``target`` ("Surface", "Points") or off (None)."""
    from bladerecon.gui.view_providers import PLAIN_MODE

    a = ref or _ref(analysis)
    lines = []
    state = map_state(analysis) if analysis.ViewObject is not None else None
    surface = analysis.Surface
    if state == "Surface" and target != "Surface":
        lines.append(f"{_ref(surface)}.ViewObject.DisplayMode = {PLAIN_MODE!r}")
    if state == "Points" and target != "Points":
        lines.append(f"{a}.ViewObject.Visibility = False")
    # what the map hides: visible now, or hidden by the map it replaces (shown again by the lines above)
    was_hidden = set(analysis.ViewObject.HiddenByMap) if state == "Points" else set()
    if state == "Surface":
        was_hidden |= set(surface.ViewObject.HiddenByMode)
    if target == "Surface":
        hide = [o for o in _covering(analysis) if o.ViewObject.Visibility or o.Name in was_hidden]
        kept = [n for n in surface.ViewObject.HiddenByMode if n not in {o.Name for o in hide}] \
            if state != "Surface" and surface.ViewObject.DisplayMode in ("Zebra", "Curvature") else []
        s = _ref(surface)
        lines += [f"{a}.ViewObject.DisplayMode = 'Surface'", f"{a}.ViewObject.Visibility = False",
                  f"{s}.ViewObject.HiddenByMode = {kept + [o.Name for o in hide]!r}"]
        lines += [f"{_ref(o)}.ViewObject.Visibility = False" for o in hide]
        lines += [f"{s}.ViewObject.DeviationMap = {analysis.Name!r}", f"{s}.ViewObject.DisplayMode = 'Deviation'",
                  f"{s}.ViewObject.Visibility = True"]
    elif target == "Points":
        under = _covering(analysis) + ([surface] if surface is not None else [])
        hide = [o for o in under if o.ViewObject.Visibility or o.Name in was_hidden or
                (o == surface and state == "Surface")]
        lines += [f"{a}.ViewObject.HiddenByMap = {[o.Name for o in hide]!r}"]
        lines += [f"{_ref(o)}.ViewObject.Visibility = False" for o in hide]
        lines += [f"{a}.ViewObject.DisplayMode = 'Points'", f"{a}.ViewObject.Visibility = True"]
    return lines


def show_deviation_map(analysis: Any, target: str | None = "Surface") -> None:
    """Show the deviation colour map on the ``"Surface"`` (a display mode of the surface) or the
    ``"Points"``; ``None`` switches it off. One undo step, nothing recomputed.

    What the map would be drawn under (the points, their section curves; the surface under the
    points map) is hidden while it is on and shown again when it goes.
    """
    if target == "Surface" and analysis.Surface is None:
        show_error(f"{analysis.Label} has no surface to colour: link one in its properties, or use the map on points")
        return
    if target == "Points" and analysis.Measured is None:
        show_error(f"{analysis.Label} has no points to colour: link them in its properties")
        return
    _view_step(analysis.Document, "Deviation colour map", _map_lines(analysis, target))


def set_surface_analysis(surface: Any, mode: str | None, stripes: int | None = None, direction: str | None = None,
                         curvature: str | None = None) -> None:
    """Zebra (``mode="Zebra"``), curvature (``"Curvature"``) or plain (``None``) display of a BladeSurface.

    ``stripes``, ``direction`` (span, x, y) and ``curvature`` (Mean, Gaussian) set the view
    properties first; only colours are recomputed, never the surface. The analysis modes are
    modes of the surface, so a deviation map on it gives way (and what it hid stays hidden
    until the surface goes back to its plain display). One undo step.
    """
    from bladerecon.gui.view_providers import PLAIN_MODE

    lines = [f"_br_view = {_ref(surface)}.ViewObject"]
    if stripes is not None:
        lines.append(f"_br_view.ZebraStripes = {int(stripes)}")
    if direction is not None:
        lines.append(f"_br_view.ZebraDirection = {direction!r}")
    if curvature is not None:
        lines.append(f"_br_view.CurvatureKind = {curvature!r}")
    lines.append(f"_br_view.DisplayMode = {mode or PLAIN_MODE!r}")
    lines.append("_br_view.Visibility = True")
    _view_step(surface.Document, "Surface analysis", lines)


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


def _snapshot(analysis: Any) -> Any:
    """What the report reads of ``analysis``, copied out of the document (the report runs off the
    GUI thread while the document stays editable)."""
    from types import SimpleNamespace as NS

    def proxy(kind: str) -> Any:
        return NS(Type=kind)

    m = analysis.Measured
    measured = None if m is None else NS(
        Proxy=proxy("MeasuredPoints"), Label=m.Label, Points=list(m.Points), SectionIndex=list(m.SectionIndex),
        LineNumbers=list(m.LineNumbers), SectionNames=list(m.SectionNames), SourceFile=m.SourceFile, Format=m.Format,
        Cloud=bool(getattr(m, "Cloud", False)))
    n = analysis.Nominal
    nominal = None if n is None else NS(Label=n.Label, Shape=n.Shape.copy())
    s = analysis.Surface
    surface = None if s is None else NS(Label=s.Label, Shape=s.Shape.copy())
    return NS(Proxy=proxy("DeviationAnalysis"), Label=analysis.Label, Measured=measured, Nominal=nominal,
              Surface=surface, Alignment=analysis.Alignment, Tolerance=analysis.Tolerance,
              RobustFit=analysis.RobustFit)


class Cancelled(Exception):
    """The user cancelled a long step on FreeCAD's progress bar."""


def off_the_gui_thread(text: str, work: Any, abandoned: Any = None) -> Any:
    """Run ``work()`` in a worker thread while FreeCAD's progress bar runs in the status bar (the
    GUI keeps drawing; Esc on the bar asks and cancels: :class:`Cancelled` is raised here at once,
    and the worker's result, when it comes, is thrown away). Returns ``work()``'s result or
    raises its exception.

    ``abandoned()``, when given, runs once the cancelled work has really ended (in the worker,
    or here if it ended first): what the work was writing can only be cleared then, else the
    work would write it again after it was cleared."""
    import threading
    import time

    box: dict = {}
    lock = threading.Lock()

    def target() -> None:
        try:
            box["result"] = work()
        except BaseException as err:  # handed to the GUI thread
            box["error"] = err
        with lock:
            box["done"] = True
            clear = box.get("cancelled", False)
        if clear and abandoned is not None:
            abandoned()

    worker = threading.Thread(target=target, name=f"BladeRecon: {text}", daemon=True)
    maker = getattr(FreeCAD.Base, "ProgressIndicator", None) if FreeCAD.GuiUp else None
    bar = maker() if maker is not None else None
    worker.start()
    if bar is not None:
        bar.start(text, 0)
    try:
        while worker.is_alive():
            worker.join(0.05)
            if bar is not None:
                try:
                    bar.next(True)
                except Exception as err:   # FreeCAD 0.20: RuntimeError("abort progress indicator")
                    if "abort" in f"{type(err).__name__} {err}".lower():
                        with lock:
                            box["cancelled"] = True
                            clear = box.get("done", False)
                        if clear and abandoned is not None:
                            abandoned()
                        raise Cancelled(text) from None
                    raise
            if FreeCAD.GuiUp:
                FreeCADGui.updateGui()
            time.sleep(0.0)
    finally:
        if bar is not None:
            bar.stop()
    if "error" in box:
        raise box["error"]
    return box.get("result")


def write_report(analysis: Any, folder: str, ask: bool = True) -> dict | None:
    """Write the deviation report (report.html, plots, deviations.csv, summary.json) into ``folder``.

    The report is made off the GUI thread under FreeCAD's progress bar (Esc cancels), in a
    folder of its own next to ``folder``; only a finished report replaces ``folder``, and an
    existing ``folder`` only after the user said yes (``ask``). The console line it runs
    (``br_report.write_analysis_report``) replays it in the foreground.
    """
    import shutil
    import tempfile

    folder = os.path.abspath(folder)
    parent = os.path.dirname(folder)
    if not os.path.isdir(parent):
        show_error(f"report folder {folder}: folder {parent} does not exist; create it first")
        return None
    if ask and os.path.exists(folder) and FreeCAD.GuiUp:
        qt = _qt_widgets()
        answer = qt.QMessageBox.question(
            FreeCADGui.getMainWindow(), "Replace the report?",
            f"{folder} exists. Replace it with the report of {analysis.Label}?",
            qt.QMessageBox.Yes | qt.QMessageBox.No, qt.QMessageBox.No)
        if answer != qt.QMessageBox.Yes:
            FreeCAD.Console.PrintMessage(f"BladeRecon: report not written: {folder} kept\n")
            return None
    # the same report in the foreground, from the console:
    FreeCADGui.doCommand(f"# import bladerecon.report.deviation as br_report; _br_report = "
                         f"br_report.write_analysis_report({_ref(analysis)}, {folder!r})")
    from bladerecon.report.deviation import write_analysis_report

    snapshot = _snapshot(analysis)
    staging = tempfile.mkdtemp(prefix=".bladerecon-report-", dir=parent)
    made = os.path.join(staging, os.path.basename(folder))
    cancelled = False
    try:
        # a cancelled report is cleared when its work has ended, not at the cancel: the work
        # goes on writing for a while and would leave a half staging folder behind
        summary = off_the_gui_thread(f"{analysis.Label}: writing the report",
                                     lambda: write_analysis_report(snapshot, made),
                                     abandoned=lambda: shutil.rmtree(staging, ignore_errors=True))
        if os.path.isdir(folder):
            shutil.rmtree(folder)
        os.replace(made, folder)
    except Cancelled:
        cancelled = True
        FreeCAD.Console.PrintWarning(f"BladeRecon: report cancelled; {folder} "
                                     f"{'kept as it was' if os.path.exists(folder) else 'not written'}\n")
        return None
    except BladeReconError as err:
        show_error(str(err))
        return None
    except Exception as err:
        FreeCAD.Console.PrintLog(traceback.format_exc())
        show_error(f"report failed: {type(err).__name__}: {err}")
        return None
    finally:
        if not cancelled:
            shutil.rmtree(staging, ignore_errors=True)
    FreeCAD.Console.PrintMessage(f"BladeRecon: report in {folder}\n")
    return summary


# --------------------------------------------------------------------------- commands
