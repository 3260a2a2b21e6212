# SPDX-License-Identifier: LGPL-2.1-or-later
"""Contract tests of :mod:`bladerecon.core.geometry.projection.newton`: the trust-region Newton
iteration, checked on what it documents and against referees that share no code with it.

Referees (none uses the package's evaluation or Newton code):

* closed forms: the feet on a degree-2 plane, line, parabola and paraboloid (whose B-spline
  poles are exact: the blossoms of x, x^2 at the knots, all small integers or halves), the
  paraboloid's feet by the monotone Lagrange equation of the quadric (``scipy.optimize.brentq``),
  the parabola's by the roots of its cubic (``numpy.roots``); the paraboloid's fundamental
  forms for the focal ratio (1 - k1 d)(1 - k2 d); the feet on a folded plane;
* constructed feet: P = S + d n (+ a move across an edge) on polynomial surfaces and curves
  that a bicubic spline holds exactly (interpolated with scipy's collocation matrix: a cubic
  patch under scalings of its parameters, a skewed plane with a cubic term in v, a C1 surface
  with a double knot, the cubic curve (t, e t^3)), checked with the polynomial and its
  derivatives by hand: the foot S(u, v), the tangential residuals, the Newton step;
* two Newton iterations on the parabola's closed-form distance, for the refined step.

What the Newton iteration documents, and so what is checked:

* steps are clipped to four knot spans at first, then to at most eight, the direction kept;
  a rejected step quarters the trust region (``_TRUST_START``, ``_TRUST_MAX``);
* every step is refined on the quadratic Taylor model (two Newton iterations on it, no new
  evaluation): on a degree-2 surface that model is exact, so a start close enough converges
  with ``max_iter = 0``;
* a step small enough is taken by Taylor expansion with an error under 0.1 ``tol`` in the
  foot (``_FINISH``); the point has converged when the tangential residual and the next step
  are both <= ``tol``; the foot returned at ``max_iter`` unconverged is the best one found;
* the exact Hessian is used where it is positive definite, else Gauss-Newton J^T J (its
  diagonal raised, a descent direction even where J^T J is singular): Newton converges
  quadratically on any parametrisation (knots scaled by 1e-3 ... 1e6, and 1e5 apart), and
  never to a saddle or maximum of the distance;
* the focal ratio returned is det H / det J^T J = (1 - k1 d)(1 - k2 d) at the foot.

Run time: every test well under a second; no test changes module state.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline
from scipy.optimize import brentq


from bladerecon.core.geometry.projection import evaluation as proj_evaluation
from bladerecon.core.geometry.projection import newton as proj_newton
from bladerecon.core.geometry.projection import project_points_to_curve, project_points_to_surface
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

TOL = 1e-10          # mm: the projection's default tolerance


from spline_referees import fresh_cache, greville as _greville  # noqa: F401 (fresh_cache: autouse)


# --------------------------------------------------------------------------- exact degree-2 splines
def _degree2_knots(lo: float, hi: float, step: float = 1.0):
    """Clamped degree-2 knots lo, lo + step, ..., hi (binary fractions: exact) and their blossom
    values: the Greville abscissae g_i = (t_i+1 + t_i+2) / 2 (poles of x) and t_i+1 t_i+2 (poles
    of x^2)."""
    knots = lo + step * np.arange(round((hi - lo) / step) + 1.0)
    mults = np.r_[3, np.ones(knots.size - 2, int), 3]
    t = np.repeat(knots, mults)
    return knots, mults, 0.5 * (t[1:-2] + t[2:-1]), t[1:-2] * t[2:-1]


SPAN_U, SPAN_V = 2.0, 0.5      # knot span lengths of the plane (different: a radius not in spans shows)


def plane2(n: int = 40) -> BSplineSurface:
    """S(u, v) = (3 u / SPAN_U, 4 v / SPAN_V, 0) on [0, n SPAN_U] x [0, n SPAN_V]: biquadratic,
    n x n knot spans of 3 x 4 mm."""
    ku, mu, gu, _ = _degree2_knots(0, n * SPAN_U, SPAN_U)
    kv, mv, gv, _ = _degree2_knots(0, n * SPAN_V, SPAN_V)
    U, V = np.meshgrid(gu, gv, indexing="ij")
    return BSplineSurface(np.stack([3 * U / SPAN_U, 4 * V / SPAN_V, 0 * U], axis=-1), ku, mu, kv, mv, 2, 2)


def line2(n: int = 40) -> BSplineCurve:
    """C(t) = (3, -4) t / SPAN_U on [0, n SPAN_U]: quadratic, n knot spans of 5 mm."""
    k, m, g, _ = _degree2_knots(0, n * SPAN_U, SPAN_U)
    return BSplineCurve(np.column_stack([3 * g, -4 * g]) / SPAN_U, k, m, 2, False)


C_PAR = 0.1


def parabola2() -> BSplineCurve:
    """y = c x^2, x = t on [-16, 16], quadratic with spans of 2."""
    k, m, g, g2 = _degree2_knots(-16, 16, 2)
    return BSplineCurve(np.column_stack([g, C_PAR * g2]), k, m, 2, False)


def parabola_feet(P: np.ndarray):
    """Closest points of y = c x^2 (unbounded): x solves 2c^2 x^3 + (1 - 2c y0) x - x0 = 0."""
    out = np.empty(len(P))
    for i, (x0, y0) in enumerate(P):
        r = np.roots([2 * C_PAR ** 2, 0.0, 1 - 2 * C_PAR * y0, -x0])
        r = r[np.abs(r.imag) < 1e-9].real
        out[i] = r[np.argmin((r - x0) ** 2 + (C_PAR * r * r - y0) ** 2)]
    return out


A_PAR, B_PAR = 0.1, 0.05


def paraboloid2(M=((1.0, 0.0), (0.0, 1.0)), lo: int = -16, hi: int = 16, step: int = 2) -> BSplineSurface:
    """z = a X^2 + b Y^2 with (X, Y) = M (u, v), biquadratic on [lo, hi]^2 (spans ``step``).
    Exact poles: X, Y, X^2, XY, Y^2 are replaced by their blossoms at the knots."""
    k, m, g, g2 = _degree2_knots(lo, hi, step)
    (p, q), (r, s) = M
    U, V = np.meshgrid(g, g, indexing="ij")
    UU, VV = np.meshgrid(g2, g2, indexing="ij")
    X, Y = p * U + q * V, r * U + s * V
    XX = p * p * UU + 2 * p * q * U * V + q * q * VV
    YY = r * r * UU + 2 * r * s * U * V + s * s * VV
    return BSplineSurface(np.stack([X, Y, A_PAR * XX + B_PAR * YY], axis=-1), k, m, k, m, 2, 2)


def paraboloid_feet(P: np.ndarray) -> np.ndarray:
    """Closest points (X, Y) of z = a X^2 + b Y^2 (unbounded, a, b > 0): X = x0 / (1 + 2a mu),
    Y = y0 / (1 + 2b mu) with mu = z - z0 the one root of the decreasing function below on
    mu > -1 / (2 max(a, b)) (the Lagrange condition of the global minimum)."""
    out = np.empty((len(P), 2))
    lo = -1.0 / (2 * max(A_PAR, B_PAR))
    for i, (x0, y0, z0) in enumerate(P):
        phi = lambda mu: (A_PAR * x0 ** 2 / (1 + 2 * A_PAR * mu) ** 2 + B_PAR * y0 ** 2 / (1 + 2 * B_PAR * mu) ** 2
                          - z0 - mu)
        mu = brentq(phi, lo + 1e-12, 1e6, xtol=1e-15, rtol=1e-15)
        out[i] = x0 / (1 + 2 * A_PAR * mu), y0 / (1 + 2 * B_PAR * mu)
    return out


def paraboloid_focal(X, Y, P):
    """(1 - k1 d)(1 - k2 d) at the foot (X, Y) of P: det(G - d II) / det G with the first and
    second fundamental forms of z = a X^2 + b Y^2 in (X, Y) and d = (P - S).n (the ratio does
    not depend on the parametrisation)."""
    n = paraboloid_normal(X, Y)
    d = np.einsum("ij,ij->i", P - on_paraboloid(X, Y), n)
    E, F, G = 1 + 4 * A_PAR ** 2 * X ** 2, 4 * A_PAR * B_PAR * X * Y, 1 + 4 * B_PAR ** 2 * Y ** 2
    L, N = 2 * A_PAR * n[:, 2], 2 * B_PAR * n[:, 2]
    return ((E - d * L) * (G - d * N) - F * F) / (E * G - F * F)


def _interpolated(f, knots, degree=3):
    """Clamped bicubic surface on knots x knots whose poles interpolate f(u, v) -> (..., 3) at
    the Greville points (scipy's collocation matrix): exactly f for a bicubic polynomial f."""
    mults = np.r_[degree + 1, np.ones(knots.size - 2, int), degree + 1]
    t = np.repeat(knots, mults)
    g = _greville(t, degree)
    F = f(g[:, None] + 0 * g[None, :], g[None, :] + 0 * g[:, None])
    B = BSpline(t, np.eye(g.size), degree)(g)
    C = np.linalg.solve(B, F.reshape(g.size, -1)).reshape(g.size, g.size, 3)
    C = np.linalg.solve(B, C.transpose(1, 0, 2).reshape(g.size, -1)).reshape(g.size, g.size, 3).transpose(1, 0, 2)
    return BSplineSurface(np.ascontiguousarray(C), knots, mults, knots, mults, degree, degree)


def cubic_z(X, Y, order=0):
    """z = 0.05 X^2 + 0.03 Y^2 + 0.001 X^3 + 0.0005 X Y^2 and its derivatives: (z,) with
    order 0, (z_X, z_Y) with 1, (z_XX, z_XY, z_YY) with 2. Convex on [-10, 10]^2
    (z_XX in [0.04, 0.16], z_YY in [0.055, 0.065]), third derivatives 0.006 and 0.001."""
    if order == 0:
        return 0.05 * X ** 2 + 0.03 * Y ** 2 + 0.001 * X ** 3 + 0.0005 * X * Y ** 2
    if order == 1:
        return 0.1 * X + 0.003 * X ** 2 + 0.0005 * Y ** 2, 0.06 * Y + 0.001 * X * Y
    return 0.1 + 0.006 * X, 0.001 * Y, 0.06 + 0.001 * X


class CubicPatch:
    """S(u, v) = (X, Y, cubic_z(X, Y)) with (X, Y) = M (u / su, v / sv) + c: a bicubic spline
    on [0, 20 su] x [0, 20 sv] (4 x 4 spans), exact (interpolated at the Greville points).
    ``su``, ``sv`` scale the parameters (knots times su, sv: the same surface)."""

    def __init__(self, M=((1.0, 0.0), (0.0, 1.0)), c=(-10.0, -10.0), su=1.0, sv=1.0):
        self.M, self.c, self.su, self.sv = np.asarray(M, float), np.asarray(c, float), su, sv
        knots = np.array([0.0, 5.0, 10.0, 15.0, 20.0])

        def f(u, v):
            X, Y = self.xy(u, v)
            return np.stack([X, Y, cubic_z(X, Y)], axis=-1)
        base = _interpolated(f, knots)
        self.surface = BSplineSurface(base.poles, knots * su, base.u_mults, knots * sv, base.v_mults, 3, 3)

    def xy(self, u, v):
        """(X, Y) at the unscaled parameters (u, v) in [0, 20]^2."""
        return self.M[0, 0] * u + self.M[0, 1] * v + self.c[0], self.M[1, 0] * u + self.M[1, 1] * v + self.c[1]

    def params(self, X, Y):
        """The scaled parameters of (X, Y)."""
        u, v = np.linalg.solve(self.M, np.stack([X - self.c[0], Y - self.c[1]]))
        return u * self.su, v * self.sv

    def point(self, X, Y):
        return np.column_stack([X, Y, cubic_z(X, Y)])

    def tangents(self, X, Y):
        """dS/dX, dS/dY and the unit normal (closed form)."""
        zx, zy = cubic_z(X, Y, 1)
        SX = np.column_stack([np.ones_like(X), np.zeros_like(X), zx])
        SY = np.column_stack([np.zeros_like(X), np.ones_like(X), zy])
        n = np.cross(SX, SY)
        return SX, SY, n / np.linalg.norm(n, axis=1, keepdims=True)

    def at_params(self, u, v):
        """S, S_u, S_v at the scaled parameters (closed form)."""
        X, Y = self.xy(u / self.su, v / self.sv)
        SX, SY, _ = self.tangents(X, Y)
        Su = (self.M[0, 0] * SX + self.M[1, 0] * SY) / self.su
        Sv = (self.M[0, 1] * SX + self.M[1, 1] * SY) / self.sv
        return self.point(X, Y), Su, Sv


def on_paraboloid(X, Y):


    return np.column_stack([X, Y, A_PAR * X ** 2 + B_PAR * Y ** 2])


def paraboloid_normal(X, Y):
    n = np.column_stack([-2 * A_PAR * X, -2 * B_PAR * Y, np.ones_like(X)])
    return n / np.linalg.norm(n, axis=1, keepdims=True)


# --------------------------------------------------------------------------- trust region
def test_surface_steps_are_clipped_to_four_then_eight_spans_direction_kept():
    """On a biquadratic plane (unit knot spans) from starts 12.5 and 20.5 spans from the foot
    (along u, along v, and along (1, 0.4)), the iterate after ``max_iter`` = 0, 1, 2 has moved
    4, 12, 20 spans (the trust region: four spans at first, then eight) along the Newton step's
    own direction, and the foot is reached afterwards. A degree-2 patch has no third derivative,
    so every step is "small" and at ``max_iter`` the (exact) Taylor step is returned when it is
    closer. Exact to rounding (1e-9 spans). Catches other trust radii, a radius not in knot
    spans (divided by the span length), a step divided instead of multiplied by its clip
    factor, and u and v clipped each on its own."""
    s = plane2()
    uf, vf = np.array([28.3, 28.3, 20.3, 18.7]), np.array([20.6, 19.1, 30.7, 19.2])     # in knot spans
    P = np.column_stack([3 * uf, 4 * vf, np.full(4, 2.0)])
    for off in (12.5, 20.5):
        du, dv = np.array([off, off, 0.0, -off]), np.array([0.0, 0.4 * off, off, -0.4 * off])
        u0, v0 = uf - du, vf - dv
        for max_iter, reach in ((0, 4.0), (1, 12.0), (2, 20.0)):
            r = project_points_to_surface(s, P, u0 * SPAN_U, v0 * SPAN_V, max_iter=max_iter)
            frac = min(reach / off, 1.0)
            assert np.abs(r.u / SPAN_U - (u0 + frac * du)).max() < 1e-9, (off, max_iter)
            assert np.abs(r.v / SPAN_V - (v0 + frac * dv)).max() < 1e-9, (off, max_iter)
            assert not r.converged[np.full(4, reach < off)].any()
        r = project_points_to_surface(s, P, u0 * SPAN_U, v0 * SPAN_V, max_iter=4)
        assert r.converged.all() and np.abs(r.u / SPAN_U - uf).max() < 1e-9 and np.abs(r.distance - 2.0).max() < 1e-9


def test_curve_steps_are_clipped_to_four_then_eight_spans():
    """The curve form: a quadratic straight line (unit spans, 5 mm each), starts 12.5 and
    20.5 spans from the foot on either side: after ``max_iter`` = 0, 1, 2 the iterate has
    moved 4, 12, 20 spans towards the foot. Catches the same faults in the curve's clip."""
    c = line2()
    tf = np.array([28.3, 11.7])                                   # in knot spans
    P = np.column_stack([3 * tf, -4 * tf]) + [4.0, 3.0]          # 5 mm off the line
    for off in (12.5, 20.5):
        dt = np.array([off, -off])
        t0 = tf - dt
        for max_iter, reach in ((0, 4.0), (1, 12.0), (2, 20.0)):
            r = project_points_to_curve(c, P, t0 * SPAN_U, max_iter=max_iter)
            assert np.abs(r.t / SPAN_U - (t0 + min(reach / off, 1.0) * dt)).max() < 1e-9, (off, max_iter)
        r = project_points_to_curve(c, P, t0 * SPAN_U, max_iter=4)
        assert r.converged.all() and np.abs(r.t / SPAN_U - tf).max() < 1e-9 and np.abs(r.distance - 5.0).max() < 1e-9


# points just off the centre of curvature of the vertex (x = 0, y = 1 / (2c) = 5): from the
# vertex the Newton step is far too long (the distance is nearly stationary there); clipped to
# four spans (8 mm) it lands farther from P than the start and is rejected
NEAR_FOCUS = np.array([[0.999, 5.1746], [-0.4604, 5.0493], [2.07, 5.42]])


def test_unconverged_foot_at_max_iter_is_the_best_found():
    """With ``max_iter`` too small to converge, the foot returned is the best one found: no
    farther from P than the start, on the curve (y = c x^2 at the returned t) and at the
    distance reported. From the vertex, for points near its centre of curvature, the first
    step (four spans) lands farther than the start: it used to be returned for
    ``max_iter = 0`` (7.1 mm from P instead of the start's 5.3 mm). The same on the paraboloid.
    Tolerances: rounding of ~10 mm coordinates (1e-12)."""
    c = parabola2()
    start = np.hypot(NEAR_FOCUS[:, 0], NEAR_FOCUS[:, 1])
    for max_iter in range(4):
        r = project_points_to_curve(c, NEAR_FOCUS, np.zeros(3), max_iter=max_iter)
        assert np.all(r.distance <= start + 1e-12), max_iter
        assert np.abs(r.foot - np.column_stack([r.t, C_PAR * r.t ** 2])).max() < 1e-12
        assert np.abs(np.linalg.norm(NEAR_FOCUS - r.foot, axis=1) - r.distance).max() < 1e-12
    s = paraboloid2()
    Q = np.column_stack([NEAR_FOCUS[:, 0], [0.3, 0.2, -0.1], NEAR_FOCUS[:, 1]])
    for max_iter in range(4):
        r = project_points_to_surface(s, Q, np.zeros(3), np.zeros(3), max_iter=max_iter)
        assert np.all(r.distance <= np.linalg.norm(Q, axis=1) + 1e-12), max_iter
        assert np.abs(r.foot - on_paraboloid(r.u, r.v)).max() < 1e-12


def test_a_rejected_step_quarters_the_trust_region():
    """From the vertex, for points near its centre of curvature, the first step (clipped to
    four spans) lands farther from P and is rejected; the next one is clipped to a quarter of
    that, one span (2 mm), and accepted: after ``max_iter = 1`` the iterate has moved exactly
    one span (on a degree-2 curve the Taylor step is exact, and closer than the start). Run to
    the end, Newton reaches the closed-form foot (roots of the cubic) to 1e-9 mm (10 tol).
    The same on the paraboloid along u. Catches a rejected step that does not shrink the
    trust region (Newton would retry the same step until max_iter) or shrinks it otherwise."""
    c = parabola2()
    sign = np.sign(NEAR_FOCUS[:, 0])
    r = project_points_to_curve(c, NEAR_FOCUS, np.zeros(3), max_iter=1)
    assert np.abs(r.t - 2.0 * sign).max() < 1e-12 and not r.converged.any()
    r = project_points_to_curve(c, NEAR_FOCUS, np.zeros(3))
    assert r.converged.all() and np.abs(r.t - parabola_feet(NEAR_FOCUS)).max() < 1e-9
    s = paraboloid2()
    Q = np.column_stack([NEAR_FOCUS[:, 0], [0.003, 0.002, -0.001], NEAR_FOCUS[:, 1]])
    r = project_points_to_surface(s, Q, np.zeros(3), np.zeros(3), max_iter=1)
    assert np.abs(r.u - 2.0 * sign).max() < 1e-9 and not r.converged.any()
    r = project_points_to_surface(s, Q, np.zeros(3), np.zeros(3))
    want = paraboloid_feet(Q)
    assert r.converged.all() and np.abs(r.u - want[:, 0]).max() < 1e-9 and np.abs(r.v - want[:, 1]).max() < 1e-9


def _paraboloid_points(m: int, rng, d_max: float = 3.0):
    """Points at distance up to ``d_max`` on either side of the paraboloid over feet (X, Y) in
    [-10, 10]^2 (their feet are the closed form's: the focal ratio stays >= 0.4 > 0)."""
    X, Y = rng.uniform(-10, 10, m), rng.uniform(-10, 10, m)
    return on_paraboloid(X, Y) + paraboloid_normal(X, Y) * rng.uniform(-d_max, d_max, m)[:, None]


def test_max_iter_zero_converges_from_close_starts_on_degree_two_splines():
    """On a degree-2 surface or curve the quadratic Taylor model is exact, so the refined step
    (two Newton iterations on the model, no evaluation) from a start e parameter units off the
    foot is within K^3 e^4 of it, K = max |f3| / (2 min f2) <= 1.5 (f = |S - P|^2 / 2 along x,
    f2 and f3 its 2nd and 3rd derivatives: f3 = 3 S_x.S_xx <= 12 a^2 |x| <= 1.2 and
    f2 >= (1 - k d) |S_x|^2 >= 0.4 for |x| <= 10, d <= 3 mm). From e = 1e-3 that is 3e-12:
    with ``max_iter = 0`` every point has converged to the closed-form foot (1e-9, 10 tol).
    From e = 0.3 it is 0.03: not converged, but the foot returned is that refined step (closer
    than the start), not the start. Catches a refinement that goes the wrong way or starts
    from the wrong point, and converged feet replaced by the start."""
    rng = np.random.default_rng(21)
    s = paraboloid2()
    P = _paraboloid_points(40, rng)
    want = paraboloid_feet(P)
    for e0, close in ((1e-3, True), (0.3, False)):
        ang = rng.uniform(0, 2 * np.pi, 40)
        u0, v0 = want[:, 0] + e0 * np.cos(ang), want[:, 1] + e0 * np.sin(ang)
        r = project_points_to_surface(s, P, u0, v0, max_iter=0)
        err = np.hypot(r.u - want[:, 0], r.v - want[:, 1])
        if close:
            assert r.converged.all() and err.max() < 1e-9
            assert np.abs(r.foot - on_paraboloid(*want.T)).max() < 1e-9
        else:
            assert not r.converged.any() and err.max() < 0.03
            start = np.linalg.norm(P - on_paraboloid(u0, v0), axis=1)
            assert np.all(r.distance < start)
    c = parabola2()
    x = rng.uniform(-10, 10, 40)
    n = np.column_stack([-2 * C_PAR * x, np.ones(40)]) / np.hypot(2 * C_PAR * x, 1)[:, None]
    Q = np.column_stack([x, C_PAR * x * x]) + n * rng.uniform(-3, 3, 40)[:, None]
    tf = parabola_feet(Q)
    r = project_points_to_curve(c, Q, tf + rng.choice([-1e-3, 1e-3], 40), max_iter=0)
    assert r.converged.all() and np.abs(r.t - tf).max() < 1e-9
    r = project_points_to_curve(c, Q, tf + rng.choice([-0.3, 0.3], 40), max_iter=0)
    assert not r.converged.any() and np.abs(r.t - tf).max() < 0.03



# --------------------------------------------------------------------------- Hessian, focal ratio
ROT45 = ((SQ := np.sqrt(0.5), -SQ), (SQ, SQ))       # (X, Y) = the parameters turned by 45 degrees


@pytest.mark.parametrize("su, sv", [(1.0, 1.0), (1e6, 1e6), (1e-3, 1e4), (1e4, 1e-3)])
def test_newton_never_stops_at_a_saddle_of_the_distance(su, sv):
    """P = (0, 0, 6) on the axis of the paraboloid, between the centres of curvature of the
    vertex along X (5 mm) and Y (10 mm): the vertex is a saddle of the distance (a maximum
    along X), the feet are at X = +-sqrt((2ah - 1) / (2a^2)), d = sqrt(h/a - 1/(4a^2)) = 5.92
    (closed form). With the parameters turned by 45 degrees the Hessian at starts next to the
    vertex has both diagonal terms positive but a negative determinant: Newton must take the
    Gauss-Newton step there, which leaves the saddle, and reach a foot; the Newton step on the
    indefinite Hessian goes to the saddle (distance 6, a root of eq. 10 too). 1e-9 mm (10 tol).
    The same surface with its knots (parameters) scaled by (su, sv): the feet must not depend
    on the parametrisation. With speeds |S_u| / |S_v| ~ 1e7 apart, a Gauss-Newton term shared
    by both directions (1e-12 (S_u.S_u + S_v.S_v)) swamped S_v.S_v and Newton stalled 0.08 mm
    off the foot. Catches a positive-definiteness test that looks at the diagonal only or
    misreads the determinant, and thresholds or regularisers not scaled with the metric."""
    s0 = paraboloid2(ROT45)
    s = BSplineSurface(s0.poles, s0.u_knots * su, s0.u_mults, s0.v_knots * sv, s0.v_mults, 2, 2)
    h = 6.0
    P = np.tile([0.0, 0.0, h], (4, 1))
    X0, Y0 = np.array([0.5, -0.4, 0.3, -0.6]), np.array([0.05, -0.1, 0.0, 0.02])
    u0, v0 = SQ * (X0 + Y0), SQ * (Y0 - X0)                     # (X, Y) = ROT45 (u, v)
    r = project_points_to_surface(s, P, u0 * su, v0 * sv)
    assert r.converged.all()
    assert np.abs(r.distance - np.sqrt(h / A_PAR - 1 / (4 * A_PAR ** 2))).max() < 1e-9
    X = SQ * (r.u / su - r.v / sv)

    assert np.abs(np.abs(X) - np.sqrt((2 * A_PAR * h - 1) / (2 * A_PAR ** 2))).max() < 1e-9


def test_focal_ratio_is_the_product_of_one_minus_curvature_times_distance():
    """The focal ratio returned with each foot is det H / det J^T J = (1 - k1 d)(1 - k2 d)
    (documented; the global search reads it to tell a point near a centre of curvature): on the
    paraboloid in twisted parameters (S_u.S_v != 0, S_uv.n != 0), at converged feet on both
    sides, it is the closed form det(G - d II) / det G to 1e-9 (the foot within tol = 1e-10 of
    the true one moves the ratio by ~1e-10 x |d(ratio)/dX| < 1e-9). On the parabola (curve) it
    is 1 - k d. Catches a wrong determinant of the Hessian or of the metric and a ratio
    multiplied instead of divided."""
    rng = np.random.default_rng(22)
    s = paraboloid2(((0.8, 0.5), (-0.3, 0.9)))
    model = proj_evaluation._SurfaceModel(s)
    P = _paraboloid_points(30, rng)
    want = paraboloid_feet(P)
    uv = np.linalg.solve([[0.8, 0.5], [-0.3, 0.9]], want.T + rng.normal(0, 0.05, (2, 30)))
    Pt = np.ascontiguousarray(P.T)
    u, v, D, conv, focal = proj_newton._newton_surface(model, Pt, model.evaluate(uv[0], uv[1], 2), TOL, 30, 1e-12)
    assert conv.all()
    assert np.abs(focal - paraboloid_focal(want[:, 0], want[:, 1], P)).max() < 1e-9
    assert focal.min() < 0.6 and focal.max() > 1.5                  # both sides
    c = parabola2()
    cmodel = proj_evaluation._CurveModel(c)
    x = rng.uniform(-10, 10, 30)
    nrm = np.column_stack([-2 * C_PAR * x, np.ones(30)]) / np.hypot(2 * C_PAR * x, 1)[:, None]
    d = rng.uniform(-3, 3, 30)
    Q = np.column_stack([x, C_PAR * x * x]) + nrm * d[:, None]
    t, Dc, conv, focal = proj_newton._newton_curve(cmodel, np.ascontiguousarray(Q.T), cmodel.evaluate(x + 0.05, 2),
                                                   TOL, 30, 1e-12)
    assert conv.all()
    k = 2 * C_PAR / (1 + 4 * C_PAR ** 2 * x ** 2) ** 1.5          # curvature, centre on the +n side
    assert np.abs(focal - (1 - k * d)).max() < 1e-9


# --------------------------------------------------------------------------- any parametrisation
def _cubic_points(cp: CubicPatch, rng, m: int = 16):
    """Points with known feet on the cubic patch: interior feet (X0, Y0) at distance d on
    either side (P = S + d n: a local minimum, the focal ratio >= (1 - 0.16 x 3)^2 > 0), and
    feet on the edges X = 10 (u held) and Y = 10 (v held): P = S + d n + e t with t the unit
    tangent across the edge, outwards (P - S is orthogonal to the edge, the gradient pushes
    out). Returns P, the feet (X, Y) and which are on an edge."""
    X, Y = rng.uniform(-8, 8, 3 * m), rng.uniform(-8, 8, 3 * m)
    X[m:2 * m], Y[2 * m:] = 10.0, 10.0
    SX, SY, n = cp.tangents(X, Y)
    across = np.where(np.arange(3 * m)[:, None] < 2 * m, SX - np.einsum("ij,ij->i", SX, SY)[:, None] * SY
                      / np.einsum("ij,ij->i", SY, SY)[:, None], SY - np.einsum("ij,ij->i", SY, SX)[:, None] * SX
                      / np.einsum("ij,ij->i", SX, SX)[:, None])
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    e = np.where(np.arange(3 * m) < m, 0.0, rng.uniform(0.5, 3.0, 3 * m))
    P = cp.point(X, Y) + n * rng.uniform(-3, 3, 3 * m)[:, None] + across * e[:, None]
    return P, X, Y, np.arange(3 * m) >= m


def _check_feet(cp: CubicPatch, r, P, X, Y, edge, tol=TOL):
    """Converged; the feet (X, Y) as constructed and the foot, distance as S at the returned
    (u, v) by the closed form, to 10 tol; the foot returned is S(u, v) to 0.1 tol (the
    Taylor finish's bound) plus rounding (1e-12 for 10 mm coordinates); the tangential
    residuals at the interior feet <= tol (+ rounding)."""
    assert r.converged.all()
    Xr, Yr = cp.xy(r.u / cp.su, r.v / cp.sv)
    assert np.abs(Xr - X).max() < 10 * tol and np.abs(Yr - Y).max() < 10 * tol
    S, Su, Sv = cp.at_params(r.u, r.v)
    assert np.abs(r.foot - S).max() <= 0.1 * tol + 1e-12
    assert np.abs(np.linalg.norm(P - S, axis=1) - r.distance).max() <= 0.1 * tol + 1e-12
    off = S - P
    inner = ~edge
    for T in (Su, Sv):
        res = np.abs(np.einsum("ij,ij->i", T, off)) / np.linalg.norm(T, axis=1)
        assert res[inner].max() <= tol + 1e-12


@pytest.mark.parametrize("su, sv", [(1.0, 1.0), (1e-3, 1e-3), (1e6, 1e6), (1e-2, 1e3), (1e3, 1e-2)])
def test_newton_converges_quadratically_on_any_parametrisation(su, sv):
    """The same cubic patch with its parameters scaled by (su, sv) (parameter speeds from 1e-6
    to 1e4 mm per unit, and 1e5 apart): from starts 0.4 mm off the feet Newton with the exact
    Hessian converges quadratically (0.4 -> ~2e-2 -> ~6e-5 -> ~5e-10 mm for K ~ 0.15/mm; the
    last step by Taylor expansion): two evaluations, and up to two more where the speeds
    differ (the Taylor finish's bound, third derivatives over the smallest speed cubed, is
    cautious there and the last steps are evaluated instead), so ``max_iter = 4`` suffices
    everywhere, also along the edges where one parameter is held. Gauss-Newton converges only
    linearly (rate |k d| up to 0.5 here: 0.4 x 0.5^4 = 0.025 mm off after four): a Hessian
    test, a collapse test or a regulariser that is not scale-free fails, and so does a Taylor
    finish bound that is not (its error shows in the foot). Each foot is checked by
    :func:`_check_feet`."""
    cp = CubicPatch(su=su, sv=sv)
    rng = np.random.default_rng(23)
    P, X, Y, edge = _cubic_points(cp, rng)
    ang = rng.uniform(0, 2 * np.pi, X.size)
    dX, dY = 0.4 * np.cos(ang), 0.4 * np.sin(ang)
    dX, dY = np.where(X >= 10, -np.abs(dX), dX), np.where(Y >= 10, -np.abs(dY), dY)     # starts inside
    u0, v0 = cp.params(X + dX, Y + dY)

    r = project_points_to_surface(cp.surface, P, u0, v0, max_iter=4)

    _check_feet(cp, r, P, X, Y, edge)


# --------------------------------------------------------------------------- the Taylor finish
E_CUB = 0.05


def cubic_curve() -> BSplineCurve:
    """C(t) = (t, e t^3) on [-10, 10]: one cubic Bezier span, exact (interpolated at the
    Greville points); C''' = (0, 6e) everywhere, so the span's bound of the third derivative
    is exactly |C'''| = 0.3 and a quadratic Taylor step of a misses C by exactly e a^3."""
    knots, mults = np.array([-10.0, 10.0]), np.array([4, 4])
    t = np.repeat(knots, mults)
    g = _greville(t, 3)
    poles = np.linalg.solve(BSpline(t, np.eye(4), 3)(g), np.column_stack([g, E_CUB * g ** 3]))
    return BSplineCurve(poles, knots, mults, 3, False)


def test_taylor_finish_error_stays_under_a_tenth_of_tol():
    """A step is taken by Taylor expansion only while its error stays below 0.1 tol: with
    k3 = |C'''| / |C'|^3 the foot error of a step s (mm) is k3 s^3 / 6 exactly on this cubic,
    and the residual's about k3 s^2 d / 2. tol = 1e-5 (so rounding, 1e-12, is far below).
    (1) P on the curve, starts s = 2.1 s0 away, s0 = (0.1 tol / k3)^(1/3): such a step must
    be evaluated, not expanded (expanded, its foot would be off by 8.6 / 6 x 0.1 tol). (2) P
    100 mm off on the convex side, starts 0.02 mm away: the residual's bound allows only
    sqrt(0.1 tol / (k3 d)) ~ 4e-4 mm (expanded, the residual would be ~1e-3 mm). Checked:
    converged, the foot is C(t) (closed form) to 0.1 tol + 1e-12 and the tangential residual
    |C'.(C - P)| / |C'| at t is <= tol + 1e-12. Catches a larger finish factor and a finish
    bound that ignores, or inverts, the distance."""
    tol = 1e-5
    c = cubic_curve()
    on = lambda t: np.column_stack([t, E_CUB * t ** 3])
    tangent = lambda t: np.column_stack([np.ones_like(t), 3 * E_CUB * t ** 2])
    ts = np.array([-2.0, -0.5, 0.3, 1.0, 2.5, 4.0])
    speed = np.linalg.norm(tangent(ts), axis=1)
    s0 = (0.1 * tol / (6 * E_CUB / speed ** 3)) ** (1 / 3)
    starts = []
    for sign in (-1.0, 1.0):
        t0 = ts + sign * 2.1 * s0 / speed
        for _ in range(3):                           # the arc 2.1 s0 long, to ~1e-6 of itself
            arc = np.array([np.linalg.norm(on(np.linspace(a, b, 64))[1:] - on(np.linspace(a, b, 64))[:-1], axis=1).sum()
                            for a, b in zip(ts, t0)])
            t0 = ts + (t0 - ts) * 2.1 * s0 / arc
        starts.append(t0)
    P = np.concatenate([on(ts), on(ts)])
    t0 = np.concatenate(starts)
    n = tangent(ts)[:, ::-1] * [-1.0, 1.0] / speed[:, None]           # unit normal, towards C''
    far = on(ts) - 100.0 * n * np.sign(ts)[:, None]                    # convex side (C'' = (0, 6e t))
    P = np.concatenate([P, far])
    t0 = np.concatenate([t0, ts + 0.02 / speed])
    r = project_points_to_curve(c, P, t0, tol=tol)
    assert r.converged.all()
    assert np.abs(r.foot - on(r.t)).max() <= 0.1 * tol + 1e-12
    T = tangent(r.t)
    res = np.abs(np.einsum("ij,ij->i", T, on(r.t) - P)) / np.linalg.norm(T, axis=1)
    assert res.max() <= tol + 1e-12


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e6])
def test_curve_newton_converges_quadratically_on_any_parametrisation(scale):
    """The cubic curve with its knots scaled (speeds 1e3 to 1e-6 mm per unit): points at
    distance d from feet t* with 1.5 <= |t*| <= 6 (away from the inflection at 0) and the
    focal ratio 1 - k d in [0.3, 1.6] (both sides), starts 0.3 mm off: quadratic convergence
    within ``max_iter = 3``, to t* (10 tol), the foot C(t) to 0.1 tol + 1e-12, the residual
    <= tol + 1e-12 (closed form). Catches a step test or a Hessian threshold in parameter
    units instead of millimetres."""
    rng = np.random.default_rng(24)
    ts = rng.uniform(1.5, 6, 30) * rng.choice([-1, 1], 30)
    tangent = np.column_stack([np.ones(30), 3 * E_CUB * ts ** 2])
    speed = np.linalg.norm(tangent, axis=1)
    n = tangent[:, ::-1] * [-1.0, 1.0] / speed[:, None]
    kappa = 6 * E_CUB * ts / speed ** 3                              # signed, along n
    d = (1 - rng.uniform(0.3, 1.6, 30)) / kappa
    P = np.column_stack([ts, E_CUB * ts ** 3]) + n * d[:, None]
    c0 = cubic_curve()
    c = BSplineCurve(c0.poles, c0.knots * scale, c0.mults, 3, False)
    r = project_points_to_curve(c, P, (ts + rng.choice([-0.3, 0.3], 30) / speed) * scale, max_iter=3)
    assert r.converged.all()
    t = r.t / scale
    assert np.abs((t - ts) * speed).max() < 10 * TOL
    foot = np.column_stack([t, E_CUB * t ** 3])
    assert np.abs(r.foot - foot).max() <= 0.1 * TOL + 1e-12
    T = np.column_stack([np.ones(30), 3 * E_CUB * t ** 2])
    assert (np.abs(np.einsum("ij,ij->i", T, foot - P)) / np.linalg.norm(T, axis=1)).max() <= TOL + 1e-12


