# SPDX-License-Identifier: LGPL-2.1-or-later
"""Inspection of a measured blade against a nominal shape and an inspection plan (issue 19).

Glue between the FreeCAD-side deviation (:mod:`bladerecon.fc.deviation`: the nominal's
closest points, the least-squares fit) and the core inspection
(:mod:`bladerecon.core.inspection`: the plan, the zone best fit, the verdicts); used by
``deviation --plan`` and the workbench's DeviationAnalysis. mm and degrees.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from bladerecon.core.errors import BladeReconError

__all__ = ["InspectionResult", "inspect_measured"]


@dataclass(frozen=True)
class InspectionResult:
    result: object            # the DeviationResult after the plan's fit
    verdicts: dict            # inspect_blade's JSON: verdict, sections, fit, plan
    zone: np.ndarray          # zone of every point (LEADING_EDGE, TRAILING_EDGE, FLANKS)
    halfwidth: np.ndarray     # zone half-width of every point (mm, inf: no zone)
    table: dict | None        # section parameters {"rows", "names"} or {"error"}; None if not asked


def _point_zones(pointset, ss, flow=None) -> np.ndarray:
    """Zone of every point of ``pointset`` (file order) from the segmentation of its ordered
    sections. Points are matched by their coordinates (a section holds no repeated point:
    build_sections refuses them), so any file layout maps back; a dropped closing point
    takes its nearest neighbour's zone."""
    from scipy.spatial import cKDTree

    from bladerecon.core.inspection.verdicts import FLANKS, point_zones

    zones = point_zones([s.points for s in ss.sections], ss.span_axis, not ss.sections[0].reordered, flow)
    P = np.asarray(pointset.points, float)
    out = np.full(len(P), FLANKS, dtype=int)
    for k, (s, z) in enumerate(zip(ss.sections, zones)):
        mine = np.flatnonzero(np.asarray(pointset.section) == k)
        _, j = cKDTree(s.points).query(P[mine])
        out[mine] = z[j]
    return out


def inspect_measured(pointset, nominal, plan, *, tolerance: float = 0.03, robust: bool = False,
                     nominal_name: str = "nominal", say=None, flow: np.ndarray | None = None) -> InspectionResult:
    """Fit (the plan's ``fit.mode``), measure and judge ``pointset`` (a sectioned
    :class:`PointSet`) against ``nominal`` (:class:`bladerecon.fc.deviation.Nominal`). ``flow``
    (the direction the fluid travels): the LE zone and parameters at every section's upstream end."""
    from bladerecon.core.analysis.alignment import Alignment, apply_transform
    from bladerecon.core.inspection.verdicts import halfwidths, inspect_blade
    from bladerecon.core.inspection.zone_fit import zone_fit
    from bladerecon.core.sections.ordering import build_sections
    from bladerecon.fc.deviation import DeviationResult, deviation_summary, measure_deviation

    say = say or (lambda msg: None)
    if not pointset.structured:
        raise BladeReconError(f"{pointset.source}: an inspection plan judges sections: give the points with "
                              "section labels (a section column or blocks), not a cloud")
    P0 = np.asarray(pointset.points, float)
    section = np.asarray(pointset.section)
    names = list(pointset.section_names)
    ss = build_sections(pointset)
    say("zones: segmenting every section (LE, TE, flanks)")
    zone = _point_zones(pointset, ss, flow)
    hw = halfwidths(plan, section, zone, names)
    mode = plan.fit_mode
    res = measure_deviation(P0, nominal, "rigid" if mode == "zone" else mode, tolerance,
                            source=pointset.source, robust=robust)
    finite = np.isfinite(hw)
    ls_value = float(np.abs(res.deviation.signed[finite] / hw[finite]).max()) if finite.any() else None
    fit = {"mode": mode, "per_section": plan.per_section}
    if res.alignment is not None:
        fit["least_squares"] = {**res.alignment.as_dict(), "max_normalised": ls_value}
    if mode == "zone":
        say("zone best fit (minimax, linear programmes)")
        zf = zone_fit(P0, nominal.projector(), hw, start=res.alignment.matrix)
        t0 = time.perf_counter()
        P = apply_transform(P0, zf.matrix)
        dev = nominal.measure(P)
        ls = res.alignment
        al = Alignment("zone", zf.matrix, zf.rotation_deg, zf.axis, zf.translation_mm, ls.rms_before,
                       float(np.sqrt(np.mean(dev.signed ** 2))), ls.iterations + zf.iterations, zf.converged)
        res = DeviationResult(P, dev, al, deviation_summary(dev.signed, tolerance),
                              {**res.seconds, "zone_fit": zf.seconds, "measure": time.perf_counter() - t0})
        fit["zone"] = zf.as_dict()
    d = res.deviation.signed
    fit["max_normalised"] = float(np.abs(d[finite] / hw[finite]).max()) if finite.any() else None
    fit["matrix"] = (res.alignment.matrix if res.alignment is not None else np.eye(4)).tolist()
    table, rows = None, None
    if plan.limits:
        from bladerecon.fc.section_compare import compare_section_parameters

        say("section parameters, measured vs nominal")
        M = res.alignment.matrix if res.alignment is not None else np.eye(4)
        try:
            rows = compare_section_parameters([apply_transform(s.points, M) for s in ss.sections], ss.span_axis,
                                              not ss.sections[0].reordered, nominal.shape, name=nominal_name,
                                              flow=flow)
            table = {"rows": rows, "names": [s.name for s in ss.sections]}
        except BladeReconError as err:
            say(f"no section parameters: {err}")
            table = {"error": str(err)}
            rows = [{"error": str(err)}] * len(ss.sections)
    verdicts = inspect_blade(plan, res.points, d, res.deviation.normal, section, zone, names, ss.span_axis,
                             rows, fit)
    return InspectionResult(res, verdicts, zone, hw, table)
