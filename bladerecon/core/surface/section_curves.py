# SPDX-License-Identifier: LGPL-2.1-or-later
"""Section curves: one closed cubic B-spline per measured section, by interpolation or smoothing.

Stage "sections → curves" of the pipeline. Two ways to make a section curve:

* **interpolate** — periodic cubic through every point, centripetal parameters
  (seed 000 §2.4, eqs. 7 and 9). Right for sparse, accurate points (a measurement plan).
* **approximate** — periodic least squares with knots inserted where the residuals say the
  shape is not yet resolved (NURBS Book §9.4 with adaptive knots; seed 003 §1), parameters
  corrected by projecting the points on the curve (Hoschek), a small strain-energy term
  (seed 004 §1) against wiggles. Right for dense, noisy points.

:func:`choose_method` decides between them from point spacing against the estimated noise.
Units: mm.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.special import gammaincinv

from bladerecon.core.geometry.bspline import closed_parameters, collocation_matrix, curve_derivatives, evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.fitting import interpolate_closed_curve, smoothing_matrix, solve_sparse
from bladerecon.core.geometry.spline import BSplineCurve

__all__ = [
    "SectionCurve",
    "MethodChoice",
    "estimate_noise",
    "choose_method",
    "fit_section_interpolate",
    "fit_section_approximate",
    "refine_curve_parameters",
    "TANGENT_NOISE_LIMIT",
]

#: interpolation is chosen while noise/spacing (≈ tangent-direction noise, radians) stays below this
TANGENT_NOISE_LIMIT = 0.02


@dataclass(frozen=True)
class SectionCurve:
    """A closed section curve on its own parameter t ∈ [0, 1) and the measured points on it."""

    index: int
    curve: BSplineCurve
    t_points: np.ndarray   # parameter of each measured point's foot on the curve
    residual: np.ndarray   # distance of each measured point to the curve (mm)


@dataclass(frozen=True)
class MethodChoice:
    method: str            # "interpolate" | "approximate"
    reason: str
    noise_mm: float        # estimated noise (1 sigma per coordinate, mm)
    min_spacing_mm: float  # smallest distance between consecutive points over all sections
    tangent_noise: float   # noise_mm / min_spacing_mm


def _local_frames(points: np.ndarray, half: int) -> tuple[np.ndarray, np.ndarray]:
    """Tangent and an in-plane normal at every point of a closed loop, from its neighbours."""
    n = points.shape[0]
    fwd = points[(np.arange(n) + half) % n]
    bwd = points[(np.arange(n) - half) % n]
    t = fwd - bwd
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    # plane of the loop: normal from the PCA of the whole loop
    c = points - points.mean(axis=0)
    _, _, vt = np.linalg.svd(c, full_matrices=False)
    plane_n = vt[-1]
    nrm = np.cross(plane_n, t)
    nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
    return t, nrm


def estimate_noise(points: np.ndarray, half: int = 3) -> float:
    """Noise level (1 sigma per coordinate, mm) of a closed, ordered loop of points.

    A cubic ``y(x)`` is fitted in the local tangent frame of every window of ``2·half+1``
    consecutive points (all windows at once, batched normal equations); the median over the
    windows of the residual RMS, corrected for the 4 fitted coefficients, estimates sigma.
    The median keeps the few windows around a tight leading/trailing edge, where a cubic
    cannot follow the shape, from counting as noise.
    """
    P = np.asarray(points, dtype=float)
    n = P.shape[0]
    w = 2 * half + 1
    if n < w + 2:
        return 0.0
    t, nrm = _local_frames(P, half)
    idx = (np.arange(n)[:, None] + np.arange(-half, half + 1)[None, :]) % n
    d = P[idx] - P[:, None, :]                      # (n, w, 3)
    x = np.einsum("nwd,nd->nw", d, t)
    y = np.einsum("nwd,nd->nw", d, nrm)
    scale = np.maximum(np.abs(x).max(axis=1, keepdims=True), 1e-300)
    xs = x / scale
    V = np.stack([np.ones_like(xs), xs, xs**2, xs**3], axis=2)    # (n, w, 4)
    VtV = np.einsum("nwi,nwj->nij", V, V) + 1e-12 * np.eye(4)
    Vty = np.einsum("nwi,nw->ni", V, y)
    coef = np.linalg.solve(VtV, Vty[..., None])[..., 0]
    res = y - np.einsum("nwi,ni->nw", V, coef)
    dof = w - 4
    rms = np.sqrt((res**2).sum(axis=1) / dof)
    # Each window's rms² is σ²·χ²(dof)/dof, whose median is median(χ²(dof))/dof·σ² (0.79 σ² for
    # dof = 3): the median rms is 11 % low; the factor takes it back to σ on pure noise.
    chi2_median = 2.0 * gammaincinv(0.5 * dof, 0.5)
    return float(np.median(rms) * np.sqrt(dof / chi2_median))


def _loop_spacing(points: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.roll(points, -1, axis=0) - points, axis=1)


REPEAT_SIGMAS = 4.0        # consecutive points closer than this many noise sigmas: one spot measured again
REPEAT_SHARE = 0.05        # ... merged only while they are this few (else the data is dense: smoothing)


def repeated_measurements(sections: list[np.ndarray]) -> list[np.ndarray] | None:
    """Per section, a group number for each point (runs of consecutive points closer than
    REPEAT_SIGMAS noise sigmas, the closing pair included, share one), when such repeats are
    isolated: at most REPEAT_SHARE of the points and at most one in ten of every section's
    points. None when there are none, or so many that the data is dense (smoothing's case)."""
    sigma = float(np.median([estimate_noise(p) for p in sections]))
    radius = max(REPEAT_SIGMAS * sigma, 1e-4)
    groups, repeats, total = [], 0, 0
    for p in sections:
        close = _loop_spacing(np.asarray(p, float)) < radius          # point k and k+1 (mod n) together
        n = len(p)
        if close.sum() > 0.1 * n or close.all():
            return None
        g = np.concatenate([[0], np.cumsum(~close[:-1])])
        if close[-1] and g[-1] != g[0]:                                # the last point repeats the first
            g[g == g[-1]] = g[0]
        groups.append(g)
        repeats += int(close.sum())
        total += n
    if repeats == 0 or repeats > REPEAT_SHARE * total:
        return None
    return groups


def merge_groups(points: np.ndarray, group: np.ndarray) -> np.ndarray:
    """The mean point of each group, in the order the groups first appear."""
    _, first, inverse = np.unique(group, return_index=True, return_inverse=True)
    sums = np.zeros((first.size, points.shape[1]))
    np.add.at(sums, inverse.ravel(), points)
    merged = sums / np.bincount(inverse.ravel())[:, None]
    return merged[np.argsort(first)]


def choose_method(sections: list[np.ndarray]) -> MethodChoice:
    """Interpolate or smooth, decided from the data (point spacing against noise).

    Interpolating noisy points turns the noise into tangent noise of about
    ``sigma / spacing`` radians between the closest points: tens of micrometres of wiggle
    when points a few micrometres apart carry 2 µm of noise. While that ratio stays below
    :data:`TANGENT_NOISE_LIMIT` (≈1°) interpolation keeps every measured point and is the
    right choice (sparse plans, nominal tables); above it the section is smoothed.
    """
    sigmas = [estimate_noise(p) for p in sections]
    sigma = float(np.median(sigmas))
    spacing = float(min(_loop_spacing(p).min() for p in sections))
    ratio = sigma / max(spacing, 1e-12)
    if ratio > TANGENT_NOISE_LIMIT:
        why = (f"noise {sigma * 1000:.2f} µm against closest point spacing {spacing * 1000:.2f} µm "
               f"(ratio {ratio:.3f} > {TANGENT_NOISE_LIMIT}): interpolation would wiggle, smoothing")
        return MethodChoice("approximate", why, sigma, spacing, ratio)
    why = (f"noise {sigma * 1000:.2f} µm against closest point spacing {spacing * 1000:.1f} µm "
           f"(ratio {ratio:.4f} ≤ {TANGENT_NOISE_LIMIT}): interpolating every point")
    return MethodChoice("interpolate", why, sigma, spacing, ratio)


def refine_curve_parameters(curve: BSplineCurve, points: np.ndarray, t: np.ndarray,
                            iterations: int = 3) -> np.ndarray:
    """Move each parameter to the foot of its point on the curve (Newton, local, vectorised).

    Solves ``C'(t)·(C(t) − P) = 0`` (the curve form of seed 001 eq. 10) from a nearby start;
    the step is limited to a fraction of the parameter range so a point cannot jump across
    a thin edge to the other side of the blade.
    """
    t = np.asarray(t, dtype=float).copy()
    lo, hi = curve.domain
    max_step = 0.5 * (hi - lo) / max(curve.n_poles, 1)
    for _ in range(iterations):
        d = curve_derivatives(curve, t, 2)
        r = d[:, 0] - points
        g = np.einsum("nd,nd->n", d[:, 1], r)
        h = np.einsum("nd,nd->n", d[:, 1], d[:, 1]) + np.einsum("nd,nd->n", d[:, 2], r)
        h = np.where(h > 1e-300, h, np.einsum("nd,nd->n", d[:, 1], d[:, 1]))
        step = np.clip(-g / h, -max_step, max_step)
        t = t + step
        if curve.periodic:
            t = lo + np.mod(t - lo, hi - lo)
        else:
            t = np.clip(t, lo, hi)
        if np.max(np.abs(step)) < 1e-13:
            break
    return t


def fit_section_interpolate(index: int, points: np.ndarray) -> SectionCurve:
    """Periodic cubic interpolation of a closed section (seed 000 eqs. 7, 9; centripetal)."""
    u = closed_parameters(points, "centripetal")
    curve = interpolate_closed_curve(points, 3, params=u)
    return SectionCurve(index, curve, u, np.zeros(points.shape[0]))


def fit_section_approximate(index: int, points: np.ndarray, tolerance: float, rms_target: float | None = None,
                            max_poles: int | None = None, fairness: float = 1e-7,
                            max_rounds: int = 30) -> SectionCurve:
    """Periodic least-squares section with adaptive knots (fewest poles for the tolerance).

    Starts from uniform knots in chord-length parameter and inserts a knot in the middle of
    every span where a point is farther than ``tolerance`` from the curve, or where the RMS
    of the span's residuals exceeds ``rms_target`` (the noise-consistent criterion used by
    the automatic mode), until no span asks for more (NURBS Book §9.4.1 fitting with a
    knot-refinement loop). Parameters are corrected by projection after every solve.
    ``fairness`` weights the strain energy relative to the data term.
    """
    P = np.asarray(points, dtype=float)
    n = P.shape[0]
    max_poles = max_poles or max(8, n // 2)
    t = closed_parameters(P, "chord")
    n0 = int(min(max_poles, max(8, n // 40)))
    knots = np.linspace(0.0, 1.0, n0 + 1)
    curve = None
    for _ in range(max_rounds):
        mults = np.ones(knots.size, dtype=int)
        n_poles = knots.size - 1
        E = smoothing_matrix(knots, mults, 3, True, n_poles)
        for it in range(2):
            A = collocation_matrix(knots, mults, 3, True, n_poles, t)
            AtA = (A.T @ A).tocsc()
            lam = fairness * AtA.diagonal().sum() / max(E.diagonal().sum(), 1e-300)
            poles = solve_sparse(AtA + lam * E, A.T @ P)
            curve = BSplineCurve(poles, knots, mults, 3, True)
            t = refine_curve_parameters(curve, P, t, iterations=2)
        res = np.linalg.norm(evaluate_curve(curve, t) - P, axis=1)
        span = np.clip(np.searchsorted(knots, t, side="right") - 1, 0, n_poles - 1)
        count = np.bincount(span, minlength=n_poles)
        worst = np.zeros(n_poles)
        np.maximum.at(worst, span, res)
        bad = worst > tolerance
        if rms_target is not None:
            ss = np.bincount(span, weights=res**2, minlength=n_poles)
            rms = np.sqrt(ss / np.maximum(count, 1))
            bad |= (count >= 4) & (rms > rms_target)
        # a span is split only when both halves keep 2 points: a half with fewer is held by the
        # fairness term alone and waves between the points (1.5 mm off on a sliced 50 000-point
        # cloud whose random spacing left such spans, with 1500 poles on 1500 points)
        mid_of = 0.5 * (knots[:-1] + knots[1:])
        left = np.bincount(span, weights=(t < mid_of[span]).astype(float), minlength=n_poles)
        bad &= (left >= 2) & (count - left >= 2)
        if not bad.any() or n_poles >= max_poles:
            break
        mids = 0.5 * (knots[:-1] + knots[1:])[bad]
        room = max_poles - n_poles
        if mids.size > room:
            mids = mids[np.argsort(-worst[bad])[:room]]
        knots = np.sort(np.concatenate([knots, mids]))
    res = np.linalg.norm(curve_derivatives(curve, t, 0)[:, 0] - P, axis=1)
    if not np.all(np.isfinite(res)):
        raise BladeReconError(f"section {index}: the smoothing fit failed (non-finite result)")
    return SectionCurve(index, curve, t, res)