# --------------------------------------------------------------------------- convergence test
def test_tol_zero_converges_where_the_foot_is_exact():
    """tol bounds the residual and the next step with <= (documented): with tol = 0 a foot
    whose residual and step are exactly zero has still converged. Beyond a corner of the
    plane both parameters are held on their ends, so the residual over the free directions
    and the step are exactly 0: converged at the corner, from the corner as start; beyond an
    end of the line, likewise. Catches strict comparisons (< tol, < finish size)."""
    s = plane2()
    P = np.array([[-3.0, -5.0, 2.0], [125.0, -1.0, -1.0], [-2.0, 170.0, 0.5], [121.0, 162.0, 3.0]])
    u0 = np.array([0.0, 40.0, 0.0, 40.0]) * SPAN_U
    v0 = np.array([0.0, 0.0, 40.0, 40.0]) * SPAN_V
    r = project_points_to_surface(s, P, u0, v0, tol=0.0)
    assert r.converged.all() and np.array_equal(r.u, u0) and np.array_equal(r.v, v0)
    assert np.abs(r.foot - np.column_stack([3 * u0 / SPAN_U, 4 * v0 / SPAN_V, np.zeros(4)])).max() < 1e-12
    c = line2()
    Q = np.array([[-4.0, 1.0], [125.0, -158.0]])                    # beyond t = 0 and t = 40 spans
    rc = project_points_to_curve(c, Q, np.array([0.0, 40.0 * SPAN_U]), tol=0.0)
    assert rc.converged.all() and np.array_equal(rc.t, [0.0, 40.0 * SPAN_U])


