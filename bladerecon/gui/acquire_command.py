# SPDX-License-Identifier: LGPL-2.1-or-later
"""Workbench command: acquire points live from an instrument, then build MeasuredPoints.

The reader (:class:`bladerecon.acquire.reader.InstrumentReader`, journal first) runs in a
thread; a Qt timer in the GUI thread shows the points arriving as one vertex compound
(``LiveAcquisition``) and the counters in the status bar. At the ``$E`` record the points are
written to the chosen CSV and imported through :func:`bladerecon.gui.commands.import_points`
(a replayable, undoable step that builds a ``MeasuredPoints`` object); the live preview is
removed. Importing this module registers ``BladeRecon_Acquire``.
"""
from __future__ import annotations

import os
import threading
import traceback
from typing import Any

import FreeCAD
import FreeCADGui

from bladerecon.core.errors import BladeReconError

from bladerecon.gui import commands

__all__ = ["LiveAcquisition", "AcquireCommand", "update_preview", "COMMAND_NAME"]

PREVIEW_NAME = "LiveAcquisition"
REFRESH_MS = 500


def update_preview(doc: Any, points) -> Any:
    """Show ``points`` ((n, 3), mm) as one vertex compound ``LiveAcquisition`` in ``doc``."""
    import Part

    from bladerecon.fc.convert import compound

    obj = doc.getObject(PREVIEW_NAME)
    if obj is None:
        obj = doc.addObject("Part::Feature", PREVIEW_NAME)
        obj.Label = "Live acquisition"
        if FreeCAD.GuiUp:
            obj.ViewObject.PointSize = commands.SECTION_POINT_SIZE
    obj.Shape = compound([Part.Vertex(float(x), float(y), float(z)) for x, y, z in points])
    return obj


class LiveAcquisition:
    """One capture: ``start()`` returns at once; ``finished`` is set when it is over.

    ``result``: the MeasuredPoints object after the import, ``error``: the message shown.
    """

    def __init__(self, port: str, output: str, baud: int = 115200, calibration: str | None = None,
                 journal: str | None = None) -> None:
        from bladerecon.acquire.reader import default_journal
        from bladerecon.acquire.reader import InstrumentReader
        from bladerecon.core.io.instrument import Calibration, load_calibration

        cal = load_calibration(calibration) if calibration else Calibration()
        self.output = output
        self.journal = journal or default_journal(output)
        self.reader = InstrumentReader(port, baud, cal, self.journal)
        self.finished = threading.Event()
        self.error: str | None = None
        self.result = None
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._timer = None

    def start(self) -> None:
        from PySide import QtCore

        self.doc = FreeCAD.ActiveDocument or FreeCAD.newDocument()
        self._thread.start()
        self._timer = QtCore.QTimer()
        self._timer.timeout.connect(self._refresh)
        self._timer.start(REFRESH_MS)

    def _run(self) -> None:
        try:
            self.reader.run()
        except BladeReconError as err:
            self.error = str(err)
        except Exception as err:  # a reader bug: one line here, the traceback in the log
            FreeCAD.Console.PrintLog(traceback.format_exc())
            self.error = f"acquisition failed: {type(err).__name__}: {err}"

    def _refresh(self) -> None:
        acq = self.reader.acq
        c = acq.summary()
        FreeCADGui.getMainWindow().statusBar().showMessage(
            f"BladeRecon: {c['points']} points, {c['sections']} sections, {c['bad_checksum']} bad checksums, "
            f"{c['malformed']} malformed, {c['missing_seq']} missing, {c['reconnects']} reconnects")
        points, _ = acq.points()
        if len(points):
            update_preview(self.doc, points)
            self.doc.recompute()
        if not self._thread.is_alive():
            self._timer.stop()
            self._finish()

    def _finish(self) -> None:
        from bladerecon.core.io.readers import write_points_csv

        if self.doc.getObject(PREVIEW_NAME) is not None:
            self.doc.removeObject(PREVIEW_NAME)
        acq = self.reader.acq
        points, section = acq.points()
        if self.error is None and not len(points):
            self.error = f"no valid point arrived; journal {self.journal} kept"
        if self.error is not None:
            commands.show_error(self.error)
        else:
            write_points_csv(self.output, points, section, acq.section_names)
            self.result = commands.import_points(self.output)
            FreeCAD.Console.PrintMessage(f"BladeRecon: acquired {acq.summary()}\n")
        self.finished.set()


class AcquireCommand(commands._Command):
    """Ask for a port and an output CSV, then capture live."""

    icon = "BladeRecon_Acquire"
    menu_text = "Acquire from instrument"
    tool_tip = ("Read points live from a measuring instrument over a serial line (BladeRecon protocol), "
                "then build the measured points")

    def Activated(self) -> None:  # noqa: N802
        qt = commands._qt_widgets()
        params = FreeCAD.ParamGet(commands._PARAMS)
        mw = FreeCADGui.getMainWindow()
        port, ok = qt.QInputDialog.getText(mw, "Acquire from instrument", "Port (device or pyserial URL):",
                                           text=params.GetString("LastPort", "/dev/ttyUSB0"))
        if not ok or not port:
            return
        output, _ = qt.QFileDialog.getSaveFileName(mw, "Write acquired points", params.GetString("LastPointsDir", ""),
                                                   "CSV (*.csv)")
        if not output:
            return
        params.SetString("LastPort", port)
        try:
            self.capture = LiveAcquisition(port, output)
            self.capture.start()
        except BladeReconError as err:
            commands.show_error(str(err))


COMMAND_NAME = "BladeRecon_Acquire"
FreeCADGui.addCommand(COMMAND_NAME, AcquireCommand())
