# SPDX-License-Identifier: LGPL-2.1-or-later
"""Referees the projection contract tests share: B-spline knots, basis functions and
interpolated surfaces built with scipy.interpolate.BSpline, never with the package's own
helpers; and the fixture that empties the projection's spline cache around each test
(import ``fresh_cache`` into a test module to make it autouse there)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from bladerecon.core.geometry.projection import cache as proj_cache
from bladerecon.core.geometry.spline import BSplineSurface

__all__ = ["full_knots", "basis", "greville", "interpolated_surface", "fresh_cache"]


@pytest.fixture(autouse=True)
def fresh_cache():
    """The spline cache empty before and after every test, whatever the test does."""
    proj_cache._cache.clear()
    try:
        yield
    finally:
        proj_cache._cache.clear()


def full_knots(knots, mults, degree, periodic=False):
    """The expanded knot vector (built here, not with the package's helper)."""
    knots, mults = np.asarray(knots, float), np.asarray(mults, int)
    if not periodic:
        return np.repeat(knots, mults)
    period = knots[-1] - knots[0]
    core = np.repeat(knots[:-1], mults[:-1])
    return np.concatenate([core[core.size - degree:] - period, core, core[: degree + 1] + period])


def basis(t, k, x, nu=0):
    """All B-spline basis functions (or their nu-th derivatives) at x: (len(x), n)."""
    n = len(t) - k - 1
    return BSpline(t, np.eye(n), k)(np.asarray(x, float), nu)


def greville(t, k):
    """The Greville abscissae of the full knot vector t for degree k."""
    n = len(t) - k - 1
    return np.array([t[i + 1: i + k + 1].mean() for i in range(n)])


def interpolated_surface(f, u_knots, u_mults, v_knots, v_mults, p, q) -> BSplineSurface:
    """Clamped surface whose poles interpolate f(u, v) -> (..., 3) at the Greville points:
    exactly f when f is a polynomial of degree <= (p, q)."""
    tu, tv = full_knots(u_knots, u_mults, p), full_knots(v_knots, v_mults, q)
    gu, gv = greville(tu, p), greville(tv, q)
    F = f(gu[:, None], gv[None, :])
    C = np.linalg.solve(basis(tu, p, gu), F.reshape(gu.size, -1)).reshape(gu.size, gv.size, 3)
    C = np.linalg.solve(basis(tv, q, gv), C.transpose(1, 0, 2).reshape(gv.size, -1)).reshape(gv.size, gu.size, 3)
    return BSplineSurface(np.ascontiguousarray(C.transpose(1, 0, 2)), np.asarray(u_knots, float),
                          np.asarray(u_mults), np.asarray(v_knots, float), np.asarray(v_mults), p, q)