# --------------------------------------------------------------------------- derivatives returned
def test_derivatives_returned_at_the_foot():
    """``_newton_curve`` returns [C, C', C''] at the foot and ``_newton_surface`` [S, S_u, S_v,
    S_uu, S_uv, S_vv] (the search keeps C', C'' / S_u, S_v for the normals and curvatures):
    on the degree-2 parabola and paraboloid (Taylor steps exact, second derivatives constant)
    they are the closed forms at the returned parameters, to rounding (1e-9 of ~10).
    Catches a derivative written to the wrong row."""
    rng = np.random.default_rng(25)
    c = parabola2()
    model = proj_evaluation._CurveModel(c)
    x = rng.uniform(-8, 8, 20)
    Q = np.column_stack([x, C_PAR * x * x]) + rng.normal(0, 1.0, (20, 2))
    t, D, conv, _ = proj_newton._newton_curve(model, np.ascontiguousarray(Q.T), model.evaluate(x, 2), TOL, 30, 1e-12)
    assert conv.all()
    want = [np.column_stack([t, C_PAR * t * t]), np.column_stack([np.ones(20), 2 * C_PAR * t]),
            np.tile([0.0, 2 * C_PAR], (20, 1))]
    for k in range(3):
        assert np.abs(D[k].T - want[k]).max() < 1e-9, k
    s = paraboloid2()
    smodel = proj_evaluation._SurfaceModel(s)
    P = _paraboloid_points(20, rng)
    X0, Y0 = paraboloid_feet(P).T
    u, v, D, conv, _ = proj_newton._newton_surface(smodel, np.ascontiguousarray(P.T), smodel.evaluate(X0 + 0.1, Y0, 2),
                                                   TOL, 30, 1e-12)
    assert conv.all()
    z = np.zeros(20)
    want = [on_paraboloid(u, v), np.column_stack([z + 1, z, 2 * A_PAR * u]), np.column_stack([z, z + 1, 2 * B_PAR * v]),
            np.tile([0.0, 0.0, 2 * A_PAR], (20, 1)), np.zeros((20, 3)), np.tile([0.0, 0.0, 2 * B_PAR], (20, 1))]
    for k in range(6):
        assert np.abs(D[k].T - want[k]).max() < 1e-9, k


