# SPDX-License-Identifier: LGPL-2.1-or-later
"""Curve fitting: global interpolation and least-squares approximation, sparse solves only.

All systems are banded (clamped) or cyclic-banded (periodic); they are assembled as sparse
collocation matrices and solved with ``scipy.sparse.linalg.splu`` — never a dense inverse.
Poles may have any dimension (3 for points; the surface code fits many rows at once by
stacking them as columns).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from bladerecon.core.geometry.bspline import (
    approximation_knots,
    averaged_knots,
    centripetal_parameters,
    chord_parameters,
    closed_parameters,
    collocation_matrix,
)
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.spline import BSplineCurve

__all__ = [
    "knots_from_full",
    "interpolate_curve",
    "interpolate_closed_curve",
    "interpolate_curve_with_end_derivatives",
    "periodic_knots_from_parameters",
    "uniform_periodic_knots",
    "smoothing_matrix",
    "least_squares_curve",
    "solve_sparse",
    "approximate_curve",
]


def knots_from_full(U: np.ndarray, tol: float = 1e-14) -> tuple[np.ndarray, np.ndarray]:
    """Distinct knots and multiplicities of a full knot vector."""
    U = np.asarray(U, dtype=float)
    new = np.concatenate([[True], np.diff(U) > tol])
    knots = U[new]
    mults = np.diff(np.concatenate([np.flatnonzero(new), [U.size]]))
    return knots, mults.astype(int)


def solve_sparse(A: sp.spmatrix, B: np.ndarray) -> np.ndarray:
    """Solve A X = B for a square sparse A (LU; raises BladeReconError when singular)."""
    try:
        lu = spla.splu(sp.csc_matrix(A))
        X = lu.solve(np.ascontiguousarray(B, dtype=float))
    except RuntimeError as exc:  # "Factor is exactly singular"
        raise BladeReconError(f"the fitting system is singular ({exc}); points may repeat or be collinear") from None
    if not np.all(np.isfinite(X)):
        raise BladeReconError("the fitting system is ill-conditioned (non-finite poles); check for repeated points")
    return X


def _params(points: np.ndarray, kind: str, closed: bool) -> np.ndarray:
    if closed:
        return closed_parameters(points, kind)
    if kind == "centripetal":
        return centripetal_parameters(points)
    if kind == "chord":
        return chord_parameters(points)
    return np.linspace(0.0, 1.0, len(points))


def interpolate_curve(points: np.ndarray, degree: int = 3, params: np.ndarray | None = None,
                      parameterisation: str = "centripetal") -> BSplineCurve:
    """Global clamped interpolation (NURBS Book A9.1; seed 000 eqs. 8-9).

    ``params`` default: centripetal (seed 000 §2.4). Knots by averaging (NURBS Book eq. 9.8).
    """
    Q = np.asarray(points, dtype=float)
    n = Q.shape[0]
    p = min(degree, n - 1)
    u = _params(Q, parameterisation, False) if params is None else np.asarray(params, float)
    U = averaged_knots(u, p)
    knots, mults = knots_from_full(U)
    A = collocation_matrix(knots, mults, p, False, n, u)
    P = solve_sparse(A, Q)
    return BSplineCurve(P, knots, mults, p, False)


def periodic_knots_from_parameters(params: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Distinct knots/mults of a periodic spline interpolating at ``params`` in [0, 1) (seed 000 eq. 7).

    Odd degree: knots at the parameters (then the collocation matrix is non-singular,
    Schoenberg-Whitney). Even degree: knots midway between parameters.
    """
    u = np.asarray(params, dtype=float)
    if degree % 2 == 0:
        nxt = np.concatenate([u[1:], [u[0] + 1.0]])
        k = 0.5 * (u + nxt)
        k = np.sort(np.mod(k, 1.0))
        knots = np.concatenate([k, [k[0] + 1.0]])
    else:
        knots = np.concatenate([u, [u[0] + 1.0]])
    return knots, np.ones(knots.size, dtype=int)


def interpolate_closed_curve(points: np.ndarray, degree: int = 3, params: np.ndarray | None = None,
                             parameterisation: str = "centripetal") -> BSplineCurve:
    """Periodic interpolation of a closed loop (closing point not repeated) (seed 000 eqs. 7, 9).

    Returns a periodic curve on [0, 1) with ``len(points)`` poles, passing through every point.
    """
    Q = np.asarray(points, dtype=float)
    n = Q.shape[0]
    if n < degree + 2:
        raise BladeReconError(f"a closed curve of degree {degree} needs at least {degree + 2} points, got {n}")
    u = _params(Q, parameterisation, True) if params is None else np.asarray(params, float)
    knots, mults = periodic_knots_from_parameters(u, degree)
    A = collocation_matrix(knots, mults, degree, True, n, u)
    P = solve_sparse(A, Q)
    return BSplineCurve(P, knots, mults, degree, True)


