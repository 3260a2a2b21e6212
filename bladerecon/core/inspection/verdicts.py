# SPDX-License-Identifier: LGPL-2.1-or-later
"""Tolerance verdicts per section and zone, per parameter, and for the blade (mm, degrees).

Issue 19 §2. Inputs are per measured point: its signed deviation from the nominal (mm, +
where material is outside, after the blade's best fit), the outward nominal normal at its
foot, its section and its zone (leading edge, trailing edge, flanks: the segmentation's LE
and TE regions, suction and pressure sides together). Per section and zone the verdict
compares the min and max deviation with the zone ±half-width (ISO 1101 line profile,
bilateral and symmetric): pass when −tol ≤ min and max ≤ tol.

*Form* and *position* are reported apart, as blade inspection does: with
``fit.per_section`` the section is moved in its own plane (``translate``: a shift,
``rotate``: a turn about the span axis through its centroid, ``both``) by least squares on
the linearised deviations

    d_i' = d_i + n_i · (u e1 + v e2) + θ ((P_i − c) × n_i) · a

(a the span axis, e1, e2 in the plane; first order in the motion, which is a few µm to
tenths of a mm: the second-order error is |motion|² κ / 2, under 1 µm for 0.03 mm on a
0.5 mm edge radius); the zones are then judged on d' (the form) and the fit's motion is
reported. *Position* is the section's centroid offset in its plane: the length of the
least-squares shift (u, v) that best removes the section's deviations, judged against the
plan's ``position`` radius. Section parameters (chord, max thickness, edge radii, stagger)
come as measured − nominal rows (:func:`bladerecon.core.sections.parameters.compare_with_nominal`)
and are judged against their [lower, upper] limits.

The blade passes when every judged item of every section passes: the form zones where a
per-section fit was asked, else the profile zones; the parameters; the position.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.inspection.plan import PARAMETERS, ZONES, InspectionPlan

__all__ = ["LEADING_EDGE", "TRAILING_EDGE", "FLANKS", "point_zones", "halfwidths", "zone_table",
           "section_fit", "parameter_verdicts", "inspect_blade"]

LEADING_EDGE, TRAILING_EDGE, FLANKS = 0, 1, 2


def point_zones(section_points: list[np.ndarray], span_axis: np.ndarray | None = None,
                first_point_is_measured: bool = True, flow: np.ndarray | None = None) -> list[np.ndarray]:
    """Zone of every point (LEADING_EDGE, TRAILING_EDGE, FLANKS) of each ordered closed
    section (m_k, 3), from the segmentation (:func:`segment_sections`) of the points; with
    ``flow`` the LE is every section's upstream end."""
    from bladerecon.core.sections.parameters import segment_sections
    from bladerecon.core.sections.segmentation import LE, TE

    segs = segment_sections(section_points, span_axis, first_point_is_measured, flow=flow)
    out = []
    for seg in segs:
        z = np.full(len(seg.labels), FLANKS, dtype=int)
        z[seg.labels == LE] = LEADING_EDGE
        z[seg.labels == TE] = TRAILING_EDGE
        out.append(z)
    return out


def halfwidths(plan: InspectionPlan, section: np.ndarray, zone: np.ndarray, labels) -> np.ndarray:
    """Zone half-width (mm) of every point; ``inf`` where the plan gives no zone."""
    h = np.full(len(zone), np.inf)
    for k in np.unique(section):
        tols = plan.zones_for(int(k), labels[int(k)] if labels is not None else None)
        for z, name in enumerate(ZONES):
            if name in tols:
                h[(section == k) & (zone == z)] = tols[name]
    return h


def zone_table(d: np.ndarray, zone: np.ndarray, tols: dict) -> dict:
    """{zone name: {"min", "max", "tol", "pass", "points"}} for one section (mm); zones the
    plan does not give, or without points, are left out."""
    out = {}
    for z, name in enumerate(ZONES):
        sel = zone == z
        if name not in tols or not sel.any():
            continue
        lo, hi, tol = float(d[sel].min()), float(d[sel].max()), float(tols[name])
        out[name] = {"min": lo, "max": hi, "tol": tol, "pass": bool(lo >= -tol and hi <= tol),
                     "points": int(sel.sum())}
    return out