def test_taylor_finish_bound_holds_on_a_skewed_cubic_parametrisation():
    """The plane z = 0 with a skewed parametrisation cubic in v: X = u + c (v + al v^3),
    Y = s v, c = 0.99 (S_u and S_v 8 degrees apart), al = 0.02 (bicubic, exact). The
    quadratic Taylor model misses S by the parametrisation's cubic term, largest along the
    slow direction, which the finish bound covers through the metric's smallest eigenvalue.
    tol = 1e-5; P at heights up to 2 mm over 12 feet, starts on rings of 0.01 to 1 parameter
    units round them: converged, the foot returned is S(u, v) (closed form) to 0.1 tol + 1e-12
    and the orthogonal projection of P to 10 tol. Catches a smallest eigenvalue or a foot
    move that ignores or misreads S_u.S_v (steps then expanded that should be evaluated)."""
    c, s, al = 0.99, np.sqrt(1 - 0.99 ** 2), 0.02
    xy = lambda u, v: (u + c * (v + al * v ** 3), s * v)

    def f(u, v):
        X, Y = xy(u, v)
        return np.stack([X, Y, 0 * X], axis=-1)
    surf = _interpolated(f, np.array([-10.0, -5.0, 0.0, 5.0, 10.0]))
    tol = 1e-5
    rng = np.random.default_rng(26)
    u, v = rng.uniform(-6, 6, 12), rng.uniform(-6, 6, 12)
    X0, Y0 = xy(u, v)
    P = np.column_stack([X0, Y0, rng.uniform(-2, 2, 12)])
    ang = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    radii = np.array([0.01, 0.03, 0.1, 0.3, 1.0])
    ring = (radii[:, None] * np.exp(1j * ang[None, :])).ravel()
    U0, V0 = (u[:, None] + ring.real).ravel(), (v[:, None] + ring.imag).ravel()
    PP = np.repeat(P, ring.size, axis=0)
    r = project_points_to_surface(surf, PP, U0, V0, tol=tol)
    assert r.converged.all()
    Xr, Yr = xy(r.u, r.v)
    assert np.abs(r.foot - np.column_stack([Xr, Yr, 0 * Xr])).max() <= 0.1 * tol + 1e-12
    assert np.abs(r.foot - PP * [1.0, 1.0, 0.0]).max() <= 10 * tol