def interpolate_curve_with_end_derivatives(points: np.ndarray, d_start: np.ndarray, d_end: np.ndarray,
                                           degree: int = 3, params: np.ndarray | None = None,
                                           parameterisation: str = "chord") -> BSplineCurve:
    """Interpolation with prescribed end derivatives (seed 001 §1.1 eqs. 3-4; NURBS Book §9.2.2).

    n+1 points and two end derivatives give n+3 poles; the two extra equations are
    ``-P0 + P1 = (u_{p+1}/p) D0`` and ``-P_{n+1} + P_{n+2} = ((1-u_{m-p-1})/p) Dn``, written
    here as derivative rows of the collocation matrix (the same equations). Parameters by
    chord length (seed 001), knots by averaging. Derivatives are d/du on u in [0, 1].
    """
    Q = np.asarray(points, dtype=float)
    n_pts = Q.shape[0]
    p = degree
    if n_pts < 2:
        raise BladeReconError("end-derivative interpolation needs at least 2 points")
    u = _params(Q, parameterisation, False) if params is None else np.asarray(params, float)
    n_poles = n_pts + 2
    U = averaged_knots(u, p, n_poles)
    knots, mults = knots_from_full(U)
    A0 = collocation_matrix(knots, mults, p, False, n_poles, u)
    A1 = collocation_matrix(knots, mults, p, False, n_poles, np.array([u[0], u[-1]]), der=1)
    A = sp.vstack([A0[:1], A1[:1], A0[1:-1], A1[1:], A0[-1:]])
    B = np.vstack([Q[:1], np.atleast_2d(d_start), Q[1:-1], np.atleast_2d(d_end), Q[-1:]])
    P = solve_sparse(A, B)
    return BSplineCurve(P, knots, mults, p, False)


def uniform_periodic_knots(n_poles: int) -> tuple[np.ndarray, np.ndarray]:
    """Uniform periodic knots on [0, 1] for ``n_poles`` poles."""
    knots = np.linspace(0.0, 1.0, n_poles + 1)
    return knots, np.ones(n_poles + 1, dtype=int)


def smoothing_matrix(knots: np.ndarray, mults: np.ndarray, degree: int, periodic: bool, n_poles: int,
                     order: int = 2) -> sp.csr_matrix:
    """Gram matrix of the ``order``-th derivative: E = ∫ N_i^(k) N_j^(k) du (exact, Gauss-Legendre).

    ``c^T E c`` is the bending ("strain") energy ∫|C''|² du of seed 004 §1 for order 2.
    """
    p = degree
    ng = max(p - order + 1, 1)
    gx, gw = np.polynomial.legendre.leggauss(ng)
    a, b = knots[:-1], knots[1:]
    h = b - a
    live = h > 0
    a, h = a[live], h[live]
    u = (a[:, None] + 0.5 * h[:, None] * (gx[None, :] + 1.0)).ravel()
    w = (0.5 * h[:, None] * gw[None, :]).ravel()
    D = collocation_matrix(knots, mults, p, periodic, n_poles, u, der=order)
    return (D.T @ sp.diags(w) @ D).tocsr()


def least_squares_curve(points: np.ndarray, params: np.ndarray, knots: np.ndarray, mults: np.ndarray,
                        degree: int = 3, periodic: bool = False, smoothing: float = 0.0,
                        weights: np.ndarray | None = None, fix_ends: bool = False) -> BSplineCurve:
    """Least-squares B-spline with given knots (NURBS Book §9.4.1; seed 003 eq. 5).

    Minimises ``Σ w_k |C(u_k) - Q_k|² + smoothing · ∫|C''|² du`` (the smoothing term is the
    strain energy of seed 004; ``smoothing`` is in mm²·(parameter units)³ and is scaled by the
    caller). ``fix_ends`` (clamped only) makes the curve pass through the first and last point
    (NURBS Book A9.7's end conditions) by heavy weighting.
    """
    Q = np.asarray(points, dtype=float)
    u = np.asarray(params, dtype=float)
    if periodic:
        n_poles = int(np.sum(mults[:-1]))
    else:
        n_poles = int(np.sum(mults)) - degree - 1
    if Q.shape[0] < n_poles and smoothing <= 0:
        raise BladeReconError(f"least squares with {n_poles} poles needs at least {n_poles} points, got {Q.shape[0]}")
    A = collocation_matrix(knots, mults, degree, periodic, n_poles, u)
    w = np.ones(u.size) if weights is None else np.asarray(weights, float)
    if fix_ends and not periodic:
        w = w.copy()
        w[[0, -1]] = 1e8 * max(w.max(), 1.0)
    W = sp.diags(w)
    M = (A.T @ W @ A).tocsc()
    if smoothing > 0:
        M = M + smoothing * smoothing_matrix(knots, mults, degree, periodic, n_poles)
    M = M + sp.identity(n_poles, format="csc") * (1e-14 * max(abs(M).max(), 1.0))
    P = solve_sparse(M, A.T @ (w[:, None] * Q))
    return BSplineCurve(P, np.asarray(knots, float), np.asarray(mults, int), degree, periodic)


def approximate_curve(points: np.ndarray, n_poles: int, degree: int = 3, params: np.ndarray | None = None,
                      parameterisation: str = "chord") -> BSplineCurve:
    """Clamped least-squares approximation with ``n_poles`` poles, ends interpolated
    (NURBS Book A9.7 with knots by eq. 9.69; seed 003 §2)."""
    Q = np.asarray(points, dtype=float)
    u = _params(Q, parameterisation, False) if params is None else np.asarray(params, float)
    U = approximation_knots(u, degree, n_poles)
    knots, mults = knots_from_full(U)
    return least_squares_curve(Q, u, knots, mults, degree, False, fix_ends=True)

