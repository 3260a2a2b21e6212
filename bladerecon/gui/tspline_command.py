# SPDX-License-Identifier: LGPL-2.1-or-later
"""Workbench command: fit an adaptive analysis-suitable T-spline (seed 002) to a point file.

Asks for the point file and the tolerance (mm), fits off the GUI thread under FreeCAD's
progress bar (Esc cancels), then adds the sewn Bézier-patch shell as one undo step.
Importing registers ``BladeRecon_TSpline``.
"""
from __future__ import annotations

import os
import traceback

import FreeCAD
import FreeCADGui

from bladerecon.core.errors import BladeReconError

from bladerecon.gui import actions, commands

__all__ = ["TSplineCommand", "fit_tspline_into_document", "COMMAND_NAME"]

COMMAND_NAME = "BladeRecon_TSpline"


def fit_tspline_into_document(path: str, tolerance: float):
    """Fit ``path`` at ``tolerance`` mm into the active document (a new one if none).

    The fit runs off the GUI thread under FreeCAD's progress bar (Esc cancels); the sewn
    shell is then added as one undo step. The console shows the line that does the same in
    the foreground (``make_tspline_feature``).
    """
    from bladerecon.core.surface.tspline_job import fit_point_file
    from bladerecon.fc.tspline_export import add_tspline_feature, patch_faces, sew_patches

    said: list[str] = []

    def work():
        _, patches, summary = fit_point_file(path, tolerance, say=said.append)
        return sew_patches(patch_faces(patches)), summary

    try:
        shell, summary = actions.off_the_gui_thread(f"T-spline fit of {os.path.basename(path)}", work)
    except actions.Cancelled:
        FreeCAD.Console.PrintWarning(f"BladeRecon: T-spline fit of {path} cancelled\n")
        return None
    except BladeReconError as err:
        commands.show_error(str(err))
        return None
    except Exception as err:
        FreeCAD.Console.PrintLog(traceback.format_exc())
        commands.show_error(f"T-spline fit of {path} failed: {type(err).__name__}: {err}")
        return None
    for line in said:
        FreeCAD.Console.PrintMessage(f"BladeRecon: {line}\n")
    doc = FreeCAD.ActiveDocument or FreeCAD.newDocument()
    doc.openTransaction("Fit T-spline")
    try:
        FreeCADGui.doCommand(f"# import bladerecon.fc.tspline_export; bladerecon.fc.tspline_export."
                             f"make_tspline_feature(App.ActiveDocument, {path!r}, {float(tolerance)!r})")
        obj = add_tspline_feature(doc, path, shell, summary)
        doc.recompute()
    except Exception as err:
        doc.abortTransaction()
        FreeCAD.Console.PrintLog(traceback.format_exc())
        commands.show_error(f"T-spline fit of {path} failed: {type(err).__name__}: {err}")
        return None
    doc.commitTransaction()
    if FreeCADGui.ActiveDocument is not None:
        FreeCADGui.SendMsgToActiveView("ViewFit")
    return obj


class TSplineCommand(commands._Command):
    """Choose a point file and a tolerance; add the adaptive T-spline surface."""

    icon = "BladeRecon_TSpline"
    menu_text = "Fit adaptive T-spline"
    tool_tip = ("Analysis-suitable T-spline fit with local refinement until every point is within the "
                "tolerance (seed 002); exported as sewn bicubic Bézier patches")

    def Activated(self) -> None:  # noqa: N802
        params = FreeCAD.ParamGet(commands._PARAMS)
        qt = commands._qt_widgets()
        win = FreeCADGui.getMainWindow()
        path, _ = qt.QFileDialog.getOpenFileName(win, "Points to fit with a T-spline",
                                                 params.GetString("LastPointsDir", ""), commands.POINT_FILTER)
        if not path:
            return
        params.SetString("LastPointsDir", os.path.dirname(path))
        tol, ok = qt.QInputDialog.getDouble(win, "T-spline tolerance", "Largest error at a point (mm):",
                                            params.GetFloat("TSplineTolerance", 0.05), 1e-5, 100.0, 4)
        if not ok:
            return
        params.SetFloat("TSplineTolerance", tol)
        fit_tspline_into_document(path, tol)


FreeCADGui.addCommand(COMMAND_NAME, TSplineCommand())
