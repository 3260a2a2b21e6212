# SPDX-License-Identifier: LGPL-2.1-or-later
"""Local bicubic (Bézier-patch) interpolation of a grid of blade points (seed 004 eqs. 9-11).

Seed 004 §2 (after The NURBS Book §9.3.5): one bicubic Bézier patch per grid cell. The
boundary control points of a patch come from the tangents of cubic interpolants of the grid
rows and columns, the four inner ones from the corner twist vectors; kept as a B-spline
with every interior knot doubled (eqs. 10-11) the surface has (2m+2)(2n+2) poles — the
rows and columns through the data points themselves are dropped, they are the midpoints of
their neighbours — and is C1 (G1) across the patch boundaries, not C2.

With ``Δu_k = u_{k+1} − u_k`` and the tangents ``T^u, T^v`` and twist ``T^{uv}`` at a grid
point Q, the four poles around Q are ``Q ± Δu/3 T^u ± Δv/3 T^v + (±Δu)(±Δv)/9 T^{uv}``
with the interval on the respective side. Tangents: derivatives of the cubic interpolants
of the rows (periodic around a closed section) and of the columns (clamped along the span);
twist: the span derivative of the column interpolant of ``T^u`` (the mixed partial of the
global bicubic interpolant, so neighbouring patches agree).

Units: mm.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.geometry.bspline import averaged_knots, collocation_matrix, curve_derivatives
from bladerecon.core.geometry.fitting import knots_from_full, periodic_knots_from_parameters, solve_sparse
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

__all__ = ["local_bicubic_surface", "bezier_patches"]


def _row_tangents(values: np.ndarray, u: np.ndarray, periodic: bool) -> np.ndarray:
    """d/du at the parameters of the cubic interpolants of many rows at once.

    ``values`` (N, k): N samples of k coordinates along u. Periodic: knots at the
    parameters (seed 000 eq. 7); clamped: averaged knots (NURBS Book eq. 9.8).
    """
    N = values.shape[0]
    if periodic:
        knots, mults = periodic_knots_from_parameters(u, 3)
    else:
        knots, mults = knots_from_full(averaged_knots(u, 3))
    A = collocation_matrix(knots, mults, 3, periodic, N, u)
    P = solve_sparse(A, values)
    D = collocation_matrix(knots, mults, 3, periodic, N, u, der=1)
    return D @ P


def local_bicubic_surface(grid: np.ndarray, u: np.ndarray, v: np.ndarray,
                          u_periodic: bool = True) -> BSplineSurface:
    """Local bicubic interpolation of ``grid`` (S, N, 3): S rows (sections, along v) of N
    points (around the section, along u) at common parameters ``u`` (N,) in [0, 1) (periodic)
    or [0, 1] and ``v`` (S,) in [0, 1]. Returns the C1 B-spline with double knots
    (seed 004 eqs. 9-11): 2N x 2S poles when periodic, (2N) x (2S) clamped too.
    """
    G = np.asarray(grid, float)
    S, N, _ = G.shape
    u = np.asarray(u, float)
    v = np.asarray(v, float)
    # T^u: rows along u; T^v and T^uv: columns along v
    Tu = _row_tangents(G.transpose(1, 0, 2).reshape(N, 3 * S), u, u_periodic).reshape(N, S, 3).transpose(1, 0, 2)
    Tv = _row_tangents(G.reshape(S, 3 * N), v, False).reshape(S, N, 3)
    Tuv = _row_tangents(Tu.reshape(S, 3 * N), v, False).reshape(S, N, 3)
    # interval before (−) and after (+) each parameter; 0 at a clamped end (pole = the point)
    if u_periodic:
        du_next = np.diff(np.concatenate([u, [u[0] + 1.0]]))
        du_prev = np.roll(du_next, 1)
    else:
        du_next = np.concatenate([np.diff(u), [0.0]])
        du_prev = np.concatenate([[0.0], np.diff(u)])
    dv_next = np.concatenate([np.diff(v), [0.0]])
    dv_prev = np.concatenate([[0.0], np.diff(v)])
    su = np.stack([-du_prev, du_next], axis=1) / 3.0        # (N, 2): offsets along u
    sv = np.stack([-dv_prev, dv_next], axis=1) / 3.0        # (S, 2)
    # poles[l, b, k, a] = Q + su[k,a] Tu + sv[l,b] Tv + su sv Tuv
    P = (G[:, None, :, None, :]
         + su[None, None, :, :, None] * Tu[:, None, :, None, :]
         + sv[:, :, None, None, None] * Tv[:, None, :, None, :]
         + (sv[:, :, None, None, None] * su[None, None, :, :, None]) * Tuv[:, None, :, None, :])
    P = P.reshape(2 * S, 2 * N, 3).transpose(1, 0, 2)       # (2N, 2S, 3): u index = 2k + a
    if u_periodic:
        P = np.roll(P, 1, axis=0)          # OCC periodic convention: pole 0 is the + pole of the last point
        u_knots = np.concatenate([u, [u[0] + 1.0]])
        u_mults = np.full(N + 1, 2)
    else:
        u_knots = u.copy()
        u_mults = np.concatenate([[4], np.full(N - 2, 2), [4]])
    v_knots = v.copy()
    v_mults = np.concatenate([[4], np.full(S - 2, 2), [4]])
    return BSplineSurface(np.ascontiguousarray(P), u_knots, u_mults, v_knots, v_mults, 3, 3, u_periodic, False)


def bezier_patches(surface: BSplineSurface) -> np.ndarray:
    """Bicubic Bézier control nets (n_u_spans, n_v_spans, 4, 4, 3) of a C1 double-knot surface.

    Every span of a cubic with double interior knots is one Bézier piece: the inner two
    control points are poles, the end points are the interval-weighted averages of the two
    poles around the knot (the data points of the local interpolation).
    """
    def pieces(knots, periodic, n_poles):
        k = np.asarray(knots, float)
        h = np.diff(k)
        n_sp = h.size
        # pole index of the "+" pole starting span j, and of the "−" pole ending it
        if periodic:
            plus = (2 * np.arange(n_sp) + 2) % n_poles
            minus_next = (2 * np.arange(n_sp) + 3) % n_poles
            prev_minus = (2 * np.arange(n_sp) + 1) % n_poles
            next_plus = (2 * np.arange(n_sp) + 4) % n_poles
            h_prev = np.roll(h, 1)
            h_next = np.roll(h, -1)
        else:
            plus = 2 * np.arange(n_sp) + 1
            minus_next = 2 * np.arange(n_sp) + 2
            prev_minus = 2 * np.arange(n_sp)
            next_plus = 2 * np.arange(n_sp) + 3
            h_prev = np.concatenate([[0.0], h[:-1]])
            h_next = np.concatenate([h[1:], [0.0]])
        # b0 = (h_j * P[prev_minus] + h_prev * P[plus]) / (h_prev + h_j), b3 likewise
        w0 = np.stack([h / (h_prev + h), h_prev / (h_prev + h)], axis=1)
        w3 = np.stack([h_next / (h + h_next), h / (h + h_next)], axis=1)
        return n_sp, plus, minus_next, prev_minus, next_plus, w0, w3

    P = np.asarray(surface.poles, float)
    nu, nv = surface.shape
    U = pieces(surface.u_knots, surface.u_periodic, nu)
    V = pieces(surface.v_knots, surface.v_periodic, nv)

    def along(Pm, spec, axis):
        n_sp, plus, minus_next, prev_minus, next_plus, w0, w3 = spec
        take = lambda idx: np.take(Pm, idx, axis=axis)  # noqa: E731
        shape = [1] * Pm.ndim
        shape[axis] = n_sp
        w = lambda a: a.reshape(shape)  # noqa: E731
        b0 = w(w0[:, 0]) * take(prev_minus) + w(w0[:, 1]) * take(plus)
        b3 = w(w3[:, 0]) * take(minus_next) + w(w3[:, 1]) * take(next_plus)
        return np.stack([b0, take(plus), take(minus_next), b3], axis=axis + 1)

    A = along(P, U, 0)            # (n_u_sp, 4, nv, 3)
    B = along(A, V, 2)            # (n_u_sp, 4, n_v_sp, 4, 3)
    return B.transpose(0, 2, 1, 3, 4)
