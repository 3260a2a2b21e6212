# SPDX-License-Identifier: LGPL-2.1-or-later
"""Contract tests of :mod:`bladerecon.core.geometry.projection.newton`: the trust-region Newton
iteration, checked on what it documents and against referees that share no code with it.

Referees:

* closed forms: the feet on a degree-2 plane, line, parabola and paraboloid (whose B-spline
  poles are exact: the blossoms of x, x^2 at the knots, all small integers or halves), the
  paraboloid's feet by the monotone Lagrange equation of the quadric (``scipy.optimize.brentq``),
  the parabola's by the roots of its cubic (``numpy.roots``); the principal curvatures of the
  paraboloid at its vertex (2a, 2b) for the focal ratio (1 - k1 d)(1 - k2 d);
* the polynomial a spline interpolates, evaluated by hand with its derivatives, for the
  cubic test surfaces (foot = S(u, v), tangential residuals at the returned parameters);
* brute force: L-BFGS-B (``scipy.optimize.minimize``) on the polynomial itself.

What the Newton iteration documents, and so what is checked:

* steps are clipped to four knot spans at first, then to at most eight, the direction kept;
  a rejected step quarters the trust region (``_TRUST_START``, ``_TRUST_MAX``);
* every step is refined on the quadratic Taylor model (two Newton iterations on it, no new
  evaluation): on a degree-2 surface that model is exact, so a start close enough converges
  with ``max_iter = 0``;
* a step small enough is taken by Taylor expansion with an error under 0.1 ``tol`` in the
  foot (``_FINISH``); the point has converged when the tangential residual and the next step
  are both <= ``tol``; the foot returned at ``max_iter`` unconverged is the best one found;
* the exact Hessian is used where it is positive definite, else Gauss-Newton J^T J: Newton
  converges quadratically on any parametrisation (parameter ranges of 1e-3 or 1e5 per
  10 mm as well as of 1), and never to a saddle or maximum of the distance;
* the focal ratio returned is det H / det J^T J = (1 - k1 d)(1 - k2 d) at the foot.

Run time: every test well under a second; no test changes module state.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq, minimize

from bladerecon.core.geometry.projection import cache as proj_cache
from bladerecon.core.geometry.projection import evaluation as proj_evaluation
from bladerecon.core.geometry.projection import newton as proj_newton
from bladerecon.core.geometry.projection import project_points_to_curve, project_points_to_surface
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

TOL = 1e-10          # mm: the projection's default tolerance


@pytest.fixture(autouse=True)
def fresh_cache():
    """The spline cache empty before and after every test."""
    proj_cache._cache.clear()
    try:
        yield
    finally:
        proj_cache._cache.clear()


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
