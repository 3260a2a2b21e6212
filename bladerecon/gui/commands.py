"""Workbench commands. Importing this module registers them with FreeCADGui.

Each command goes through ``FreeCADGui.doCommand`` inside an undo transaction, so what it
did is replayable from the Python console. Errors a user can cause are shown in a
message box and the report view, never as a traceback.
"""
from __future__ import annotations

import os
import traceback
from typing import Any

import FreeCAD
import FreeCADGui

from bladerecon.core.errors import BladeReconError

from . import paths

__all__ = ["COMMANDS", "ImportPoints", "import_points", "make_point_sections", "show_error"]

_PARAMS = "User parameter:BaseApp/Preferences/Mod/BladeRecon"
POINT_FILTER = "Measured points (*.csv *.txt *.xyz *.dat *.asc *.pts);;All files (*)"
SECTION_POINT_SIZE = 4.0
SECTION_POINT_COLOR = (0.85, 0.33, 0.10)


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


def make_point_sections(doc: Any, path: str) -> Any:
    """Read measured points and add one Part compound of vertices per section, in a group.

    Points are kept in double precision (millimetres), which a Points feature would not do.
    Returns the group (``App::DocumentObjectGroup``) holding one ``Part::Feature`` per section.
    """
    import Part

    from bladerecon.core.readers import read_points

    point_set = read_points(path)
    points = point_set.points
    section = point_set.section
    names = list(point_set.section_names)
    group = doc.addObject("App::DocumentObjectGroup", "MeasuredPoints")
    group.Label = f"Measured points ({os.path.basename(path)})"
    for index in dict.fromkeys(int(i) for i in section):  # sections in order of appearance
        rows = points[section == index]
        obj = doc.addObject("Part::Feature", "Section")
        obj.Label = str(names[index]) if index < len(names) else f"section {index}"
        obj.Shape = Part.makeCompound([Part.Vertex(float(x), float(y), float(z)) for x, y, z in rows])
        group.addObject(obj)
        if FreeCAD.GuiUp:
            obj.ViewObject.PointSize = SECTION_POINT_SIZE
            obj.ViewObject.PointColor = SECTION_POINT_COLOR
    doc.recompute()
    return group


class _Command:
    """Base of BladeRecon commands: resources from class attributes, ``IsActive`` variants."""

    icon = "BladeRecon"
    menu_text = ""
    tool_tip = ""
    needs_document = False

    def GetResources(self) -> dict[str, str]:  # noqa: N802  (FreeCAD's API name)
        return {"Pixmap": paths.icon(self.icon), "MenuText": self.menu_text, "ToolTip": self.tool_tip}

    def IsActive(self) -> bool:  # noqa: N802
        return FreeCAD.ActiveDocument is not None if self.needs_document else True


class ImportPoints(_Command):
    """Choose a file of measured blade-section points and add it to the active document."""

    icon = "BladeRecon_ImportPoints"
    menu_text = "Import measured points"
    tool_tip = "Read a file of measured blade-section points (mm) into one vertex compound per section"

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


def import_points(path: str) -> Any:
    """Import ``path`` into the active document (a new one if none) as a replayable, undoable step."""
    from bladerecon.core.readers import read_points

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
    doc.openTransaction("Import measured points")
    try:
        FreeCADGui.doCommand("import bladerecon.gui.commands")
        FreeCADGui.doCommand(f"bladerecon.gui.commands.make_point_sections(App.ActiveDocument, {path!r})")
    except Exception as err:
        doc.abortTransaction()
        show_error(f"cannot import {path}: {err}")
        return None
    doc.commitTransaction()
    if FreeCADGui.ActiveDocument is not None:
        FreeCADGui.SendMsgToActiveView("ViewFit")
    return doc


COMMANDS = {"BladeRecon_ImportPoints": ImportPoints()}

for _name, _command in COMMANDS.items():
    FreeCADGui.addCommand(_name, _command)
