# SPDX-License-Identifier: LGPL-2.1-or-later
"""Workbench command "Repair target" (issue 18): a RepairAnalysis of the measured points of a
damaged blade against the nominal, as one undo step replayable from the console.

Select the MeasuredPoints and the nominal shape (or choose the nominal's file when asked).
The repair runs in the recompute, in the foreground (about 10-30 s for 40 000-100 000
points). Importing registers ``BladeRecon_Repair``.
"""
from __future__ import annotations

from typing import Any

import FreeCADGui

from bladerecon.gui import actions, commands, repair_view  # noqa: F401  (repair_view: registers the view)

__all__ = ["RepairCommand", "repair_into_document", "COMMAND_NAME"]

COMMAND_NAME = "BladeRecon_Repair"


def repair_into_document(measured: Any, nominal: Any, tolerance: float = 0.03) -> Any:
    """Add a RepairAnalysis of ``measured`` against ``nominal`` (one undo step); the nominal
    is hidden so the target shows."""
    doc = measured.Document

    def show(analysis: Any) -> list[str]:
        if nominal.ViewObject is not None and nominal.ViewObject.Visibility:
            return [f"{actions._ref(nominal)}.ViewObject.Visibility = False"]
        return []

    return actions._run(doc, "Repair target",
                        ["import bladerecon.fc.repair as br_repair",
                         f"_br_repair = br_repair.make_repair_analysis(App.getDocument({doc.Name!r}), "
                         f"{actions._ref(measured)}, {actions._ref(nominal)}, tolerance={float(tolerance)!r})"],
                        "_br_repair", then=show)


class RepairCommand(commands._Command):
    """Repair target of the selected measured points against the selected (or chosen) nominal."""

    icon = "BladeRecon_Repair"
    menu_text = "Repair target"
    tool_tip = ("Repair target of a damaged blade: the nominal adapted to the blade's service twist and bend, "
                "the damaged regions and the missing material; select the measured points and the nominal")
    needs_document = True

    def active(self) -> bool:
        return actions.find_object("MeasuredPoints") is not None

    def Activated(self) -> None:  # noqa: N802
        points = actions.find_object("MeasuredPoints")
        candidates = actions._nominal_candidates()
        nominal = candidates[0] if candidates else commands.Compare.ask_nominal()
        if nominal is None:
            return
        repair_into_document(points, nominal)


FreeCADGui.addCommand(COMMAND_NAME, RepairCommand())
