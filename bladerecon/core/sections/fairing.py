# SPDX-License-Identifier: LGPL-2.1-or-later
"""Bad-point detection and section fairing (seed 001 §1.1, seed 004 §2).

Seed 001: with a measuring system accurate to 2 µm, a point farther than 3 µm from a fair
fit of its section is a "bad point"; k consecutive bad points ``B_i..B_{i+k-1}`` are
replaced by k points taken at equal parameters on an auxiliary cubic built from the good
neighbours ``B_{i-1}, B_{i+k}``, the next points ``B_{i-2}, B_{i+k+1}`` and the tangents
there (end-derivative interpolation, seed 001 eqs. 3-4), then the section is refitted and
every replaced point's displacement is reported.

The fair fit (:func:`fair_fit`) is a periodic least-squares cubic of the closed section
with about one pole per ``points_per_pole`` points (knots by the periodic reading of The
NURBS Book eq. 9.69) and a small strain-energy term (seed 004 criterion 4) that bridges
rejected points. Bad points are found by *worst-first rejection*: fit, reject the points
whose distance exceeds the threshold and at least half the current worst distance, refit
without them, repeat; at the end every rejected point that the final fit reaches within
the threshold is taken back. A bump pulls the first fit towards itself, so its clean
neighbours may look bad at first; rejecting the worst first and re-admitting at the end
keeps them.

The round leading and trailing edges are judged first, against their own fair model
(:mod:`bladerecon.core.sections.edge_bad_points`: a circular arc tangent to the flanks, runs
left out in turn): the fair fit has a knot at every edge point and follows a run there. The
points that model finds bad stay rejected in the fair fit and are put back onto the edge
model; an edge that is not such an arc is left to the fair fit as before.

Units: mm (default threshold 0.003 mm = 3 µm).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.bspline import closed_parameters, collocation_matrix, curve_derivatives, evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.fitting import interpolate_curve_with_end_derivatives, smoothing_matrix, solve_sparse
from bladerecon.core.sections.edge_bad_points import EDGE_FRACTION, EdgeJudgement, in_plane_noise, judge_edges
from bladerecon.core.surface.section_curves import refine_curve_parameters
from bladerecon.core.geometry.spline import BSplineCurve

__all__ = [
    "DEFAULT_THRESHOLD",
    "DEFAULT_MAX_MOVE",
    "SectionFairing",
    "fair_fit",
    "detect_bad_points",
    "bad_runs",
    "replace_runs",
    "fair_section",
    "describe_runs",
]

DEFAULT_THRESHOLD = 0.003   # mm: seed 001, 3 µm for a 2 µm system
DEFAULT_MAX_MOVE = 0.5      # mm: a fairing that moves a point farther refuses
AUX_AGREEMENT = 5.0         # replaced points within this many thresholds of the fair fit


@dataclass(frozen=True)
class SectionFairing:
    """Fairing of one closed section: original and faired points, what was replaced."""

    original: np.ndarray      # (n, 3) mm, as given
    faired: np.ndarray        # (n, 3) mm, bad points replaced
    bad: np.ndarray           # (n,) bool
    displacement: np.ndarray  # (n,) mm, |faired - original| (0 for good points)
    distance: np.ndarray      # (n,) mm, distance of each original point to the fair fit
    runs: tuple[tuple[int, int], ...]   # (first index, length) of each run of bad points
    by_edge_model: np.ndarray | None = None    # (n,) bool: judged bad by the LE/TE model
    edges: tuple[EdgeJudgement, ...] = ()      # the two edge judgements (what each edge was)


def _fit(points: np.ndarray, t: np.ndarray, w: np.ndarray, knots: np.ndarray,
         smoothing: float) -> BSplineCurve:
    """Periodic cubic on ``knots`` minimising ``Σ w_i |C(t_i) - p_i|² + λ ∫|C''|²`` with
    ``λ = smoothing · tr(AᵀWA) / tr(E)`` (A the collocation matrix, E the Gram matrix of the
    second derivatives): the strain energy weighted relative to the data term, so that
    scaling every weight leaves the curve as it is."""
    mults = np.ones(knots.size, dtype=int)
    n_poles = knots.size - 1
    A = collocation_matrix(knots, mults, 3, True, n_poles, t)
    AtWA = (A.T @ (A.multiply(w[:, None]))).tocsc()
    E = smoothing_matrix(knots, mults, 3, True, n_poles)
    lam = smoothing * AtWA.diagonal().sum() / max(E.diagonal().sum(), 1e-300)
    P = solve_sparse(AtWA + lam * E, A.T @ (w[:, None] * points))
    return BSplineCurve(P, knots, mults, 3, True)


def edge_zones(points: np.ndarray, fraction: float = 0.04) -> np.ndarray:
    """Points within ``fraction`` of the chord from either end of the section (bool (n,)).

    The chord direction is the principal direction of the points; the round leading and
    trailing edges and their joints with the flanks (a curvature jump) lie in these zones.
    """
    P = np.asarray(points, float)
    c = P - P.mean(axis=0)
    x = c @ np.linalg.svd(c, full_matrices=False)[2][0]
    span = np.ptp(x)
    return (x < x.min() + fraction * span) | (x > x.max() - fraction * span)


def _robust_turning(P: np.ndarray, window: int = 21, baseline: float = 0.5) -> np.ndarray:
    """Turning (rad) per point step of a closed loop, measured over chords of about
    ``baseline`` mm (so that noise on dense points does not read as turning), running
    median over ``window`` points (so that a short run of bad points does not either).

    The chords span k = round(baseline / median step) steps, at least 1 and at most an
    eighth of the points; the turning at a point is the angle between the chords that end
    and start there, over k; the median window is centred, of max(window, 2k + 1) points
    (at most all of them)."""
    n = P.shape[0]
    h = float(np.median(np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)))
    k = int(max(1, min(n // 8, round(baseline / max(h, 1e-300)))))
    a = np.roll(P, -k, axis=0) - P
    b = P - np.roll(P, k, axis=0)
    cos = np.einsum("ij,ij->i", a, b) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-300)
    turn = np.arccos(np.clip(cos, -1.0, 1.0)) / k
    w = min(max(window, 2 * k + 1), n)
    idx = (np.arange(n)[:, None] + np.arange(-(w // 2), w - w // 2)[None, :]) % n
    return np.median(turn[idx], axis=1)


def _density_knots(t: np.ndarray, density: np.ndarray) -> np.ndarray:
    """Periodic knots at the parameters of the points where the cumulative point density
    passes a whole number (eq. 9.69 with a weight per point): a knot at every point where
    the density is 1, at every 1/density-th point elsewhere. Knots at data parameters keep
    every span supported by data (Schoenberg-Whitney), even where the knots are as dense
    as the points. Parameters outside the period [0, 1] give no knot."""
    order = np.argsort(t)
    ts, ds = t[order], density[order]
    cum = np.cumsum(ds)
    pick = np.concatenate([[True], np.floor(cum[1:] - 1e-9) > np.floor(cum[:-1] - 1e-9)])
    knots = np.concatenate([[0.0], ts[pick], [1.0]])
    knots = knots[(knots >= 0.0) & (knots <= 1.0)]
    keep = np.concatenate([[True], np.diff(knots) > 1e-9])
    knots = knots[keep]
    knots[-1] = 1.0
    return knots


def chord_parameters_of_good(points: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """Closed chord-length parameters (seed 003 eq. 6) measured along the good points only.

    The chord between two consecutive good points is shared equally by the index steps
    between them, so a gross bad point does not stretch its neighbours' parameters.
    t[0] = 0 at the first point whatever its state.
    """
    P = np.asarray(points, float)
    n = P.shape[0]
    g = np.flatnonzero(~np.asarray(bad, bool))
    if g.size == n:
        return closed_parameters(P, "chord")
    nxt = np.roll(g, -1)
    chord = np.linalg.norm(P[nxt] - P[g], axis=1)
    steps = np.mod(nxt - g, n)
    steps[steps == 0] = n
    j = np.searchsorted(g, np.arange(n), side="right") - 1       # -1 (before g[0]) wraps to the last gap
    seg = (chord / steps)[j]
    t = np.concatenate([[0.0], np.cumsum(seg)[:-1]])
    return t / seg.sum()


def fair_fit(points: np.ndarray, weights: np.ndarray | None = None, points_per_pole: float = 10.0,
             smoothing: float = 1e-6, t: np.ndarray | None = None, edge_fraction: float = 0.04,
             knot_length: float = 4.0, knot_turn: float = 0.1,
             rounds: int = 3) -> tuple[BSplineCurve, np.ndarray, np.ndarray]:
    """Weighted periodic least-squares cubic of a closed section (NURBS Book §9.4.1).

    Knots by a density-weighted periodic eq. 9.69 on chord-length parameters (seed 003
    eqs. 6-7): one pole per ``points_per_pole`` points on the flanks, one per point in the
    edge zones (:func:`edge_zones`), where the measured points barely resolve the round
    edges, and at least one per ``knot_length`` mm of arc and per ``knot_turn`` radians of
    turning (a running median, blind to short bumps). ``smoothing`` weights the strain energy ∫|C''|² (seed 004) relative to the data
    term. Parameters are corrected by projection (Hoschek) after each solve. Returns
    ``(curve, t, distance)`` with the distance of every point (weighted or not) to the
    curve (mm).
    """
    P = np.asarray(points, float)
    n = P.shape[0]
    w = np.ones(n) if weights is None else np.asarray(weights, float)
    t = closed_parameters(P, "chord") if t is None else np.asarray(t, float)
    # knots: one per point on the edges, one per points_per_pole points on the flanks, but
    # never sparser than one per knot_length of arc (sparse, uneven tables such as NASA's
    # then get a knot at nearly every point: too few points to judge there)
    seg = np.linalg.norm(np.roll(P, -1, axis=0) - P, axis=1)
    density = np.where(edge_zones(P, edge_fraction), 1.0, 1.0 / points_per_pole)
    density = np.maximum(density, seg / knot_length)
    # and one per knot_turn radians of turning, from a running median over 21 points: a
    # short run of bad points cannot raise it, a strongly curved flank does
    density = np.clip(np.maximum(density, _robust_turning(P) / knot_turn), 0.0, 1.0)
    density = np.where(w > 0, density, 0.0)     # knots advance with the points that count
    knots = _density_knots(t, density)
    if knots.size < 9:
        knots = np.linspace(0.0, 1.0, 9)
    curve = None
    for _ in range(rounds):
        curve = _fit(P, t, w, knots, smoothing)
        t = refine_curve_parameters(curve, P, t, iterations=3)
    d = np.linalg.norm(evaluate_curve(curve, t) - P, axis=1)
    return curve, t, d


def _detect(points: np.ndarray, threshold: float = DEFAULT_THRESHOLD, max_rounds: int = 60,
            name: str = "", edges: bool = True, **fit_options):
    """:func:`detect_bad_points` plus the edge judgements: ``(bad, distance, curve, t,
    edge_bad, edge_feet, judgements)``."""
    P = np.asarray(points, float)
    n = P.shape[0]
    if n < 12:
        raise BladeReconError(f"fairing needs at least 12 points on a section, got {n}")
    # the round edges first, against their own fair model (edge_bad_points): the fair fit
    # below has a knot at every edge point and follows a run there
    if edges:
        # the noise the edge model may show on its clean points: that of the flanks about
        # the fair fit, in the section plane (robust), so that an edge that is no circular
        # arc is not judged (the edge model sees no noise along the plane normal)
        curve0, t0, _ = fair_fit(P, **fit_options)
        flank = ~edge_zones(P, EDGE_FRACTION)
        noise = in_plane_noise(P, (P - evaluate_curve(curve0, t0))[flank])
        edge_bad, edge_d, feet, judgements = judge_edges(P, threshold, noise)
    else:
        edge_bad, edge_d, feet, judgements = np.zeros(n, bool), np.full(n, np.nan), np.full((n, 3), np.nan), []
    bad = edge_bad.copy()
    # in a judged edge zone the edge model is the judge: the fair fit, which bridges an edge
    # run by its strain energy alone, would flag the run's clean neighbours
    free = np.isnan(edge_d)
    for _ in range(max_rounds):
        t = chord_parameters_of_good(P, bad)
        curve, t, d = fair_fit(P, (~bad).astype(float), t=t, **fit_options)
        worst = d[~bad & free].max()
        if worst <= threshold:
            break
        bad |= (~bad) & free & (d > max(threshold, 0.5 * worst))
        if bad.sum() > 0.25 * n:
            where = f"section {name}: " if name else ""
            med = float(np.median(d))
            raise BladeReconError(f"{where}more than a quarter of the points are farther than "
                                  f"{threshold * 1000:.1f} µm from a fair curve (median distance "
                                  f"{med * 1000:.1f} µm): the threshold is below this data's noise; "
                                  f"try --fair-threshold {max(5 * med, threshold):.3f}")
    # take back rejected points that the fit of the good points reaches (not those the edge
    # model judged: the fit follows every point at the edges, it cannot judge them)
    for _ in range(3):
        back = bad & ~edge_bad & (d <= threshold)
        if not back.any():
            break
        bad &= ~back
        curve, t, d = fair_fit(P, (~bad).astype(float), t=chord_parameters_of_good(P, bad), **fit_options)
    d = np.where(np.isnan(edge_d), d, edge_d)
    return bad, d, curve, t, edge_bad, feet, tuple(judgements)


def detect_bad_points(points: np.ndarray, threshold: float = DEFAULT_THRESHOLD,
                      max_rounds: int = 60, name: str = "", edges: bool = True,
                      **fit_options) -> tuple[np.ndarray, np.ndarray, BSplineCurve, np.ndarray]:
    """Bad points of a closed, ordered section: farther than ``threshold`` from the fair fit.

    Worst-first rejection (module docstring); with ``edges`` the points within
    :data:`~bladerecon.core.sections.edge_bad_points.EDGE_FRACTION` of the chord from either
    end are judged first against a circular-arc edge model tangent to the flanks
    (:func:`~bladerecon.core.sections.edge_bad_points.judge_edges`; an edge that is not such
    an arc is left to the fair fit). Returns ``(bad (n,) bool, distance (n,) mm, fair curve,
    t)``; the distances are those of every original point to the final fit of the good
    points (to the edge model in the judged edge zones).
    """
    return _detect(points, threshold, max_rounds, name, edges, **fit_options)[:4]


def bad_runs(bad: np.ndarray) -> list[tuple[int, int]]:
    """Runs of consecutive bad points around a closed loop: (first index, length)."""
    b = np.asarray(bad, bool)
    n = b.size
    if not b.any():
        return []
    if b.all():
        return [(0, n)]
    start = int(np.flatnonzero(~b)[0])          # begin the scan at a good point
    runs, i = [], 0
    while i < n:
        j = (start + i) % n
        if b[j]:
            k = 0
            while k < n and b[(j + k) % n]:
                k += 1
            runs.append((j, k))
            i += k
        else:
            i += 1
    return runs


def replace_runs(points: np.ndarray, bad: np.ndarray, curve: BSplineCurve,
                 t: np.ndarray) -> np.ndarray:
    """Replace every run of bad points by points on an auxiliary cubic (seed 001 §1.1 steps 1-2).

    For a run ``B_i..B_{i+k-1}`` the two nearest good points on each side
    ``B_a2, B_a1 | B_b1, B_b2`` — taken as their feet on the fair fit of the good points,
    seed 001's "smooth curves fitted to the good point sequences at both ends", so that
    measurement noise on two close neighbours is not extrapolated across the gap — are
    interpolated by a cubic with the fair fit's tangent directions prescribed at ``B_a2``
    and ``B_b2`` (seed 001 eqs. 3-4,
    :func:`~bladerecon.core.geometry.fitting.interpolate_curve_with_end_derivatives`; the derivative
    length is the chord length of the four points, the speed of a chord-length-parameterised
    cubic); the k new points are taken at equal parameter steps between ``B_a1`` and ``B_b1``.
    """
    P = np.asarray(points, float)
    n = P.shape[0]
    out = P.copy()
    good = np.flatnonzero(~bad)
    if good.size < 4:
        raise BladeReconError("too few good points left on the section to build the auxiliary curves")
    for first, k in bad_runs(bad):
        after = (first + k) % n
        # nearest good points before/after the run around the loop
        pos_a = np.searchsorted(good, first) - 1
        pos_b = np.searchsorted(good, after)
        a1, a2 = good[pos_a % good.size], good[(pos_a - 1) % good.size]
        b1, b2 = good[pos_b % good.size], good[(pos_b + 1) % good.size]
        Q = evaluate_curve(curve, t[[a2, a1, b1, b2]])   # on the smooth fit of the good points
        L = float(np.linalg.norm(np.diff(Q, axis=0), axis=1).sum())
        tan = curve_derivatives(curve, t[[a2, b2]], 1)[:, 1]
        tan = tan / np.linalg.norm(tan, axis=1, keepdims=True) * L
        aux = interpolate_curve_with_end_derivatives(Q, tan[0], tan[1], 3, parameterisation="chord")
        u = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(Q, axis=0), axis=1))]) / L
        s = u[1] + (u[2] - u[1]) * np.arange(1, k + 1) / (k + 1)
        idx = (first + np.arange(k)) % n
        out[idx] = evaluate_curve(aux, s)
    return out


def fair_section(points: np.ndarray, threshold: float = DEFAULT_THRESHOLD,
                 max_move: float = DEFAULT_MAX_MOVE, name: str = "", **fit_options) -> SectionFairing:
    """Detect and replace the bad points of one closed, ordered section (seed 001 §1.1).

    Raises BladeReconError (and names the section and point) if a replacement would move a
    point farther than ``max_move`` (mm): such a point is a gross outlier or the section is
    not what the fairing assumes; remove it or raise the limit knowingly.
    """
    P = np.asarray(points, float)
    bad, d, curve, t, edge_bad, feet, judgements = _detect(P, threshold, name=name, **fit_options)
    faired = replace_runs(P, bad, curve, t) if bad.any() else P.copy()
    # a run the edge model found goes back onto that model: the fair fit has a knot at every
    # edge point and bridges the gap the run leaves by its strain energy alone
    faired[edge_bad] = feet[edge_bad]
    disp = np.linalg.norm(faired - P, axis=1)
    where = f"section {name}, " if name else ""
    if (bad & ~edge_bad).any():
        # the auxiliary cubics must agree with the fair fit of the good points; where the
        # points around a run are too sparse they do not, and the fairing says so
        idx = np.flatnonzero(bad & ~edge_bad)
        tb = refine_curve_parameters(curve, faired[idx], t[idx], iterations=6)
        stray = np.linalg.norm(evaluate_curve(curve, tb) - faired[idx], axis=1)
        if stray.max() > AUX_AGREEMENT * threshold:
            i = int(idx[np.argmax(stray)])
            raise BladeReconError(
                f"fairing refused: {where}the auxiliary curve at point {i} strays {stray.max():.4f} mm from the "
                f"fair fit of the good points (points around it too sparse or too uneven to rebuild it): "
                "raise --fair-threshold or leave this data unfaired")
    if disp.max() > max_move:
        i = int(np.argmax(disp))
        raise BladeReconError(
            f"fairing refused: {where}point {i} would move {disp[i]:.4f} mm (limit {max_move} mm); "
            "remove that point or raise --fair-limit")
    return SectionFairing(P, faired, bad, disp, d, tuple(bad_runs(bad)), edge_bad, judgements)


def describe_runs(points: np.ndarray, bad: np.ndarray, displacement: np.ndarray,
                  lines: np.ndarray | None = None) -> list[dict]:
    """Where each run of bad points of one closed, ordered section is: its first and last
    line (or index), number of points, the chord fraction of its first and last point (to 4
    decimals) and its largest displacement (mm, to the nanometre).

    The chord fraction is measured along the section's principal direction, 0 at the end
    nearer the section's first point (the reconstruction's leading edge when the points
    start there) and 1 at the other end.
    """
    P = np.asarray(points, float)
    n = P.shape[0]
    lines = np.arange(n) if lines is None else np.asarray(lines)
    c = P - P.mean(axis=0)
    x = c @ np.linalg.svd(c, full_matrices=False)[2][0]
    x = (x - x.min()) / max(np.ptp(x), 1e-300)
    if x[0] > 0.5:
        x = 1.0 - x
    out = []
    for first, k in bad_runs(bad):
        idx = (first + np.arange(k)) % n
        out.append({"first_line": int(lines[idx[0]]), "last_line": int(lines[idx[-1]]), "points": int(k),
                    "chord_fraction": [round(float(x[idx[0]]), 4), round(float(x[idx[-1]]), 4)],
                    "displacement_mm": round(float(np.max(displacement[idx])), 6)})
    return out
