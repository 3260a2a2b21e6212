# SPDX-License-Identifier: LGPL-2.1-or-later
"""Surface fitting from non-grid rows (seed 003, Mao, Wang & Liu): rows of different lengths.

In-situ measuring machines deliver rows (sections) with different point counts. Seed 003
turns them into grid data and then fits hierarchically:

1. **Data conversion** (seed 003 Part 1): for every row, chord-length parameters (eq. 6),
   knots by the averaging technique for least squares (eq. 7 = The NURBS Book eq. 9.69),
   a least-squares curve (eq. 5); every row curve is then sampled at the *same* uniformly
   spaced parameters -> a grid of ``S x num`` points.
2. **Hierarchical fitting** (seed 003 Part 2, steps 6-8): the grid rows are fitted by
   least-squares curves with ``n_u`` poles on one common knot vector (u), then the
   resulting control points are fitted column by column with ``n_v`` poles (v).

Closed sections (whole blade profiles) are fitted periodic in u. A closed row has no
natural start, so each row curve is sampled from its own leading edge: the LE/TE are
found on each row curve (:func:`~bladerecon.core.surface.skinning.anchor_section`) and the common
parameter runs LE -> TE -> LE by normalised arc length on each side (chord-length
parameters are normalised arc length up to the chord/arc difference, so this is seed
003's uniform parameter sampling with a common start). Open rows (one side of a blade,
as measured in parts on in-situ machines) are clamped and sampled on their own [0, 1].

Units: mm.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from bladerecon.core.geometry.bspline import (
    approximation_knots,
    chord_parameters,
    closed_parameters,
    collocation_matrix,
    evaluate_curve,
)
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.fitting import knots_from_full, least_squares_curve, solve_sparse
from bladerecon.core.surface.section_curves import SectionCurve, refine_curve_parameters
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

__all__ = [
    "NonGridFit",
    "periodic_approximation_knots",
    "fit_row_curve",
    "resample_rows",
    "hierarchical_surface",
    "fit_nongrid",
    "parse_poles",
    "check_rows_overlap",
]


@dataclass(frozen=True)
class NonGridFit:
    surface: BSplineSurface
    row_curves: tuple[BSplineCurve, ...]
    grid: np.ndarray          # (S, num, 3) resampled grid points (mm)
    u_grid: np.ndarray        # (num,) common u of the grid columns
    v_rows: np.ndarray        # (S,) v of each row
    row_residual: np.ndarray  # (N,) distance of each measured point to its row curve (mm)
    seconds: dict = field(default_factory=dict)


def parse_poles(text: str) -> tuple[int, int]:
    """``'24x9'`` -> (24, 9): poles around the section (u) x along the span (v)."""
    try:
        a, b = str(text).lower().replace("×", "x").split("x")
        nu, nv = int(a), int(b)
    except ValueError:
        raise BladeReconError(f"--poles {text!r}: write it as NUxNV, e.g. 24x9 (poles around x along the span)") from None
    if nu < 4 or nv < 2:
        raise BladeReconError(f"--poles {text}: need at least 4 poles around and 2 along the span")
    return nu, nv


def periodic_approximation_knots(params: np.ndarray, n_poles: int) -> np.ndarray:
    """Distinct knots of a periodic least-squares spline with ``n_poles`` poles on [0, 1].

    The periodic reading of The NURBS Book eq. 9.69 (seed 003 eq. 7): with the closing
    parameter 1 appended, knot ``j`` lies at the fractional index ``j·d``,
    ``d = m / n_poles`` (m parameters), linearly between the parameters around it, so every
    knot span holds about the same number of data points.
    """
    u = np.concatenate([np.asarray(params, float), [1.0]])
    m = u.size - 1
    if n_poles > m:
        raise BladeReconError(f"{n_poles} poles need at least {n_poles} points in the row, got {m}")
    x = np.arange(n_poles + 1) * (m / n_poles)
    knots = np.interp(x, np.arange(m + 1), u)
    knots[0], knots[-1] = 0.0, 1.0
    return knots


def fit_row_curve(points: np.ndarray, n_poles: int, closed: bool, degree: int = 3,
                  index: int = 0) -> SectionCurve:
    """Least-squares curve through one row (seed 003 Part 1 steps 1-3; eqs. 5-7).

    Chord-length parameters (eq. 6), knots by eq. 7 (NURBS Book eq. 9.69; periodic reading
    for closed rows, :func:`periodic_approximation_knots`), least squares (eq. 5). Open rows
    keep their end points (NURBS Book A9.7). The parameters are then corrected once by
    projecting the points on the curve, which only refines the reported residuals.
    """
    Q = np.asarray(points, float)
    if closed:
        t = closed_parameters(Q, "chord")
        knots = periodic_approximation_knots(t, n_poles)
        mults = np.ones(knots.size, dtype=int)
        curve = least_squares_curve(Q, t, knots, mults, degree, periodic=True)
    else:
        t = chord_parameters(Q)
        knots, mults = knots_from_full(approximation_knots(t, degree, n_poles))
        curve = least_squares_curve(Q, t, knots, mults, degree, periodic=False, fix_ends=True)
    t = refine_curve_parameters(curve, Q, t, iterations=3)
    res = np.linalg.norm(evaluate_curve(curve, t) - Q, axis=1)
    return SectionCurve(index, curve, t, res)


def check_rows_overlap(rows: list[np.ndarray], span_axis: np.ndarray, source: str = "input") -> None:
    """Open rows must cover a common stretch across the blade, and rows must differ in span.

    Rows are compared along the principal in-plane direction of all points (the chord for a
    blade side): the stretch common to all rows must be at least half of the shortest row,
    otherwise resampling them at common parameters would join unrelated parts.
    """
    a = np.asarray(span_axis, float) / np.linalg.norm(span_axis)
    allp = np.concatenate(rows)
    c = allp - allp.mean(axis=0)
    c -= np.outer(c @ a, a)
    e1 = np.linalg.svd(c, full_matrices=False)[2][0]
    lo = np.array([((r - allp.mean(axis=0)) @ e1).min() for r in rows])
    hi = np.array([((r - allp.mean(axis=0)) @ e1).max() for r in rows])
    common = hi.min() - lo.max()
    shortest = float((hi - lo).min())
    if common < 0.5 * shortest:
        i, j = int(np.argmax(lo)), int(np.argmin(hi))
        raise BladeReconError(
            f"{source}: rows {i} and {j} do not overlap across the blade (row {i} covers "
            f"{lo[i]:.3f}..{hi[i]:.3f} mm, row {j} {lo[j]:.3f}..{hi[j]:.3f} mm along the chord): "
            "measure every row over the same part of the profile, or fit the parts separately")
    h = np.array([float(np.mean(r @ a)) for r in rows])
    gap = np.diff(h)
    if np.any(np.abs(gap) < 1e-6) or not (np.all(gap > 0) or np.all(gap < 0)):
        k = int(np.argmin(np.abs(gap))) if np.any(np.abs(gap) < 1e-6) else int(np.flatnonzero(np.sign(gap) != np.sign(gap[0]))[0])
        raise BladeReconError(f"{source}: rows {k} and {k + 1} are not in span order (mean heights "
                              f"{h[k]:.4f}, {h[k + 1]:.4f} mm): sort the rows along the span")


def resample_rows(curves: list[SectionCurve], num: int, closed: bool,
                  span_axis: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Sample every row curve at the same uniform parameters (seed 003 Part 1 steps 4-5).

    Returns ``(grid (S, num, 3), u (num,))``. Closed rows: u = k/num from each row's LE with
    the LE/TE-anchored common parameter (see the module docstring); open rows: u on [0, 1].
    """
    if not closed:
        u = np.linspace(0.0, 1.0, num)
        return np.stack([evaluate_curve(sc.curve, u) for sc in curves]), u
    from bladerecon.core.surface.skinning import anchor_section, common_parameter, s_to_t

    anchored, hint = [], None
    for sc in curves:
        a = anchor_section(sc, span_axis, le_hint=hint)
        anchored.append(a)
        hint = a.le
    s_te = common_parameter(anchored)
    u = np.arange(num) / num
    grid = np.stack([evaluate_curve(a.curve, s_to_t(a, u, s_te)) for a in anchored])
    return grid, u


