# SPDX-License-Identifier: LGPL-2.1-or-later
"""Workbench commands. Importing this module registers them with FreeCADGui.

Each command's work is a replayable step of :mod:`bladerecon.gui.actions` (an undo
transaction through ``FreeCADGui.doCommand``), or a task panel of
:mod:`bladerecon.gui.task_panels` that ends in one. A command that cannot run on the current
selection is disabled (``IsActive``).
"""
from __future__ import annotations

import os
from typing import Any

import FreeCAD
import FreeCADGui

from bladerecon.fc import objects
from bladerecon.gui import paths, task_panels, view_providers  # noqa: F401  (view_providers: registers them)
from bladerecon.gui.actions import (  # noqa: F401  (the tspline and acquire commands use them too)
    _PARAMS,
    POINT_FILTER,
    SECTION_POINT_SIZE,
    _qt_widgets,
    show_error,
    selected,
    find_object,
    _nominal_candidates,
    _has_surface,
    import_points,
    import_nominal,
    analyse_sections,
    map_state,
    show_deviation_map,
    set_surface_analysis,
    export_step,
    write_report,
)

__all__ = ["COMMANDS"]


class _Command:
    """Base of BladeRecon commands: resources from class attributes, ``IsActive`` from ``active()``."""

    icon = "BladeRecon"
    menu_text = ""
    tool_tip = ""
    needs_document = False

    def GetResources(self) -> dict[str, str]:  # noqa: N802  (FreeCAD's API name)
        return {"Pixmap": paths.icon(self.icon), "MenuText": self.menu_text, "ToolTip": self.tool_tip}

    def IsActive(self) -> bool:  # noqa: N802
        if self.needs_document and FreeCAD.ActiveDocument is None:
            return False
        try:
            return bool(self.active())
        except Exception:   # a half-loaded document must not break the toolbar
            return False

    def active(self) -> bool:
        return True


class _OnObject(_Command):
    """A command on the selected object of ``target`` type (or the only one in the document)."""

    target = ""
    needs_document = True

    def active(self) -> bool:
        return find_object(self.target) is not None


class ImportPoints(_Command):
    icon = "BladeRecon_ImportPoints"
    menu_text = "Import measured points"
    tool_tip = ("Read a file of measured blade-section points (mm): CSV x,y,z,section, 'x y z' blocks or a section "
                "table; a file with no sections is a whole-blade cloud (its units asked, its sections cut automatically)")

    def Activated(self) -> None:  # noqa: N802
        params = FreeCAD.ParamGet(_PARAMS)
        qt = _qt_widgets()
        path, _ = qt.QFileDialog.getOpenFileName(
            FreeCADGui.getMainWindow(), "Import measured blade points", params.GetString("LastPointsDir", ""), POINT_FILTER
        )
        if not path:
            return
        params.SetString("LastPointsDir", os.path.dirname(path))
        import_points(path)


class AnalyseSections(_OnObject):
    icon = "BladeRecon_Sections"
    menu_text = "Analyse sections"
    tool_tip = "Order the selected measured points into closed sections and mark each leading and trailing edge"
    target = "MeasuredPoints"

    def Activated(self) -> None:  # noqa: N802
        analyse_sections(find_object(self.target))


class Reconstruct(_OnObject):
    icon = "BladeRecon_Reconstruct"
    menu_text = "Reconstruct surface"
    tool_tip = "Fit one native B-spline surface through the selected measured points (options in a task panel)"
    target = "MeasuredPoints"

    def Activated(self) -> None:  # noqa: N802

        FreeCADGui.Control.showDialog(task_panels.ReconstructPanel(find_object(self.target)))


class Compare(_Command):
    icon = "BladeRecon_Compare"
    menu_text = "Compare with nominal"
    tool_tip = ("Signed deviation of the measured points and surface from the nominal: select the nominal "
                "shape in the tree, or choose its file (STEP, IGES, BREP) when asked")
    needs_document = True

    def active(self) -> bool:
        return find_object("MeasuredPoints") is not None

    def Activated(self) -> None:  # noqa: N802
        points = find_object("MeasuredPoints")
        candidates = _nominal_candidates()
        nominal = candidates[0] if candidates else self.ask_nominal()
        if nominal is None:
            return
        FreeCADGui.Control.showDialog(task_panels.ComparePanel(points, nominal, _surface_of(points)))

    @staticmethod
    def ask_nominal() -> Any:
        """No nominal selected: choose its file; it is imported under its file name."""
        params = FreeCAD.ParamGet(_PARAMS)
        qt = _qt_widgets()
        path, _ = qt.QFileDialog.getOpenFileName(
            FreeCADGui.getMainWindow(), "Nominal blade to compare with", params.GetString("LastNominalDir", ""),
            "CAD (*.step *.stp *.iges *.igs *.brep *.brp);;All files (*)")
        if not path:
            return None
        params.SetString("LastNominalDir", os.path.dirname(path))
        return import_nominal(path)


