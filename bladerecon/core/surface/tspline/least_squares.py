# SPDX-License-Identifier: LGPL-2.1-or-later
"""Least squares for the poles (seed 002 eqs. 7 and 10) by sparse normal equations, and the
least-squares bicubic tensor-product B-spline that seed 002 §3 compares the T-splines with.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

__all__ = ["tensor_least_squares", "_least_squares", "_RIDGE"]

_RIDGE = 1e-10


def _least_squares(A: sp.csc_matrix, rhs: np.ndarray, guess: np.ndarray, ridge: float | None = None) -> np.ndarray:
    """min ||A P - rhs||² (seed 002 eq. 7 / eq. 10) by sparse normal equations.

    A ridge of ``ridge`` × mean diagonal pulls poles towards ``guess`` only where the data
    leave them undetermined (empty supports), so a singular system cannot occur.
    """
    N = (A.T @ A).tocsc()
    diag = N.diagonal()
    lam = (_RIDGE if ridge is None else ridge) * max(float(diag.mean()) if diag.size else 1.0, 1e-300)
    N = N + lam * sp.identity(N.shape[0], format="csc")
    b = A.T @ rhs + lam * guess
    lu = spla.splu(N)
    return lu.solve(np.ascontiguousarray(b))


def tensor_least_squares(uv: np.ndarray, values: np.ndarray, nu: int, nv: int, knots: str = "uniform"
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares bicubic tensor-product B-spline (NURBS with unit weights) with nu x nv
    poles on [0,1]², clamped; interior knots ``uniform`` or ``averaged`` (NURBS Book eq.
    9.69 on the distinct parameter values of each direction; uniform where there are
    fewer distinct values than poles). Returns (poles (nu*nv, d),
    per-point error). The peer of seed 002 §3 (their NURBS fits use uniform knots)."""
    from bladerecon.core.geometry.bspline import approximation_knots, collocation_matrix

    values = np.asarray(values, float).reshape(len(uv), -1)
    mats = []
    for col, n in ((0, nu), (1, nv)):
        distinct = np.unique(uv[:, col])
        if knots == "averaged" and n <= len(distinct):   # else: uniform in that direction
            U = approximation_knots(distinct, 3, n)
            inner = U[4:-4]
        else:
            inner = np.linspace(0.0, 1.0, n - 2)[1:-1]
        kn = np.concatenate([[0.0], inner, [1.0]])
        mult = np.concatenate([[4], np.ones(len(inner), int), [4]])
        mats.append(collocation_matrix(kn, mult, 3, False, n, uv[:, col]).tocsr())
    Nu, Nv = mats
    m = len(uv)
    cu, du_ = Nu.indices.reshape(m, -1), Nu.data.reshape(m, -1)
    cv, dv_ = Nv.indices.reshape(m, -1), Nv.data.reshape(m, -1)
    cols = (cu[:, :, None] * nv + cv[:, None, :]).reshape(m, -1)
    vals = (du_[:, :, None] * dv_[:, None, :]).reshape(m, -1)
    A = sp.csc_matrix((vals.ravel(), (np.repeat(np.arange(m), cols.shape[1]), cols.ravel())), shape=(m, nu * nv))
    P = _least_squares(A, values, np.tile(values.mean(axis=0), (nu * nv, 1)))
    return P, np.linalg.norm(A @ P - values, axis=1)
