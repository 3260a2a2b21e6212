# SPDX-License-Identifier: LGPL-2.1-or-later
"""Contract tests of :mod:`bladerecon.core.geometry.projection`: known answers, fast.

Every figure is checked against a referee that shares no code with the package:

* closed forms: a tilted plane and a "vee" (z = |x|, a C0 fold: two half-planes) whose
  closest points are those of rectangles (clip the point's coordinates in the rectangle's
  orthonormal frame), a collapsed triangle (foot at the apex), a paraboloid and a parabola
  (the feet of a point on the axis: d^2 = h/a - 1/(4 a^2));
* brute force: the spline evaluated by ``scipy.interpolate.BSpline`` on a fine (u, v) grid,
  the best sample polished by ``scipy.optimize.minimize`` (L-BFGS-B, analytic gradient).

The polynomial test surfaces are exact: their poles interpolate the polynomial at the
Greville abscissae (solved with scipy's collocation matrix), and a spline space holds every
polynomial of its degree, so the spline *is* the plane / paraboloid / fold.

Tolerances. Newton stops when the tangential residual and the next foot step are both below
``tol`` = 1e-10 mm (the default), so a foot is within ~1e-10 mm of the true one; with the
rounding of coordinates ~1e2 mm (1e-14 mm) the feet and distances must agree with a closed
form to 1e-9 mm (10 x tol, ``TIGHT``). Parameters: the foot error over |S_u| >= 10 mm
gives 1e-10, checked to 1e-9. The L-BFGS-B referee stops on a gradient of 1e-13 mm^2; its
distance is then within ~1e-12 mm of the minimum (the distance is quadratic in the parameter
error), so ours must not exceed it by more than ``TIGHT`` and must not undercut it by more
than ``TIGHT`` either (a distance below the true minimum is a foot off the surface).

Run time: ~3 s; every test below 0.5 s. No test shares mutable state: module constants are
changed with ``monkeypatch`` and the spline cache is emptied before and after by a fixture.
"""
from __future__ import annotations

import os
from dataclasses import replace

import numpy as np
import pytest
from scipy.interpolate import BSpline
from scipy.optimize import minimize
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.projection import (
    distance_stats,
    project_points_to_curve,
    project_points_to_surface,
    surface_derivatives_fast,
)
from bladerecon.core.geometry.projection import cache as proj_cache
from bladerecon.core.geometry.projection import curve as proj_curve
from bladerecon.core.geometry.projection import evaluation as proj_evaluation
from bladerecon.core.geometry.projection import feet as proj_feet
from bladerecon.core.geometry.projection import grid as proj_grid
from bladerecon.core.geometry.projection import parallel as proj_parallel
from bladerecon.core.geometry.projection import points as proj_points
from bladerecon.core.geometry.projection import restarts as proj_restarts
from bladerecon.core.geometry.projection import search as proj_search
from bladerecon.core.geometry.projection import surface as proj_surface
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

TIGHT = 1e-9        # mm: 10 x the Newton tolerance (see the module docstring)


# --------------------------------------------------------------------------- referees
from spline_referees import basis as _basis, fresh_cache, full_knots as _full  # noqa: F401 (fresh_cache: autouse)
from spline_referees import greville as _greville, interpolated_surface as _interpolated_surface


class _RefSurface:
    """S and its first derivatives by scipy.interpolate.BSpline (periodic: unwrapped poles)."""

    def __init__(self, s: BSplineSurface):
        self.s = s
        self.tu = _full(s.u_knots, s.u_mults, s.u_degree, s.u_periodic)
        self.tv = _full(s.v_knots, s.v_mults, s.v_degree, s.v_periodic)
        P = np.asarray(s.poles, float)
        if s.u_periodic:
            P = np.concatenate([P, P[: s.u_degree]], axis=0)
        if s.v_periodic:
            P = np.concatenate([P, P[:, : s.v_degree]], axis=1)
        self.P = P

    def _wrap(self, x, knots, periodic):
        x = np.asarray(x, float)
        return knots[0] + np.mod(x - knots[0], knots[-1] - knots[0]) if periodic else x

    def __call__(self, u, v, du=0, dv=0):
        s = self.s
        Bu = _basis(self.tu, s.u_degree, self._wrap(u, s.u_knots, s.u_periodic), du)
        Bv = _basis(self.tv, s.v_degree, self._wrap(v, s.v_knots, s.v_periodic), dv)
        return np.einsum("mi,ijd,mj->md", Bu, self.P, Bv)

    def dense(self, gu, gv):
        """S on the grid gu x gv (parameters inside the domain), (len(gu) * len(gv), 3)."""
        s = self.s
        Bu, Bv = _basis(self.tu, s.u_degree, gu), _basis(self.tv, s.v_degree, gv)
        A = (Bu @ self.P.reshape(self.P.shape[0], -1)).reshape(len(gu), self.P.shape[1], 3)
        return np.einsum("bj,ajd->abd", Bv, A, optimize=True).reshape(-1, 3)

    def grid(self, nu, nv):
        s = self.s
        gu = np.linspace(s.u_knots[0], s.u_knots[-1], nu, endpoint=not s.u_periodic)
        gv = np.linspace(s.v_knots[0], s.v_knots[-1], nv, endpoint=not s.v_periodic)
        U, V = np.meshgrid(gu, gv, indexing="ij")
        return U.ravel(), V.ravel(), self.dense(gu, gv)

    def normal(self, u, v):
        n = np.cross(self(u, v, 1, 0), self(u, v, 0, 1))
        return n / np.linalg.norm(n, axis=1, keepdims=True)


def _brute_force(s: BSplineSurface, pts, nu=300, nv=300):
    """Referee feet: nearest sample of a fine grid, polished by bounded L-BFGS-B on
    |S - P|^2 / 2 with the analytic gradient. Returns u, v, foot, distance."""
    ref = _RefSurface(s)
    U, V, X = ref.grid(nu, nv)
    _, k = cKDTree(X).query(pts)
    bounds = [(None, None) if s.u_periodic else (s.u_knots[0], s.u_knots[-1]),
              (None, None) if s.v_periodic else (s.v_knots[0], s.v_knots[-1])]
    out = np.empty((len(pts), 2))
    for i, p in enumerate(pts):
        def f(x, p=p):
            r = ref([x[0]], [x[1]])[0] - p
            return 0.5 * r @ r, np.array([r @ ref([x[0]], [x[1]], 1, 0)[0], r @ ref([x[0]], [x[1]], 0, 1)[0]])
        res = minimize(f, [U[k[i]], V[k[i]]], jac=True, method="L-BFGS-B", bounds=bounds,
                       options={"ftol": 1e-16, "gtol": 1e-13, "maxiter": 500})
        out[i] = res.x
    u = ref._wrap(out[:, 0], s.u_knots, s.u_periodic)
    v = ref._wrap(out[:, 1], s.v_knots, s.v_periodic)
    foot = ref(u, v)
    return u, v, foot, np.linalg.norm(pts - foot, axis=1)


def _rect_foot(P, origin, e1, e2, a, b):
    """Closest point of the rectangle origin + [0, a] e1 + [0, b] e2 (e1, e2 orthonormal)."""
    x = np.clip((P - origin) @ e1, 0.0, a)
    y = np.clip((P - origin) @ e2, 0.0, b)
    return origin + x[:, None] * e1 + y[:, None] * e2, x / a, y / b


# --------------------------------------------------------------------------- test surfaces
E1 = np.array([0.6, 0.0, 0.8])
E2 = np.array([0.0, 1.0, 0.0])
N_PLANE = np.cross(E1, E2)                 # (-0.8, 0, 0.6): S_u x S_v of the plane below
O_PLANE = np.array([1.0, -2.0, 3.0])