def _surface_of(points_obj: Any) -> Any:
    """The BladeSurface built on ``points_obj`` (selected first), or None."""
    sel = selected("BladeSurface")
    if sel:
        return sel[0]
    doc = points_obj.Document
    found = [o for o in doc.Objects if objects.is_type(o, "BladeSurface") and o.Points == points_obj]
    return found[-1] if found else None


class DeviationMap(_OnObject):
    icon = "BladeRecon_DeviationMap"
    menu_text = "Deviation colour map"
    tool_tip = ("Show or hide the deviation colour map (legend in µm, tolerance band marked) where it was: "
                "on the surface, or on the points")
    target = "DeviationAnalysis"

    def Activated(self) -> None:  # noqa: N802
        analysis = find_object(self.target)
        if map_state(analysis) is not None:
            show_deviation_map(analysis, None)
            return
        where = analysis.ViewObject.DisplayMode
        if where == "Surface" and analysis.Surface is None:
            where = "Points"
        show_deviation_map(analysis, where)


class DeviationOnPoints(_OnObject):
    icon = "BladeRecon_DeviationPoints"
    menu_text = "Deviation colour map on points"
    tool_tip = ("Colour the measured points by signed deviation from the nominal (legend in µm); "
                "again to put the map back on the surface")
    target = "DeviationAnalysis"

    def Activated(self) -> None:  # noqa: N802
        analysis = find_object(self.target)
        if map_state(analysis) == "Points":
            show_deviation_map(analysis, "Surface" if analysis.Surface is not None else None)
        else:
            show_deviation_map(analysis, "Points")


class _SurfaceCommand(_OnObject):
    target = "BladeSurface"

    def active(self) -> bool:
        return _has_surface(find_object(self.target))


class _SurfaceAnalysis(_SurfaceCommand):
    """Switch a surface display mode (``mode``) on through its task panel, or off again."""

    mode = ""

    def Activated(self) -> None:  # noqa: N802
        surface = find_object(self.target)
        if surface.ViewObject.DisplayMode == self.mode:
            set_surface_analysis(surface, None)
            return

        FreeCADGui.Control.showDialog(task_panels.SurfaceAnalysisPanel(surface, self.mode))


class Zebra(_SurfaceAnalysis):
    icon = "BladeRecon_Zebra"
    menu_text = "Zebra stripes"
    tool_tip = "Reflection stripes on the selected surface to judge smoothness (stripe count, direction); again to switch off"
    mode = "Zebra"


class Curvature(_SurfaceAnalysis):
    icon = "BladeRecon_Curvature"
    menu_text = "Curvature map"
    tool_tip = "Colour the selected surface by Gaussian or mean curvature, with a legend; again to switch off"
    mode = "Curvature"


class ExportStep(_SurfaceCommand):
    icon = "BladeRecon_ExportStep"
    menu_text = "Export STEP"
    tool_tip = "Write the selected blade surface to a STEP file (mm)"

    def Activated(self) -> None:  # noqa: N802
        qt = _qt_widgets()
        params = FreeCAD.ParamGet(_PARAMS)
        path, _ = qt.QFileDialog.getSaveFileName(FreeCADGui.getMainWindow(), "Export blade surface",
                                                 params.GetString("LastStepDir", ""), "STEP (*.step *.stp)")
        if path:
            params.SetString("LastStepDir", os.path.dirname(path))
            export_step(find_object(self.target), path)


class WriteReport(_OnObject):
    icon = "BladeRecon_Report"
    menu_text = "Write report"
    tool_tip = "Write the deviation report (HTML with plots, deviations.csv, summary.json) into a folder"
    target = "DeviationAnalysis"

    def Activated(self) -> None:  # noqa: N802
        qt = _qt_widgets()
        folder = qt.QFileDialog.getExistingDirectory(FreeCADGui.getMainWindow(), "Folder for the report")
        if folder:
            write_report(find_object(self.target), os.path.join(folder, "bladerecon_report"))


COMMANDS: dict[str, _Command] = {
    "BladeRecon_ImportPoints": ImportPoints(),
    "BladeRecon_AnalyseSections": AnalyseSections(),
    "BladeRecon_Reconstruct": Reconstruct(),
    "BladeRecon_Compare": Compare(),
    "BladeRecon_DeviationMap": DeviationMap(),
    "BladeRecon_DeviationOnPoints": DeviationOnPoints(),
    "BladeRecon_Zebra": Zebra(),
    "BladeRecon_Curvature": Curvature(),
    "BladeRecon_ExportStep": ExportStep(),
    "BladeRecon_WriteReport": WriteReport(),
}

for _name, _command in COMMANDS.items():
    FreeCADGui.addCommand(_name, _command)