def _plane(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    a = axis / np.linalg.norm(axis)
    e1 = np.array([1.0, 0.0, 0.0]) - a[0] * a
    if np.linalg.norm(e1) < 1e-6:
        e1 = np.array([0.0, 1.0, 0.0]) - a[1] * a
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(a, e1)


def section_fit(points: np.ndarray, normals: np.ndarray, d: np.ndarray, span_axis, mode: str) -> tuple[np.ndarray, dict]:
    """Least-squares in-plane fit of one section's deviations (module docstring).

    Returns the deviations after the fit (mm) and the motion {"shift_mm": [u, v] along e1, e2,
    "shift_length_mm", "rotation_deg"}; ``mode`` translate | rotate | both."""
    a = np.asarray(span_axis, float)
    a = a / np.linalg.norm(a)
    e1, e2 = _plane(a)
    c = points.mean(axis=0)
    cols = []
    if mode in ("translate", "both"):
        cols += [normals @ e1, normals @ e2]
    if mode in ("rotate", "both"):
        cols.append(np.cross(points - c, normals) @ a)
    if not cols:
        raise BladeReconError(f"per-section fit '{mode}': use translate, rotate or both")
    J = np.column_stack(cols)
    x, *_ = np.linalg.lstsq(J, -d, rcond=None)
    u, v = (float(x[0]), float(x[1])) if mode in ("translate", "both") else (0.0, 0.0)
    theta = float(x[-1]) if mode in ("rotate", "both") else 0.0
    return d + J @ x, {"mode": mode, "shift_mm": [u, v], "shift_length_mm": float(np.hypot(u, v)),
                       "rotation_deg": float(np.degrees(theta))}


def parameter_verdicts(plan: InspectionPlan, row: dict | None) -> dict:
    """{parameter: {"value", "nominal", "difference", "limits", "pass"}} of one measured-vs-nominal
    row (mm, degrees) for the parameters the plan limits; unmeasurable ones fail with a note."""
    out = {}
    for key in PARAMETERS:
        if key not in plan.limits:
            continue
        lo, hi = plan.limits[key]
        if row is None or "error" in row or row.get(key) is None or row["nominal"].get(key) is None:
            why = "not measured"
            if isinstance(row, dict) and "error" in row:
                why = row["error"]
            elif isinstance(row, dict) and row.get("warnings"):
                edge = {"le_radius": "leading", "te_radius": "trailing"}.get(key, "")
                said = [str(w) for w in row["warnings"] if edge in str(w)]
                why = "not measured: " + "; ".join(said) if said else why
            out[key] = {"value": None, "nominal": None, "difference": None, "limits": [lo, hi], "pass": False,
                        "note": why}
            continue
        value, nominal = float(row[key]), float(row["nominal"][key])
        diff = value - nominal
        out[key] = {"value": value, "nominal": nominal, "difference": diff, "limits": [lo, hi],
                    "pass": bool(lo <= diff <= hi)}
    return out


def inspect_blade(plan: InspectionPlan, points: np.ndarray, deviation: np.ndarray, normals: np.ndarray,
                  section: np.ndarray, zone: np.ndarray, labels, span_axis,
                  parameter_rows: list | None = None, fit: dict | None = None) -> dict:
    """The verdicts as JSON-ready data: ``{"verdict", "sections": [...], "fit"}``.

    ``points`` (m, 3) mm after the blade's fit, ``deviation`` (m,) mm signed, ``normals``
    (m, 3) outward at the feet, ``section`` (m,) index, ``zone`` (m,) LEADING_EDGE |
    TRAILING_EDGE | FLANKS, ``labels`` the section names, ``span_axis`` (3,);
    ``parameter_rows`` one measured-vs-nominal row per section (or None: no parameter
    verdicts); ``fit`` the blade fit's description, copied into the result.
    """
    P, d, n = np.asarray(points, float), np.asarray(deviation, float), np.asarray(normals, float)
    section, zone = np.asarray(section), np.asarray(zone)
    if not (len(P) == len(d) == len(n) == len(section) == len(zone)):
        raise BladeReconError("inspection: points, deviations, normals, sections and zones differ in number")
    sections = []
    for k in sorted(int(s) for s in np.unique(section)):
        sel = section == k
        label = str(labels[k]) if labels is not None and k < len(labels) else str(k)
        tols = plan.zones_for(k, label)
        entry = {"index": k, "label": label, "points": int(sel.sum()),
                 "profile": zone_table(d[sel], zone[sel], tols), "form": None}
        if plan.per_section != "none":
            d_form, motion = section_fit(P[sel], n[sel], d[sel], span_axis, plan.per_section)
            entry["form"] = {**zone_table(d_form, zone[sel], tols), "motion": motion}
        params = {}
        if parameter_rows is not None and plan.limits:
            params = parameter_verdicts(plan, parameter_rows[k] if k < len(parameter_rows) else None)
        if plan.position is not None:
            _, shift = section_fit(P[sel], n[sel], d[sel], span_axis, "translate")
            off = shift["shift_length_mm"]
            params["position"] = {"value": off, "nominal": 0.0, "difference": off,
                                  "limits": [0.0, plan.position], "pass": bool(off <= plan.position),
                                  "shift_mm": shift["shift_mm"]}
        entry["parameters"] = params
        zones = entry["form"] if entry["form"] is not None else entry["profile"]
        checks = [v["pass"] for key, v in zones.items() if key != "motion"] + [v["pass"] for v in params.values()]
        entry["verdict"] = "pass" if all(checks) else "fail"
        sections.append(entry)
    verdict = "pass" if all(s["verdict"] == "pass" for s in sections) else "fail"
    return {"verdict": verdict, "sections": sections, "fit": dict(fit or {}), "plan": plan.as_dict()}
