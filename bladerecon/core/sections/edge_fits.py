# SPDX-License-Identifier: LGPL-2.1-or-later
"""Rebuild a segmented section with curvature-continuous joints (seed 000 §2.2, eq. 6 or equivalent).

Seed 000 fits the suction and pressure sides with cubic B-splines and the LE/TE regions with
eq. 6, a polynomial with exponential terms whose 12 unknowns are fixed by point, 1st, 2nd
and 3rd derivative continuity at the joints plus least squares on the region's points. We
use a construction with the same continuity and fit, in B-spline form so that every piece
hands over to OCC unchanged:

* **flanks** (suction, pressure): clamped cubic B-spline, least squares on the measured
  points of the side (NURBS Book §9.4.1, knots by eq. 9.69), the two ends fixed on the
  joint points of the section curve; sparse sides (≤ 40 points) are interpolated.
* **edge regions** (LE, TE): clamped quintic B-spline (septic for C3) whose first and last
  ``k+1`` derivatives (k = 2 for C2, 3 for C3) equal the flanks' at the joints after the
  linear reparameterisation ``s = λ u`` (λ = edge length / flank length, so both pieces
  run at about unit speed): ``C_e^(j)(0) = λ^j C_f^(j)(1)``. Parametric C^k after a
  linear change of parameter is geometric G^k: position, tangent and curvature (and its
  slope for C3) are continuous. The remaining poles minimise the squared distances to the
  region's measured points (equality-constrained least squares, KKT system) plus a tiny
  bending-energy term so that sparse edges stay well posed.

:func:`joint_continuity` measures the jumps (position mm, tangent angle degrees, curvature
1/mm and relative to the local curvature) at the four joints; :func:`fit_segmented`
returns the pieces and those figures; :func:`sample_segmented` gives points along the
rebuilt section for the surface (``reconstruct --segmented``). All in the section plane
(mm); :func:`rebuilt_section_points` maps back to 3D, restoring the measured out-of-plane
offset of non-planar sections.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.bspline import approximation_knots, basis_derivatives, curve_derivatives, evaluate_curve, find_spans
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.fitting import interpolate_curve, knots_from_full, least_squares_curve
from bladerecon.core.sections.segmentation import LE, NONPLANAR_LIMIT, PRESSURE, SUCTION, TE, Segmentation
from bladerecon.core.geometry.spline import BSplineCurve, full_knot_vector

__all__ = ["SegmentedSection", "fit_segmented", "joint_continuity", "sample_segmented",
           "rebuilt_section_points", "unconstrained_segments", "rebuild_sections"]


@dataclass(frozen=True)
class SegmentedSection:
    """Four clamped B-spline pieces in +t loop order starting with the LE region (2D, mm)."""

    index: int
    pieces: tuple[BSplineCurve, ...]
    regions: tuple[int, ...]          # region of each piece (LE, side, TE, side)
    continuity: int                   # 2 (C2) or 3 (C3) at the joints
    joints: list                      # joint_continuity() figures
    residual_max: float               # max distance of the measured points to their piece (mm)
    residual_rms: float


def _region_points(seg: Segmentation, region: int) -> np.ndarray:
    """Measured points of a region in +t order (2D)."""
    a, b = seg.region_interval(region)
    rel = np.mod(seg.t_points - a, seg.period)
    m = rel <= (b - a)
    order = np.argsort(rel[m])
    return seg.points2d[m][order]


def _chord_params(q: np.ndarray) -> np.ndarray:
    d = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    return d / d[-1]


def _fit_flank(q: np.ndarray) -> BSplineCurve:
    """Clamped cubic through the two joint points and near the side's points (NURBS Book §9.4.1)."""
    u = _chord_params(q)
    n = len(q)
    if n <= 40:          # a sparse plan: every point is a measurement to keep
        return interpolate_curve(q, 3, params=u)
    n_poles = int(np.clip(n // 6, 8, 40))
    knots, mults = knots_from_full(approximation_knots(u, 3, n_poles))
    return least_squares_curve(q, u, knots, mults, 3, False, fix_ends=True)


def _flank_from_section_curve(seg: Segmentation, region: int) -> BSplineCurve:
    """The section curve between the side's two joints as a clamped cubic on [0, 1].

    The periodic cubic restricted to [t_a, t_b] is a cubic spline with the section curve's
    knots inside the interval; a clamped cubic on those knots (mapped to [0, 1]) represents
    it exactly, so least squares on a few samples per span recovers it to round-off.
    """
    a, b = seg.region_interval(region)
    c = seg.curve
    lo, hi = c.domain
    per = hi - lo
    kn = np.asarray(c.knots, float)
    allk = np.concatenate([kn[:-1] - per, kn[:-1], kn[:-1] + per, kn[:-1] + 2 * per])
    inner = allk[(allk > a + 1e-12 * per) & (allk < b - 1e-12 * per)]
    x = (inner - a) / (b - a)
    knots = np.concatenate([[0.0], x, [1.0]])
    mults = np.concatenate([[4], np.ones(x.size, int), [4]])
    edges = np.concatenate([[0.0], x, [1.0]])
    f = (np.arange(6) + 0.5) / 6
    uu = np.concatenate([[0.0], (edges[:-1, None] + np.diff(edges)[:, None] * f[None]).ravel(), [1.0]])
    tt = lo + np.mod(a + uu * (b - a) - lo, per)
    q = evaluate_curve(c, tt)
    return least_squares_curve(q, uu, knots, mults, 3, False, fix_ends=True)


def _length(c: BSplineCurve) -> float:
    p = evaluate_curve(c, np.linspace(*c.domain, 400))
    return float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())


def _basis_rows(knots, mults, degree, n_poles, u, order) -> np.ndarray:
    """Dense rows of the order-th derivative of the basis at parameters u (clamped)."""
    U = full_knot_vector(np.asarray(knots, float), np.asarray(mults, int), degree, False)
    u = np.asarray(u, float)
    span = find_spans(U, degree, n_poles, u)
    ders = basis_derivatives(U, degree, span, u, order)[:, order, :]
    rows = np.zeros((u.size, n_poles))
    for j in range(degree + 1):
        rows[np.arange(u.size), span - degree + j] = ders[:, j]
    return rows


def _fit_edge(q: np.ndarray, u: np.ndarray, d_start: np.ndarray, d_end: np.ndarray, k: int,
              guide: np.ndarray, u_guide: np.ndarray, guide_weight: float = 1.0) -> BSplineCurve:
    """Clamped B-spline on [0, 1] with C(0)..C^(k)(0) = d_start, C(1)..C^(k)(1) = d_end, LS on q.

    Degree 2k+1; ``k+1`` poles at each end are fixed by the constraints, the free poles
    (one per ~3 points, at least 2) shape the region by least squares (KKT system).
    ``guide``: samples of the section curve over the region with a small weight, so that a
    sparsely measured edge (fewer points than free poles) follows the interpolant between
    its points instead of bulging; dense edges are shaped by their points.
    """
    p = 2 * k + 1
    # sparse edge: one free pole per point (the guide keeps them quiet); dense: one per ~3 points
    n_free = int(np.clip(len(q) + 2 if len(q) <= 16 else len(q) // 3, 2, 24))
    n_poles = 2 * (k + 1) + n_free
    n_inner = n_poles - p - 1
    inner = np.linspace(0, 1, n_inner + 2)[1:-1]
    knots = np.concatenate([[0.0], inner, [1.0]])
    mults = np.concatenate([[p + 1], np.ones(n_inner, int), [p + 1]])
    A = _basis_rows(knots, mults, p, n_poles, u, 0)
    G = _basis_rows(knots, mults, p, n_poles, u_guide, 0)
    w = guide_weight * len(q) / len(guide)
    C = np.vstack([_basis_rows(knots, mults, p, n_poles, np.array([0.0]), j) for j in range(k + 1)]
                  + [_basis_rows(knots, mults, p, n_poles, np.array([1.0]), j) for j in range(k + 1)])
    D = np.vstack([d_start, d_end])
    H = A.T @ A + w * G.T @ G
    KKT = np.block([[2 * H, C.T], [C, np.zeros((C.shape[0], C.shape[0]))]])
    rhs = np.vstack([2 * (A.T @ q + w * G.T @ guide), D])
    sol = np.linalg.lstsq(KKT, rhs, rcond=None)[0]
    return BSplineCurve(sol[:n_poles], knots, mults, p, False)


def _edge_data(seg: Segmentation, region: int):
    """Measured points of an edge region, their arc-length parameters along the section curve
    (joints at 0 and 1), the region's length and guide samples of the curve."""
    a, b = seg.region_interval(region)
    lo, hi = seg.curve.domain
    per = hi - lo
    tt = np.linspace(a, b, 2001)
    cs = evaluate_curve(seg.curve, lo + np.mod(tt - lo, per))
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(cs, axis=0), axis=1))])
    L = float(arc[-1])
    rel = np.mod(seg.t_points - a, per)
    m = (rel > 0) & (rel < b - a)
    order = np.argsort(rel[m])
    q = seg.points2d[m][order]
    u = np.interp(a + rel[m][order], tt, arc) / L
    return q, u, L, cs[::40], arc[::40] / L


