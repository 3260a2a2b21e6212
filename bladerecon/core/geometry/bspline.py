# SPDX-License-Identifier: LGPL-2.1-or-later
"""Vectorised B-spline basics: parameters, knot vectors, basis functions, evaluation.

Every function works on arrays of parameters at once (no Python loop per point; the only
loops run over the degree, i.e. at most 4 times for a cubic).

Notation follows The NURBS Book (Piegl & Tiller, 2nd ed.): degree ``p``, full knot vector
``U = (u_0..u_{n+p})`` for ``n`` poles. Periodic splines use OpenCASCADE's convention
(see :mod:`bladerecon.core.geometry.spline`) and are evaluated through their "unwrapped" clamped-free
equivalent.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface, full_knot_vector

__all__ = [
    "chord_parameters",
    "centripetal_parameters",
    "uniform_parameters",
    "closed_parameters",
    "averaged_knots",
    "approximation_knots",
    "find_spans",
    "basis_functions",
    "basis_derivatives",
    "collocation_matrix",
    "curve_derivatives",
    "evaluate_curve",
    "curve_curvature",
    "surface_derivatives",
    "evaluate_surface",
    "wrap_parameters",
]


# --------------------------------------------------------------------------- parameters
def _segment_lengths(points: np.ndarray, closed: bool) -> np.ndarray:
    pts = np.asarray(points, dtype=float)
    if closed:
        pts = np.concatenate([pts, pts[:1]], axis=0)
    return np.linalg.norm(np.diff(pts, axis=0), axis=1)


def _normalised_cumsum(lengths: np.ndarray) -> np.ndarray:
    total = lengths.sum()
    if not total > 0:
        return np.linspace(0.0, 1.0, lengths.size + 1)
    return np.concatenate([[0.0], np.cumsum(lengths)]) / total


def uniform_parameters(n: int, closed: bool = False) -> np.ndarray:
    """Equally spaced parameters on [0, 1] (closed: on [0, 1), the closing point left out)."""
    return np.arange(n) / n if closed else np.linspace(0.0, 1.0, n)


def chord_parameters(points: np.ndarray, closed: bool = False) -> np.ndarray:
    """Chord-length parameters (The NURBS Book eq. 9.5; seed 003 eq. 6), normalised to [0, 1].

    ``closed``: the segment from the last point back to the first counts, and the returned
    n parameters lie in [0, 1) (1 is the first point again).
    """
    u = _normalised_cumsum(_segment_lengths(points, closed))
    return u[:-1] if closed else u


def centripetal_parameters(points: np.ndarray, closed: bool = False) -> np.ndarray:
    """Centripetal parameters ``d_i = d_{i-1} + |p_i - p_{i-1}|^(1/2)`` (seed 000 §2.4; NURBS Book eq. 9.6)."""
    u = _normalised_cumsum(np.sqrt(_segment_lengths(points, closed)))
    return u[:-1] if closed else u


def closed_parameters(points: np.ndarray, kind: str = "centripetal") -> np.ndarray:
    """Parameters on [0, 1) for a closed loop of points (the closing point not repeated)."""
    kinds = {"centripetal": centripetal_parameters, "chord": chord_parameters}
    if kind == "uniform":
        return uniform_parameters(len(points), closed=True)
    return kinds[kind](points, closed=True)


# --------------------------------------------------------------------------- knot vectors
def averaged_knots(params: np.ndarray, degree: int, n_poles: int | None = None) -> np.ndarray:
    """Clamped knot vector by averaging (NURBS Book eq. 9.8; seed 000 eq. 8 for the ends).

    With ``n_poles == len(params)`` this is the interpolation knot vector. With
    ``n_poles == len(params) + 2`` (end derivatives given, seed 001 eqs. 3-4) the interior
    knots are the averages of every window of ``degree`` consecutive parameters
    (NURBS Book §9.2.2).
    """
    u = np.asarray(params, dtype=float)
    p = degree
    n_pts = u.size
    n_poles = n_pts if n_poles is None else n_poles
    n_inner = n_poles - p - 1
    if n_inner < 0:
        raise ValueError("too few poles for the degree")
    if n_poles == n_pts:
        window = p
        csum = np.concatenate([[0.0], np.cumsum(u)])
        inner = (csum[1 + window : 1 + window + n_inner] - csum[1 : 1 + n_inner]) / window
    elif n_poles == n_pts + 2:
        window = p
        csum = np.concatenate([[0.0], np.cumsum(u)])
        inner = (csum[window : window + n_inner] - csum[0:n_inner]) / window
    else:
        raise ValueError("averaged_knots: n_poles must be len(params) or len(params) + 2")
    return np.concatenate([np.full(p + 1, u[0]), inner, np.full(p + 1, u[-1])])


def approximation_knots(params: np.ndarray, degree: int, n_poles: int) -> np.ndarray:
    """Clamped knot vector for least squares (NURBS Book eq. 9.69; seed 003 eq. 7).

    ``d = (m+1)/(n-p+1)``; ``u_{p+j} = (1-a) ū_{i-1} + a ū_i`` with ``i = int(j d)``,
    ``a = j d - i`` for ``j = 1..n-p`` (here ``n + 1 = n_poles``, ``m + 1 = len(params)``).
    """
    u = np.asarray(params, dtype=float)
    p = degree
    m1 = u.size
    n = n_poles - 1
    if n_poles > m1:
        raise ValueError("more poles than data points")
    d = m1 / (n - p + 1)
    j = np.arange(1, n - p + 1)
    i = np.floor(j * d).astype(int)
    a = j * d - i
    inner = (1 - a) * u[i - 1] + a * u[np.minimum(i, m1 - 1)]
    return np.concatenate([np.full(p + 1, u[0]), inner, np.full(p + 1, u[-1])])


# --------------------------------------------------------------------------- basis
def wrap_parameters(u: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Map parameters of a periodic spline into [lo, hi)."""
    return lo + np.mod(np.asarray(u, dtype=float) - lo, hi - lo)