def tilted_plane(u_knots=(0.0, 0.3, 0.5, 1.0)) -> BSplineSurface:
    """S(u, v) = O + 10 u E1 + 20 v E2 on [0, 1]^2: bicubic, non-uniform knots."""
    u_knots = np.asarray(u_knots)
    return _interpolated_surface(lambda u, v: O_PLANE + 10.0 * u[..., None] * E1 + 20.0 * v[..., None] * E2,
                                 u_knots, np.r_[4, np.ones(u_knots.size - 2, int), 4],
                                 np.array([0.0, 0.4, 1.0]), np.array([4, 1, 4]), 3, 3)


A_PAR, B_PAR, L_PAR, W_PAR = 0.1, 0.05, 10.0, 10.0


def paraboloid() -> BSplineSurface:
    """z = a x^2 + b y^2, x = L (2u - 1), y = W (2v - 1): bicubic, interior knots."""
    def f(u, v):
        x, y = L_PAR * (2 * u - 1), W_PAR * (2 * v - 1)
        x, y = np.broadcast_arrays(x, y)
        return np.stack([x, y, A_PAR * x * x + B_PAR * y * y], axis=-1)
    return _interpolated_surface(f, np.array([0, 0.3, 0.55, 1.0]), np.array([4, 1, 1, 4]),
                                 np.array([0, 0.5, 1.0]), np.array([4, 1, 4]), 3, 3)


def vee() -> BSplineSurface:
    """z = |x| for x in [-10, 10], y in [0, 8]: biquadratic, a crease knot (mult 2 = degree) at
    u = 0.5 (x = -10 + 20 u). Two half-planes: two local minima for points inside the V."""
    x = np.array([-10.0, -5.0, 0.0, 5.0, 10.0])
    y = np.array([0.0, 4.0, 8.0])
    X, Y = np.meshgrid(x, y, indexing="ij")
    poles = np.stack([X, Y, np.abs(X)], axis=-1)
    return BSplineSurface(poles, np.array([0, 0.5, 1.0]), np.array([3, 2, 3]),
                          np.array([0.0, 1.0]), np.array([3, 3]), 2, 2)


SQ2 = np.sqrt(0.5)
VEE_ARMS = [   # (origin, e1, e2, length, width, unit S_u x S_v) of each half-plane
    (np.zeros(3), np.array([SQ2, 0, SQ2]), E2, 10 / SQ2, 8.0, np.array([-SQ2, 0, SQ2])),      # x > 0
    (np.zeros(3), np.array([-SQ2, 0, SQ2]), E2, 10 / SQ2, 8.0, np.array([SQ2, 0, SQ2])),      # x < 0
]


def _vee_reference(P):
    """Closest feet on the two half-planes of :func:`vee`: foot, u, v, distance, normal."""
    best = None
    for origin, e1, e2, a, b, n in VEE_ARMS:
        foot, x, y = _rect_foot(P, origin, e1, e2, a, b)
        d = np.linalg.norm(P - foot, axis=1)
        u = 0.5 + np.sign(e1[0]) * 0.5 * x
        cand = (foot, u, y, d, np.broadcast_to(n, P.shape))
        if best is None:
            best = cand
        else:
            take = d < best[3]
            best = tuple(np.where(take[:, None] if c.ndim == 2 else take, c, bc) for c, bc in zip(cand, best))
    return best


TRI_A, TRI_B, TRI_C = np.array([0.0, 0.0, 0.0]), np.array([10.0, 0.0, 0.0]), np.array([5.0, 10.0, 0.0])


def collapsed_triangle(apex: str = "v=1") -> BSplineSurface:
    """The planar triangle A B C as a biquadratic quad with one edge collapsed to the apex C:
    ``v=1`` (S = (1 - v)((1 - u) A + u B) + v C: S_u = 0 there), ``v=0`` (the same with v
    reversed) or ``u=1`` (u and v swapped: S_v = 0 there)."""
    def f(u, v):
        u, v = u[..., None], v[..., None]
        if apex == "u=1":
            u, v = v, u
        if apex == "v=0":
            v = 1 - v
        return (1 - v) * ((1 - u) * TRI_A + u * TRI_B) + v * TRI_C
    return _interpolated_surface(f, np.array([0.0, 1.0]), np.array([3, 3]), np.array([0.0, 1.0]), np.array([3, 3]), 2, 2)


def thin_blade() -> BSplineSurface:
    """A thin closed section (ellipse-like, 20 x 1.6 mm, nose radius ~0.06 mm) swept along z,
    periodic cubic in u (non-uniform knots), clamped cubic in v with a slight shear."""
    n = 24
    th = 2 * np.pi * (np.arange(n) + 0.3 * np.sin(np.arange(n))) / n
    sec = np.column_stack([10 * np.cos(th), 0.8 * np.sin(th)])
    v_knots, v_mults = np.array([0.0, 0.5, 1.0]), np.array([4, 1, 4])
    gv = _greville(_full(v_knots, v_mults, 3), 3)
    poles = np.stack([np.column_stack([sec[:, 0] + 0.5 * g, sec[:, 1], np.full(n, 12 * g)]) for g in gv], axis=1)
    steps = 1 + 0.25 * np.cos(np.arange(n))
    u_knots = np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()
    return BSplineSurface(poles, u_knots, np.ones(n + 1, int), v_knots, v_mults, 3, 3, True, False)


