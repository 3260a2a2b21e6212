# SPDX-License-Identifier: LGPL-2.1-or-later
"""Spanwise service deformation of a blade: per span height a rigid motion in the section plane.

Units: mm and degrees at the interface (radians inside). The span axis is z.

The model (issue 18 §3, after "Geometric model reconstruction and CNC machining for damaged
blade repair": a deformation function fitted against blade height): a point x of the
nominal at height z moves to

    F(x) = c + R(theta(z)) (x - c) + d(z)          (in the plane z = const)

with a twist ``theta(z)`` about the z axis through ``c`` and an in-plane shift ``d(z)``
(the bend). Each of theta, d_x, d_y is a cubic B-spline in z over the nominal's span,
fitted to the measured points' normal residuals (point-to-plane, linearised in the
increments; Gauss-Newton with the exact inverse motion between steps) with a
third-difference penalty (P-spline, Eilers & Marx 1996): its null space holds quadratics,
so a missing tip is extrapolated by the spanwise trend (a quadratic), and the stiffness
lambda is chosen by generalised cross-validation (Craven & Wahba 1979) - noise-aware: the
noisier the points, the stiffer the field. Outliers (damage) weigh nothing (Tukey's
biweight on the residuals, as the robust best fit).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline

__all__ = ["SpanField", "fit_span_field"]

_TUKEY_C = 4.685
_SETTLED_MM = 1e-3          # the z shift joins the fit when no point moved more than this (mm)
_CONVERGED_MM = 2e-5        # Gauss-Newton ends when no point moves more than this (mm)
_MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class SpanField:
    """theta(z) (rad), d(z) (mm) as cubic B-splines in z; twist axis through ``centre`` (xy)."""

    knots: np.ndarray           # full knot vector in z (mm)
    coef: np.ndarray            # (n, 3): d_x, d_y (mm), theta (rad)
    centre: np.ndarray          # (2,)
    z_range: tuple              # nominal span (mm)
    lam: float = 0.0            # the chosen stiffness
    edf: float = 0.0            # effective degrees of freedom
    shear: np.ndarray = None    # z shift and z slopes in x, y (mm, mm/mm): the out-of-plane motion

    def values(self, z) -> np.ndarray:
        """(m, 3): d_x, d_y (mm), theta (rad) at heights z (extrapolated beyond the range)."""
        z = np.atleast_1d(np.asarray(z, float))
        return _design(self.knots, z) @ self.coef

    def twist_deg(self, z) -> np.ndarray:
        return np.degrees(self.values(z)[:, 2])

    def apply(self, points: np.ndarray, inverse: bool = False) -> np.ndarray:
        """The field (or its exact inverse) applied to points (m, 3) mm: the in-plane
        motion at each height, then the out-of-plane part ``z += s0 + s1 (x - cx) + s2 (y - cy)``
        (a small tilt's z part; its in-plane part, a linear bend, is in d(z))."""
        P = np.asarray(points, float)
        if inverse:
            P = P.copy()
            P[:, 2] -= self._lift(P)
            return self._in_plane(P, True)
        out = self._in_plane(P, False)
        out[:, 2] += self._lift(out)
        return out

    def _lift(self, P: np.ndarray) -> np.ndarray:
        if self.shear is None:
            return np.zeros(len(P))
        s = self.shear
        return s[0] + s[1] * (P[:, 0] - self.centre[0]) + s[2] * (P[:, 1] - self.centre[1])

    def tilt_deg(self) -> tuple[float, float]:
        """The out-of-plane tilt (degrees) about y and x that the z slopes stand for."""
        s = np.zeros(3) if self.shear is None else self.shear
        return float(np.degrees(np.arctan(s[1]))), float(np.degrees(np.arctan(s[2])))

    def _in_plane(self, P: np.ndarray, inverse: bool) -> np.ndarray:
        val = self.values(P[:, 2])
        a = -val[:, 2] if inverse else val[:, 2]
        c = self.centre
        x, y = P[:, 0] - c[0], P[:, 1] - c[1]
        if inverse:
            x, y = x - val[:, 0], y - val[:, 1]
        out = P.copy()
        out[:, 0] = c[0] + np.cos(a) * x - np.sin(a) * y
        out[:, 1] = c[1] + np.sin(a) * x + np.cos(a) * y
        if not inverse:
            out[:, :2] += val[:, :2]
        return out


def _knots(z0: float, z1: float, n_spans: int) -> np.ndarray:
    inner = np.linspace(z0, z1, n_spans + 1)
    return np.concatenate([[z0] * 3, inner, [z1] * 3])


def _design(knots: np.ndarray, z: np.ndarray) -> np.ndarray:
    """Cubic B-spline basis at z; linear extrapolation of each basis beyond the ends would
    kink the field, so outside the knot range the polynomial end pieces continue."""
    n = len(knots) - 4
    eye = np.eye(n)
    return BSpline(knots, eye, 3, extrapolate=True)(z)


def _penalty(n: int, order: int = 3) -> np.ndarray:
    D = np.diff(np.eye(n), order, axis=0)
    return D.T @ D


def fit_span_field(points: np.ndarray, project, centre, z_range, *, n_spans: int = 8,
                   iterations: int = 20, radius: float = 25.0) -> tuple[SpanField, dict]:
    """Fit the field to measured points (m, 3) mm (already best-fitted to the nominal).

    ``project(Q, state) -> (foot, outward normal, signed distance, state)`` projects points
    onto the nominal (``state`` carries the feet between calls for local Newton). ``radius``
    (mm) scales the twist column so the penalty treats mm and rad alike. Returns the field
    and a dict with the final residuals ``signed`` (mm, + outside), ``weights`` (Tukey, 0 =
    outlier), ``normal``, ``foot`` (deformed nominal), ``state`` and ``noise_mm`` (robust
    scale of the residuals).
    """
    P = np.asarray(points, float)
    z0, z1 = float(z_range[0]), float(z_range[1])
    knots = _knots(z0, z1, n_spans)
    n = len(knots) - 4
    c = np.asarray(centre, float)[:2]
    coef = np.zeros((n, 3))
    shear = np.zeros(3)
    field = SpanField(knots, coef, c, (z0, z1), shear=shear)
    K = np.zeros((3 * n + 3, 3 * n + 3))
    pen = _penalty(n)
    for k in range(3):
        K[k * n:(k + 1) * n, k * n:(k + 1) * n] = pen
    state = None
    with_z = False
    w = np.ones(len(P))
    lam, edf = 0.0, 0.0
    for it in range(iterations):
        Q = field.apply(P, inverse=True)
        foot, normal, signed, state = project(Q, state)
        # the first step weighs every point: before the field is fitted the deformation
        # itself looks like outliers near the tip
        w = np.ones(len(P)) if it == 0 else _biweight(signed)
        # increments in the deformed frame: normal rotated forward with the field
        B = _design(knots, foot[:, 2])
        y = field.apply(foot)
        nd = field.apply(foot + normal) - y
        arm = np.stack([-(y[:, 1] - c[1]), y[:, 0] - c[0]], axis=1)     # k x (y - c)
        # out of the section planes: the z part of a small tilt (its in-plane part is a
        # linear bend, already in d(z): kept apart, the columns are not collinear) and a z
        # shift. On a twisted blade a z shift is nearly a twist and shift at every height (a
        # helix); only the taper of chord and thickness tells them apart, so it joins only
        # once the rest has settled and the damage weighs nothing (from the start, the
        # first steps, pulled by the damage, wander along the helix).
        A = np.concatenate([B * nd[:, :1], B * nd[:, 1:2],
                            B * ((arm * nd[:, :2]).sum(1) / radius)[:, None], nd[:, 2:3],
                            (nd[:, 2] * (y[:, 0] - c[0]) / radius)[:, None],
                            (nd[:, 2] * (y[:, 1] - c[1]) / radius)[:, None]], axis=1)
        x0 = np.concatenate([coef[:, 0], coef[:, 1], coef[:, 2] * radius, np.zeros(3)])
        AtW = A.T * w
        N = AtW @ A
        rhs = AtW @ signed
        ridge = np.zeros(len(x0))
        if not with_z:
            ridge[3 * n] = 1e6 * (np.trace(N) / len(x0) + 1.0)       # holds the z shift
        x, lam, edf = _gcv_solve(N + np.diag(ridge), rhs, K, x0, signed, A, w)
        moved = float(np.max(np.abs(A @ (x - x0))))     # largest move of a point along its normal (mm)
        coef = np.stack([x[:n], x[n:2 * n], x[2 * n:3 * n] / radius], axis=1)
        shear = shear + x[3 * n:] * np.array([1.0, 1.0 / radius, 1.0 / radius])
        field = SpanField(knots, coef, c, (z0, z1), lam, edf, shear)
        if with_z and moved < _CONVERGED_MM:
            break
        if not with_z and it >= 2 and (moved < _SETTLED_MM or it >= iterations // 2):
            with_z = True
    Q = field.apply(P, inverse=True)
    foot, normal, signed, state = project(Q, state)
    w = _biweight(signed)
    y = field.apply(foot)
    nd = field.apply(foot + normal) - y
    good = w > 0
    noise = _MAD_TO_SIGMA * float(np.median(np.abs(signed[good] - np.median(signed[good])))) if good.any() else 0.0
    return field, {"nominal_frame": Q, "signed": signed, "weights": w, "normal": nd, "foot": y, "state": state,
                   "noise_mm": noise}


def _biweight(r: np.ndarray) -> np.ndarray:
    """Tukey weights of the residuals, scale from their median absolute deviation."""
    s = _MAD_TO_SIGMA * float(np.median(np.abs(r - np.median(r))))
    s = max(s, 1e-6)
    u = r / (_TUKEY_C * s)
    return np.where(np.abs(u) < 1, (1 - u * u) ** 2, 0.0)


def _gcv_solve(N, rhs, K, x0, signed, A, w):
    """Increment solve with the penalty on the total coefficients x0 + dx; lambda by GCV.

    The 21 trial lambdas share one factorisation: with N = L Lᵀ (Cholesky) and
    L⁻¹ K L⁻ᵀ = V diag(μ) Vᵀ, (N + λK)⁻¹ = L⁻ᵀ V diag(1 / (1 + λμ)) Vᵀ L⁻¹, so each trial
    is O(n²) and its degrees of freedom trace((N + λK)⁻¹ N) = Σ 1 / (1 + λμ). The chosen
    lambda is solved again directly. Without a Cholesky factor (N not positive definite)
    every lambda is solved directly.
    """
    from scipy.linalg import eigh, solve_triangular

    scale = np.trace(N) / max(np.trace(K), 1e-300)
    m = float(w.sum())
    lams = scale * np.logspace(-8, 2, 21)
    try:
        L = np.linalg.cholesky(N)
    except np.linalg.LinAlgError:
        L = None
    if L is not None:
        Li_K = solve_triangular(L, K, lower=True)
        mu, V = eigh(solve_triangular(L, Li_K.T, lower=True))
        mu = np.maximum(mu, 0.0)                                   # K is semi-definite
        AV = A @ solve_triangular(L.T, V, lower=False)           # A L⁻ᵀ V
        best = None
        for lam in lams:
            c = V.T @ solve_triangular(L, rhs - lam * K @ x0, lower=True) / (1.0 + lam * mu)
            res = signed - AV @ c
            gcv = m * float((w * res * res).sum()) / max(m - float(np.sum(1.0 / (1.0 + lam * mu))), 1.0) ** 2
            if best is None or gcv < best[0]:
                best = (gcv, lam)
        lams = [best[1]]
    best = None
    for lam in lams:
        M = N + lam * K
        try:
            dx = np.linalg.solve(M, rhs - lam * K @ x0)
        except np.linalg.LinAlgError:
            continue
        res = signed - A @ dx
        rss = float((w * res * res).sum())
        edf = float(np.trace(np.linalg.solve(M, N)))
        gcv = m * rss / max(m - edf, 1.0) ** 2
        if best is None or gcv < best[0]:
            best = (gcv, x0 + dx, lam, edf)
    return best[1], best[2], best[3]