def find_spans(U: np.ndarray, degree: int, n_poles: int, u: np.ndarray) -> np.ndarray:
    """Knot span index of each parameter (NURBS Book A2.1, vectorised with searchsorted).

    ``n_poles`` counts the poles of the (unwrapped) spline: spans are clipped to
    ``[degree, n_poles - 1]`` so the right end of the domain falls in the last span.
    """
    span = np.searchsorted(U, u, side="right") - 1
    return np.minimum(np.maximum(span, degree), n_poles - 1)      # np.clip's numbers, less overhead


def basis_functions(U: np.ndarray, degree: int, span: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Non-zero basis functions N_{span-p..span, p}(u), shape (m, p+1) (NURBS Book A2.2)."""
    return basis_derivatives(U, degree, span, u, 0)[:, 0, :]


def basis_derivatives(U: np.ndarray, degree: int, span: np.ndarray, u: np.ndarray, n_ders: int) -> np.ndarray:
    """Basis functions and derivatives up to ``n_ders``: shape (m, n_ders+1, p+1) (NURBS Book A2.3).

    Vectorised over all parameters; the loops run over the degree only. A few parameters (the
    Newton iterations of a curve's chord ends) go through :func:`_basis_derivatives_few`: the
    same operations on plain floats, the same numbers, without ~100 numpy calls' overhead.
    """
    p = degree
    u = np.asarray(u, dtype=float)
    m = u.size
    span = np.asarray(span)
    if m <= _FEW and u.ndim == 1:
        out = _basis_derivatives_few(U, p, span, u, n_ders)
        if out is not None:
            return out
    ndu = np.zeros((p + 1, p + 1, m))
    ndu[0, 0] = 1.0
    left = np.zeros((p + 1, m))
    right = np.zeros((p + 1, m))
    for j in range(1, p + 1):
        left[j] = u - U[span + 1 - j]
        right[j] = U[span + j] - u
        saved = np.zeros(m)
        for r in range(j):
            ndu[j, r] = right[r + 1] + left[j - r]
            temp = ndu[r, j - 1] / ndu[j, r]
            ndu[r, j] = saved + right[r + 1] * temp
            saved = left[j - r] * temp
        ndu[j, j] = saved
    nd = min(n_ders, p)
    ders = np.zeros((n_ders + 1, p + 1, m))
    ders[0] = ndu[:, p]
    if nd > 0:
        a = np.zeros((2, p + 1, m))
        for r in range(p + 1):
            s1, s2 = 0, 1
            a[0, 0] = 1.0
            for k in range(1, nd + 1):
                d = np.zeros(m)
                rk, pk = r - k, p - k
                if r >= k:
                    a[s2, 0] = a[s1, 0] / ndu[pk + 1, rk]
                    d = a[s2, 0] * ndu[rk, pk]
                j1 = 1 if rk >= -1 else -rk
                j2 = k - 1 if r - 1 <= pk else p - r
                for j in range(j1, j2 + 1):
                    a[s2, j] = (a[s1, j] - a[s1, j - 1]) / ndu[pk + 1, rk + j]
                    d = d + a[s2, j] * ndu[rk + j, pk]
                if r <= pk:
                    a[s2, k] = -a[s1, k - 1] / ndu[pk + 1, r]
                    d = d + a[s2, k] * ndu[r, pk]
                ders[k, r] = d
                s1, s2 = s2, s1
        fac = p
        for k in range(1, nd + 1):
            ders[k] *= fac
            fac *= p - k
    return np.transpose(ders, (2, 0, 1))


_FEW = 4     # parameters up to which the basis is computed on plain floats


def _basis_derivatives_few(U: np.ndarray, p: int, span: np.ndarray, u: np.ndarray, n_ders: int) -> np.ndarray | None:
    """:func:`basis_derivatives` for a few parameters: each one's operations exactly as the
    vectorised code does them (IEEE operations on floats give the same results in numpy and
    Python), the result in the same memory layout; None on a zero division (numpy's inf/nan)."""
    nd = min(n_ders, p)
    ders = np.zeros((n_ders + 1, p + 1, u.size))
    Ul = U.tolist()
    for i, (uu, sp) in enumerate(zip(u.tolist(), span.tolist())):
        ndu = [[0.0] * (p + 1) for _ in range(p + 1)]
        ndu[0][0] = 1.0
        left, right = [0.0] * (p + 1), [0.0] * (p + 1)
        try:
            for j in range(1, p + 1):
                left[j] = uu - Ul[sp + 1 - j]
                right[j] = Ul[sp + j] - uu
                saved = 0.0
                for r in range(j):
                    ndu[j][r] = right[r + 1] + left[j - r]
                    temp = ndu[r][j - 1] / ndu[j][r]
                    ndu[r][j] = saved + right[r + 1] * temp
                    saved = left[j - r] * temp
                ndu[j][j] = saved
            out = [[ndu[r][p] for r in range(p + 1)]] + [[0.0] * (p + 1) for _ in range(n_ders)]
            a = [[0.0] * (p + 1), [0.0] * (p + 1)]
            for r in range(p + 1):
                s1, s2 = 0, 1
                a[0][0] = 1.0
                for k in range(1, nd + 1):
                    d = 0.0
                    rk, pk = r - k, p - k
                    if r >= k:
                        a[s2][0] = a[s1][0] / ndu[pk + 1][rk]
                        d = a[s2][0] * ndu[rk][pk]
                    j1 = 1 if rk >= -1 else -rk
                    j2 = k - 1 if r - 1 <= pk else p - r
                    for j in range(j1, j2 + 1):
                        a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][rk + j]
                        d = d + a[s2][j] * ndu[rk + j][pk]
                    if r <= pk:
                        a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r]
                        d = d + a[s2][k] * ndu[r][pk]
                    out[k][r] = d
                    s1, s2 = s2, s1
        except ZeroDivisionError:
            return None
        fac = p
        for k in range(1, nd + 1):
            out[k] = [v * fac for v in out[k]]
            fac *= p - k
        ders[:, :, i] = out
    return np.transpose(ders, (2, 0, 1))


def _prepare(knots, mults, degree, periodic, n_poles, u, U=None):
    """Full knot vector, spans and pole indices (periodic indices wrapped) for parameters u
    (``U``: the full knot vector when the caller has it)."""
    if U is None:
        U = full_knot_vector(knots, mults, degree, periodic)
    u = np.asarray(u, dtype=float).ravel()
    lo, hi = float(knots[0]), float(knots[-1])
    if periodic:
        u = wrap_parameters(u, lo, hi)
        n_unwrapped = n_poles + degree
    else:
        u = np.clip(u, lo, hi)
        n_unwrapped = n_poles
    span = find_spans(U, degree, n_unwrapped, u)
    idx = span[:, None] - degree + np.arange(degree + 1)[None, :]
    if periodic:
        idx = idx % n_poles
    return U, u, span, idx


def collocation_matrix(
    knots: np.ndarray, mults: np.ndarray, degree: int, periodic: bool, n_poles: int, u: np.ndarray, der: int = 0
) -> sp.csr_matrix:
    """Sparse matrix A (m, n_poles) with A[k, i] = N_i^(der)(u_k); periodic columns wrapped."""
    U, uu, span, idx = _prepare(knots, mults, degree, periodic, n_poles, u)
    vals = basis_derivatives(U, degree, span, uu, der)[:, der, :]
    rows = np.repeat(np.arange(uu.size), degree + 1)
    A = sp.coo_matrix((vals.ravel(), (rows, idx.ravel())), shape=(uu.size, n_poles))
    return A.tocsr()  # duplicates (wrapped periodic columns) are summed


# --------------------------------------------------------------------------- curves
def curve_derivatives(curve: BSplineCurve, u: np.ndarray, n_ders: int = 0, knot_vector=None) -> np.ndarray:
    """C^(k)(u) for k = 0..n_ders, shape (m, n_ders+1, dim) (NURBS Book A3.2, vectorised).
    ``knot_vector``: ``curve.full_knots()`` when the caller evaluates the curve many times."""
    U, uu, span, idx = _prepare(curve.knots, curve.mults, curve.degree, curve.periodic, curve.n_poles, u,
                                knot_vector)
    ders = basis_derivatives(U, curve.degree, span, uu, n_ders)  # (m, k, p+1)
    P = np.take(np.asarray(curve.poles, dtype=float), idx, axis=0)  # (m, p+1, dim): [idx]'s array, 10x faster
    return np.matmul(ders, P)


def evaluate_curve(curve: BSplineCurve, u: np.ndarray, knot_vector=None) -> np.ndarray:
    """Points C(u), shape (m, dim)."""
    return curve_derivatives(curve, u, 0, knot_vector)[:, 0, :]


def curve_curvature(curve: BSplineCurve, u: np.ndarray) -> np.ndarray:
    """Curvature ``|C' x C''| / |C'|^3`` (1/mm) of a 3D curve (parametric form of seed 000 eq. 4)."""
    d = curve_derivatives(curve, u, 2)
    c1, c2 = d[:, 1], d[:, 2]
    if c1.shape[1] == 2:
        num = np.abs(c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0])
    else:
        num = np.linalg.norm(np.cross(c1, c2), axis=1)
    return num / np.maximum(np.linalg.norm(c1, axis=1) ** 3, 1e-300)


