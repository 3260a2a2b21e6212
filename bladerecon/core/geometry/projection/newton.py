# SPDX-License-Identifier: LGPL-2.1-or-later
"""Newton: the trust-region Newton iteration for the feet of many points on a surface or a
curve (seed 001 §2 eq. 10), vectorised over the points and refined on local Taylor models.

Eq. 10, S_u · (S - P) = 0 and S_v · (S - P) = 0, is solved by a trust-region Newton
iteration on f = |S - P|^2 / 2, vectorised over all points (the only Python loops run over
iterations, never over points). Each Newton step is refined on the local quadratic Taylor
model, and the last, tiny step is taken by Taylor expansion with a bound on its error, so
most points need only one or two evaluations after the start sample.

Where eq. 10 has no root - the foot on a clamped edge of the surface, or on a crease (a
knot of multiplicity >= degree) - Newton holds that parameter on the edge and minimises
along the other (the boundary case of eq. 11). Collapsed edges (S_u or S_v = 0, a cone
apex) are handled too.

Units: millimetres (points, feet, distances, ``tol``).
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.geometry.projection.evaluation import _CurveModel, _dot, _SurfaceModel

__all__ = [
    "_newton_surface", "_newton_curve", "_surface_step", "_foot_move", "_finish_size", "_smallest_eigenvalue",
    "_taylor", "_model_step", "_clip_step", "_curve_step", "_curve_taylor", "_curve_model_step",
    "_step_scale",
]

_TRUST_MAX = 8.0            # Newton steps are clipped to at most eight knot spans
_TRUST_START = 4.0          # ... and to four at first
_FINISH = 0.1               # Taylor-expanded steps keep their error under 0.1 tol
_INNER = 1                  # Newton iterations on the local Taylor model per evaluation


def _surface_step(model: _SurfaceModel, u, v, pieces, r, Su, Sv, Suu, Suv, Svv):
    """Newton step for f = |S - P|^2 / 2 at (u, v) with r = S - P (seed 001 eq. 10).

    H d = -grad f with H the exact Hessian where it is positive definite, else the
    Gauss-Newton matrix J^T J (a descent direction all the same). On the bound of a clamped
    direction or of a piece (``pieces``), where the gradient pushes outwards, that
    parameter is held and f is minimised along the other one only.

    Returns du, dv, the tangential residual max(|S_u·r|/|S_u|, |S_v·r|/|S_v|) over the free
    directions (mm), the metric (S_u·S_u, S_u·S_v, S_v·S_v) and det H / det J^T J, which
    is (1 - k1 d)(1 - k2 d): near 0 or negative where P is close to a centre of curvature.
    """
    guu, guv, gvv = _dot(Su, Su), _dot(Su, Sv), _dot(Sv, Sv)
    gu, gv = _dot(Su, r), _dot(Sv, r)
    huu, huv, hvv = guu + _dot(Suu, r), guv + _dot(Suv, r), gvv + _dot(Svv, r)
    det = huu * hvv - huv * huv
    gram = guu * gvv - guv * guv
    exact = (huu > 0) & (hvv > 0) & (det > 1e-12 * huu * hvv)
    # J^T J with each diagonal term raised by 1e-12 of itself: positive definite, and the same
    # on any scaling of u and v (one shared term would swamp the smaller one)
    lam_u, lam_v = 1e-12 * guu + 1e-300, 1e-12 * gvv + 1e-300
    muu = np.where(exact, huu, guu + lam_u)
    mvv = np.where(exact, hvv, gvv + lam_v)
    muv = np.where(exact, huv, guv)
    detm = muu * mvv - muv * muv
    fix_u, fix_v = model.u.held(u, gu, pieces[0]), model.v.held(v, gv, pieces[1])
    fix_u |= guu <= 1e-20 * gvv            # a collapsed edge: moving u does not move the foot
    fix_v |= gvv <= 1e-20 * guu
    # with one parameter held, Newton along the other uses its own second derivative
    du = np.where(fix_v, -gu / np.where(huu > 0, huu, guu + lam_u), -(mvv * gu - muv * gv) / detm)
    dv = np.where(fix_u, -gv / np.where(hvv > 0, hvv, gvv + lam_v), -(muu * gv - muv * gu) / detm)

    du[fix_u] = 0.0
    dv[fix_v] = 0.0
    res_u = np.where(fix_u, 0.0, np.abs(gu) / np.sqrt(np.maximum(guu, 1e-300)))
    res_v = np.where(fix_v, 0.0, np.abs(gv) / np.sqrt(np.maximum(gvv, 1e-300)))
    focal = det / np.maximum(gram, 1e-300)
    return du, dv, np.maximum(res_u, res_v), (guu, guv, gvv), focal


def _foot_move(du: np.ndarray, dv: np.ndarray, metric: tuple) -> np.ndarray:
    """Length (mm) of the foot displacement S_u du + S_v dv."""
    guu, guv, gvv = metric
    return np.sqrt(np.maximum(du * du * guu + 2.0 * du * dv * guv + dv * dv * gvv, 0.0))


def _finish_size(third: np.ndarray, lam_min: np.ndarray, dist: np.ndarray, tol: float) -> np.ndarray:
    """Largest foot step (mm) that may be taken by Taylor expansion instead of a new evaluation.

    With k3 = (bound of the 3rd derivatives) / lam_min^1.5 (1/mm^2; lam_min the smallest
    eigenvalue of the metric J^T J), a step s leaves an error below k3 s^2 d in the
    tangential residual and below k3 s^3 in the foot; both are kept under ``_FINISH * tol``.
    """
    k3 = third / np.maximum(lam_min, 1e-300) ** 1.5
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.minimum(np.sqrt(_FINISH * tol / (k3 * dist)), np.cbrt(_FINISH * tol / k3))
    return np.where(np.isnan(s), 0.0, s)


def _smallest_eigenvalue(metric: tuple) -> np.ndarray:
    guu, guv, gvv = metric
    lam_max = 0.5 * (guu + gvv + np.sqrt((guu - gvv) ** 2 + 4.0 * guv * guv))
    return (guu * gvv - guv * guv) / np.maximum(lam_max, 1e-300)


def _taylor(D: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S, S_u, S_v at (u + a, v + b) from the derivatives D (6, 3, m) at (u, v), to second order."""
    S, Su, Sv, Suu, Suv, Svv = D
    tmp = Suv * b
    Su2 = Suu * a
    Su2 += tmp
    Su2 += Su
    Sv2 = Svv * b
    np.multiply(Suv, a, out=tmp)
    Sv2 += tmp
    Sv2 += Sv
    S2 = Su + Su2
    S2 *= 0.5 * a
    np.add(Sv, Sv2, out=tmp)
    tmp *= 0.5 * b
    S2 += tmp
    S2 += S
    return S2, Su2, Sv2