def test_a_taylor_step_across_a_knot_is_not_kept():
    """z = a1 X^2 (X < 0), a2 X^2 (X >= 0) + b Y^2: a C1 surface (a double knot at u = 0 of a
    bicubic: the curvature jumps from 0.1 to 0.3). The Taylor model of one patch is wrong on
    the other, so a finish step that ends in another knot span (in u alone: v stays in its
    span) must be evaluated: from starts across the knot from feet 0.01 to 0.3 mm beside it,
    tol = 1e-5, the feet converge to the constructed ones (10 tol) with the foot S(u, v)
    (closed form) to 0.1 tol + 1e-12 (a kept step would be off by ~0.1 x (0.3 mm)^2)."""
    a1, a2, b = 0.05, 0.15, 0.03
    z = lambda X, Y: np.where(X < 0, a1, a2) * X ** 2 + b * Y ** 2
    knots = [np.array([-10.0, -5.0, 0.0, 5.0, 10.0]), np.array([-10.0, 0.0, 10.0])]
    mults = [np.array([4, 1, 2, 1, 4]), np.array([4, 1, 4])]
    t = [np.repeat(k, m) for k, m in zip(knots, mults)]
    g = [_greville(tt, 3) for tt in t]
    B = [BSpline(tt, np.eye(gg.size), 3)(gg) for tt, gg in zip(t, g)]
    U, V = np.meshgrid(g[0], g[1], indexing="ij")
    C = np.linalg.solve(B[0], np.stack([U, V, z(U, V)], axis=-1).reshape(g[0].size, -1)).reshape(U.shape + (3,))
    C = np.linalg.solve(B[1], C.transpose(1, 0, 2).reshape(g[1].size, -1)).reshape(g[1].size, g[0].size, 3)
    surf = BSplineSurface(np.ascontiguousarray(C.transpose(1, 0, 2)), knots[0], mults[0], knots[1], mults[1], 3, 3)
    tol = 1e-5
    rng = np.random.default_rng(27)
    X0, Y0 = rng.choice([-1, 1], 40) * rng.uniform(0.01, 0.3, 40), rng.uniform(-3, 3, 40)
    n = np.column_stack([-np.where(X0 < 0, 2 * a1, 2 * a2) * X0, -2 * b * Y0, np.ones(40)])
    P = np.column_stack([X0, Y0, z(X0, Y0)]) + n / np.linalg.norm(n, axis=1, keepdims=True) * rng.uniform(-2, 2, 40)[:, None]
    r = project_points_to_surface(surf, P, -X0 * rng.uniform(0.5, 2, 40), Y0 + 0.01, tol=tol)
    assert r.converged.all()
    assert np.abs(r.u - X0).max() < 10 * tol and np.abs(r.v - Y0).max() < 10 * tol
    assert np.abs(r.foot - np.column_stack([r.u, r.v, z(r.u, r.v)])).max() <= 0.1 * tol + 1e-12