def _end_derivatives(c: BSplineCurve, at_end: bool, k: int, scale: float) -> np.ndarray:
    """C^(j) at one end for j = 0..k, multiplied by scale^j (linear reparameterisation)."""
    lo, hi = c.domain
    d = curve_derivatives(c, np.array([hi if at_end else lo]), k)[0]
    return d * (scale ** np.arange(k + 1))[:, None]


def _curvature(d1: np.ndarray, d2: np.ndarray) -> float:
    return float((d1[0] * d2[1] - d1[1] * d2[0]) / max(np.linalg.norm(d1) ** 3, 1e-300))


def joint_continuity(pieces: tuple[BSplineCurve, ...], regions: tuple[int, ...]) -> list[dict]:
    """Jumps at the joints between consecutive pieces (closed loop): mm, degrees, 1/mm."""
    out = []
    for i in range(len(pieces)):
        a, b = pieces[i], pieces[(i + 1) % len(pieces)]
        da = curve_derivatives(a, np.array([a.domain[1]]), 2)[0]
        db = curve_derivatives(b, np.array([b.domain[0]]), 2)[0]
        ka, kb = _curvature(da[1], da[2]), _curvature(db[1], db[2])
        cosang = np.clip(da[1] @ db[1] / (np.linalg.norm(da[1]) * np.linalg.norm(db[1])), -1, 1)
        local = max(abs(ka), abs(kb), 1e-12)
        out.append({"between": f"{_NAMES[regions[i]]}|{_NAMES[regions[(i + 1) % len(pieces)]]}",
                    "position": float(np.linalg.norm(da[0] - db[0])),
                    "tangent_deg": float(np.degrees(np.arccos(cosang))),
                    "curvature": float(abs(ka - kb)), "curvature_rel": float(abs(ka - kb) / local),
                    "local_curvature": float(0.5 * (abs(ka) + abs(kb)))})
    return out


