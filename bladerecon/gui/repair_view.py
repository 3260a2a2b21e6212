# SPDX-License-Identifier: LGPL-2.1-or-later
"""View of a RepairAnalysis: its shapes (the target and the tip's missing material, Part's own
display modes) and, in every mode, the measured points coloured by their missing depth (the
deviation colours over ±2x the tolerance: blue where material is missing). Importing
registers it for the objects :func:`bladerecon.fc.repair.make_repair_analysis` makes."""
from __future__ import annotations

from typing import Any

import numpy as np

from bladerecon.fc import objects
from bladerecon.gui import colormap
from bladerecon.gui.view_providers import ColouredPoints, _ViewProvider

__all__ = ["ViewProviderRepairAnalysis"]


class ViewProviderRepairAnalysis(_ViewProvider):
    ICON = "BladeRecon_Compare"

    def attach(self, vobj: Any) -> None:
        self.Object = vobj.Object
        self.points = ColouredPoints(3.0)
        vobj.RootNode.addChild(self.points.node)     # beside the shape, whatever the display mode
        self._update(vobj.Object)

    def updateData(self, obj: Any, prop: str) -> None:  # noqa: N802
        if prop in ("PointDepth", "Measured") and hasattr(self, "points"):
            self._update(obj)

    def onChanged(self, vobj: Any, prop: str) -> None:  # noqa: N802
        if prop == "Visibility" and hasattr(self, "points"):
            self._update(vobj.Object)

    def colours(self) -> int:
        """How many points are drawn (for tests)."""
        return int(self.points.points.numPoints.getValue())

    def _update(self, obj: Any) -> None:
        measured = getattr(obj, "Measured", None)
        depth = np.asarray(getattr(obj, "PointDepth", []), float)
        if measured is None or len(depth) != len(measured.Points) or not len(depth):
            self.points.set(np.zeros((0, 3)), np.zeros((0, 3)))
            return
        pts = np.array([(v.x, v.y, v.z) for v in measured.Points])
        limit = 2.0 * max(float(obj.Tolerance), 1e-6)
        self.points.set(pts, colormap.deviation_colours(-depth, limit))


    def claimChildren(self) -> list:  # noqa: N802
        from bladerecon.fc.repair import repair_pieces
        return repair_pieces(self.Object) if getattr(self, "Object", None) is not None else []


class ViewProviderRepairPiece(_ViewProvider):
    """A RepairPiece: Part's own display of its shape (hidden when made, as the analysis shows
    both shapes with the coloured points; shown on its own from the tree)."""

    ICON = "BladeRecon_Compare"

    def attach(self, vobj: Any) -> None:
        self.Object = vobj.Object


objects.register_view_provider("RepairAnalysis", ViewProviderRepairAnalysis)
objects.register_view_provider("RepairPiece", ViewProviderRepairPiece)