def test_max_iter_zero_on_a_parabola_returns_two_clipped_newton_iterations():
    """With ``max_iter = 0`` on a degree-2 curve (its quadratic Taylor model exact) the foot
    returned is the start moved by the refined step: two Newton iterations on
    f(t) = |C(t) - P|^2 / 2 (closed form: f' = (t - x) + 2ct (ct^2 - y), f'' = 1 + 2c (3ct^2 - y)),
    each clipped to the trust region (four spans: 8) and to the domain, where it is no farther
    from P than the start (else the start). Starts where f'' > 0 at both points (the Newton
    branch), 1e-9 (rounding of t ~ 16). Catches a first step clipped wrongly before its
    refinement (the refinement then starts elsewhere)."""
    c = parabola2()
    rng = np.random.default_rng(28)
    P, t0 = rng.uniform(-14, 14, (400, 2)), rng.uniform(-16, 16, 400)
    d1 = lambda t: (t - P[:, 0]) + 2 * C_PAR * t * (C_PAR * t * t - P[:, 1])
    d2 = lambda t: 1 + 2 * C_PAR * (3 * C_PAR * t * t - P[:, 1])
    clip = lambda a: np.clip(t0 + np.clip(a, -8.0, 8.0), -16.0, 16.0) - t0
    a1 = clip(-d1(t0) / d2(t0))
    a2 = clip(a1 - d1(t0 + a1) / d2(t0 + a1))
    newton = (d2(t0) > 0.05) & (d2(t0 + a1) > 0.05)
    assert newton.sum() > 300
    dist = lambda t: np.hypot(t - P[:, 0], C_PAR * t * t - P[:, 1])
    want = np.where(dist(t0 + a2) <= dist(t0), t0 + a2, t0)
    r = project_points_to_curve(c, P, t0, max_iter=0)
    assert np.abs(r.t - want)[newton].max() < 1e-9