#: weight of the bending energy of an edge piece relative to its data term
_SMOOTH = 1e-5

_NAMES = {LE: "le", SUCTION: "suction", TE: "te", PRESSURE: "pressure"}


def _loop_regions(seg: Segmentation) -> tuple[int, int, int, int]:
    return (LE, SUCTION, TE, PRESSURE) if seg.suction_forward else (LE, PRESSURE, TE, SUCTION)


def _joint_point(seg: Segmentation, name: str) -> np.ndarray:
    return evaluate_curve(seg.curve, np.array([seg.t_joints[name]]))[0]


def _region_with_joints(seg: Segmentation, region: int) -> np.ndarray:
    """Measured points of a region with the joint points of the section curve at both ends."""
    a, b = seg.region_interval(region)
    ends = evaluate_curve(seg.curve, np.array([a, b]))
    q = _region_points(seg, region)
    tol = 1e-9
    keep = (np.linalg.norm(q - ends[0], axis=1) > tol) & (np.linalg.norm(q - ends[1], axis=1) > tol)
    return np.vstack([ends[:1], q[keep], ends[1:]])


def fit_segmented(seg: Segmentation, continuity: int = 2) -> SegmentedSection:
    """Flanks by cubic B-spline, LE/TE regions C2 (or C3) with them (see module docstring)."""
    if continuity not in (2, 3):
        raise BladeReconError(f"continuity must be 2 (C2) or 3 (C3), got {continuity}")
    regions = _loop_regions(seg)
    side1, side2 = regions[1], regions[3]
    f1 = _flank_from_section_curve(seg, side1)
    f2 = _flank_from_section_curve(seg, side2)
    pieces = {}
    pieces[side1], pieces[side2] = f1, f2
    k = continuity
    for edge, before, after in ((LE, f2, f1), (TE, f1, f2)):
        q, u, L_e, guide, u_guide = _edge_data(seg, edge)
        if len(q) < 1:
            raise BladeReconError(f"section {seg.index}: the {_NAMES[edge].upper()} region has no measured points "
                                  "between its joints: measure the edge")
        d_start = _end_derivatives(before, True, k, L_e / _length(before))
        d_end = _end_derivatives(after, False, k, L_e / _length(after))
        pieces[edge] = _fit_edge(q, u, d_start, d_end, k, guide, u_guide)
    ordered = tuple(pieces[r] for r in regions)
    joints = joint_continuity(ordered, regions)
    res = _residuals(seg, ordered, regions)
    return SegmentedSection(seg.index, ordered, regions, continuity, joints, float(res.max()),
                            float(np.sqrt(np.mean(res ** 2))))