def _blade_points(s, m, rng, spread=0.6):
    """Points round the thin section, many near the two tight ends."""
    ref = _RefSurface(s)
    u = np.concatenate([rng.random(m // 2), rng.normal(0.0, 0.03, m // 4) % 1.0, (0.5 + rng.normal(0, 0.03, m - m // 2 - m // 4)) % 1.0])
    v = rng.uniform(-0.05, 1.05, m)
    return ref(u, np.clip(v, 0, 1)) + rng.normal(scale=spread, size=(m, 3)) + np.where(v[:, None] > 1, 1.0, 0.0) * [0, 0, 1.0]


# --------------------------------------------------------------------------- planes
def test_tilted_plane_feet_distances_and_signs_closed_form():
    """Points on both sides of and beyond a tilted plane patch: foot, u, v, distance, the
    signed distance and the unit normal S_u x S_v all as the rectangle's closed form. Catches
    a wrong Newton step or residual, a flipped normal (cross product order), a sign kept
    from the wrong side, feet not clamped at the patch's ends, or u and v swapped."""
    s = tilted_plane()
    rng = np.random.default_rng(1)
    a, b, h = rng.uniform(-0.3, 1.3, 60), rng.uniform(-0.3, 1.3, 60), rng.uniform(-4, 4, 60)
    P = O_PLANE + 10 * a[:, None] * E1 + 20 * b[:, None] * E2 + h[:, None] * N_PLANE
    res = project_points_to_surface(s, P)
    foot, u, v = _rect_foot(P, O_PLANE, E1, E2, 10.0, 20.0)
    assert np.abs(res.foot - foot).max() < TIGHT
    assert np.abs(res.u - u).max() < TIGHT and np.abs(res.v - v).max() < TIGHT
    d = np.linalg.norm(P - foot, axis=1)
    assert np.abs(res.distance - d).max() < TIGHT
    assert np.abs(res.signed - np.sign(h) * d).max() < TIGHT
    assert np.abs(res.normal - N_PLANE).max() < 1e-12
    assert res.converged.all()
    outside = (a < 0) | (a > 1) | (b < 0) | (b > 1)
    assert outside.sum() > 10                              # beyond the ends: clamped exactly
    assert np.all((res.u[a < 0] == 0.0)) and np.all(res.u[a > 1] == 1.0)
    assert np.all((res.v[b < 0] == 0.0)) and np.all(res.v[b > 1] == 1.0)


def test_plane_with_a_tiny_knot_span_uses_the_searched_span_lookup():
    """A knot span 1e-7 long makes the interval look-up table too big, so spans are found by
    binary search instead: the feet must still be the closed form's. Catches a broken
    fall-back look-up (wrong span, off by one at a break)."""
    s = tilted_plane(u_knots=(0.0, 0.5, 0.5 + 1e-7, 1.0))
    assert proj_evaluation._SurfaceModel(s).u.spans.table is None
    rng = np.random.default_rng(2)
    a = np.r_[rng.uniform(0, 1, 30), 0.5, 0.5 + 1e-7, 0.25]
    b = rng.uniform(0, 1, a.size)
    P = O_PLANE + 10 * a[:, None] * E1 + 20 * b[:, None] * E2 + 0.5 * N_PLANE
    res = project_points_to_surface(s, P)
    assert np.abs(res.u - a).max() < TIGHT and np.abs(res.v - b).max() < TIGHT
    assert np.abs(res.signed - 0.5).max() < TIGHT


def test_interval_lookup_table_at_and_between_breaks():
    """Span index of values at, just below and just above every break, and at both ends,
    against numpy's searchsorted (the last interval closed at the right). Catches an off-by-
    one in the look-up table's corrections."""
    breaks = np.array([0.0, 0.1, 0.15, 0.4, 0.7, 1.0])
    look = proj_evaluation._Intervals(breaks)
    assert look.table is not None
    x = np.concatenate([breaks, np.nextafter(breaks, -1), np.nextafter(breaks, 2), np.linspace(0, 1, 1001)])
    x = np.clip(x, 0.0, 1.0)
    want = np.clip(np.searchsorted(breaks, x, side="right") - 1, 0, breaks.size - 2)
    assert np.array_equal(look(x), want)


def test_modified_surface_is_not_served_from_the_cache():
    """The same plane moved 1 mm along its normal (a new surface object): distances of points
    on the positive side drop by exactly 1 mm. Catches a cache keyed on anything coarser than
    the surface itself (stale feet from the old surface)."""
    s = tilted_plane()
    moved = replace(s, poles=s.poles + N_PLANE)
    a = np.linspace(0.1, 0.9, 9)
    P = O_PLANE + 10 * a[:, None] * E1 + 20 * a[::-1, None] * E2 + 3.0 * N_PLANE
    first = project_points_to_surface(s, P)
    second = project_points_to_surface(moved, P)
    assert np.abs(first.signed - 3.0).max() < TIGHT and np.abs(second.signed - 2.0).max() < TIGHT
    assert np.abs(second.u - a).max() < TIGHT


def test_cache_returns_the_same_grid_for_the_same_surface_and_keeps_the_latest_four(monkeypatch):
    """The same surface object gives back the same model and start grid (no rebuild); a new
    object, even equal in content, gets its own; the least recently used one is dropped
    after ``_CACHE_SIZE`` others, and a use moves a surface to the front. Catches a cache
    that never hits, that is unbounded, or that evicts the wrong entry."""
    s = tilted_plane()
    m1, g1 = proj_cache._surface_grid(s)
    m2, g2 = proj_cache._surface_grid(s)
    assert m1 is m2 and g1 is g2
    assert proj_cache._cached(s, proj_evaluation._SurfaceModel)[0] is m1
    twin = replace(s, poles=s.poles.copy())
    mt, gt = proj_cache._surface_grid(twin)
    assert mt is not m1 and gt is not g1
    others = [replace(s, poles=s.poles + k) for k in range(1, 4)]
    for o in others[:2]:
        proj_cache._cached(o, proj_evaluation._SurfaceModel)
    assert proj_cache._cached(s, proj_evaluation._SurfaceModel)[0] is m1      # s now the newest
    proj_cache._cached(others[2], proj_evaluation._SurfaceModel)                 # twin drops out
    assert len(proj_cache._cache) == proj_cache._CACHE_SIZE == 4
    assert proj_cache._surface_grid(s)[1] is g1
    assert proj_cache._surface_grid(twin)[0] is not mt
    monkeypatch.setattr(proj_cache, "_CACHE_SIZE", 2)
    proj_cache._cached(others[0], proj_evaluation._SurfaceModel)
    assert len(proj_cache._cache) == 2


# --------------------------------------------------------------------------- curved surfaces
def test_paraboloid_feet_against_brute_force_both_sides():
    """Points above and below a paraboloid (bicubic, interior knots): feet, parameters,
    distances and signed distances against the L-BFGS-B referee; the normal is S_u x S_v
    (pointing to +z here) and equals the referee's. Catches wrong second derivatives in the
    Newton step, a wrong Taylor finish, and sign errors."""
    s = paraboloid()
    rng = np.random.default_rng(3)
    u, v = rng.uniform(0.05, 0.95, 14), rng.uniform(0.05, 0.95, 14)
    ref = _RefSurface(s)
    P = ref(u, v) + ref.normal(u, v) * rng.uniform(-3, 3, 14)[:, None]
    res = project_points_to_surface(s, P)
    ru, rv, rfoot, rd = _brute_force(s, P, 120, 120)
    assert np.abs(res.distance - rd).max() < TIGHT
    assert np.abs(res.foot - rfoot).max() < 1e-6 and np.abs(res.u - ru).max() < 1e-6
    z_side = np.sign(P[:, 2] - (A_PAR * P[:, 0] ** 2 + B_PAR * P[:, 1] ** 2))
    assert np.array_equal(np.sign(res.signed), z_side)
    assert np.abs(np.abs(res.signed) - res.distance).max() == 0.0
    assert np.abs(res.normal - ref.normal(res.u, res.v)).max() < 1e-9
    assert np.abs(np.linalg.norm(res.foot - P, axis=1) - res.distance).max() < 1e-12
    assert res.converged.all()


def test_paraboloid_axis_points_choose_the_steeper_pair_of_feet():
    """A point on the axis above both centres of curvature has four local minima, along x
    and along y, with d^2 = h/a - 1/(4 a^2) and the same with b: the steeper direction (a)
    is closer. Below both centres the foot is the vertex. Catches a search that stops at the
    first (saddle-side) root Newton reaches, or a wrong second derivative."""
    s = paraboloid()
    h = np.array([11.0, 12.0, 14.0, 7.0, 3.0])     # centres of curvature at 1/(2a) = 5, 1/(2b) = 10
    P = np.column_stack([np.zeros(5), np.zeros(5), h])
    res = project_points_to_surface(s, P)
    far = h > 1 / (2 * A_PAR)
    want = np.where(far, np.sqrt(h / A_PAR - 1 / (4 * A_PAR ** 2)), h)
    assert np.abs(res.distance - want).max() < TIGHT
    both = h > 1 / (2 * B_PAR)
    assert both.sum() == 3 and np.all(np.sqrt(h[both] / B_PAR - 1 / (4 * B_PAR ** 2)) > want[both] + 1.0)
    x_foot = np.sqrt((2 * A_PAR * h[far] - 1) / (2 * A_PAR ** 2))
    assert np.abs(np.abs(res.foot[far, 0]) - x_foot).max() < 1e-8
    assert np.abs(res.foot[far, 1]).max() < 1e-8
    assert np.all(res.signed > 0)
    # just off the axis, near the vertex's centres of curvature: two roots side by side
    x0, h0 = np.meshgrid([-0.3, 0.02, 0.15], [4.6, 5.3, 6.0, 10.4])
    Q = np.column_stack([x0.ravel(), 0.03 * x0.ravel(), h0.ravel()])
    near = project_points_to_surface(s, Q)
    _, _, _, rd = _brute_force(s, Q, 100, 100)
    assert np.abs(near.distance - rd).max() < TIGHT


def test_surface_derivatives_fast_closed_form_and_scipy(monkeypatch):
    """All six derivatives on the paraboloid against their closed forms, and on the periodic
    thin blade (with u beyond the period, which must wrap) against scipy's BSpline; with a
    small block size so that several blocks are joined. Catches a wrong Horner order, a
    missing factor 2 of the second derivatives, S_uv and S_vv swapped, and blocks joined
    at the wrong rows."""
    monkeypatch.setattr(proj_surface, "_CHUNK", 7)
    s = paraboloid()
    rng = np.random.default_rng(4)
    u, v = rng.random(20), rng.random(20)
    S, Su, Sv, Suu, Suv, Svv = surface_derivatives_fast(s, u, v)
    x, y = L_PAR * (2 * u - 1), W_PAR * (2 * v - 1)
    z0 = np.zeros(20)
    want = [np.column_stack([x, y, A_PAR * x * x + B_PAR * y * y]),
            np.column_stack([z0 + 2 * L_PAR, z0, 4 * A_PAR * L_PAR * x]),
            np.column_stack([z0, z0 + 2 * W_PAR, 4 * B_PAR * W_PAR * y]),
            np.column_stack([z0, z0, z0 + 8 * A_PAR * L_PAR ** 2]),
            np.zeros((20, 3)),
            np.column_stack([z0, z0, z0 + 8 * B_PAR * W_PAR ** 2])]
    for got, w in zip((S, Su, Sv, Suu, Suv, Svv), want):
        assert np.abs(got - w).max() < 1e-11
    b = thin_blade()
    ref = _RefSurface(b)
    u, v = rng.uniform(-1.0, 2.0, 20), rng.random(20)
    got = surface_derivatives_fast(b, u, v)
    for g, (du, dv) in zip(got, ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))):
        w = ref(u, v, du, dv)
        assert np.abs(g - w).max() < 1e-9 * max(1.0, np.abs(w).max())
    single = surface_derivatives_fast(b, 0.3, 0.4)
    assert single[0].shape == (1, 3) and np.abs(single[0] - ref([0.3], [0.4])).max() < 1e-12


def saddle() -> BSplineSurface:
    """The hyperbolic paraboloid z = c x y (a twisted bilinear patch, S_uv != 0), x = 10 (2u - 1),
    y = 10 (2v - 1): bicubic with interior knots."""
    def f(u, v):
        x, y = np.broadcast_arrays(10 * (2 * u - 1), 10 * (2 * v - 1))
        return np.stack([x, y, 0.08 * x * y], axis=-1)
    return _interpolated_surface(f, np.array([0, 0.4, 1.0]), np.array([4, 1, 4]),
                                 np.array([0, 0.6, 1.0]), np.array([4, 1, 4]), 3, 3)


def test_newton_on_a_twisted_patch_converges_in_few_steps():
    """On the saddle z = c x y, from starts ~1 mm off the feet, Newton with the exact
    Hessian (its S_uv.(S - P) cross term matters here) converges within 3 iterations for
    every point (it needs one), to the brute-force referee's distance; with max_iter = 0
    none has converged. Catches a wrong Hessian (cross term, sign), which still creeps to
    the foot through the trust region but only linearly."""
    s = saddle()
    ref = _RefSurface(s)
    rng = np.random.default_rng(14)
    u, v = rng.uniform(0.2, 0.8, 60), rng.uniform(0.2, 0.8, 60)
    P = ref(u, v) + ref.normal(u, v) * rng.uniform(-4, 4, 60)[:, None]
    res = project_points_to_surface(s, P, u + 0.06, v - 0.05, max_iter=3)
    assert res.converged.all()
    _, _, _, rd = _brute_force(s, P[:10], 80, 80)
    assert np.abs(res.distance[:10] - rd).max() < TIGHT
    full = project_points_to_surface(s, P)
    assert np.abs(res.distance - full.distance).max() < TIGHT and np.abs(res.u - full.u).max() < 1e-9
    assert not project_points_to_surface(s, P, u + 0.06, v - 0.05, max_iter=0).converged.any()


def test_vee_fold_picks_the_closer_arm_and_the_crease():
    """z = |x| (a C0 crease): inside the V each arm holds a local minimum and the closer one
    must win, even where they differ by microns (x0 ~ 1e-3); below the crease the foot is on
    the crease line (a boundary minimum of both pieces); beyond the ends it is clamped.
    Signs: S_u x S_v points into the V. Catches a global search that keeps the first root,
    Newton crossing a crease, and a crease foot not held on the piece end."""
    s = vee()
    rng = np.random.default_rng(5)
    inside = np.column_stack([rng.choice([-1, 1], 30) * rng.uniform(1e-3, 2.0, 30), rng.uniform(0.5, 7.5, 30),
                              rng.uniform(2.5, 9.0, 30)])
    below = np.column_stack([rng.uniform(-1.0, 1.0, 10), rng.uniform(0.5, 7.5, 10), rng.uniform(-5.0, -1.5, 10)])
    beyond = np.array([[12.0, 9.0, 3.0], [-13.0, -1.0, 14.0], [0.2, 10.0, -1.0], [6.0, -2.0, 8.0]])
    P = np.concatenate([inside, below, beyond])
    res = project_points_to_surface(s, P)
    foot, u, v, d, n = _vee_reference(P)
    assert np.abs(res.distance - d).max() < TIGHT
    assert np.abs(res.foot - foot).max() < TIGHT
    assert np.abs(res.u - u).max() < TIGHT and np.abs(res.v - v).max() < TIGHT
    side = np.sign(np.einsum("ij,ij->i", P - foot, n))
    assert np.array_equal(np.sign(res.signed), side)
    assert np.all(side[:30] > 0) and np.all(side[30:40] < 0)
    on_crease = np.abs(foot[:, 0]) < 1e-12
    assert on_crease[30:40].all() and np.all(res.u[30:40] == 0.5)
    arm = ~on_crease
    assert np.abs(res.normal[arm] - n[arm]).max() < 1e-12
    assert res.converged.all()


def test_warm_starts_give_the_same_feet_and_max_iter_marks_unconverged():
    """Local projection from given (u0, v0) near the feet gives the closed-form feet of the
    V's arms (Newton alone, no global search); with max_iter=0 and starts far away it stops
    unconverged at a foot no closer than the truth. Catches a warm start that ignores the
    hints or v0 used for u0, and a converged flag that lies."""
    s = vee()
    rng = np.random.default_rng(6)
    P = np.column_stack([rng.uniform(0.5, 2.0, 12), rng.uniform(1, 7, 12), rng.uniform(3, 8, 12)])
    foot, u, v, d, _ = _vee_reference(P)
    res = project_points_to_surface(s, P, u + 0.01, v - 0.02)
    assert np.abs(res.distance - d).max() < TIGHT and np.abs(res.u - u).max() < TIGHT
    assert np.abs(res.v - v).max() < TIGHT and res.converged.all()
    # the V's arms are planes (a Newton step is exact there): max_iter on the curved blade
    b = thin_blade()
    Q = _RefSurface(b)(np.full(6, 0.25), np.linspace(0.1, 0.9, 6)) + [0.0, 1.0, 0.0]
    good = project_points_to_surface(b, Q)
    stuck = project_points_to_surface(b, Q, np.full(6, 0.05), np.full(6, 0.5), max_iter=0)
    assert good.converged.all() and not stuck.converged.any()
    assert np.all(stuck.distance > good.distance + 1e-3)
    assert np.abs(stuck.distance - np.linalg.norm(Q - stuck.foot, axis=1)).max() < 1e-12
    again = project_points_to_surface(b, Q, good.u + 0.003, good.v - 0.004)
    assert again.converged.all() and np.abs(again.distance - good.distance).max() < TIGHT


@pytest.mark.parametrize("apex, plane_normal", [("v=1", 1.0), ("v=0", -1.0), ("u=1", -1.0)])
def test_collapsed_apex_normal_and_sign_on_both_sides(apex, plane_normal):
    """A planar triangle as a quad with one edge collapsed to the apex C (S_u = 0 or S_v = 0
    there, at either end): a point beyond the apex has its foot at C, the normal is the
    direction to the point turned to the side of the plane's normal S_u x S_v (+z or -z,
    by the closed-form derivatives), and the signed distance takes that side. Inside the
    triangle the foot is the plane's. Catches a normal taken from S_u x S_v where it
    vanishes (NaN or zero), the side turned the wrong way, and the collapsed direction
    mistaken (S_u for S_v) or sampled outside the domain."""
    s = collapsed_triangle(apex)
    assert np.sign(_RefSurface(s).normal([0.3], [0.4])[0, 2]) == plane_normal
    P = np.array([[5.0, 12.0, 3.0], [5.0, 12.0, -3.0], [5.5, 11.0, 0.7], [4.0, 3.0, 2.0], [6.0, 2.0, -1.5]])
    res = project_points_to_surface(s, P)
    at_c = np.array([True, True, True, False, False])
    want_foot = np.where(at_c[:, None], TRI_C, P * [1, 1, 0])
    d = np.linalg.norm(P - want_foot, axis=1)
    assert np.abs(res.foot - want_foot).max() < TIGHT
    assert np.abs(res.distance - d).max() < TIGHT
    assert np.abs(res.signed - plane_normal * np.sign(P[:, 2]) * d).max() < TIGHT
    edge = {"v=1": res.v, "v=0": 1 - res.v, "u=1": res.u}[apex]
    assert np.abs(edge[at_c] - 1.0).max() < TIGHT
    # at the apex: the offset direction, turned to the side of the plane's normal
    want_n = plane_normal * np.sign(P[at_c, 2])[:, None] * (P[at_c] - TRI_C) / d[at_c, None]
    assert np.abs(res.normal[at_c] - want_n).max() < 1e-9
    assert np.abs(res.normal[~at_c] - [0, 0, plane_normal]).max() < 1e-12
    assert res.converged.all()


def test_periodic_thin_blade_against_brute_force():
    """A thin closed section swept along z (periodic in u): points round both tight ends,
    beyond both end sections, inside and outside. Distances and signs as the brute-force
    referee's, u within [0, 1). Catches a search that keeps the wrong side of a thin edge,
    a seam not wrapped, and feet beyond the end sections not clamped."""
    s = thin_blade()
    rng = np.random.default_rng(7)
    P = _blade_points(s, 16, rng, spread=0.5)
    P = np.concatenate([P, [[10.3, 0.05, 6.0], [-10.2, -0.02, 5.0], [9.0, 0.0, -2.0], [2.0, 0.1, 14.0]]])
    res = project_points_to_surface(s, P)
    ru, rv, rfoot, rd = _brute_force(s, P, 400, 40)
    assert np.abs(res.distance - rd).max() < TIGHT
    assert np.abs(res.foot - rfoot).max() < 1e-5
    assert np.all((res.u >= 0) & (res.u < 1))
    ref = _RefSurface(s)
    side = np.sign(np.einsum("ij,ij->i", P - res.foot, ref.normal(res.u, res.v)))
    assert np.array_equal(np.sign(res.signed), side)
    assert res.v[-2] == 0.0 and res.v[-1] == 1.0
    assert res.converged.all()


def _near_edge_points():
    """Points just off the thin blade's ends (near the centres of curvature of the noses)
    and across the section, where the nearest grid sample may lie on the wrong side."""
    s = thin_blade()
    ref = _RefSurface(s)
    rng = np.random.default_rng(8)
    m = 300
    u = np.r_[rng.normal(0.0, 0.02, m // 2), 0.5 + rng.normal(0.0, 0.02, m - m // 2)] % 1.0
    v = rng.uniform(0.0, 1.0, m)
    P = ref(u, v) - ref.normal(u, v) * rng.uniform(0.0, 0.8, m)[:, None] + rng.normal(scale=0.05, size=(m, 3))
    return s, P


def test_global_search_finds_the_closest_foot_near_thin_edges():
    """300 points near and inside the two tight noses (radius ~0.06 mm) of the thin blade:
    no distance above the referee's dense sample (0.02 mm apart round the noses), and each
    foot on the surface at that distance. Catches restarts that are skipped or that keep
    the farther foot."""
    s, P = _near_edge_points()
    res = project_points_to_surface(s, P)
    ref = _RefSurface(s)
    gu = np.r_[np.linspace(-0.08, 0.08, 1500), np.linspace(0.42, 0.58, 1500), np.linspace(0, 1, 600)] % 1.0
    gv = np.linspace(0, 1, 60)
    X = ref.dense(gu, gv)
    dense = cKDTree(X).query(P)[0]
    assert np.all(res.distance <= dense + TIGHT)
    assert np.abs(ref(res.u, res.v) - res.foot).max() < 1e-10
    assert np.abs(np.linalg.norm(P - res.foot, axis=1) - res.distance).max() < 1e-12


def _coarse_grid(monkeypatch):
    """One start sample per median knot span and per 120 (surface) or 360 (curve) degrees
    of turning: the nearest sample then often leads Newton to the wrong local minimum."""
    monkeypatch.setattr(proj_grid, "_SAMPLES_PER_SPAN", 1)
    monkeypatch.setattr(proj_grid, "_MAX_TURN_PER_SAMPLE", np.radians(120.0))


def _with_and_without_turn(monkeypatch, project, shape, P):
    """``project(shape, P)`` as it is, then again with the restarts round an edge switched off
    (``_TURN`` infinite, the cache cleared): (with, without)."""
    res = project(shape, P)
    monkeypatch.setattr(proj_search, "_TURN", np.inf)
    proj_cache._cache.clear()
    return res, project(shape, P)


def test_coarse_grid_vee_extra_starts_pick_the_closer_arm(monkeypatch):
    """On a coarse start grid, points inside the V (the arms' distances differ by 1e-3 to
    3 mm) start Newton on the wrong arm; the extra starts from other samples in reach must
    still give the closed-form foot. Without them (``_MAX_STARTS`` = 0) some stay on the
    wrong arm - which proves the points exercise them. Catches extra starts skipped,
    blocked wrongly, or a farther foot kept."""
    _coarse_grid(monkeypatch)
    s = vee()
    rng = np.random.default_rng(12)
    P = np.column_stack([rng.choice([-1, 1], 150) * rng.uniform(1e-3, 2.0, 150), rng.uniform(0.5, 7.5, 150),
                         rng.uniform(2.5, 9.0, 150)])
    foot, u, v, d, _ = _vee_reference(P)
    res = project_points_to_surface(s, P)
    assert np.abs(res.distance - d).max() < TIGHT and np.abs(res.u - u).max() < TIGHT
    assert np.abs(res.foot - foot).max() < TIGHT
    monkeypatch.setattr(proj_restarts, "_MAX_STARTS", 0)
    proj_cache._cache.clear()
    bare = project_points_to_surface(s, P)
    wrong = np.flatnonzero(bare.distance > d + 1e-4)
    assert wrong.size >= 5
    monkeypatch.undo()                                  # the extra starts back, for one point alone
    _coarse_grid(monkeypatch)
    proj_cache._cache.clear()
    alone = project_points_to_surface(s, P[wrong[:1]])
    assert abs(alone.distance[0] - d[wrong[0]]) < TIGHT


def test_coarse_grid_curve_starts_round_the_nose(monkeypatch):
    """Points round the tight nose (radius ~0.06 mm) of the thin closed section, on a start
    grid with one sample per 180 degrees of turning: Newton from the nearest sample stops
    round the nose from the closest foot. Wherever the starts moved round the edge
    (``_TURN``) change a foot, the new one is the referee's (L-BFGS-B from a 4000-sample
    curve), and they change at least 3. (On so coarse a grid a few feet are missed either
    way: the grid is far outside its design, so only the improvements are checked.)
    Catches the turn restarts skipped or moved the wrong way, and a farther foot taken."""
    _coarse_grid(monkeypatch)
    monkeypatch.setattr(proj_grid, "_MAX_TURN_PER_SAMPLE", np.radians(180.0))
    s = thin_blade()
    c = BSplineCurve(s.poles[:, 0, :2], s.u_knots, s.u_mults, 3, True)
    rng = np.random.default_rng(3)
    P = np.column_stack([rng.normal(9.9, 0.3, 400), rng.normal(0, 0.3, 400)])
    res, bare = _with_and_without_turn(monkeypatch, project_points_to_curve, c, P)
    worse = np.flatnonzero(bare.distance > res.distance + 1e-6)
    assert worse.size >= 3
    _, _, rd = _curve_brute_force(c, P[worse])
    assert np.abs(res.distance[worse] - rd).max() < TIGHT
    assert np.all(bare.distance >= res.distance - TIGHT)


@pytest.mark.parametrize("tol", [1e-10, 1e-5])
def test_tolerance_bounds_residual_and_taylor_finish(tol):
    """On the thin blade (third derivatives non-zero, so the Taylor-expanded last step has an
    error): every converged foot is S(u, v) by scipy to 0.1 tol (the finish's bound), its
    distance |P - S(u, v)| to 0.1 tol, and the orthogonality residuals |S_u.(S - P)|/|S_u|
    and |S_v.(S - P)|/|S_v| are <= tol (free directions: v strictly inside). Catches a Taylor
    finish taken too early (wrong third-derivative bound or finish factor) and a
    convergence test that ignores the residual."""
    s = thin_blade()
    ref = _RefSurface(s)
    P = _blade_points(s, 60, np.random.default_rng(13), spread=0.4)
    r = project_points_to_surface(s, P, tol=tol)
    S, Su, Sv = ref(r.u, r.v), ref(r.u, r.v, 1, 0), ref(r.u, r.v, 0, 1)
    off = S - P
    assert r.converged.all()
    assert np.abs(S - r.foot).max() <= 0.1 * tol + 1e-12
    assert np.abs(np.linalg.norm(off, axis=1) - r.distance).max() <= 0.1 * tol + 1e-12
    inner = (r.v > 0) & (r.v < 1)
    assert inner.sum() > 40
    res_u = np.abs(np.sum(Su * off, axis=1)) / np.linalg.norm(Su, axis=1)
    res_v = np.abs(np.sum(Sv * off, axis=1)) / np.linalg.norm(Sv, axis=1)
    assert res_u.max() <= tol and res_v[inner].max() <= tol


def test_principal_curvature_and_its_direction_closed_form():
    """``_surface_turn`` on the paraboloid along y = 0: principal curvatures
    2a / (1 + 4a^2x^2)^1.5 (along x) and 2b / (1 + 4a^2x^2)^0.5 (along y); the larger is
    returned with the parameter step moving the foot 1 mm along it (du = +-1/|S_u|, dv = 0, or
    the reverse) - near the vertex x wins, at x = 8 y wins. ``_curve_turn`` on the parabola:
    2c / (1 + 4c^2x^2)^1.5 and dt = 1/|C'|. Catches a wrong principal curvature (mean and
    Gauss curvature formulas), the smaller one taken, or the direction of the other."""
    s = paraboloid()
    x = np.array([0.0, 2.0, -3.0, 8.0, -9.0])
    u, v = (x / L_PAR + 1) / 2, np.full(5, 0.5)
    D = np.stack([d.T for d in surface_derivatives_fast(s, u, v)])
    k, step = proj_feet._surface_turn(D)
    q = 1 + 4 * A_PAR ** 2 * x ** 2
    kx, ky = 2 * A_PAR / q ** 1.5, 2 * B_PAR / q ** 0.5
    assert np.abs(k - np.maximum(kx, ky)).max() < 1e-12
    along_x = kx > ky
    assert along_x.sum() == 3
    su = 1 / np.sqrt((2 * L_PAR) ** 2 + (4 * A_PAR * L_PAR * x) ** 2)
    assert np.abs(np.abs(step[0]) - np.where(along_x, su, 0.0)).max() < 1e-12
    assert np.abs(np.abs(step[1]) - np.where(along_x, 0.0, 1 / (2 * W_PAR))).max() < 1e-12
    c = parabola_curve(2)
    t = np.array([0.5, 0.7, 0.1])
    xc = L_CURVE * (2 * t - 1)
    tt = _full(c.knots, c.mults, 3)
    Dc = np.stack([(_basis(tt, 3, t, nu) @ c.poles).T for nu in range(3)])
    kc, sc = proj_feet._curve_turn(Dc)
    assert np.abs(kc - 2 * C_PAR / (1 + 4 * C_PAR ** 2 * xc ** 2) ** 1.5).max() < 1e-12
    speed = 2 * L_CURVE * np.sqrt(1 + 4 * C_PAR ** 2 * xc ** 2)
    assert sc.shape == (1, 3) and np.abs(sc[0] - 1 / speed).max() < 1e-12


def test_first_least_per_point():
    """Per group of pairs, the first pair with the least finite key; groups of only inf
    keys get none. Catches the last instead of the first of equal keys, a group boundary
    off by one, and inf keys taken."""
    key = np.array([3.0, 1.0, 1.0, np.inf, np.inf, 2.0, 0.5, 5.0, 0.5])
    row = np.array([0, 0, 0, 1, 1, 2, 2, 3, 3])
    starts = np.array([0, 3, 5, 7])
    assert np.array_equal(proj_restarts._first_least(key, row, starts), [1, 6, 8])
    assert proj_restarts._first_least(np.full(2, np.inf), np.array([0, 0]), np.array([0])).size == 0


def test_coarse_grid_surface_starts_round_the_nose(monkeypatch):
    """The surface form of the test above: near the thin blade's noses, on a start grid with
    one sample per 360 degrees of turning, the starts moved round the edge change at least 5
    feet, each to the brute-force referee's distance, and never to a farther one. Catches
    the turned feet not handed back to the caller (the result keeps the first foot) and the
    turn restarts skipped."""
    _coarse_grid(monkeypatch)
    monkeypatch.setattr(proj_grid, "_MAX_TURN_PER_SAMPLE", np.radians(360.0))
    s, P = _near_edge_points()
    res, bare = _with_and_without_turn(monkeypatch, project_points_to_surface, s, P)
    better = np.flatnonzero(bare.distance > res.distance + 1e-6)
    assert better.size >= 5
    assert np.all(bare.distance >= res.distance - TIGHT)
    rd = _brute_force(s, P[better], 400, 40)[3]
    assert np.abs(res.distance[better] - rd).max() < TIGHT


# --------------------------------------------------------------------------- parallel
def _projection_fields(res):
    return {k: getattr(res, k) for k in ("u", "v", "foot", "distance", "signed", "normal", "converged")}


def test_blocks_forks_threads_and_one_process_agree(monkeypatch):
    """The thin-blade points in blocks of 40 (forked children, threads, or all here; the
    suspects in batches of 30, the points visited in voxel order) give bit-identical feet to
    one block in one process. Catches blocks that skip or repeat rows, a child's results lost,
    the voxel order not undone, and the suspects' batches misaligned."""
    s, P = _near_edge_points()
    one = _projection_fields(project_points_to_surface(s, P))
    monkeypatch.setattr(proj_parallel._for_each_block, "__defaults__", (40, False))
    monkeypatch.setattr(proj_surface, "_CHUNK", 40)
    monkeypatch.setattr(proj_search, "_MIN_BATCH", 30)
    monkeypatch.setattr(proj_search, "_MAX_BATCH", 45)
    monkeypatch.setattr(proj_parallel, "_THREADS", 2)
    monkeypatch.delenv("BLADERECON_PROCESSES", raising=False)
    runs = {"forked": project_points_to_surface(s, P)}
    monkeypatch.setenv("BLADERECON_PROCESSES", "0")
    runs["threads"] = project_points_to_surface(s, P)
    monkeypatch.setattr(proj_parallel, "_THREADS", 3)
    runs["three threads"] = project_points_to_surface(s, P)
    for name, res in runs.items():
        for k, a in _projection_fields(res).items():
            assert np.array_equal(a, one[k]), (name, k)


def test_for_each_block_covers_every_row_once(monkeypatch):
    """Every row is visited exactly once, in forked children (shared memory), on threads
    and in one process; the k-d tree workers are -1 alone and 1 in parallel; a failing child
    has its blocks run again here. Catches lost or doubled blocks and a child's failure
    leaving rows unset."""
    parent = os.getpid()
    for threads, fork, shared, workers, chunk in ((1, True, True, -1, 4), (3, True, True, 1, 4), (2, False, True, 1, 4),
                                                  (2, True, False, 1, 4), (2, True, True, 1, 12), (4, True, True, -1, 23)):
        monkeypatch.setattr(proj_parallel, "_THREADS", threads)
        monkeypatch.setattr(proj_parallel, "_can_fork", lambda fork=fork: fork)
        hits = proj_parallel._shared((23,), np.int64)
        seen = proj_parallel._shared((23,), np.int64)

        def work(a, b, w):
            hits[a:b] += 1
            seen[a:b] = w
        proj_parallel._for_each_block(23, work, chunk=chunk, shared=shared)
        assert np.array_equal(hits, np.ones(23)), (threads, fork, shared)
        assert np.all(seen == workers)
    out = proj_parallel._shared((12,))
    ran_here = proj_parallel._shared((12,), bool)

    def failing(a, b, w):
        if os.getpid() != parent:
            raise RuntimeError("a child that fails")
        out[a:b] = np.arange(a, b)
        ran_here[a:b] = True
    monkeypatch.setattr(proj_parallel, "_THREADS", 3)
    monkeypatch.setattr(proj_parallel, "_can_fork", lambda: True)
    proj_parallel._for_each_block(12, failing, chunk=2, shared=True)
    assert np.array_equal(out, np.arange(12)) and ran_here.all()
    empty = proj_parallel._shared((0, 3), bool)
    assert empty.shape == (0, 3) and empty.dtype == bool


def test_can_fork_switch(monkeypatch):
    """``BLADERECON_PROCESSES=0`` turns forking off, anything else leaves it on, in a process
    with one thread and no GUI toolkit on Linux; a second thread or a GUI toolkit turns it off.
    The thread count and the loaded modules are set here, not taken from whatever the suite's
    earlier tests left (on FreeCAD 1.0 they had left a thread running, and this test failed).
    Catches a switch read the wrong way round."""
    if not os.sys.platform.startswith("linux"):
        pytest.skip("forking is used on Linux only")
    monkeypatch.setattr(proj_parallel.threading, "active_count", lambda: 1)
    monkeypatch.setattr(proj_parallel, "_GUI_MODULES", ("a_gui_toolkit_not_loaded",))
    monkeypatch.setenv("BLADERECON_PROCESSES", "0")
    assert not proj_parallel._can_fork()
    monkeypatch.delenv("BLADERECON_PROCESSES")
    assert proj_parallel._can_fork()
    monkeypatch.setenv("BLADERECON_PROCESSES", "1")
    assert proj_parallel._can_fork()
    monkeypatch.setattr(proj_parallel.threading, "active_count", lambda: 2)
    assert not proj_parallel._can_fork()
    monkeypatch.setattr(proj_parallel.threading, "active_count", lambda: 1)
    monkeypatch.setattr(proj_parallel, "_GUI_MODULES", ("os",))
    assert not proj_parallel._can_fork()


# --------------------------------------------------------------------------- curves
C_PAR, L_CURVE = 0.1, 8.0


def parabola_curve(dim=2) -> BSplineCurve:
    """y = c x^2 (and z = 0.5 x in 3D), x = L (2t - 1): clamped cubic, interior knots."""
    knots, mults = np.array([0.0, 0.25, 0.6, 1.0]), np.array([4, 1, 1, 4])
    t = _full(knots, mults, 3)
    g = _greville(t, 3)
    x = L_CURVE * (2 * g - 1)
    F = np.column_stack([x, C_PAR * x * x, 0.5 * x])[:, :dim]
    poles = np.linalg.solve(_basis(t, 3, g), F)
    return BSplineCurve(poles, knots, mults, 3, False)


def _curve_brute_force(c: BSplineCurve, P):
    t = _full(c.knots, c.mults, c.degree, c.periodic)
    poles = np.asarray(c.poles, float)
    if c.periodic:
        poles = np.concatenate([poles, poles[: c.degree]])
    lo, hi = c.knots[0], c.knots[-1]
    wrap = (lambda x: lo + np.mod(x - lo, hi - lo)) if c.periodic else (lambda x: x)
    ev = lambda x, nu=0: _basis(t, c.degree, np.atleast_1d(wrap(x)), nu) @ poles
    g = np.linspace(lo, hi, 4000, endpoint=not c.periodic)
    k = cKDTree(ev(g)).query(P)[1]
    out = np.empty(len(P))
    for i, p in enumerate(P):
        def f(x, p=p):
            r = ev(x[0])[0] - p
            return 0.5 * r @ r, np.array([r @ ev(x[0], 1)[0]])
        out[i] = minimize(f, [g[k[i]]], jac=True, method="L-BFGS-B",
                          bounds=[(None, None) if c.periodic else (lo, hi)],
                          options={"ftol": 1e-16, "gtol": 1e-13}).x[0]
    out = wrap(out)
    foot = ev(out)
    return out, foot, np.linalg.norm(P - foot, axis=1)


@pytest.mark.parametrize("dim", [2, 3])
def test_curve_projection_onto_a_parabola(dim):
    """Points round an exact parabola (2D and lifted to 3D): feet, t and distances against
    the L-BFGS-B referee; a point on the axis above the centre of curvature has two feet at
    d^2 = h/c - 1/(4c^2); points beyond the ends get t = 0 or 1 exactly. Catches a wrong
    curve Newton step or Taylor finish, a search that keeps the vertex (a maximum of the
    distance there), and unclamped ends."""
    c = parabola_curve(dim)
    rng = np.random.default_rng(9)
    x = rng.uniform(-7, 7, 12)
    P = np.column_stack([x, C_PAR * x * x + rng.uniform(-3, 3, 12), 0.5 * x + rng.normal(size=12)])[:, :dim]
    ends = np.array([[16.0, 6.0, 8.0], [-16.0, 6.0, -8.0]])[:, :dim]     # beyond both end normals
    P = np.concatenate([P, ends])
    res = project_points_to_curve(c, P)
    rt, rfoot, rd = _curve_brute_force(c, P)
    assert np.abs(res.distance - rd).max() < TIGHT
    assert np.abs(res.t - rt).max() < 1e-7 and np.abs(res.foot - rfoot).max() < 1e-6
    assert res.t[-2] == 1.0 and res.t[-1] == 0.0
    assert res.converged.all()
    if dim == 2:
        h = np.array([7.0, 8.0, 3.0])            # centre of curvature of the vertex at 1/(2c) = 5
        axis = project_points_to_curve(c, np.column_stack([np.zeros(3), h]))
        want = np.where(h > 1 / (2 * C_PAR), np.sqrt(h / C_PAR - 1 / (4 * C_PAR ** 2)), h)
        assert np.abs(axis.distance - want).max() < TIGHT
        x0, h0 = np.meshgrid([-0.2, 0.01, 0.1], [4.7, 5.2, 6.0])
        Q = np.column_stack([x0.ravel(), h0.ravel()])
        _, _, rq = _curve_brute_force(c, Q)
        assert np.abs(project_points_to_curve(c, Q).distance - rq).max() < TIGHT


def test_curve_warm_starts_blocks_and_voxel_order(monkeypatch):
    """The same feet from t0 hints (local Newton), and from the global search with the points
    in blocks of 16 and visited in voxel order (undone on return). Catches t0 ignored, the
    inverse permutation wrong, and blocks joined at the wrong rows."""
    c = parabola_curve(2)
    rng = np.random.default_rng(10)
    x = rng.uniform(-7, 7, 90)
    P = np.column_stack([x, C_PAR * x * x + rng.uniform(-2, 2, 90)])
    base = project_points_to_curve(c, P)
    rt, rfoot, rd = _curve_brute_force(c, P[:8])
    assert np.abs(base.distance[:8] - rd).max() < TIGHT
    warm = project_points_to_curve(c, P, base.t + 0.01)
    assert np.abs(warm.t - base.t).max() < 1e-9 and np.abs(warm.distance - base.distance).max() < TIGHT
    monkeypatch.setattr(proj_curve, "_CHUNK", 16)
    monkeypatch.setattr(proj_parallel._for_each_block, "__defaults__", (16, False))
    monkeypatch.setattr(proj_parallel, "_THREADS", 2)
    blocked = project_points_to_curve(c, P)
    warm_blocked = project_points_to_curve(c, P, base.t + 0.01)
    assert np.array_equal(blocked.t, base.t) and np.array_equal(blocked.distance, base.distance)
    assert np.array_equal(blocked.foot, base.foot)
    assert np.abs(warm_blocked.t - base.t).max() < 1e-9
    with pytest.raises(ValueError):
        project_points_to_curve(c, P, np.zeros(3))


def test_periodic_curve_projection_against_brute_force():
    """A closed thin section (periodic cubic, 2D): points round both tight ends and across
    the seam; t in [0, 1), distances as the referee's. Catches the seam not wrapped and the
    wrong side of a thin edge kept."""
    s = thin_blade()
    c = BSplineCurve(s.poles[:, 0, :2] - [0.0, 0.0], s.u_knots, s.u_mults, 3, True)
    rng = np.random.default_rng(11)
    t = np.r_[rng.normal(0, 0.03, 8), 0.5 + rng.normal(0, 0.03, 8), rng.random(4)] % 1.0
    _, foot0, _ = _curve_brute_force(c, np.zeros((1, 2)))
    tt = _full(c.knots, c.mults, 3, True)
    poles = np.concatenate([c.poles, c.poles[:3]])
    on = _basis(tt, 3, t) @ poles
    P = on + rng.normal(scale=0.3, size=on.shape)
    res = project_points_to_curve(c, P)
    rt, rfoot, rd = _curve_brute_force(c, P)
    assert np.abs(res.distance - rd).max() < TIGHT
    assert np.all((res.t >= 0) & (res.t < 1))
    assert res.converged.all()


# --------------------------------------------------------------------------- stats, input
def test_distance_stats_by_hand():
    """max / mean / std (ddof 0) / rms / min of |d|, n, and the signed extremes only for
    signed input, against numpy by hand. Catches ddof 1, stats of d instead of |d|, and the
    signed keys given or withheld wrongly."""
    d = np.array([[0.4, -1.2, 0.3], [0.0, -0.05, 2.5]])
    a = np.abs(d.ravel())
    st = distance_stats(d)
    assert st["n"] == 6
    assert st["max"] == a.max() and st["min"] == a.min()
    assert st["mean"] == pytest.approx(a.sum() / 6, abs=1e-15)
    assert st["std"] == pytest.approx(np.sqrt(((a - a.sum() / 6) ** 2).sum() / 6), abs=1e-15)
    assert st["rms"] == pytest.approx(np.sqrt((a * a).sum() / 6), abs=1e-15)
    assert st["min_signed"] == -1.2 and st["max_signed"] == 2.5
    assert set(distance_stats(a)) == {"n", "max", "mean", "std", "rms", "min"}
    forced = distance_stats(np.array([0.2, 0.7]), signed=True)
    assert forced["min_signed"] == 0.2 and forced["max_signed"] == 0.7
    assert "min_signed" not in distance_stats(d, signed=False)
    assert all(isinstance(v, float) for k, v in st.items() if k != "n") and isinstance(st["n"], int)
    with pytest.raises(BladeReconError):
        distance_stats([])


def test_bad_input_is_refused_and_edge_cases():
    """NaN / inf rows are named, a sum that overflows is not taken for an infinity, wrong
    shapes and half or wrong-length start parameters are refused, one point as a 1D array
    is accepted, and no points give empty results. Catches the checks turned off or
    reporting the wrong row."""
    s = tilted_plane()
    with pytest.raises(BladeReconError, match="row 1"):
        project_points_to_surface(s, np.array([[0.0, 0.0, 0.0], [np.nan, 1.0, 1.0]]))
    with pytest.raises(BladeReconError, match=r"1 point\(s\).*row 2"):
        project_points_to_surface(s, np.array([[1e308, 0.0, 0.0], [1e308, 0.0, 0.0], [0.0, -np.inf, 0.0]]))
    big = np.array([[1e97, 0.0, 0.0], [1e97, 0.0, 0.0]] * 200)     # each within the limit, their sum far
    assert np.array_equal(proj_points._check_points(big, 3), big)
    with pytest.raises(BladeReconError, match=r"\(m, 3\)"):
        project_points_to_surface(s, np.zeros((4, 2)))
    with pytest.raises(BladeReconError):
        project_points_to_surface(s, np.zeros((2, 2, 3)))
    with pytest.raises(ValueError, match="both"):
        project_points_to_surface(s, np.zeros((4, 3)), u0=np.zeros(4))
    with pytest.raises(ValueError, match="both"):
        project_points_to_surface(s, np.zeros((4, 3)), v0=np.zeros(4))
    with pytest.raises(ValueError, match="u0"):
        project_points_to_surface(s, np.zeros((4, 3)), np.zeros(3), np.zeros(4))
    one = project_points_to_surface(s, O_PLANE + 2.0 * N_PLANE)
    # the foot is the patch's corner: u = 0 up to rounding (5e-17 on numpy 2.2)
    assert one.u.shape == (1,) and abs(one.signed[0] - 2.0) < TIGHT and abs(one.u[0]) < 1e-12
    empty = project_points_to_surface(s, np.zeros((0, 3)))
    assert empty.distance.shape == (0,) and empty.foot.shape == (0, 3) and empty.normal.shape == (0, 3)
    c = parabola_curve(2)
    with pytest.raises(BladeReconError, match=r"\(m, 2\)"):
        project_points_to_curve(c, np.zeros((3, 3)))
    assert project_points_to_curve(c, np.zeros((0, 2))).t.shape == (0,)


@pytest.mark.parametrize("far", [1e154, 1e200, -1e300])
def test_coordinates_so_large_their_squares_overflow_are_refused_in_one_line(far):
    """Finite points at 1e154 mm and beyond crashed the projection with an IndexError from the
    start grid (squared distances overflowed and the k-d tree returned its "no neighbour"
    index); they are refused by the input check, naming the row, and ordinary large ones
    (1e6 mm) still project."""
    surf = tilted_plane()
    P = np.array([[0.2, 0.3, 0.1], [far, 0.0, 0.0], [0.4, 0.4, -0.2]])
    with pytest.raises(BladeReconError, match=r"1 point\(s\) have coordinates beyond 1e\+100 mm \(first at row 1\)"):
        project_points_to_surface(surf, P)
    r = project_points_to_surface(surf, np.array([[0.2, 0.3, 0.1], [1e6, 0.0, 0.0]]))
    assert np.all(np.isfinite(r.distance))