def test_converged_means_the_residual_and_the_step_are_both_within_tol():
    """Points 30 to 300 mm off the convex side of the degree-2 paraboloid and parabola, starts
    0.01 to 3 mm off their feet, tol = 1e-6: every point converges, and its tangential
    residual at the returned parameters (closed form; rounding ~1e-13 at 300 mm) is <= tol.
    There the Hessian is large ((1 + k d) |S_u|^2, 1 + k d up to 60), so the next Newton step
    is that much smaller than the residual: a convergence test on the step alone (or on
    either) stops with residuals up to 60 tol. Degree 2: every step is expanded (no third
    derivative), so the test runs at every iteration."""
    tol = 1e-6
    rng = np.random.default_rng(29)
    m = 600
    X0, Y0 = rng.uniform(-10, 10, m), rng.uniform(-10, 10, m)
    P = on_paraboloid(X0, Y0) - paraboloid_normal(X0, Y0) * rng.uniform(30, 300, m)[:, None]
    e, ang = 10 ** rng.uniform(-2, 0.5, m), rng.uniform(0, 2 * np.pi, m)
    r = project_points_to_surface(paraboloid2(), P, X0 + e * np.cos(ang), Y0 + e * np.sin(ang), tol=tol)
    assert r.converged.all()
    off = on_paraboloid(r.u, r.v) - P
    for T in (np.column_stack([np.ones(m), np.zeros(m), 2 * A_PAR * r.u]),
              np.column_stack([np.zeros(m), np.ones(m), 2 * B_PAR * r.v])):
        assert (np.abs(np.einsum("ij,ij->i", T, off)) / np.linalg.norm(T, axis=1)).max() <= tol
    x = rng.uniform(-10, 10, m)
    n = np.column_stack([-2 * C_PAR * x, np.ones(m)]) / np.hypot(2 * C_PAR * x, 1)[:, None]
    Q = np.column_stack([x, C_PAR * x * x]) - n * rng.uniform(30, 300, m)[:, None]
    rc = project_points_to_curve(parabola2(), Q, x + e * np.cos(ang), tol=tol)
    assert rc.converged.all()
    T = np.column_stack([np.ones(m), 2 * C_PAR * rc.t])
    off = np.column_stack([rc.t, C_PAR * rc.t ** 2]) - Q
    assert (np.abs(np.einsum("ij,ij->i", T, off)) / np.linalg.norm(T, axis=1)).max() <= tol