def _lsq_columns(values: np.ndarray, params: np.ndarray, n_poles: int, closed: bool,
                 degree: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least squares of many curves sharing parameters and knots: one factorisation for all.

    ``values`` (m, k): m samples of k coordinates. Knots by eq. 9.69 (periodic reading when
    closed). Clamped fits keep the first and last sample (NURBS Book A9.7).
    """
    m = values.shape[0]
    if closed:
        knots = periodic_approximation_knots(params, n_poles)
        mults = np.ones(knots.size, dtype=int)
    else:
        knots, mults = knots_from_full(approximation_knots(params, degree, n_poles))
    A = collocation_matrix(knots, mults, degree, closed, n_poles, params)
    w = np.ones(m)
    if not closed:
        w[[0, -1]] = 1e8
    import scipy.sparse as sp
    W = sp.diags(w)
    M = (A.T @ W @ A).tocsc()
    P = solve_sparse(M, A.T @ (w[:, None] * values))
    return P, knots, mults


def hierarchical_surface(grid: np.ndarray, u: np.ndarray, v: np.ndarray, n_u: int, n_v: int,
                         closed: bool, degree: int = 3) -> BSplineSurface:
    """Hierarchical least squares of a grid (seed 003 Part 2, steps 6-8).

    u direction first: every grid row with ``n_u`` poles on one knot vector (eq. 9.69 on
    the common u); then every column of the resulting control points with ``n_v`` poles
    along v (eq. 9.69 on v). ``grid`` (S, num, 3).
    """
    S, num, _ = grid.shape
    q = min(degree, n_v - 1)
    if n_v > S:
        raise BladeReconError(f"{n_v} poles along the span need at least {n_v} rows, got {S}")
    if n_u > num:
        raise BladeReconError(f"{n_u} poles around need at least {n_u} samples per row, got {num}")
    R, uk, um = _lsq_columns(grid.transpose(1, 0, 2).reshape(num, 3 * S), u, n_u, closed, degree)
    R = R.reshape(n_u, S, 3)                                       # row control points R_{i,l}
    P, vk, vm = _lsq_columns(R.transpose(1, 0, 2).reshape(S, 3 * n_u), v, n_v, False, q)
    poles = P.reshape(n_v, n_u, 3).transpose(1, 0, 2).copy()        # (n_u, n_v, 3)
    return BSplineSurface(poles, uk, um, vk, vm, degree, q, closed, False)


def fit_nongrid(rows: list[np.ndarray], span_axis: np.ndarray, poles: tuple[int, int] = (24, 9),
                closed: bool = True, row_poles: int | None = None, num: int | None = None,
                degree: int = 3, source: str = "input") -> NonGridFit:
    """Seed 003 end to end: non-grid rows (hub to tip) -> one surface with ``poles`` = (n_u, n_v).

    ``row_poles``: poles of each row curve in the data conversion (default, at most 200:
    closed rows one per point — a sparse closed row does not resolve its round edges with
    fewer —, open rows half the points; the surface is the smoothing step); ``num``: samples per row (default: the longest row's point count, at least
    4·n_u). The v parameters of the rows are chord-length (eq. 6) averaged over the grid
    columns.
    """
    if len(rows) < 2:
        raise BladeReconError(f"{source}: a surface needs at least 2 rows, got {len(rows)}")
    n_u, n_v = poles
    counts = np.array([len(r) for r in rows])
    for k, n in enumerate(counts):
        if n < degree + 2:
            raise BladeReconError(f"{source}: row {k} has {n} points; a cubic row curve needs at least "
                                  f"{degree + 2}: measure more points on it or drop the row")
    if not closed:
        check_rows_overlap(rows, span_axis, source)
    t0 = time.perf_counter()
    def poles_of(n: int) -> int:
        if row_poles:
            return min(row_poles, n)
        return int(min(200, n if closed else max(degree + 1, n // 2)))

    curves = [fit_row_curve(r, poles_of(len(r)), closed, degree, k) for k, r in enumerate(rows)]
    t1 = time.perf_counter()
    num = num or int(max(counts.max(), 4 * n_u))
    grid, u = resample_rows(curves, num, closed, span_axis)
    d = np.linalg.norm(np.diff(grid, axis=0), axis=2).mean(axis=1)      # eq. 6 along v
    if np.any(d <= 0):
        raise BladeReconError(f"{source}: two rows coincide; every row must be at a different span height")
    v = np.concatenate([[0.0], np.cumsum(d)]) / d.sum()
    t2 = time.perf_counter()
    surface = hierarchical_surface(grid, u, v, n_u, n_v, closed, degree)
    t3 = time.perf_counter()
    res = np.concatenate([sc.residual for sc in curves])
    return NonGridFit(surface, tuple(sc.curve for sc in curves), grid, u, v, res,
                      {"rows": t1 - t0, "resample": t2 - t1, "surface": t3 - t2, "total": t3 - t0})
