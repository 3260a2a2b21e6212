# SPDX-License-Identifier: LGPL-2.1-or-later
"""Blade surface from section curves: LE/TE-anchored common parameterisation and skinning.

Stage "curves → surface" of the pipeline (seed 000 §2.3-2.4):

1. On every section curve find the leading and trailing edge (:func:`find_le_te`).
2. Give every section the same parameter ``s`` ∈ [0, 1): ``s = 0`` at the LE, ``s = s_te`` at
   the TE (the same for every section), normalised arc length in between on each side. This
   is the "common parameterisation anchored at the leading and trailing edge": the LE of one
   section meets the LE of the next and the surface cannot twist.
3. Fit all sections in ``s`` with **one** periodic cubic knot vector (compatible curves,
   NURBS Book §10.3), knots inserted until every section is reproduced within ``refit_tol``.
4. Interpolate the section poles spanwise: clamped cubic, centripetal parameters averaged
   over the sections' points (seed 000 eqs. 8-10). The surface passes through every section
   curve; u is periodic (around the section), v is the span.

Units: mm.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.bspline import averaged_knots, collocation_matrix, curve_derivatives, evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.fitting import knots_from_full, solve_sparse
from bladerecon.core.surface.section_curves import SectionCurve
from bladerecon.core.sections.ordering import section_plane_frame
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

__all__ = [
    "AnchoredSection",
    "find_le_te",
    "anchor_section",
    "common_parameter",
    "fit_compatible_sections",
    "span_parameters",
    "skin_surface",
    "interpolate_grid",
    "closed_grid_parameters",
]

_TABLE = 4000  # samples per section for the arc-length table


@dataclass(frozen=True)
class AnchoredSection:
    """A section curve with its LE/TE and the map from its own t to the common s."""

    index: int
    curve: BSplineCurve
    t_le: float
    t_te: float
    le: np.ndarray
    te: np.ndarray
    t_table: np.ndarray   # increasing t from t_le over one period
    arc_table: np.ndarray  # arc length from the LE at t_table (mm)
    arc_te: float          # arc length LE → TE along +t (mm)
    perimeter: float       # mm


def find_le_te(curve: BSplineCurve, span_axis: np.ndarray, samples: int = _TABLE) -> tuple[float, float]:
    """Leading/trailing edge parameters: the two points of the section extreme along its chord.

    The chord direction d is iterated from the principal direction of the section: LE =
    argmin C·d, TE = argmax C·d with d = (TE − LE)/|TE − LE|, then each refined to where the
    tangent is perpendicular to the chord (C'·d = 0). For a round edge this is the point of
    the edge circle farthest along the chord — well defined even though the curvature of a
    circular edge has no single peak. Which end is the LE is decided by the caller
    (:func:`anchor_section`); here t_le is the end at −e1.
    """
    lo, hi = curve.domain
    t = lo + (hi - lo) * np.arange(samples) / samples
    pts = evaluate_curve(curve, t)
    origin, e1, e2 = section_plane_frame(pts, span_axis)
    basis = np.stack([e1, e2])
    xy = (pts - origin) @ basis.T
    d = np.array([1.0, 0.0])
    for _ in range(6):
        i_le, i_te = int(np.argmin(xy @ d)), int(np.argmax(xy @ d))
        nd = xy[i_te] - xy[i_le]
        nd /= np.linalg.norm(nd)
        if np.allclose(nd, d, atol=1e-12):
            break
        d = nd
    d3 = d @ basis
    ts = [t[i_le], t[i_te]]
    for _ in range(4):  # chord from the refined ends until it stops moving: a fixed point
        ts = [_tangent_perpendicular(curve, tt, d3, samples) for tt in ts]
        ends = evaluate_curve(curve, np.array(ts))
        nd3 = ends[1] - ends[0]
        nd3 -= (nd3 @ span_axis) * span_axis / (span_axis @ span_axis)
        nd3 /= np.linalg.norm(nd3)
        moved = np.linalg.norm(nd3 - d3)
        d3 = nd3
        if moved < 1e-13:
            break
    return ts[0], ts[1]


def _tangent_perpendicular(curve: BSplineCurve, t0: float, d3: np.ndarray, samples: int) -> float:
    """Newton on f(t) = C'(t)·d from t0: where the tangent is perpendicular to the chord."""
    lo, hi = curve.domain
    tt = np.array([t0])
    for _ in range(20):
        der = curve_derivatives(curve, tt, 2)
        f, fp = der[0, 1] @ d3, der[0, 2] @ d3
        if abs(fp) < 1e-300:
            break
        step = float(np.clip(-f / fp, -(hi - lo) / samples, (hi - lo) / samples))
        tt = tt + step
        if abs(step) < 1e-14:
            break
    return float(lo + np.mod(tt[0] - lo, hi - lo))


def _arc_table(curve: BSplineCurve, t_start: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Arc length from t_start over one period, by 3-point Gauss-Legendre on n intervals."""
    lo, hi = curve.domain
    per = hi - lo
    tb = t_start + per * np.arange(n + 1) / n
    gx, gw = np.polynomial.legendre.leggauss(3)
    h = per / n
    tq = (tb[:-1, None] + 0.5 * h * (gx[None, :] + 1.0)).ravel()
    speed = np.linalg.norm(curve_derivatives(curve, tq, 1)[:, 1], axis=1).reshape(n, 3)
    seg = 0.5 * h * (speed * gw[None, :]).sum(axis=1)
    return tb, np.concatenate([[0.0], np.cumsum(seg)])


def anchor_section(sc: SectionCurve, span_axis: np.ndarray, le_hint: np.ndarray | None = None) -> AnchoredSection:
    """Find LE/TE on a section curve and tabulate its arc length from the LE.

    ``le_hint``: a point near the previous section's LE; the edge closer to it becomes this
    section's LE (keeps LE and TE from swapping between sections). Without a hint the LE is
    the end with the larger edge radius — blunter edges are leading edges on compressor and
    turbine blades alike — measured as the width of the section near each end.
    """
    curve = sc.curve
    t_a, t_b = find_le_te(curve, span_axis)
    pa, pb = evaluate_curve(curve, np.array([t_a, t_b]))
    if le_hint is not None:
        swap = np.linalg.norm(pb - le_hint) < np.linalg.norm(pa - le_hint)
    else:
        swap = _edge_width(curve, t_b, pb, pa) > _edge_width(curve, t_a, pa, pb)
    if swap:
        t_a, t_b, pa, pb = t_b, t_a, pb, pa
    lo, hi = curve.domain
    t_table, arc = _arc_table(curve, t_a, _TABLE)
    t_te_unwrapped = t_a + np.mod(t_b - t_a, hi - lo)
    arc_te = float(np.interp(t_te_unwrapped, t_table, arc))
    return AnchoredSection(sc.index, curve, t_a, t_b, pa, pb, t_table, arc, arc_te, float(arc[-1]))


def _edge_width(curve: BSplineCurve, t_edge: float, p_edge: np.ndarray, p_other: np.ndarray) -> float:
    """Width of the section at a depth of 1 % of the chord behind an edge.

    For a round edge of radius r the width at depth δ < r is ``2·sqrt(2rδ − δ²)``: it grows
    with the edge radius, while deeper in (several % of the chord) the width follows the
    thickness distribution instead. Used to tell the blunter (leading) edge.
    """
    chord = p_other - p_edge
    L = np.linalg.norm(chord)
    d = chord / L
    lo, hi = curve.domain
    t = lo + (hi - lo) * np.arange(_TABLE) / _TABLE
    pts = evaluate_curve(curve, t)
    depth = (pts - p_edge) @ d
    perp = (pts - p_edge) - np.outer(depth, d)
    size = np.linalg.norm(perp, axis=1)
    side = perp @ (perp[np.argmax(size)] / max(size.max(), 1e-300))
    target = 0.01 * L
    widths = []
    for sign in (1.0, -1.0):  # one crossing of the depth line on each side of the edge
        m = (np.sign(side) == sign) & (depth < 0.5 * L)
        if not m.any():
            return 0.0
        j = np.flatnonzero(m)[np.argmin(np.abs(depth[m] - target))]
        widths.append(abs(side[j]))
    return float(sum(widths))


def common_parameter(anchored: list[AnchoredSection]) -> float:
    """The common s of the trailing edge: the mean fraction of the perimeter on the LE→TE side."""
    return float(np.mean([a.arc_te / a.perimeter for a in anchored]))


def s_to_t(a: AnchoredSection, s: np.ndarray, s_te: float) -> np.ndarray:
    """Section parameter t for common parameters s (arc length normalised on each side)."""
    s = np.mod(np.asarray(s, float), 1.0)
    arc = np.where(s <= s_te, s / s_te * a.arc_te,
                   a.arc_te + (s - s_te) / (1.0 - s_te) * (a.perimeter - a.arc_te))
    t = np.interp(arc, a.arc_table, a.t_table)
    lo, hi = a.curve.domain
    return lo + np.mod(t - lo, hi - lo)


def t_to_s(a: AnchoredSection, t: np.ndarray, s_te: float) -> np.ndarray:
    """Common parameter s of section parameters t (inverse of :func:`s_to_t`)."""
    lo, hi = a.curve.domain
    tt = a.t_le + np.mod(np.asarray(t, float) - a.t_le, hi - lo)
    arc = np.interp(tt, a.t_table, a.arc_table)
    return np.where(arc <= a.arc_te, arc / a.arc_te * s_te,
                    s_te + (arc - a.arc_te) / (a.perimeter - a.arc_te) * (1.0 - s_te))


def _initial_common_knots(anchored: list[AnchoredSection], s_te: float, n_spans: int) -> np.ndarray:
    """Knots equidistributing curvature-weighted arc length, averaged over the sections.

    Weight ``1 + sqrt(κ·L)`` (L = perimeter) puts roughly 5-10x more knots on a round edge
    than on the flanks, which is where a cubic needs them.
    """
    s = (np.arange(2000) + 0.5) / 2000
    dens = np.zeros_like(s)
    for a in anchored:
        t = s_to_t(a, s, s_te)
        d = curve_derivatives(a.curve, t, 2)
        sp1 = np.linalg.norm(d[:, 1], axis=1)
        kappa = np.linalg.norm(np.cross(d[:, 1], d[:, 2]), axis=1) / np.maximum(sp1**3, 1e-300)
        dens += 1.0 + np.sqrt(kappa * a.perimeter)
    cum = np.concatenate([[0.0], np.cumsum(dens)])
    cum /= cum[-1]
    sb = np.concatenate([[0.0], s + 0.5 / 2000])
    knots = np.interp(np.linspace(0, 1, n_spans + 1), cum, sb)
    knots[0], knots[-1] = 0.0, 1.0
    return knots


def _span_samples(knots: np.ndarray, per_span: int) -> np.ndarray:
    h = np.diff(knots)
    f = (np.arange(per_span) + 0.5) / per_span
    return (knots[:-1, None] + h[:, None] * f[None, :]).ravel()


def fit_compatible_sections(anchored: list[AnchoredSection], s_te: float, refit_tol: float,
                            n_start: int = 40, max_poles: int = 1500,
                            per_span: int = 6) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """All sections on one periodic cubic knot vector in s (compatible curves, NURBS Book §10.3).

    Every section curve is sampled at the same s-values (``per_span`` per knot span) and
    fitted by least squares with the common knots — one sparse factorisation serves all
    sections (the collocation matrix is the same). A knot is inserted in every span where
    some section deviates by more than ``refit_tol`` (mm) until none does. Returns
    ``(knots, mults, poles (n_sections, n_poles, 3), max_refit_error)``.
    """
    knots = _initial_common_knots(anchored, s_te, n_start)
    S = len(anchored)
    err = np.inf
    while True:
        n = knots.size - 1
        mults = np.ones(knots.size, dtype=int)
        s = _span_samples(knots, per_span)
        # check points in between the fitted samples too
        s_chk = _span_samples(knots, per_span + 1)
        Q = np.stack([evaluate_curve(a.curve, s_to_t(a, s, s_te)) for a in anchored])        # (S, m, 3)
        Qc = np.stack([evaluate_curve(a.curve, s_to_t(a, s_chk, s_te)) for a in anchored])
        A = collocation_matrix(knots, mults, 3, True, n, s)
        M = (A.T @ A).tocsc()
        rhs = (A.T @ Q.transpose(1, 0, 2).reshape(s.size, 3 * S))
        P = solve_sparse(M, rhs).reshape(n, S, 3).transpose(1, 0, 2)           # (S, n, 3)
        Ac = collocation_matrix(knots, mults, 3, True, n, s_chk)
        fit = np.stack([Ac @ P[k] for k in range(S)])                          # (S, m_chk, 3)
        dev = np.linalg.norm(fit - Qc, axis=2).max(axis=0)                     # (m_chk,)
        err = float(dev.max())
        span_err = dev.reshape(n, per_span + 1).max(axis=1)
        bad = span_err > refit_tol
        if not bad.any():
            break
        if n >= max_poles:
            break
        mids = 0.5 * (knots[:-1] + knots[1:])[bad]
        mids = mids[: max_poles - n]
        knots = np.sort(np.concatenate([knots, mids]))
    return knots, mults, P, err


def span_parameters(section_points: np.ndarray, kind: str = "centripetal") -> np.ndarray:
    """Spanwise parameters of the sections, averaged over corresponding points (seed 000 §2.4).

    ``section_points``: (S, m, 3) corresponding points (same s on every section).
    """
    d = np.linalg.norm(np.diff(section_points, axis=0), axis=2)   # (S-1, m)
    if kind == "centripetal":
        d = np.sqrt(d)
    elif kind != "chord":
        return np.linspace(0.0, 1.0, section_points.shape[0])
    step = d.mean(axis=1)
    if np.any(step <= 0):
        raise BladeReconError("two sections coincide: every section must be at a different span height")
    v = np.concatenate([[0.0], np.cumsum(step)])
    return v / v[-1]


def skin_surface(u_knots: np.ndarray, u_mults: np.ndarray, section_poles: np.ndarray,
                 v_params: np.ndarray, v_degree: int = 3) -> BSplineSurface:
    """Interpolate compatible section poles spanwise (seed 000 eqs. 8-10): periodic u, clamped v.

    With fewer than 4 sections the spanwise degree drops to ``n_sections - 1``.
    """
    S = section_poles.shape[0]
    q = min(v_degree, S - 1)
    U = averaged_knots(v_params, q)
    v_knots, v_mults = knots_from_full(U)
    A = collocation_matrix(v_knots, v_mults, q, False, S, v_params)
    n = section_poles.shape[1]
    R = solve_sparse(A, section_poles.reshape(S, n * 3)).reshape(S, n, 3)
    poles = R.transpose(1, 0, 2).copy()                    # (n_u, n_v, 3)
    return BSplineSurface(poles, np.asarray(u_knots, float), np.asarray(u_mults, int),
                          v_knots, v_mults, 3, q, True, False)


def closed_grid_parameters(grid: np.ndarray) -> np.ndarray:
    """Centripetal parameters around closed sections (S, N, 3), averaged over the sections (seed 000 §2.4)."""
    seg = np.sqrt(np.linalg.norm(np.roll(grid, -1, axis=1) - grid, axis=2))   # (S, N)
    u_rows = np.cumsum(seg, axis=1) / seg.sum(axis=1, keepdims=True)
    return np.concatenate([[0.0], u_rows[:, :-1].mean(axis=0)])


def interpolate_grid(grid: np.ndarray, v_kind: str = "centripetal") -> BSplineSurface:
    """Tensor-product interpolation of a closed grid of corresponding points (seed 000 §2.4).

    ``grid``: (S, N, 3) — S sections (hub to tip) of N corresponding points each, every
    section a closed loop (closing point not repeated). Centripetal parameters around each
    section, averaged over the sections; periodic cubic knots at them (eq. 7); every section
    interpolated with that one knot vector (eq. 9, one factorisation for all sections), then
    the poles spanwise (eq. 8, :func:`skin_surface`).
    """
    from bladerecon.core.geometry.fitting import periodic_knots_from_parameters

    S, N, _ = grid.shape
    u = closed_grid_parameters(grid)
    knots, mults = periodic_knots_from_parameters(u, 3)
    A = collocation_matrix(knots, mults, 3, True, N, u)
    poles = solve_sparse(A, grid.transpose(1, 0, 2).reshape(N, 3 * S)).reshape(N, S, 3).transpose(1, 0, 2)
    return skin_surface(knots, mults, poles, span_parameters(grid, v_kind))
