# SPDX-License-Identifier: LGPL-2.1-or-later
"""Zone best fit: the rigid motion that minimises the largest zone-normalised deviation (mm, degrees).

Issue 19 §3. Each measured point P_i has a profile-zone half-width h_i (mm, from the
inspection plan: leading edge, trailing edge or flank of its section). Least squares
(:func:`bladerecon.core.analysis.alignment.best_fit`) minimises the sum of squared
deviations; an inspection asks instead whether *some* placement puts every point inside
its zone, i.e. the minimax (Chebyshev) fit

    min over (R, t)   max_i  | n_i · (R P_i + t − F_i) | / h_i

with F_i the closest nominal point and n_i the outward unit normal there. Linearising the
rotation about the centroid c, R ≈ I + [w]x (as the least-squares fit does, Chen & Medioni
1992), the deviation is affine in (w, t):

    d_i(w, t) ≈ r_i + ((P_i − c) × n_i) · w + n_i · t

and the minimax of affine functions is the linear programme

    min s   subject to   −s ≤ d_i(w, t) / h_i ≤ s   for every i,   |w|·L, |t| ≤ ρ

(s, w, t unknown; the box of side ρ mm, L the cloud's radius, is a trust region that keeps
the step where the linearisation holds; a cost of 1e-3 per mm of motion added to s picks the
smallest motion among near-equal ones: a blade barely fixes its slide along the span, and
the end sections would otherwise slide off the nominal's ends). It is solved by scipy's ``linprog`` (HiGHS). The
exact rotation exp([w]x) (Rodrigues) is composed onto the motion, the points re-projected
and the largest normalised deviation measured exactly; a step that does not lower it is
retried with ρ/4 (a sequential linear programme with a trust region, e.g. Nocedal & Wright,
*Numerical Optimization*, §18.5). It starts from the least-squares fit when given one.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from bladerecon.core.analysis.alignment import Projector, _angle_axis, _rodrigues, apply_transform
from bladerecon.core.errors import BladeReconError

__all__ = ["ZoneFit", "zone_fit", "normalised_deviation"]

_MAX_ITER = 40
_REL_STOP = 1e-7        # a step that lowers the largest normalised deviation by less than this stops
_RHO_MIN = 1e-9         # mm: trust region this small: no better motion nearby
_MOTION_COST = 1e-3     # per mm of motion (|x|₁), in units of the normalised deviation: a tie-break


@dataclass(frozen=True)
class ZoneFit:
    """Result of :func:`zone_fit`: ``matrix`` (4x4, mm) moves the measured points;
    ``max_normalised`` is the largest |deviation| / half-width after it (≤ 1: inside every
    zone), ``max_normalised_start`` the same at the start motion; ``history`` the value
    after each accepted step; ``lp_seconds`` the time spent in ``linprog``."""

    matrix: np.ndarray
    max_normalised: float
    max_normalised_start: float
    iterations: int
    projections: int
    converged: bool
    rotation_deg: float
    axis: np.ndarray
    translation_mm: np.ndarray
    history: list = field(default_factory=list)
    seconds: float = 0.0
    lp_seconds: float = 0.0

    @property
    def inside(self) -> bool:
        """True when every point lies inside its zone after the fit."""
        return self.max_normalised <= 1.0

    def as_dict(self) -> dict:
        return {"mode": "zone", "matrix": self.matrix.tolist(), "rotation_deg": self.rotation_deg,
                "axis": self.axis.tolist(), "translation_mm": self.translation_mm.tolist(),
                "max_normalised": self.max_normalised, "max_normalised_start": self.max_normalised_start,
                "iterations": self.iterations, "projections": self.projections,
                "converged": self.converged, "seconds": self.seconds}


def normalised_deviation(points: np.ndarray, project: Projector, halfwidth: np.ndarray):
    """Signed distances (mm), their gradients in the point, and distance / half-width.

    The distance is |P − F| signed by the outward normal, so a point whose foot lies on a
    boundary edge of the nominal (off the end of the blade surface) counts its whole
    distance; its gradient is then (P − F)/d rather than the normal at the edge."""
    foot, normal = project(points)
    normal = np.asarray(normal, float)
    off = points - np.asarray(foot, float)
    along = np.einsum("ij,ij->i", off, normal)
    dist = np.linalg.norm(off, axis=1)
    r = np.where(along < 0, -dist, dist)
    use = dist > 1e-9 * max(float(dist.max()), 1.0)
    grad = normal.copy()
    grad[use] = off[use] / r[use, None]
    return r, grad, r / halfwidth


def _lp_step(P: np.ndarray, r: np.ndarray, n: np.ndarray, h: np.ndarray, c: np.ndarray, L: float, rho: float):
    """One linear programme: (w rad (3,), t mm (3,), predicted max normalised deviation)."""
    from scipy.optimize import linprog

    arm = np.cross(P - c, n) / L                  # unknown w·L (mm) keeps the columns alike in size
    J = np.hstack([arm, n]) / h[:, None]
    g = r / h
    m = len(r)
    ones = np.ones((m, 1))
    # motion x = x+ − x− (both ≥ 0) so that a small cost on |x|₁ picks, among motions as good
    # (a blade barely fixes its slide along the span), the one nearest the start
    A = np.vstack([np.hstack([J, -J, -ones]), np.hstack([-J, J, -ones])])
    b = np.concatenate([-g, g])
    cost = np.full(13, _MOTION_COST)
    cost[12] = 1.0
    res = linprog(cost, A_ub=A, b_ub=b, bounds=[(0, rho)] * 12 + [(0, None)], method="highs")
    if res.status != 0:
        raise BladeReconError(f"zone fit: the linear programme failed ({res.message}); "
                              "use the least-squares fit (fit.mode = \"rigid\")")
    x = res.x[:6] - res.x[6:12]
    s = float(np.abs(g + J @ x).max())               # the model's value without the motion cost
    return x[:3] / L, x[3:6], s


def zone_fit(points: np.ndarray, project: Projector, halfwidth: np.ndarray, *, start: np.ndarray | None = None,
             max_iter: int = _MAX_ITER) -> ZoneFit:
    """Minimax rigid fit of ``points`` (m, 3) mm to the nominal, each point's deviation
    divided by its zone half-width ``halfwidth`` (m,) mm (module docstring).

    ``project(P) -> (foot, outward unit normal)`` as for ``best_fit``; ``start`` a 4x4
    motion to begin from (the least-squares fit), default the identity. Points with an
    infinite half-width (no zone) do not count.
    """
    t0 = time.perf_counter()
    P0 = np.asarray(points, float)
    h = np.asarray(halfwidth, float)
    if P0.ndim != 2 or P0.shape[1] != 3 or len(P0) < 12:
        raise BladeReconError("zone fit needs at least 12 points (m, 3), mm")
    if h.shape != (len(P0),) or np.any(~(h > 0)):
        raise BladeReconError("zone fit: every point needs a positive zone half-width (mm)")
    keep = np.isfinite(h)
    if keep.sum() < 12:
        raise BladeReconError("zone fit: fewer than 12 points have a tolerance zone: give the plan's [profile]")
    P0, h = P0[keep], h[keep]
    M = np.eye(4) if start is None else np.asarray(start, float).copy()
    P = apply_transform(P0, M)
    c = P.mean(axis=0)
    L = float(np.max(np.linalg.norm(P - c, axis=1))) or 1.0
    r, n, g = normalised_deviation(P, project, h)
    best = float(np.abs(g).max())
    history, projections, lp_time = [best], 1, 0.0
    start_value = best
    rho = max(4.0 * float(np.abs(r).max()), 1e-3)
    converged, it = False, 0
    for it in range(1, max_iter + 1):
        tl = time.perf_counter()
        w, t, predicted = _lp_step(P, r, n, h, c, L, rho)
        lp_time += time.perf_counter() - tl
        if best - predicted <= _REL_STOP * max(best, 1e-12):
            converged = True                  # the linear model sees no better motion
            break
        R = _rodrigues(w)
        step = np.eye(4)
        step[:3, :3] = R
        step[:3, 3] = c - R @ c + t
        M_try = step @ M
        P_try = apply_transform(P0, M_try)
        r_try, n_try, g_try = normalised_deviation(P_try, project, h)
        projections += 1
        value = float(np.abs(g_try).max())
        if value < best - _REL_STOP * best:
            gain = best - value
            M, P, r, n, best = M_try, P_try, r_try, n_try, value
            history.append(best)
            c = P.mean(axis=0)
            step_size = max(float(np.abs(t).max()), float(np.abs(w).max()) * L)
            rho = max(2.0 * step_size, 1e-6)
            if gain <= _REL_STOP * best:
                converged = True
                break
        else:
            rho /= 4.0
            if rho < _RHO_MIN:
                converged = True
                break
    angle, axis = _angle_axis(M[:3, :3])
    return ZoneFit(M, best, start_value, it, projections, converged, angle, axis, M[:3, 3].copy(), history,
                   time.perf_counter() - t0, lp_time)