def _model_step(model: _SurfaceModel, u, v, pieces, P, D, radius_u, radius_v):
    """Newton step from (u, v), refined by ``_INNER`` Newton iterations on the quadratic
    Taylor model of S about (u, v) (no new evaluation: the step error becomes third order),
    clipped to the trust radii and to a clamped domain.

    Returns the step (a, b) and, at (u, v), the residual, metric and focal ratio of
    :func:`_surface_step`.
    """
    S, Su, Sv, Suu, Suv, Svv = D
    du, dv, res, metric, focal = _surface_step(model, u, v, pieces, S - P, Su, Sv, Suu, Suv, Svv)
    a, b = _clip_step(model, u, v, pieces, du, dv, radius_u, radius_v)
    for _ in range(_INNER):
        S2, Su2, Sv2 = _taylor(D, a, b)
        du, dv = _surface_step(model, u + a, v + b, pieces, S2 - P, Su2, Sv2, Suu, Suv, Svv)[:2]
        a, b = _clip_step(model, u, v, pieces, a + du, b + dv, radius_u, radius_v)
    return a, b, res, metric, focal


def _clip_step(model: _SurfaceModel, u, v, pieces, a, b, radius_u, radius_v):
    """The step (a, b) shrunk to the trust radii (direction kept) and clipped to the pieces."""
    scale = np.minimum(_step_scale(a, radius_u), _step_scale(b, radius_v))
    return model.u.step(u, a * scale, pieces[0]) - u, model.v.step(v, b * scale, pieces[1]) - v


