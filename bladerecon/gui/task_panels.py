# SPDX-License-Identifier: LGPL-2.1-or-later
"""Task panels for the options of the long or tunable commands (forms in resources/ui/*.ui).

``accept()`` runs the same replayable step as the console would (``bladerecon.gui.commands``);
the panels only gather options. Long steps show FreeCAD's progress bar, where Esc cancels.
"""
from __future__ import annotations

from typing import Any

import FreeCADGui

from bladerecon.gui import actions, paths

__all__ = ["ReconstructPanel", "ComparePanel", "SurfaceAnalysisPanel"]


def _load(name: str) -> Any:
    return FreeCADGui.PySideUic.loadUi(paths.ui_file(name))


class _Panel:
    """Base of the panels: ``form`` is the loaded .ui file named by ``FORM``.

    FreeCAD's task dialog takes an attribute named ``ui`` for the path of a .ui file (before it
    looks at ``form``), so no panel may have one.
    """

    FORM = ""

    def __init__(self) -> None:
        self.form = _load(self.FORM)
        self.result = None

    def reject(self) -> bool:
        FreeCADGui.Control.closeDialog()
        return True

    def accept(self) -> bool:
        options = self.options()          # read the form before closing: closing deletes it
        FreeCADGui.Control.closeDialog()
        self.result = self.run(**options)
        return True

    def options(self) -> dict:
        return {}

    def run(self, **options: Any) -> Any:
        raise NotImplementedError


class ReconstructPanel(_Panel):
    """Method and tolerance (and, for a whole-blade cloud, the choices of its cut: blade kind,
    span axis, span range, sections, rotor axis), then :func:`actions.reconstruct_surface`."""

    FORM = "Reconstruct"

    def __init__(self, points_obj: Any) -> None:
        from bladerecon.fc.objects import is_cloud

        super().__init__()
        self.points = points_obj
        self.cloud = is_cloud(points_obj)
        what = (f"a whole-blade cloud, coordinates times {points_obj.CloudScale:g}" if self.cloud
                else f"{points_obj.SectionCount} sections")
        self.form.source.setText(f"Points: {points_obj.Label} ({points_obj.PointCount} points, {what}, "
                                 f"{points_obj.Units})")
        self.form.rotorAxis.setCurrentText("z")
        self.form.cloud.setVisible(self.cloud)

    def options(self) -> dict:
        options = {"method": self.form.method.currentText(), "tolerance": self.form.tolerance.value()}
        if self.cloud:
            f = self.form
            options.update(blade_kind=f.bladeKind.currentText(), span_axis=f.spanAxis.currentText(),
                           span_range=f.spanRange.text().strip(), sections=f.sections.value(),
                           rotor_axis=f.rotorAxis.currentText())
        return options

    def run(self, **options: Any) -> Any:
        return actions.reconstruct_surface(self.points, **options)


class ComparePanel(_Panel):
    """Alignment, tolerance and whether to colour the surface, then :func:`actions.compare_with_nominal`."""

    FORM = "Compare"

    def __init__(self, measured: Any, nominal: Any, surface: Any = None) -> None:
        super().__init__()
        self.measured, self.nominal, self.surface = measured, nominal, surface
        self.form.inputs.setText(f"Measured: {measured.Label}\nNominal: {nominal.Label}\n"
                                 f"Surface: {surface.Label if surface is not None else '(none)'}")
        self.form.useSurface.setEnabled(surface is not None)
        self.form.useSurface.setChecked(surface is not None)
        self.form.alignment.currentTextChanged.connect(self._robust_only_with_a_fit)
        self._robust_only_with_a_fit(self.form.alignment.currentText())

    def _robust_only_with_a_fit(self, mode: str) -> None:
        self.form.robust.setEnabled(mode != "none")

    def options(self) -> dict:
        return {"surface": self.surface if self.form.useSurface.isChecked() else None,
                "alignment": self.form.alignment.currentText(), "tolerance": self.form.tolerance.value(),
                "robust": self.form.robust.isEnabled() and self.form.robust.isChecked()}

    def run(self, **options: Any) -> Any:
        return actions.compare_with_nominal(self.measured, self.nominal, **options)


class SurfaceAnalysisPanel(_Panel):
    """Zebra (stripe count, direction), curvature (mean/Gaussian) or off; previewed as it changes.

    The preview is undone before OK runs the step, so that the step (one undo transaction)
    records the change from what the surface showed before the panel.
    """

    FORM = "SurfaceAnalysis"
    PROPS = ("ZebraStripes", "ZebraDirection", "CurvatureKind", "DisplayMode")

    def __init__(self, surface: Any, mode: str = "Zebra") -> None:
        super().__init__()
        self.surface = surface
        vobj = surface.ViewObject
        self.before = {p: getattr(vobj, p) for p in self.PROPS}
        self.form.mode.setCurrentText(mode)
        self.form.stripes.setValue(vobj.ZebraStripes)
        self.form.direction.setCurrentText(vobj.ZebraDirection)
        self.form.curvature.setCurrentText(vobj.CurvatureKind)
        for box in (self.form.mode, self.form.direction, self.form.curvature):
            box.currentIndexChanged.connect(self.preview)
        self.form.stripes.valueChanged.connect(self.preview)
        self.preview()

    def options(self) -> dict:
        mode = self.form.mode.currentText()
        return {"mode": None if mode == "Off" else mode, "stripes": self.form.stripes.value(),
                "direction": self.form.direction.currentText(), "curvature": self.form.curvature.currentText()}

    def preview(self, *_: Any) -> None:
        from bladerecon.gui.view_providers import PLAIN_MODE

        o = self.options()
        vobj = self.surface.ViewObject
        vobj.ZebraStripes, vobj.ZebraDirection, vobj.CurvatureKind = o["stripes"], o["direction"], o["curvature"]
        previous = self.before["DisplayMode"]
        # "Off" previews what the surface showed before (a deviation map stays), else the plain display
        vobj.DisplayMode = o["mode"] or (previous if previous not in ("Zebra", "Curvature") else PLAIN_MODE)

    def _undo_preview(self) -> None:
        vobj = self.surface.ViewObject
        for prop, value in self.before.items():
            if getattr(vobj, prop) != value:
                setattr(vobj, prop, value)

    def reject(self) -> bool:
        self._undo_preview()
        return super().reject()

    def accept(self) -> bool:
        options = self.options()
        FreeCADGui.Control.closeDialog()
        self._undo_preview()
        self.result = self.run(**options)
        return True

    def run(self, **options: Any) -> Any:
        actions.set_surface_analysis(self.surface, **options)