def unconstrained_segments(seg: Segmentation) -> SegmentedSection:
    """The same four pieces, each fitted on its own (cubic LS, ends on the joints): the reference
    for what the continuity constraints buy (position joins, tangent and curvature jump)."""
    regions = _loop_regions(seg)
    ordered = tuple(_fit_flank(_region_with_joints(seg, r)) for r in regions)
    res = _residuals(seg, ordered, regions)
    return SegmentedSection(seg.index, ordered, regions, 0, joint_continuity(ordered, regions),
                            float(res.max()), float(np.sqrt(np.mean(res ** 2))))


def _residuals(seg: Segmentation, pieces, regions) -> np.ndarray:
    """Distance of every measured point to the piece of its region (Newton foot point)."""
    from bladerecon.core.geometry.projection import project_points_to_curve
    out = []
    for c, r in zip(pieces, regions):
        q = _region_points(seg, r)
        if len(q):
            out.append(project_points_to_curve(c, q).distance)
    return np.concatenate(out)


def sample_segmented(ss: SegmentedSection, n: int = 800, edge_weight: float = 4.0) -> np.ndarray:
    """Points (n, 2) along the rebuilt section, LE region first; the edge regions get
    ``edge_weight`` times the density of the flanks per mm (they carry the curvature)."""
    lengths = np.array([_length(c) for c in ss.pieces])
    w = np.array([edge_weight if r in (LE, TE) else 1.0 for r in ss.regions])
    share = lengths * w / (lengths * w).sum()
    counts = np.maximum(np.round(share * n).astype(int), 4)
    pts = []
    for c, m in zip(ss.pieces, counts):
        lo, hi = c.domain
        pts.append(evaluate_curve(c, lo + (hi - lo) * np.arange(m) / m))   # end = next piece's start
    return np.vstack(pts)


def rebuilt_section_points(seg: Segmentation, ss: SegmentedSection, measured: np.ndarray, n: int = 800
                           ) -> np.ndarray:
    """3D points (n, 3) along the rebuilt section, starting at the LE region's first joint.

    The section plane keeps in-plane shape; the measured points' offset from the plane (a
    stream-surface section) is restored by interpolating it along the loop.
    """
    q = sample_segmented(ss, n)
    fr = seg.frame
    w_meas = (np.asarray(measured, float) - fr.origin) @ fr.normal
    if fr.flatness <= NONPLANAR_LIMIT:      # planar: the offsets are measurement noise
        return fr.to_space(q)
    # offset along the loop: a periodic cubic w(t) through the measured points' (t, w),
    # evaluated at the samples' feet on the section curve (smooth, so the surface stays fair)
    from scipy.interpolate import CubicSpline
    from bladerecon.core.geometry.projection import project_points_to_curve
    lo, hi = seg.curve.domain
    order = np.argsort(seg.t_points)
    t_m, w_m = seg.t_points[order], w_meas[order]
    keep = np.concatenate([[True], np.diff(t_m) > 1e-12])
    t_m, w_m = t_m[keep], w_m[keep]
    spline = CubicSpline(np.concatenate([t_m, [t_m[0] + (hi - lo)]]), np.concatenate([w_m, [w_m[0]]]),
                         bc_type="periodic")
    t_s = project_points_to_curve(seg.curve, q).t
    t_s = t_m[0] + np.mod(t_s - t_m[0], hi - lo)
    return fr.to_space(q) + spline(t_s)[:, None] * fr.normal


def rebuild_sections(section_points: list[np.ndarray], span_axis: np.ndarray, first_point_is_measured: bool = True,
                     continuity: int = 2, n: int = 800) -> tuple[list[np.ndarray], list[dict]]:
    """Segment and rebuild every section; 3D points along each rebuilt section (LE point first)
    for :func:`bladerecon.core.reconstruct.reconstruct`, and per-section figures (mm, degrees)."""
    from bladerecon.core.sections.parameters import segment_sections

    segs = segment_sections(section_points, span_axis, first_point_is_measured)
    out, info = [], []
    for seg, measured in zip(segs, section_points):
        ss = fit_segmented(seg, continuity)
        pts = rebuilt_section_points(seg, ss, measured, n)
        start = int(np.argmin(np.linalg.norm(pts - seg.lift(seg.le)[0], axis=1)))
        out.append(np.roll(pts, -start, axis=0))
        info.append({"index": seg.index, "continuity": continuity,
                     "joint_position_max": max(j["position"] for j in ss.joints),
                     "joint_tangent_deg_max": max(j["tangent_deg"] for j in ss.joints),
                     "joint_curvature_rel_max": max(j["curvature_rel"] for j in ss.joints),
                     "residual_max": ss.residual_max, "residual_rms": ss.residual_rms})
    return out, info