def _newton_surface(model: _SurfaceModel, P: np.ndarray, start: tuple, tol: float, max_iter: int, noise: float):
    """Trust-region Newton (:func:`_model_step`) for the points P (3, m) from ``start``.

    A step is clipped to ``trust`` knot spans and kept only if the distance does not grow
    (within the rounding ``noise``); a rejected step quarters the trust region. A step
    small enough (:func:`_finish_size`) is taken by Taylor expansion instead of a new
    evaluation; the point has converged when there the tangential residual and the next
    Newton step are both <= tol (mm). A point still unconverged at ``max_iter`` keeps the
    best foot found: the last accepted one, or its Taylor-expanded step where that is no
    farther from P.

    Returns u, v, the derivatives [S, S_u, S_v, S_uu, S_uv, S_vv] at the foot (6, 3, m) (the
    second ones from the last evaluation), converged, focal (see :func:`_surface_step`).
    """
    m = P.shape[1]
    u, v, su, sv, ders = start
    D = ders if isinstance(ders, np.ndarray) else np.stack(ders)
    pu, pv = model.u.piece_of_span[su], model.v.piece_of_span[sv]      # Newton stays in these
    out_u, out_v, out_focal = np.empty(m), np.empty(m), np.empty(m)
    out_D = np.empty((6, 3, m))
    converged = np.zeros(m, dtype=bool)
    idx = np.arange(m)
    trust = np.full(m, _TRUST_START)
    dist = np.sqrt(_dot(D[0] - P, D[0] - P))
    for it in range(max_iter + 1):
        a, b, res, metric, focal = _model_step(
            model, u, v, (pu, pv), P, D, trust * model.u.lengths[su], trust * model.v.lengths[sv]
        )
        finish = _finish_size(model.third[model.patch(su, sv)], _smallest_eigenvalue(metric), dist, tol)
        small = np.flatnonzero(_foot_move(a, b, metric) <= finish)
        done = np.zeros(u.size, dtype=bool)
        if small.size:
            Ds, Ps = D[:, :, small], P[:, small]
            T = _taylor(Ds, a[small], b[small])
            ps = (pu[small], pv[small])
            u2, su2, _ = model.u.locate(u[small] + a[small], ps[0])
            v2, sv2, _ = model.v.locate(v[small] + b[small], ps[1])
            du2, dv2, res2, metric2, focal2 = _surface_step(model, u2, v2, ps, T[0] - Ps, T[1], T[2], *Ds[3:])
            ok = (res2 <= tol) & (_foot_move(du2, dv2, metric2) <= tol)
            ok &= (su2 == su[small]) & (sv2 == sv[small])        # the expansion holds on its own patch
            # at max_iter an unconverged point keeps the expanded step only where it is no farther
            take = ok | ((it == max_iter) & (np.sqrt(_dot(T[0] - Ps, T[0] - Ps)) <= dist[small] + noise))
            k, w = idx[small[take]], small[take]
            out_u[k], out_v[k], out_focal[k], converged[k] = u2[take], v2[take], focal2[take], ok[take]
            out_D[:3, :, k] = np.stack(T)[:, :, take]
            out_D[3:, :, k] = Ds[3:, :, take]
            done[w] = True
        if it == max_iter:
            rest = ~done
            k = idx[rest]
            out_u[k], out_v[k], out_focal[k] = u[rest], v[rest], focal[rest]
            out_D[:, :, k] = D[:, :, rest]
            break
        if done.any():
            keep = ~done
            if not keep.any():
                break
            idx, P, trust, dist = idx[keep], P[:, keep], trust[keep], dist[keep]
            u, v, su, sv, a, b, D = u[keep], v[keep], su[keep], sv[keep], a[keep], b[keep], D[:, :, keep]
            pu, pv = pu[keep], pv[keep]
        ut, vt, sut, svt, trial = model.evaluate(u + a, v + b, 2, (pu, pv))
        Dt = np.stack(trial)
        dt = np.sqrt(_dot(Dt[0] - P, Dt[0] - P))
        accept = dt <= dist + noise
        trust = np.where(accept, np.minimum(2.0 * trust, _TRUST_MAX), 0.25 * trust)
        if accept.all():
            u, v, su, sv, D, dist = ut, vt, sut, svt, Dt, dt
            continue
        for cur, new in zip((u, v, su, sv, dist), (ut, vt, sut, svt, dt)):
            np.copyto(cur, new, where=accept)
        np.copyto(D, Dt, where=accept)
    return out_u, out_v, out_D, converged, out_focal


def _curve_step(model: _CurveModel, t: np.ndarray, piece: np.ndarray, r: np.ndarray, C1: np.ndarray, C2: np.ndarray):
    """The 1D form of :func:`_surface_step`: step, residual |C'·r|/|C'|, |C'|^2, focal ratio."""
    g11 = _dot(C1, C1)
    g = _dot(C1, r)
    h = g11 + _dot(C2, r)
    focal = h / np.maximum(g11, 1e-300)
    h = np.where(h > 1e-12 * g11, h, g11 + 1e-300)
    fixed = model.t.held(t, g, piece)
    dt = np.where(fixed, 0.0, -g / h)
    res = np.where(fixed, 0.0, np.abs(g) / np.sqrt(np.maximum(g11, 1e-300)))
    return dt, res, g11, focal


