# SPDX-License-Identifier: LGPL-2.1-or-later
"""Projection onto a curve: :func:`project_points_to_curve` and its result
:class:`CurveProjection`, the 1D form of the surface projection (curves of any dimension).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.projection.cache import _cached
from bladerecon.core.geometry.projection.evaluation import _CurveModel
from bladerecon.core.geometry.projection.feet import _curve_turn
from bladerecon.core.geometry.projection.grid import _CurveGrid
from bladerecon.core.geometry.projection.newton import _newton_curve
from bladerecon.core.geometry.projection.parallel import _CHUNK, _for_each_block
from bladerecon.core.geometry.projection.points import (
    _check_points,
    _inverse,
    _rounding_noise,
    _spatial_order,
    _start_parameters,
)
from bladerecon.core.geometry.projection.search import _search
from bladerecon.core.geometry.spline import BSplineCurve
from bladerecon.core.tolerances import NEWTON_MAX_ITER

__all__ = ["CurveProjection", "project_points_to_curve"]


@dataclass(frozen=True)
class CurveProjection:
    """Closest points on a curve for m points (mm)."""

    t: np.ndarray
    foot: np.ndarray
    distance: np.ndarray
    converged: np.ndarray


def project_points_to_curve(
    curve: BSplineCurve,
    points: np.ndarray,
    t0: np.ndarray | None = None,
    *,
    tol: float = 1e-10,
    max_iter: int = NEWTON_MAX_ITER,
) -> CurveProjection:
    """Closest point on ``curve`` for each of ``points`` (m, dim), mm.

    The 1D form of :func:`project_points_to_surface`: solve C'·(C - P) = 0 by trust-region
    Newton from the nearest curve samples (or only from ``t0``), closest root wins.
    """
    dim = int(np.asarray(curve.poles).shape[1])
    P = _check_points(points, dim)
    m = P.shape[0]
    t0 = _start_parameters(t0, m, "t0")
    model, slot = _cached(curve, _CurveModel)
    if t0 is None and m and slot[0] is None:
        slot[0] = _CurveGrid(model)
    grid = slot[0] if t0 is None and m else None
    noise = _rounding_noise(model.scale, P)

    def solve(Pc: np.ndarray, start: tuple):
        tc, D, cc, focal = _newton_curve(model, Pc, start, tol, max_iter, noise)
        return [tc], D, cc, focal

    if grid is not None:
        order = _spatial_order(P, grid) if m > _CHUNK else None
        if order is not None:
            P = np.take(P, order, axis=0)
        (t,), D, conv = _search(grid, solve, lambda p: model.evaluate(p[0], 2), _curve_turn, P, noise)
    else:
        order = None
        t, D, conv = np.empty(m), np.empty((1, dim, m)), np.empty(m, dtype=bool)

        def work(s: int, e: int, kd_workers: int) -> None:
            (t[s:e],), Dc, conv[s:e], _ = solve(np.ascontiguousarray(P[s:e].T), model.evaluate(t0[s:e], 2))
            D[:, :, s:e] = Dc[:1]

        _for_each_block(m, work)
    foot = np.ascontiguousarray(D[0].T)
    dist = np.linalg.norm(P - foot, axis=1)
    if order is not None:
        back = _inverse(order)
        t, foot, dist, conv = (np.take(a, back, axis=0) for a in (t, foot, dist, conv))
    return CurveProjection(t=t, foot=foot, distance=dist, converged=conv)