# --------------------------------------------------------------------------- surfaces
_CHUNK = 200_000


def surface_derivatives(surface: BSplineSurface, u: np.ndarray, v: np.ndarray, n_ders: int = 0) -> np.ndarray:
    """Partial derivatives S^(k,l)(u,v) for k + l <= n_ders: shape (m, n_ders+1, n_ders+1, 3).

    Entry [:, k, l] is d^(k+l) S / du^k dv^l (NURBS Book A3.6, vectorised; evaluated in
    chunks so that a million points fit in memory).
    """
    u = np.asarray(u, dtype=float).ravel()
    v = np.asarray(v, dtype=float).ravel()
    if u.size != v.size:
        raise ValueError("u and v must have the same length")
    out = np.empty((u.size, n_ders + 1, n_ders + 1, 3))
    nu, nv = surface.shape
    P = np.asarray(surface.poles, dtype=float)
    for s in range(0, u.size, _CHUNK):
        uc, vc = u[s : s + _CHUNK], v[s : s + _CHUNK]
        Uu, uu, su, iu = _prepare(surface.u_knots, surface.u_mults, surface.u_degree, surface.u_periodic, nu, uc)
        Uv, vv, sv, iv = _prepare(surface.v_knots, surface.v_mults, surface.v_degree, surface.v_periodic, nv, vc)
        Nu = basis_derivatives(Uu, surface.u_degree, su, uu, n_ders)  # (m, k, p+1)
        Nv = basis_derivatives(Uv, surface.v_degree, sv, vv, n_ders)  # (m, l, q+1)
        G = P[iu[:, :, None], iv[:, None, :]]  # (m, p+1, q+1, 3)
        out[s : s + _CHUNK] = np.einsum("mka,mlb,mabd->mkld", Nu, Nv, G, optimize=True)
    return out


def evaluate_surface(surface: BSplineSurface, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Points S(u, v), shape (m, 3)."""
    return surface_derivatives(surface, u, v, 0)[:, 0, 0, :]