def _curve_taylor(D: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """C, C' at t + a from the derivatives D (3, dim, m) at t, to second order."""
    C, C1, C2 = D
    return C + (C1 + 0.5 * C2 * a) * a, C1 + C2 * a


def _curve_model_step(model: _CurveModel, t, piece, P, D, radius):
    """The 1D form of :func:`_model_step`."""
    C, C1, C2 = D
    dt, res, g11, focal = _curve_step(model, t, piece, C - P, C1, C2)
    a = model.t.step(t, dt * _step_scale(dt, radius), piece) - t
    for _ in range(_INNER):
        Ca, C1a = _curve_taylor(D, a)
        dt = a + _curve_step(model, t + a, piece, Ca - P, C1a, C2)[0]
        a = model.t.step(t, dt * _step_scale(dt, radius), piece) - t
    return a, res, g11, focal


def _newton_curve(model: _CurveModel, P: np.ndarray, start: tuple, tol: float, max_iter: int, noise: float):
    """The 1D form of :func:`_newton_surface` for points P (dim, m): C'·(C - P) = 0.

    Returns t, [C, C', C''] at the foot (3, dim, m), converged, focal.
    """
    m, dim = P.shape[1], P.shape[0]
    t, span, ders = start
    D = ders if isinstance(ders, np.ndarray) else np.stack(ders)
    piece = model.t.piece_of_span[span]
    out_t, out_D, out_focal = np.empty(m), np.empty((3, dim, m)), np.empty(m)
    converged = np.zeros(m, dtype=bool)
    idx = np.arange(m)
    trust = np.full(m, _TRUST_START)
    dist = np.sqrt(_dot(D[0] - P, D[0] - P))
    for it in range(max_iter + 1):
        a, res, g11, focal = _curve_model_step(model, t, piece, P, D, trust * model.t.lengths[span])
        finish = _finish_size(model.third[span], g11, dist, tol)
        small = np.flatnonzero(np.abs(a) * np.sqrt(g11) <= finish)
        done = np.zeros(t.size, dtype=bool)
        if small.size:
            Ds = D[:, :, small]
            Cs, C1s = _curve_taylor(Ds, a[small])
            t2, span2, _ = model.t.locate(t[small] + a[small], piece[small])
            dt2, res2, g2, focal2 = _curve_step(model, t2, piece[small], Cs - P[:, small], C1s, Ds[2])
            ok = (res2 <= tol) & (np.abs(dt2) * np.sqrt(g2) <= tol) & (span2 == span[small])
            Ps = P[:, small]
            take = ok | ((it == max_iter) & (np.sqrt(_dot(Cs - Ps, Cs - Ps)) <= dist[small] + noise))
            k, w = idx[small[take]], small[take]
            out_t[k], out_focal[k], converged[k] = t2[take], focal2[take], ok[take]
            out_D[0][:, k], out_D[1][:, k], out_D[2][:, k] = Cs[:, take], C1s[:, take], Ds[2][:, take]
            done[w] = True
        if it == max_iter:
            rest = ~done
            k = idx[rest]
            out_t[k], out_focal[k] = t[rest], focal[rest]
            out_D[:, :, k] = D[:, :, rest]
            break
        if done.any():
            keep = ~done
            if not keep.any():
                break
            idx, P, trust, dist = idx[keep], P[:, keep], trust[keep], dist[keep]
            t, span, a, D, piece = t[keep], span[keep], a[keep], D[:, :, keep], piece[keep]
        tt, spant, trial = model.evaluate(t + a, 2, piece)
        Dt = np.stack(trial)
        dnew = np.sqrt(_dot(Dt[0] - P, Dt[0] - P))
        accept = dnew <= dist + noise
        trust = np.where(accept, np.minimum(2.0 * trust, _TRUST_MAX), 0.25 * trust)
        if accept.all():
            t, span, D, dist = tt, spant, Dt, dnew
            continue
        for cur, new in zip((t, span, dist), (tt, spant, dnew)):
            np.copyto(cur, new, where=accept)
        np.copyto(D, Dt, where=accept)
    return out_t, out_D, converged, out_focal


def _step_scale(step: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Factor (<= 1) that shrinks a step to the trust radius."""
    a = np.abs(step)
    return np.where(a > radius, radius / np.where(a > 0, a, 1.0), 1.0)
