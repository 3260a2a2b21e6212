# SPDX-License-Identifier: LGPL-2.1-or-later
"""Blending functions: the cubic B-spline N[t0..t4](x), the sparse basis matrix
A_ji = B_i(u_j, v_j) (seed 002 eqs. 2, 7), and the cubic Bernstein polynomials.

Cubic blending functions ``B_i(u,v) = N[u_i](u) N[v_i](v)`` (eq. 2), evaluated by the
Cox–de Boor recursion vectorised over all points into a sparse basis matrix A. The
Bernstein polynomials and their inverse at four samples (``_BERN_T``, ``_BERN_INV``) give
the Bézier coefficients of a cubic, for the seam equations and the Bézier extraction.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

__all__ = [
    "bspline_basis_1d", "basis_matrix", "_PointIndex", "_column", "_bernstein", "_BERN_T", "_BERN_INV",
]


def bspline_basis_1d(knots: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Cubic B-spline N[t0..t4](x) by the Cox–de Boor recursion (NURBS Book eq. 2.5),
    0/0 = 0, half-open spans. ``knots`` (5,) or (m, 5) row per x; ``x`` (m,)."""
    t = np.broadcast_to(np.asarray(knots, float), (len(x), 5)) if np.ndim(knots) == 1 else knots
    x = np.asarray(x, float)
    N = [((t[:, k] <= x) & (x < t[:, k + 1])).astype(float) for k in range(4)]
    for p in range(1, 4):
        nxt = []
        for k in range(4 - p):
            d1 = t[:, k + p] - t[:, k]
            d2 = t[:, k + p + 1] - t[:, k + 1]
            a = np.divide(x - t[:, k], d1, out=np.zeros_like(x), where=d1 > 0)
            b = np.divide(t[:, k + p + 1] - x, d2, out=np.zeros_like(x), where=d2 > 0)
            nxt.append(a * N[k] + b * N[k + 1])
        N = nxt
    return N[0]


class _PointIndex:
    """Points sorted by u for fast support queries (rectangles in parameter space)."""

    def __init__(self, uv: np.ndarray) -> None:
        self.order = np.argsort(uv[:, 0], kind="stable")
        self.u = uv[self.order, 0]
        self.v = uv[self.order, 1]

    def in_box(self, u0: float, u1: float, v0: float, v1: float) -> np.ndarray:
        a = np.searchsorted(self.u, u0, side="left")
        b = np.searchsorted(self.u, u1, side="right")
        vv = self.v[a:b]
        return self.order[a:b][(vv >= v0) & (vv <= v1)]


def _column(index: _PointIndex, uv: np.ndarray, ku: np.ndarray, kv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    rows = index.in_box(ku[0], ku[4], kv[0], kv[4])
    vals = bspline_basis_1d(ku, uv[rows, 0]) * bspline_basis_1d(kv, uv[rows, 1])
    nz = vals != 0
    return rows[nz], vals[nz]


def basis_matrix(uv: np.ndarray, ku: np.ndarray, kv: np.ndarray, index: _PointIndex | None = None,
                 cache: dict | None = None, nodes: np.ndarray | None = None) -> sp.csc_matrix:
    """Sparse (m, n) matrix A_ji = B_i(u_j, v_j) (seed 002 eq. 2, eq. 7).

    One vectorised evaluation per node over the points in its support. With ``cache``
    (keyed by node position and knots) columns of unchanged blending functions are reused,
    so a refinement step only evaluates the new and changed ones.
    """
    if index is None:
        index = _PointIndex(uv)
    rows, cols, vals = [], [], []
    for i in range(len(ku)):
        key = None
        if cache is not None:
            key = (tuple(nodes[i]), tuple(ku[i]), tuple(kv[i]))
            hit = cache.get(key)
        if cache is None or hit is None:
            hit = _column(index, uv, ku[i], kv[i])
            if cache is not None:
                cache[key] = hit
        r, v = hit
        rows.append(r)
        vals.append(v)
        cols.append(np.full(len(r), i))
    A = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(len(uv), len(ku)))
    return A


_BERN_T = np.array([0.125, 0.375, 0.625, 0.875])


def _bernstein(t: np.ndarray) -> np.ndarray:
    s = 1.0 - t
    return np.stack([s ** 3, 3 * t * s * s, 3 * t * t * s, t ** 3], axis=-1)


_BERN_INV = np.linalg.inv(_bernstein(_BERN_T))