def test_converged_feet_near_centres_of_curvature_in_skewed_parameters():
    """The paraboloid in parameters 8 degrees apart ((X, Y) = (u - 0.99 v, 0.14 v)), points on
    the concave side near a centre of curvature of their foot (focal ratio q in [0.02, 0.3]:
    d = (1 - q) / k1, k1 the larger principal curvature, closed form), starts 0.001 to 0.3
    off, tol = 1e-6. There the next Newton step is up to 1/q times the residual, so the test
    on the step's length |du S_u + dv S_v| is what holds the foot. At each converged foot the
    residual and the next Newton step's length |J H^-1 g| (closed form in (X, Y): Newton steps
    do not depend on a linear reparametrisation) are <= tol (1 + 1e-6, rounding), wherever
    both parameters are free (a foot held on the domain's edge has a longer step outwards).
    (Near a centre of curvature a second foot may lie next to the constructed one, so the foot
    reached is not compared with it.) Catches a step length that misreads S_u.S_v (it stops
    with steps of several tol)."""
    tol = 1e-6
    c = -0.99
    M = ((1.0, c), (0.0, np.sqrt(1 - c * c)))
    rng = np.random.default_rng(30)
    m = 1500
    X0, Y0 = rng.uniform(-5, 5, m), rng.uniform(-1.3, 1.3, m)        # (u, v) inside [-15, 15]^2
    n = paraboloid_normal(X0, Y0)
    E, F, G = 1 + 4 * A_PAR ** 2 * X0 ** 2, 4 * A_PAR * B_PAR * X0 * Y0, 1 + 4 * B_PAR ** 2 * Y0 ** 2
    L, N = 2 * A_PAR * n[:, 2], 2 * B_PAR * n[:, 2]
    det = E * G - F * F
    H, K = (E * N + G * L) / (2 * det), L * N / det                # mean and Gauss curvature (M = 0)
    k1 = H + np.sqrt(H * H - K)
    d = (1 - rng.uniform(0.02, 0.3, m)) / k1
    P = on_paraboloid(X0, Y0) + n * d[:, None]
    uv = np.linalg.solve(M, np.vstack([X0, Y0]))
    e, ang = 10 ** rng.uniform(-3, -0.5, m), rng.uniform(0, 2 * np.pi, m)
    r = project_points_to_surface(paraboloid2(M), P, uv[0] + e * np.cos(ang), uv[1] + e * np.sin(ang), tol=tol)
    inner = r.converged & (np.abs(r.u) < 16) & (np.abs(r.v) < 16)       # free in both parameters
    assert inner.mean() > 0.99
    X, Y = (np.asarray(M) @ np.vstack([r.u, r.v]))[:, inner]
    k = X.size
    off = on_paraboloid(X, Y) - P[inner]

    SX = np.column_stack([np.ones(k), np.zeros(k), 2 * A_PAR * X])
    SY = np.column_stack([np.zeros(k), np.ones(k), 2 * B_PAR * Y])
    gX, gY = np.einsum("ij,ij->i", SX, off), np.einsum("ij,ij->i", SY, off)
    hXX = np.einsum("ij,ij->i", SX, SX) + 2 * A_PAR * off[:, 2]
    hXY = np.einsum("ij,ij->i", SX, SY)
    hYY = np.einsum("ij,ij->i", SY, SY) + 2 * B_PAR * off[:, 2]
    detH = hXX * hYY - hXY * hXY
    dX, dY = -(hYY * gX - hXY * gY) / detH, -(hXX * gY - hXY * gX) / detH
    assert np.all(detH > 0)
    assert np.linalg.norm(SX * dX[:, None] + SY * dY[:, None], axis=1).max() <= tol * (1 + 1e-6)
    assert np.maximum(np.abs(gX) / np.linalg.norm(SX, axis=1), np.abs(gY) / np.linalg.norm(SY, axis=1)).max() <= tol * (1 + 1e-6)



def test_gauss_newton_steps_descend_where_the_parametrisation_folds():
    """S(u, v) = (u + v, (u - v)^2, 0) (biquadratic, exact): the plane z = 0 over y >= 0, folded
    along u = v, where S_u = S_v (J^T J singular). For P over y > 0 the feet are (x, y, 0) at
    |u - v| = sqrt(y), distance |z| (closed form); across the fold the distance has a maximum
    (the Hessian is indefinite), so Newton takes the Gauss-Newton step there, which must stay
    a descent direction though J^T J is singular: its diagonal is raised, never lowered.
    Starts 1e-9 to 1e-7 off the fold: every point converges to the closed-form distance
    (1e-9, 10 tol). (On the fold the metric is singular and the Taylor finish bound is 0 / 0,
    which the code reads as "no expansion": numpy's warning is silenced here.)"""
    k, m, g, g2 = _degree2_knots(-4, 4, 1)
    U, V = np.meshgrid(g, g, indexing="ij")
    UU, VV = np.meshgrid(g2, g2, indexing="ij")
    s = BSplineSurface(np.stack([U + V, UU - 2 * U * V + VV, 0 * U], axis=-1), k, m, k, m, 2, 2)
    rng = np.random.default_rng(31)
    n = 200
    P = np.column_stack([rng.uniform(-2, 2, n), rng.uniform(0.2, 3, n), rng.uniform(-1, 1, n)])
    w0, s0 = rng.choice([-1, 1], n) * 10 ** rng.uniform(-9, -7, n), rng.uniform(-2, 2, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = project_points_to_surface(s, P, (s0 + w0) / 2, (s0 - w0) / 2)
    assert r.converged.all()
    assert np.abs(r.distance - np.abs(P[:, 2])).max() < 1e-9
    assert np.abs(r.foot - P * [1.0, 1.0, 0.0]).max() < 1e-9
