# SPDX-License-Identifier: LGPL-2.1-or-later
"""Surface fairing on a grid of mesh points (seed 001 §1.2, seed 004 §2 and §3 step 5).

The surface is held as a grid ``(S, N, 3)``: S sections (u mesh curves, closed) of N
corresponding points, whose columns are the spanwise (v) mesh curves. Two operations:

* :func:`fair_grid_alternating` — seed 001/004's alternating fairing: fair the v mesh
  curves (bad points replaced by auxiliary cubics, as for sections), regenerate, fair the
  u mesh curves (sections), and repeat until a pass in both directions changes nothing.
* :func:`repair_regions` — seed 004's auxiliary-surface fairing: grid cells whose measured
  points lie farther than 0.02 mm from the surface mark an unfair region; its grid points
  are cut out and rebuilt from the mesh lines around it (auxiliary cubics with the end
  tangents of the kept surface, along the sections), so that the rebuilt surface joins the
  rest with G1 (the local bicubic surface through the grid is C1 everywhere).

Units: mm.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.bspline import approximation_knots, chord_parameters, collocation_matrix, curve_derivatives, evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.sections.fairing import DEFAULT_THRESHOLD, bad_runs, detect_bad_points, replace_runs
from bladerecon.core.geometry.fitting import interpolate_curve_with_end_derivatives, knots_from_full, smoothing_matrix, solve_sparse
from bladerecon.core.geometry.spline import BSplineCurve

__all__ = ["GridFairing", "detect_bad_open", "fair_open_curve", "fair_grid_alternating", "repair_regions",
           "REPAIR_THRESHOLD", "MIN_SECTIONS_V"]

REPAIR_THRESHOLD = 0.02   # mm: seed 004 §3 step 5 (1)
#: fewer sections than this leave a spanwise mesh curve too short to judge against a cubic
#: fit (4 poles): the v direction is then not faired, and the summary says so
MIN_SECTIONS_V = 8


@dataclass(frozen=True)
class GridFairing:
    grid: np.ndarray            # (S, N, 3) faired grid
    passes: int                 # alternating passes run (a pass = v curves then u curves)
    v_faired: bool              # False with fewer than MIN_SECTIONS_V sections
    replaced_v: int             # grid points replaced while fairing the v mesh curves
    replaced_u: int             # ... the u mesh curves (sections)
    converged: bool             # the last pass changed nothing
    moved: np.ndarray           # (S, N) total displacement of each grid point (mm)


def _fit_open(P: np.ndarray, w: np.ndarray, t: np.ndarray, n_poles: int) -> BSplineCurve:
    knots, mults = knots_from_full(approximation_knots(t, 3, n_poles))
    A = collocation_matrix(knots, mults, 3, False, n_poles, t)
    M = (A.T @ A.multiply(w[:, None])).tocsc()
    E = smoothing_matrix(knots, mults, 3, False, n_poles)
    M = M + 1e-9 * M.diagonal().sum() / max(E.diagonal().sum(), 1e-300) * E
    return BSplineCurve(solve_sparse(M, A.T @ (w[:, None] * P)), knots, mults, 3, False)


def detect_bad_open(points: np.ndarray, threshold: float = DEFAULT_THRESHOLD, points_per_pole: float = 5.0,
                    max_rounds: int = 30) -> tuple[np.ndarray, np.ndarray, BSplineCurve, np.ndarray]:
    """Bad points of an open mesh curve (worst-first rejection, as :func:`detect_bad_points`).

    Clamped least squares with chord-length parameters and eq. 9.69 knots, at least 4
    poles, one per ``points_per_pole`` points. The two end points are never rejected (no
    good neighbour beyond them to build an auxiliary curve from); a bad end point therefore
    also spoils the judgement of its next neighbours.
    """
    P = np.asarray(points, float)
    n = P.shape[0]
    n_poles = int(min(n, max(4, round(n / points_per_pole))))
    t = chord_parameters(P)
    bad = np.zeros(n, dtype=bool)
    for _ in range(max_rounds):
        curve = _fit_open(P, (~bad).astype(float), t, n_poles)
        d = np.linalg.norm(evaluate_curve(curve, t) - P, axis=1)
        cand = ~bad
        cand[[0, -1]] = False
        if not cand.any():
            break
        worst = d[cand].max()
        if worst <= threshold or (~bad).sum() - 1 <= n_poles:
            break
        bad |= cand & (d > max(threshold, 0.5 * worst))
    back = bad & (d <= threshold)
    bad &= ~back
    return bad, d, curve, t


def fair_open_curve(points: np.ndarray, threshold: float = DEFAULT_THRESHOLD, **options) -> tuple[np.ndarray, np.ndarray]:
    """Replace the bad points of an open mesh curve by auxiliary cubics (seed 001 §1.1).

    Returns ``(faired points, bad mask)``. A run next to an end uses the end point itself
    twice as its outer neighbour.
    """
    P = np.asarray(points, float)
    bad, _, curve, t = detect_bad_open(P, threshold, **options)
    out = P.copy()
    good = np.flatnonzero(~bad)
    for first, k in bad_runs(bad):
        pa = np.searchsorted(good, first) - 1
        pb = np.searchsorted(good, first + k)
        a1, a2 = good[pa], good[max(pa - 1, 0)]
        b1, b2 = good[pb], good[min(pb + 1, good.size - 1)]
        idx = [a2, a1, b1, b2] if a2 != a1 and b2 != b1 else [a1, b1]
        Q = evaluate_curve(curve, t[idx])
        L = float(np.linalg.norm(np.diff(Q, axis=0), axis=1).sum())
        tan = curve_derivatives(curve, t[[idx[0], idx[-1]]], 1)[:, 1]
        tan = tan / np.linalg.norm(tan, axis=1, keepdims=True) * L
        aux = interpolate_curve_with_end_derivatives(Q, tan[0], tan[1], 3, parameterisation="chord")
        u = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(Q, axis=0), axis=1))]) / L
        i1, i2 = (1, 2) if len(idx) == 4 else (0, 1)
        s = u[i1] + (u[i2] - u[i1]) * np.arange(1, k + 1) / (k + 1)
        out[first:first + k] = evaluate_curve(aux, s)
    return out, bad


def fair_grid_alternating(grid: np.ndarray, threshold: float = DEFAULT_THRESHOLD, max_passes: int = 10,
                          max_move: float = 0.5) -> GridFairing:
    """Alternate fairing of the v mesh curves (columns) and the u mesh curves (sections)
    until a whole pass replaces nothing (seed 001 §1.2; seed 004 §2 surface criteria 1-2).
    """
    G = np.array(grid, dtype=float)
    S, N, _ = G.shape
    start = G.copy()
    rv = ru = 0
    converged = False
    passes = 0
    for passes in range(1, max_passes + 1):
        changed = 0
        if S >= MIN_SECTIONS_V:
            for k in range(N):
                col, bad = fair_open_curve(G[:, k], threshold)
                G[:, k] = col
                rv += int(bad.sum())
                changed += int(bad.sum())
        for j in range(S):
            # the fair fit alone: runs it flags are replaced from it (replace_runs), and the
            # edge model's verdicts, replaced from the fair curve, would never settle
            bad, _, curve, t = detect_bad_points(G[j], threshold, edges=False)
            if bad.any():
                G[j] = replace_runs(G[j], bad, curve, t)
                ru += int(bad.sum())
                changed += int(bad.sum())
        if changed == 0:
            converged = True
            break
    moved = np.linalg.norm(G - start, axis=2)
    if moved.max() > max_move:
        j, k = np.unravel_index(int(np.argmax(moved)), moved.shape)
        raise BladeReconError(f"surface fairing refused: grid point {k} of section {j} would move "
                              f"{moved[j, k]:.4f} mm (limit {max_move} mm)")
    return GridFairing(G, passes, S >= MIN_SECTIONS_V, rv, ru, converged, moved)


def repair_regions(grid: np.ndarray, cell_error: np.ndarray, threshold: float = REPAIR_THRESHOLD,
                   margin: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Rebuild the grid points of unfair cells from the mesh lines around them (seed 004 §3 step 5).

    ``cell_error`` (S-1, N): the largest distance (mm) of the measured points in each grid
    cell (cell (j, k) spans sections j..j+1 and grid points k..k+1) to the surface. Cells
    above ``threshold`` (grown by ``margin`` cells around the section) mark the region; its
    grid points are replaced along u (the sections through the region) by auxiliary cubics
    from the kept points and the tangents on both sides (seed 001 eqs. 3-4), the mesh lines
    outside being kept. Returns ``(repaired grid, replaced mask (S, N))``.
    """
    from bladerecon.core.sections.fairing import fair_fit

    G = np.array(grid, dtype=float)
    S, N, _ = G.shape
    bad_cells = np.asarray(cell_error) > threshold
    if not bad_cells.any():
        return G, np.zeros((S, N), dtype=bool)
    grown = bad_cells.copy()
    for m in range(1, margin + 1):
        grown |= np.roll(bad_cells, m, axis=1) | np.roll(bad_cells, -m, axis=1)
    # a grid point is cut out when the cells on both of its u sides, on a section next to
    # the region, are unfair: the kept mesh lines around it carry the boundary and tangents
    row = np.zeros((S, N), dtype=bool)
    row[:-1] |= grown
    row[1:] |= grown
    pts = row & np.roll(row, 1, axis=1)
    est = G.copy()
    for j in range(S):
        if pts[j].any():
            curve, t, _ = fair_fit(G[j], (~pts[j]).astype(float))
            est[j] = replace_runs(G[j], pts[j], curve, t)
    return est, pts
