# SPDX-License-Identifier: LGPL-2.1-or-later
"""Bad points at the leading and trailing edges: a fair edge model a run cannot pull.

The fair fit of :mod:`bladerecon.core.sections.fairing` needs a knot at every point of the
round edges (the points barely resolve them), so it follows a run of displaced points there.
Here each edge is judged against the shape seed 004 §2.1 gives it: a **circular arc joined
tangentially (G1) to the two flanks**, with the curvature jump at the joints that a blade
machined to a round edge has. Near each joint the flank is a graph over the joint's tangent,

    y(x) = a x² + b x³ + c x⁴      (x along the tangent, away from the arc; y along the normal)

which starts on the circle with the circle's tangent, so the whole edge model has 5 free
geometric numbers (centre, radius, the two joint angles) and 6 linear ones. It is fitted by
variable projection (the linear flank coefficients solved inside each residual evaluation)
with ``scipy.optimize.least_squares``, on the points of the section plane within
``EDGE_FRACTION`` of the chord from the end. A run of displaced points cannot pull it: a
run along the arc moves a concentric arc, and the circle that reaches it is no longer
tangent to the flanks; a run on a flank is a step the quartic does not have.

Bad points are found by leaving runs out (:func:`judge_edge`): when the model fitted to the
whole zone misses a point by more than ``threshold`` (seed 001's 3 µm for a 2 µm system), or
fits it worse than a fair edge would, every run of 1-5 points near the worst point is left
out in turn and the model refitted without it; the run that leaves the rest fitting best is
kept, and of it the points the refitted model misses by more than the threshold are bad. The
model that judges a run never saw it, so the run cannot pull it. An edge that is not a
circular arc (an elliptical or otherwise designed edge, whose curvature grows and falls
along it; or an edge with two runs) is **not judged**: reported, no point flagged, and the
fair fit of the section stays in charge there as before.

Units: mm.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from bladerecon.core.sections.parameters import kasa_circle

__all__ = ["EDGE_FRACTION", "EdgeJudgement", "in_plane_noise", "section_plane", "edge_zone", "judge_edge", "judge_edges"]

# The edge model is fitted in the section plane by variable projection: the 5 geometric
# numbers by scipy's Levenberg-Marquardt, the flank coefficients by linear least squares
# inside each evaluation. Starts and scans are loops over a handful of candidates, never over
# points.

EDGE_FRACTION = 0.08     # zone of each edge model: this fraction of the chord from the end
MAX_RUN = 5              # longest run of bad points left out at a time
NOISE_FACTOR = 1.5       # the edge model may miss its clean points by this times the flanks' noise (rms)
ARC_CURVATURE_TOLERANCE = 0.25   # relative: a circular arc's three-point curvatures agree this well
FRESH_STARTS = 3         # best left-out runs refitted from fresh starts
MIN_ZONE_POINTS = 12     # fewer points than this in a zone: the edge is not judged
CURVATURE_SIGMAS = 4.0   # three-point curvatures of a circular arc agree within this many of their noise sigmas


@dataclass(frozen=True)
class EdgeJudgement:
    """One edge (``end`` 0: low end of the principal direction, 1: high end)."""

    end: int
    index: np.ndarray          # (m,) indices of the zone's points in the section, loop order
    bad: np.ndarray            # (m,) bool
    distance: np.ndarray       # (m,) mm, in-plane distance of each zone point to the edge model
    foot: np.ndarray           # (m, 2) the nearest point of the model (plane coordinates, mm)
    radius: float              # mm, of the edge arc (nan when not judged)
    judged: bool
    note: str


def section_plane(points: np.ndarray):
    """Centroid, in-plane axes (principal direction first) and plane coordinates (n, 2)."""
    P = np.asarray(points, float)
    o = P.mean(axis=0)
    axes = np.linalg.svd(P - o, full_matrices=False)[2][:2]
    return o, axes, (P - o) @ axes.T


def in_plane_noise(points: np.ndarray, offsets: np.ndarray) -> float:
    """Robust standard deviation (mm) of the noise the edge model sees: ``offsets`` (k, 3) of
    some points of the section ``points`` (n, 3) from a fair curve of it, their component
    along the section plane's normal removed, 1.4826 times the median length (MAD). The
    edge model works in the plane; a 3D distance would add the noise along the normal and,
    for isotropic Gaussian noise, read a Rayleigh median, 1.75 sigma instead of 1."""
    P = np.asarray(points, float)
    normal = np.linalg.svd(P - P.mean(axis=0), full_matrices=False)[2][2]
    r = np.asarray(offsets, float)
    r = r - (r @ normal)[:, None] * normal
    return 1.4826 * float(np.median(np.linalg.norm(r, axis=1))) if len(r) else 0.0


def edge_zone(q: np.ndarray, end: int, fraction: float = EDGE_FRACTION) -> np.ndarray:
    """Indices (loop order) of the longest cyclic stretch of points within ``fraction`` of
    the chord from one end of the principal direction."""
    x = q[:, 0]
    x = (x - x.min()) / max(np.ptp(x), 1e-300)
    inside = x < fraction if end == 0 else x > 1.0 - fraction
    n = inside.size
    if inside.all() or not inside.any():
        return np.flatnonzero(inside)
    start = int(np.flatnonzero(~inside)[0])
    rolled = np.roll(inside, -start)                 # starts outside: runs do not wrap
    edges = np.diff(np.concatenate([[0], rolled.astype(int), [0]]))
    firsts, lasts = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    k = int(np.argmax(lasts - firsts))
    return (start + np.arange(firsts[k], lasts[k])) % n


def _frames(g, sense):
    """Joint points (2, 2), tangents away from the arc (2, 2) and outward normals (2, 2) of
    the two joints of geometry ``g = (cx, cy, r, phi1, phi2)``."""
    phi = g[3:5]
    e = np.empty((2, 2))            # filled in place, not np.stack: _model calls this ~10⁴ times a section
    e[:, 0], e[:, 1] = np.cos(phi), np.sin(phi)
    tangent = np.empty((2, 2))
    tangent[:, 0], tangent[:, 1] = -e[:, 1], e[:, 0]
    tangent *= sense * _FLIP
    return g[:2] + g[2] * e, tangent, e


_FLIP = np.array([[-1.0], [1.0]])           # the first joint's tangent turns against the loop's sense


POWERS = np.array([2, 3, 4])     # the flank graph over the joint's tangent: a x² + b x³ + c x⁴
BENDING = 1e-12                  # mm³: weight of ∫y''² against the squared distances (a flank bending 1/(10 mm) over 3 mm costs (0.2 µm)², a wild one bridging a left-out run (5 µm)² or more)


_P, _R = POWERS[:, None], POWERS[None, :]
_BENDING_FACTOR = _P * (_P - 1) * _R * (_R - 1)     # integers: the p (p-1) r (r-1) of _bending, exact
_BENDING_POWER = _P + _R - 3


def _bending(span):
    """∫_0^span y''² dx = cᵀ M c for y = Σ c_p x^p, p in POWERS (seed 004: small strain energy)."""
    return _BENDING_FACTOR * span ** _BENDING_POWER / _BENDING_POWER


def _flank(xs, ys, fit):
    """The flank graph of one joint fitted to its points ``(xs, ys)`` (tangent, normal
    coordinates) of ``fit`` True: its values ``f`` and slopes ``df`` at every point, and its
    bending energy (None when too few points to fit: the flank is then the tangent line)."""
    B = xs[:, None] ** POWERS[None, :]
    k = min(POWERS.size, max(int(fit.sum()) - 1, 0))
    coef = np.zeros(POWERS.size)
    bent = None
    if k > 0:
        # least squares plus a little bending energy: where a left-out run leaves the
        # flank unsupported next to its joint, the fairest flank bridges it (not a wild one)
        Bf = B[fit][:, :k]
        M = BENDING * _bending(max(float(xs.max()), 1e-9))[:k, :k]
        coef[:k] = np.linalg.lstsq(Bf.T @ Bf + M, Bf.T @ ys[fit], rcond=None)[0]
        bent = float(coef[:k] @ M @ coef[:k])
    f = B @ coef
    df = (POWERS[None, :] * xs[:, None] ** (POWERS[None, :] - 1)) @ coef
    return f, df, bent


def _model(q, w, g, sense, tip, with_feet=False, energy=None):
    """Signed in-plane distances (mm) of all points to the edge model with geometry ``g``,
    the flank coefficients fitted to the points of weight > 0; with ``with_feet`` also the
    nearest model points and each point's piece (0 first flank, 1 arc, 2 second flank).

    The zone's points come in loop order, so a point before the tip is on the first flank
    when it lies beyond the first joint along that flank's tangent, likewise after the tip.
    """
    m = q.shape[0]
    t0, tan, nor = _frames(g, sense)
    rel = q[:, None, :] - t0[None, :, :]                       # (m, 2 joints, 2)
    x = np.einsum("mjk,jk->mj", rel, tan)
    y = np.einsum("mjk,jk->mj", rel, nor)
    order = np.arange(m)
    piece = np.where((order < tip) & (x[:, 0] > 0.0), 0, np.where((order > tip) & (x[:, 1] > 0.0), 2, 1))
    v = q - g[:2]
    rho = np.sqrt(np.einsum("ij,ij->i", v, v))
    res = rho - g[2]
    feet = np.empty_like(q) if with_feet else None
    if with_feet:
        feet[:] = g[:2] + g[2] * v / np.maximum(rho, 1e-300)[:, None]
    for j, which in ((0, 0), (1, 2)):
        sel = piece == which
        if not sel.any():
            continue
        xs, ys = x[sel, j], y[sel, j]
        f, df, bent = _flank(xs, ys, w[sel] > 0)
        if energy is not None and bent is not None:
            energy[j] = bent
        res[sel] = (ys - f) / np.sqrt(1.0 + df * df)
        if with_feet:
            feet[sel] = t0[j] + xs[:, None] * tan[j] + f[:, None] * nor[j]
    if with_feet:
        return res, feet, piece
    return res




def _grown(q, w, lo, hi, tolerance):
    """Start circle from the counted points (``w`` > 0) lo..hi around the tip, grown one
    point at a time on either side (left-out points are stepped over) while all its counted
    points stay within ``tolerance`` (mm) of their circle. Returns ``(centre, radius, lo, hi)``."""
    m = q.shape[0]
    use = w > 0

    def circle(a, b):
        sel = np.flatnonzero(use[a:b + 1]) + a
        return (kasa_circle(q[sel], 1e-12), sel) if sel.size >= 3 else ((None, None), sel)

    (c, r), _ = circle(lo, hi)
    if c is None:
        c, r = kasa_circle(q[lo:hi + 1], 1e-12)
    grown = True
    while grown:
        grown = False
        for j in (lo - 1, hi + 1):
            if 0 <= j < m:
                a, b = min(lo, j), max(hi, j)
                (cj, rj), sel = circle(a, b)
                if cj is not None and np.abs(np.linalg.norm(q[sel] - cj, axis=1) - rj).max() < tolerance:
                    lo, hi, c, r, grown = a, b, cj, rj, True
                elif not use[j]:
                    lo, hi, grown = a, b, True
    return c, r, lo, hi


def _cost(q, w, g, sense, tip):
    d = _model(q, w, g, sense, tip)[w > 0]
    return float(d @ d)


def _costs(q, w, G, sense, tip):
    """:func:`_cost` of every geometry of ``G`` (T, 5), the same numbers bit for bit: the
    frames, the points' coordinates and pieces of all trials at once (elementwise, as
    :func:`_model` does them), then each trial's flank fit by :func:`_flank` (its small
    least squares is ill-conditioned where a trial joint leaves a long flank, so another
    solver or summation order would move the sums of squares by far more than rounding).
    A flank whose joint is the same in every trial (a scan turns one joint) is fitted once."""
    G = np.asarray(G, float)
    T, m = G.shape[0], q.shape[0]
    phi = G[:, 3:5]
    e = np.stack([np.cos(phi), np.sin(phi)], axis=2)                                   # (T, 2 joints, 2)
    tan = np.stack([-e[:, :, 1], e[:, :, 0]], axis=2) * (sense * np.array([-1.0, 1.0]))[:, None]
    t0 = G[:, None, :2] + G[:, 2, None, None] * e
    rel = q[None, :, None, :] - t0[:, None, :, :]                                      # (T, m, 2, 2)
    x = np.einsum("tmjk,tjk->tmj", rel, tan)
    y = np.einsum("tmjk,tjk->tmj", rel, e)
    order = np.arange(m)
    v = q[None, :, :] - G[:, None, :2]
    res = np.sqrt(np.einsum("tij,tij->ti", v, v)) - G[:, 2, None]                      # (T, m)
    counted = w > 0
    for j, before in ((0, order < tip), (1, order > tip)):
        on = before[None, :] & (x[:, :, j] > 0.0)                                      # (T, m) this flank's points
        same = (G[:, [0, 1, 2, 3 + j]] == G[0, [0, 1, 2, 3 + j]]).all()
        for t in range(1 if same else T):
            sel = on[t]
            if not sel.any():
                continue
            xs, ys = x[t, sel, j], y[t, sel, j]
            f, df, _ = _flank(xs, ys, counted[sel])
            if same:
                res[:, sel] = (ys - f) / np.sqrt(1.0 + df * df)
            else:
                res[t, sel] = (ys - f) / np.sqrt(1.0 + df * df)
    out = np.empty(T)
    for t in range(T):
        d = res[t][counted]
        out[t] = d @ d
    return out


def _start(q, w, sense, tip, tolerance, steps=48):
    """Start of the edge model. For the circles through three consecutive points near the
    tip (the tip itself may end the arc where the points are uneven), grown by
    :func:`_grown`: each joint angle scanned from just inside the grown arc's end to a quarter
    turn beyond it, twice in turn (a joint in a wide gap between points leaves local minima
    for the fit), then the least-squares fit. Best: most points within
    ``tolerance``, then the smallest sum of squares."""
    m = q.shape[0]
    best, key = None, None
    ang = lambda c, i: float(np.arctan2(q[i, 1] - c[1], q[i, 0] - c[0]))  # noqa: E731
    seen = set()
    for a in range(max(tip - 4, 0), min(tip + 3, m - 2)):
        c, r, lo, hi = _grown(q, w, a, a + 2, tolerance)
        if (lo, hi) in seen:
            continue
        seen.add((lo, hi))
        g = np.array([c[0], c[1], r, ang(c, lo), ang(c, hi)])
        for _ in range(2):
            for k in (0, 1):
                a0 = ang(c, lo if k == 0 else hi)
                trial = np.repeat(g[None, :], steps, axis=0)
                trial[:, 3 + k] = a0 + (1.0 if k else -1.0) * sense * np.linspace(-0.5, 0.5 * np.pi, steps)
                g = trial[int(np.argmin(_costs(q, w, trial, sense, tip)))]
        g = _fit(q, w, g, sense, tip)
        d = np.abs(_model(q, w, g, sense, tip)[w > 0])
        k = (-int((d < tolerance).sum()), float(d @ d))
        if key is None or k < key:
            best, key = g, k
    return best


def _fit(q, w, g0, sense, tip):
    def fun(g):
        energy = [0.0, 0.0]
        res = _model(q, w, g, sense, tip, energy=energy)[w > 0]
        return np.concatenate([res, np.sqrt(np.maximum(energy, 0.0))])
    sol = least_squares(fun, g0, method="lm", x_scale="jac", max_nfev=400)
    return sol.x


def _constant_curvature(z, arc, r, noise):
    """Whether the good arc points turn as one circle: the circle through every three
    consecutive ones has a curvature within ``ARC_CURVATURE_TOLERANCE`` of 1/r, plus
    ``CURVATURE_SIGMAS`` times what the noise does to it. Three points ``h1``, ``h2`` apart
    whose normal offsets have a standard deviation ``noise`` give a curvature with standard
    deviation ``2 noise sqrt(1/(h1 h2)² + 1/(h1 (h1+h2))² + 1/(h2 (h1+h2))²)`` (the middle
    point moves the sagitta over ``h1 h2 / 2``, an end one over ``h (h1+h2) / 2``): at random
    spacing a close pair makes its triples blind, the others still judge. An edge whose
    curvature grows and falls along it (an elliptical or designed edge) fits a circle plus
    flanks within a few µm when the flanks take up the difference; the points themselves
    say otherwise."""
    i = np.flatnonzero(arc[:-2] & arc[1:-1] & arc[2:])
    if i.size == 0:
        return True
    a, b, c = z[i], z[i + 1], z[i + 2]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    h1, h2, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1))
    kappa = 2.0 * np.abs(cross) / np.maximum(h1 * h2 * ca, 1e-300)
    h1, h2 = np.maximum(h1, 1e-300), np.maximum(h2, 1e-300)
    spread = 2.0 * noise * np.sqrt((h1 * h2) ** -2.0 + (h1 * (h1 + h2)) ** -2.0 + (h2 * (h1 + h2)) ** -2.0)
    return bool(np.all(np.abs(kappa * r - 1.0) <= ARC_CURVATURE_TOLERANCE + CURVATURE_SIGMAS * spread * r))


def judge_edge(q: np.ndarray, index: np.ndarray, end: int, sense: float, threshold: float,
               noise: float = 0.0, max_runs: int = 1, longest: int = MAX_RUN, reach: int = 3) -> EdgeJudgement:
    """Bad points of one edge zone ``q[index]`` against the circular-arc edge model.

    Leave-run-out: when a point of the zone is farther than ``threshold`` from the model
    fitted to all of them, or their rms exceeds what a fair edge leaves (a sixth of the
    threshold, or ``NOISE_FACTOR`` times the flanks' ``noise``), every run of 1..``longest``
    consecutive points within ``reach`` of the worst point is left out in turn and the model
    refitted without it; the run kept is the shortest that leaves about the smallest sum of
    squares (within the threshold squared), and of it only the points the refitted model
    does not reach are bad (a run left out with
    clean neighbours keeps them). A run cannot hide by pulling the model: the model that
    judges it never saw it. One run per edge (``max_runs``); the edge is then judged only if
    the rest fits as a fair circular edge (:func:`_constant_curvature`, the rms, a radius
    smaller than half the zone's width, at least two good arc points); otherwise it is not
    judged and nothing in it is flagged.
    """
    z = q[index]
    m = z.shape[0]
    if m < MIN_ZONE_POINTS:
        nan = np.full(m, np.nan)
        return EdgeJudgement(end, index, np.zeros(m, bool), nan, np.full((m, 2), np.nan), float("nan"), False,
                             f"{m} points in the edge zone: too few to judge the edge")
    tip = int(np.argmin(z[:, 0]) if end == 0 else np.argmax(z[:, 0]))
    w = np.ones(m)
    g = _start(z, w, sense, tip, 0.5 * threshold)
    d = np.abs(_model(z, w, g, sense, tip))
    floor = max(NOISE_FACTOR * noise, threshold / 6.0)
    for _ in range(max_runs):
        counted = w > 0
        if d[counted].max() <= threshold and np.sqrt(np.mean(d[counted] ** 2)) <= floor:
            break          # (a run that pulled the model within the threshold still spoils its fit)
        worst = int(np.argmax(np.where(counted, d, -1.0)))
        def left_out(centre, before, after, start):
            """Each run of 1..longest counted points from ``centre - before - k + 1`` to
            ``centre + after`` left out in turn, the model refitted from ``start``."""
            out = []
            for k in range(1, longest + 1):
                for first in range(max(centre - before - k + 1, 0), min(centre + after, m - k) + 1):
                    if not counted[first:first + k].all():
                        continue
                    w2 = w.copy()
                    w2[first:first + k] = 0.0
                    g2 = _fit(z, w2, start, sense, tip)
                    out.append((_cost(z, w2, g2, sense, tip), first, k, g2))
            return out

        trials = left_out(worst, reach, reach, g)
        # a run over the apex pulls the first model into another basin, and its worst point
        # may then lie off the run: the runs over the tip are also fitted from a start grown
        # without the tip's five points
        apex = w.copy()
        apex[max(tip - 2, 0):tip + 3] = 0.0
        if (apex > 0).sum() >= MIN_ZONE_POINTS - 5:
            trials += left_out(tip, 0, 0, _start(z, apex, sense, tip, 0.5 * threshold))
        if not trials:
            break
        # the few best left-out runs again from fresh starts: the model the run pulled may sit
        # in a basin the refit without the run does not leave
        refined = []
        for _, first, k, g2 in sorted(trials, key=lambda r: r[0])[:FRESH_STARTS]:
            w2 = w.copy()
            w2[first:first + k] = 0.0
            fits = [(_cost(z, w2, cand, sense, tip), cand) for cand in (g2, _start(z, w2, sense, tip, 0.5 * threshold))]
            c, cand = min(fits, key=lambda f: f[0])
            refined.append((c, first, k, cand))
        # the shortest run that fits the rest about as well as the best: leaving out a clean
        # neighbour as well lowers the sum of squares by its noise, a bad point by more than
        # the threshold squared
        lowest = min(r[0] for r in refined)
        _, first, k, g2 = min((r for r in refined if r[0] <= lowest + threshold ** 2), key=lambda r: (r[2], r[0]))
        w2 = w.copy()
        w2[first:first + k] = 0.0
        d2 = np.abs(_model(z, w2, g2, sense, tip))
        out = np.zeros(m, bool)
        out[first:first + k] = d2[first:first + k] > threshold
        if not out.any():              # the model left without them reaches them all: no run
            break
        w[out] = 0.0
        g = _fit(z, w, g2, sense, tip)
        d = np.abs(_model(z, w, g, sense, tip))
    bad = w == 0
    res, foot, piece = _model(z, w, g, sense, tip, with_feet=True)
    d = np.abs(res)
    arc_good = int(((piece == 1) & ~bad).sum())
    rms = float(np.sqrt(np.mean(d[~bad] ** 2)))
    if (d[~bad].max() > threshold or rms > floor or arc_good < 2 or not 0 < g[2] < 0.5 * np.ptp(z[:, 1])
            or not _constant_curvature(z, (piece == 1) & ~bad, g[2], noise)):
        return EdgeJudgement(end, index, np.zeros(m, bool), d, foot, float("nan"), False,
                             f"the edge is not a circular arc within {threshold * 1000:.1f} µm "
                             f"({int(bad.sum())} of {m} points left out, the rest {rms * 1000:.1f} µm rms, "
                             f"{d[~bad].max() * 1000:.1f} µm at worst): not judged")
    return EdgeJudgement(end, index, bad, d, foot, float(g[2]), True,
                         f"circular arc of radius {g[2]:.4f} mm through {arc_good} good points")


def judge_edges(points: np.ndarray, threshold: float, noise: float = 0.0, fraction: float = EDGE_FRACTION):
    """Both edges of a closed, ordered section (n, 3) mm. Returns ``(bad (n,) bool,
    distance (n,) mm (nan outside the judged zones), replacement (n, 3) mm (the foot on the
    edge model; nan where none), [EdgeJudgement, EdgeJudgement])``."""
    P = np.asarray(points, float)
    n = P.shape[0]
    o, axes, q = section_plane(P)
    area2 = np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1])
    sense = 1.0 if area2 > 0 else -1.0
    bad = np.zeros(n, bool)
    dist = np.full(n, np.nan)
    feet = np.full((n, 3), np.nan)
    out = []
    for end in (0, 1):
        idx = edge_zone(q, end, fraction)
        j = judge_edge(q, idx, end, sense, threshold, noise)
        out.append(j)
        if j.judged:
            bad[idx] = j.bad
            dist[idx] = j.distance
            # back to 3D, keeping each point's measured offset from the plane
            off = (P[idx] - o) - q[idx] @ axes
            feet[idx] = o + j.foot @ axes + off
    return bad, dist, feet, out
