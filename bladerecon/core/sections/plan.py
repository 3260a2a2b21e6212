# SPDX-License-Identifier: LGPL-2.1-or-later
"""Measurement plan from a dense nominal section: "less measured points" (seed 000 §2.1).

For every dense nominal section (a closed loop of points, e.g. a STEP nominal cut by a plane
and discretised at 0.1 mm, the paper's measurement step):

1. start with 8 points equally spaced in arc length (from the LE curvature peak) plus the 2
   curvature extrema of the section (LE and TE region, :mod:`segmentation`);
2. interpolate them with a periodic cubic B-spline (centripetal, seed 000 eqs. 7, 9);
3. measure the Hausdorff distance between that curve and the dense section: nominal →
   curve (each nominal point projected on the curve, Newton from its arc-length position)
   and curve → nominal (dense curve samples to the nominal polyline's segments);
4. add the nominal point where the distance is largest; repeat 2-4 until the Hausdorff
   distance is within the compression tolerance (0.05 mm default, as in the paper).

Compression rate = 1 − kept / dense points. Units mm.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from bladerecon.core.geometry.bspline import closed_parameters, evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.fitting import interpolate_closed_curve
from bladerecon.core.surface.section_curves import refine_curve_parameters
from bladerecon.core.sections.segmentation import segment_section

__all__ = ["SectionPlan", "SurfacePlan", "plan_section", "plan_sections", "plan_for_surface", "hausdorff_to_polyline", "cut_surface", "DEFAULT_TOLERANCE"]

DEFAULT_TOLERANCE = 0.05
N_EQUAL = 8


@dataclass(frozen=True)
class SectionPlan:
    index: int
    indices: np.ndarray        # kept points: indices into the dense section, in loop order
    points: np.ndarray         # (k, 3) mm
    dense_points: int
    hausdorff: float           # achieved max distance between the plan's cubic and the section (mm)
    iterations: int
    extrema: tuple[int, int]   # dense indices of the LE and TE curvature maxima
    initial: int = 10          # points in the starting set (8 equal + 2 extrema, fewer if they coincide)

    @property
    def compression(self) -> float:
        return 1.0 - len(self.indices) / self.dense_points


def _segment_distance(points: np.ndarray, poly: np.ndarray, tree: cKDTree) -> np.ndarray:
    """Distance of points to a closed polyline: the two segments at the nearest vertex."""
    n = len(poly)
    _, i = tree.query(points)
    best = np.full(len(points), np.inf)
    for j0, j1 in ((i - 1) % n, i), (i, (i + 1) % n):
        a, b = poly[j0], poly[j1]
        ab = b - a
        s = np.clip(((points - a) * ab).sum(axis=1) / np.maximum((ab * ab).sum(axis=1), 1e-300), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - (a + s[:, None] * ab), axis=1))
    return best


def hausdorff_to_polyline(curve, poly: np.ndarray, t_poly: np.ndarray, samples_per_point: int = 4
                          ) -> tuple[float, int, float, np.ndarray]:
    """Two-sided Hausdorff distance between a closed curve and a closed dense polyline.

    ``t_poly``: start parameters of the polyline points on the curve. Returns
    (hausdorff, index of the farthest polyline point, curve→polyline max, refined t).
    """
    t = refine_curve_parameters(curve, poly, t_poly, iterations=4)
    d_nom = np.linalg.norm(evaluate_curve(curve, t) - poly, axis=1)
    lo, hi = curve.domain
    ts = lo + (hi - lo) * np.arange(samples_per_point * len(poly)) / (samples_per_point * len(poly))
    cs = evaluate_curve(curve, ts)
    tree = cKDTree(poly)
    d_cur = _segment_distance(cs, poly, tree)
    k = int(np.argmax(d_nom))
    far_curve = float(d_cur.max())
    worst = k
    if far_curve > d_nom[k]:
        worst = int(tree.query(cs[int(np.argmax(d_cur))])[1])
    return max(float(d_nom[k]), far_curve), worst, far_curve, t


def plan_section(dense: np.ndarray, index: int = 0, tolerance: float = DEFAULT_TOLERANCE,
                 span_axis: np.ndarray | None = None, max_points: int | None = None,
                 flow: np.ndarray | None = None) -> SectionPlan:
    """The seed 000 §2.1 plan of one dense closed section (n, 3) mm; see the module docstring.
    ``flow``: the direction the fluid travels; the plan starts at the upstream edge (issue 24)."""
    P = np.asarray(dense, float)
    n = len(P)
    if n < 20:
        raise BladeReconError(f"section {index}: the nominal section has {n} points; a plan needs a dense "
                              "section (hundreds of points): use a smaller step")
    if not tolerance > 0:
        raise BladeReconError(f"--tolerance {tolerance}: give a positive distance in mm")
    seg = segment_section(P, index, span_axis, method="interpolate", flow=flow)
    # dense indices of the two curvature extrema: the nominal points nearest the peaks
    peaks = evaluate_curve(seg.curve, np.array([seg.t_le_peak, seg.t_te_peak]))
    q = seg.frame.to_plane(P)
    i_le = int(np.argmin(np.linalg.norm(q - peaks[0], axis=1)))
    i_te = int(np.argmin(np.linalg.norm(q - peaks[1], axis=1)))
    seglen = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seglen)])      # arc[i] at point i, arc[n] = perimeter
    per = arc[-1]
    start = arc[i_le]
    # half a spacing off the LE peak, so that the 8 + 2 starting points are 10 distinct points
    targets = np.mod(start + per * (np.arange(N_EQUAL) + 0.5) / N_EQUAL, per)
    equal = np.searchsorted(arc[:-1], targets)
    equal = np.clip(equal, 0, n - 1)
    keep = np.unique(np.concatenate([equal, [i_le, i_te]]))
    initial = len(keep)
    max_points = max_points or n
    # arc-length position of every dense point, to start its projection on the plan curve
    it = 0
    while True:
        it += 1
        pts = P[keep]
        u = closed_parameters(pts, "centripetal")
        curve = interpolate_closed_curve(pts, 3, params=u)
        # start parameters: linear in arc length between consecutive kept points
        a_keep = arc[keep]
        a_ext = np.concatenate([a_keep, [a_keep[0] + per]])
        u_ext = np.concatenate([u, [1.0]])
        a_all = arc[:-1].copy()
        a_all[a_all < a_keep[0]] += per
        t0 = np.mod(np.interp(a_all, a_ext, u_ext), 1.0)
        h, worst, _, _ = hausdorff_to_polyline(curve, P, t0)
        if h <= tolerance or len(keep) >= max_points:
            break
        if worst in keep:     # the far spot is at a kept point: take its neighbour with the larger gap
            worst = (worst + 1) % n
            if worst in keep:
                break
        keep = np.sort(np.append(keep, worst))
    return SectionPlan(index, keep, P[keep], n, float(h), it, (i_le, i_te), initial)


def plan_sections(sections: list[np.ndarray], tolerance: float = DEFAULT_TOLERANCE,
                  span_axis: np.ndarray | None = None, flow: np.ndarray | None = None) -> list[SectionPlan]:
    """Plans of several dense sections (one per section, hub to tip)."""
    return [plan_section(p, k, tolerance, span_axis, flow=flow) for k, p in enumerate(sections)]


@dataclass(frozen=True)
class SurfacePlan:
    """A plan whose reconstructed surface was checked: the section plans, the section
    tolerance they were made at (mm), the surface error reached (mm) and the rounds."""

    plans: list
    section_tolerance: float
    surface_error: float
    rounds: int
    within: bool


def plan_for_surface(sections: list[np.ndarray], tolerance: float, surface_error,
                     span_axis: np.ndarray | None = None, max_rounds: int = 8,
                     flow: np.ndarray | None = None) -> SurfacePlan:
    """Plans whose *surface* is within ``tolerance`` of the nominal (mm), not only each
    section's cubic.

    Seed 000 §2.1 bounds the cubic through each section's plan; the surface interpolated
    spanwise through those cubics can stray further between the sections (the section
    errors of neighbouring heights do not cancel). ``surface_error(plans) -> float`` measures
    the surface built from the plans against the nominal (max, mm, between the sections
    too); while it exceeds the tolerance every section is planned again at a tighter section
    tolerance (scaled by tolerance / error, at least 10 % tighter a round). ``within`` is
    False if ``max_rounds`` did not get there (the last plan and its error are returned).
    """
    section_tol = float(tolerance)
    for rounds in range(1, max_rounds + 1):
        plans = plan_sections(sections, section_tol, span_axis, flow)
        error = float(surface_error(plans))
        if error <= tolerance:
            return SurfacePlan(plans, section_tol, error, rounds, True)
        section_tol *= min(0.9, tolerance / error)
    return SurfacePlan(plans, section_tol / min(0.9, tolerance / error), error, max_rounds, False)


def cut_surface(surface, origin: np.ndarray, normal: np.ndarray, step: float = 0.1,
                n_u: int = 3000, n_v: int = 40) -> np.ndarray:
    """Points (m, 3) of the closed section of a u-periodic blade surface by the plane
    ``normal·(x − origin) = 0``, one every ``step`` mm of arc length (mm).

    Each u iso-line (spanwise) must cross the plane once: the sign change of the plane
    distance along v is found on a grid, then Newton on ``f(v) = n·S(u, v) − d`` gives the
    crossing to round-off; the loop of crossings is resampled at equal arc length (linear in
    u between 3000 exact crossings, refined again by Newton). Raises :class:`BladeReconError`
    when the plane misses the surface.
    """
    from bladerecon.core.geometry.bspline import evaluate_surface, surface_derivatives

    n = np.asarray(normal, float) / np.linalg.norm(normal)
    d = float(n @ np.asarray(origin, float))
    u_lo, u_hi = float(surface.u_knots[0]), float(surface.u_knots[-1])
    v_lo, v_hi = float(surface.v_knots[0]), float(surface.v_knots[-1])

    def crossings(u):
        vg = np.linspace(v_lo, v_hi, n_v)
        uu, vv = np.meshgrid(u, vg, indexing="ij")
        f = (evaluate_surface(surface, uu.ravel(), vv.ravel()) @ n - d).reshape(u.size, n_v)
        s = np.sign(f)
        change = s[:, :-1] * s[:, 1:] <= 0
        if not change.any(axis=1).all():
            raise BladeReconError(f"the plane through {np.round(origin, 3).tolist()} mm (normal "
                                  f"{np.round(n, 4).tolist()}) does not cross the nominal all round: choose a "
                                  "height inside the blade")
        j = np.argmax(change, axis=1)
        f0, f1 = f[np.arange(u.size), j], f[np.arange(u.size), j + 1]
        v = vg[j] + (vg[j + 1] - vg[j]) * f0 / np.where(f0 != f1, f0 - f1, 1.0)
        for _ in range(30):
            der = surface_derivatives(surface, u, v, 1)
            g = der[:, 0, 0] @ n - d
            gv = der[:, 0, 1] @ n
            step_v = -g / np.where(np.abs(gv) > 1e-300, gv, 1e-300)
            v = np.clip(v + step_v, v_lo, v_hi)
            if np.abs(step_v).max() < 1e-14 * (v_hi - v_lo):
                break
        return v

    u = u_lo + (u_hi - u_lo) * np.arange(n_u) / n_u
    pts = evaluate_surface(surface, u, crossings(u))
    seg = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    m = max(int(round(arc[-1] / step)), 20)
    ut = np.interp(arc[-1] * np.arange(m) / m, arc, np.concatenate([u, [u_hi]]))
    return evaluate_surface(surface, ut, crossings(ut))
