# SPDX-License-Identifier: LGPL-2.1-or-later
"""Projection onto a surface: :func:`project_points_to_surface` (seed 001 §2 eqs. 10-11) and
its result :class:`Projection`; :func:`surface_derivatives_fast` from the same patches.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.projection.cache import _cached, _surface_grid
from bladerecon.core.geometry.projection.evaluation import _dot, _SurfaceModel
from bladerecon.core.geometry.projection.feet import _surface_turn
from bladerecon.core.geometry.projection.newton import _newton_surface
from bladerecon.core.geometry.projection.parallel import _CHUNK, _for_each_block, _shared
from bladerecon.core.geometry.projection.points import (
    _check_points,
    _rounding_noise,
    _spatial_order,
    _start_parameters,
)
from bladerecon.core.geometry.projection.search import _search
from bladerecon.core.geometry.spline import BSplineSurface
from bladerecon.core.tolerances import NEWTON_MAX_ITER

__all__ = ["Projection", "project_points_to_surface", "surface_derivatives_fast"]


@dataclass(frozen=True)
class Projection:
    """Closest points on a surface for m points (mm).

    ``signed`` is positive on the side the normal ``S_u x S_v`` points to; ``normal`` is
    that unit normal at the foot. ``converged`` is False where Newton stopped at
    ``max_iter`` before meeting the tolerance (the result is still the best foot found).
    """

    u: np.ndarray
    v: np.ndarray
    foot: np.ndarray
    distance: np.ndarray
    signed: np.ndarray
    normal: np.ndarray
    converged: np.ndarray


def surface_derivatives_fast(surface: BSplineSurface, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, ...]:
    """S, S_u, S_v, S_uu, S_uv, S_vv at (u, v), each (m, 3) (mm): the projection's
    polynomial patches, a few times faster than :func:`bspline.surface_derivatives`."""
    model, _ = _cached(surface, _SurfaceModel)
    u, v = np.atleast_1d(np.asarray(u, float)), np.atleast_1d(np.asarray(v, float))
    out = [np.empty((u.size, 3)) for _ in range(6)]
    for s in range(0, u.size, _CHUNK):
        ders = model.evaluate(u[s:s + _CHUNK], v[s:s + _CHUNK], 2)[4]
        for o, d in zip(out, ders):
            o[s:s + _CHUNK] = d.T
    return tuple(out)


def _collapsed_side(model, u: np.ndarray, v: np.ndarray, across_u: np.ndarray, off: np.ndarray) -> np.ndarray:
    """±1 per foot on a collapsed edge: the side of the offset ``off`` (3, k) relative to the
    mean unit normal of the surface just inside the edge (16 samples along the collapsed
    direction, a millionth of the domain in from the edge). At a cone's apex the normals
    there sweep a cone about the mean; any one of them alone may be at right angles to the
    offset and give either sign."""
    U, V = model.u, model.v
    along = np.linspace(0.0, 1.0, 16, endpoint=False)
    out = np.ones(u.size)
    for i in range(u.size):
        if across_u[i]:            # S_u = 0: the edge is a point for every u at this v
            uu = U.lo + along * (U.hi - U.lo)
            step = 1e-6 * (V.hi - V.lo)
            vv = np.full(along.size, v[i] - step if v[i] - V.lo > V.hi - v[i] else v[i] + step)
        else:
            vv = V.lo + along * (V.hi - V.lo)
            step = 1e-6 * (U.hi - U.lo)
            uu = np.full(along.size, u[i] - step if u[i] - U.lo > U.hi - u[i] else u[i] + step)
        D = model.evaluate(uu, vv, 1)[4]
        m = np.cross(D[1], D[2], axis=0)
        m = (m / np.maximum(np.sqrt(_dot(m, m)), 1e-300)).sum(axis=1)
        out[i] = -1.0 if float(m @ off[:, i]) < 0.0 else 1.0
    return out


def project_points_to_surface(
    surface: BSplineSurface,
    points: np.ndarray,
    u0: np.ndarray | None = None,
    v0: np.ndarray | None = None,
    *,
    tol: float = 1e-10,
    max_iter: int = NEWTON_MAX_ITER,
) -> Projection:
    """Closest point on ``surface`` for each of ``points`` (m, 3), mm (seed 001 §2 eqs. 10-11).

    Without ``u0``/``v0`` the search is global (:func:`_search`): Newton starts from the
    nearest sample of a grid on the surface with square cells (about 6 samples on a knot
    span of median length, more on long or sharply turning spans); where another part of
    the surface comes close enough to hold a closer foot (the other side of a thin leading
    or trailing edge) or the point lies near a centre of curvature, Newton starts again
    from the nearest samples there, and from feet moved round the edge; the closest foot
    wins (eq. 11). With ``u0`` and ``v0`` (one pair per point) only a local Newton
    iteration from them is run: use it to re-project after small changes.

    ``tol`` (mm) bounds both the tangential residuals |S_u·(S-P)|/|S_u|, |S_v·(S-P)|/|S_v|
    (the orthogonality cosines times the distance) and the next Newton step of the foot.
    Points are processed in blocks of ``_CHUNK`` in parallel (``_THREADS`` processes or
    threads, :func:`_for_each_block`), so a million points fit in memory.
    """
    P = _check_points(points, 3)
    m = P.shape[0]
    u0 = _start_parameters(u0, m, "u0")
    v0 = _start_parameters(v0, m, "v0")
    if (u0 is None) != (v0 is None):
        raise ValueError("give both u0 and v0, or neither")
    if u0 is None and m:
        model, grid = _surface_grid(surface)
    else:
        model, grid = _cached(surface, _SurfaceModel)[0], None
    noise = _rounding_noise(model.scale, P)

    def solve(Pc: np.ndarray, start: tuple):
        uc, vc, D, cc, focal = _newton_surface(model, Pc, start, tol, max_iter, noise)
        return [uc, vc], D, cc, focal

    out = Projection(u=_shared((m,)), v=_shared((m,)), foot=_shared((m, 3)), distance=_shared((m,)),
                     signed=_shared((m,)), normal=_shared((m, 3)), converged=_shared((m,), bool))
    order = None

    def emit(rows, params: list, D: np.ndarray, conv: np.ndarray) -> None:
        """Normals and signs of the feet of the points ``rows`` (a slice or indices of P),
        written to ``out`` in the caller's point order."""
        target = order[rows] if order is not None else rows
        S, Su, Sv = D[0], D[1], D[2]
        n = np.cross(Su, Sv, axis=0)
        n_len = np.sqrt(_dot(n, n))
        off = np.ascontiguousarray(P[rows].T) - S
        dist = np.sqrt(_dot(off, off))
        # where S_u x S_v vanishes (a collapsed edge: S_u or S_v zero to rounding, or parallel)
        # the offset direction is the normal, turned to the side the normals next to the
        # collapsed edge point to (:func:`_collapsed_side`)
        su2, sv2 = _dot(Su, Su), _dot(Sv, Sv)
        degenerate = ((n_len <= 1e-14 * np.sqrt(np.maximum(su2 * sv2, 1e-300)))
                      | (su2 <= 1e-18 * sv2) | (sv2 <= 1e-18 * su2))
        n = np.where(degenerate, off / np.maximum(dist, 1e-300), n / np.where(degenerate, 1.0, n_len))
        if degenerate.any():
            k = np.flatnonzero(degenerate)
            n[:, k] *= _collapsed_side(model, params[0][k], params[1][k], su2[k] <= sv2[k], off[:, k])
        out.u[target], out.v[target], out.converged[target] = params[0], params[1], conv
        out.foot[target], out.normal[target], out.distance[target] = S.T, n.T, dist
        out.signed[target] = np.where(_dot(off, n) < 0, -dist, dist)

    if grid is not None:
        order = _spatial_order(P, grid) if m > _CHUNK else None
        if order is not None:
            P = np.take(P, order, axis=0)
        _search(grid, solve, lambda p: model.evaluate(p[0], p[1], 2), _surface_turn, P, noise, emit)
    else:
        def work(s: int, e: int, kd_workers: int) -> None:
            params, D, conv, _ = solve(np.ascontiguousarray(P[s:e].T), model.evaluate(u0[s:e], v0[s:e], 2))
            emit(slice(s, e), params, D, conv)

        _for_each_block(m, work, shared=True)
    return out
