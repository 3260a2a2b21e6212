# SPDX-License-Identifier: LGPL-2.1-or-later
"""B-spline basics against scipy's BSpline (an implementation we did not write)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from bladerecon.core.geometry.bspline import (
    approximation_knots,
    averaged_knots,
    basis_derivatives,
    centripetal_parameters,
    chord_parameters,
    closed_parameters,
    collocation_matrix,
    curve_curvature,
    curve_derivatives,
    evaluate_surface,
    find_spans,
    surface_derivatives,
)
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface, full_knot_vector


def _random_clamped(rng, n=12, p=3, dim=3):
    inner = np.sort(rng.random(n - p - 1))
    knots = np.concatenate([[0.0], inner, [1.0]])
    mults = np.concatenate([[p + 1], np.ones(inner.size, int), [p + 1]])
    return BSplineCurve(rng.random((n, dim)), knots, mults, p, False)


@pytest.mark.parametrize("p", [1, 2, 3, 4])
def test_clamped_curve_and_derivatives_match_scipy(p):
    rng = np.random.default_rng(p)
    c = _random_clamped(rng, n=11, p=p)
    ref = BSpline(full_knot_vector(c.knots, c.mults, p, False), c.poles, p)
    u = np.linspace(0, 1, 777)
    d = curve_derivatives(c, u, min(p, 3))
    for k in range(min(p, 3) + 1):
        want = ref(u) if k == 0 else ref.derivative(k)(u)
        scale = max(1.0, np.abs(want).max())
        assert np.abs(d[:, k] - want).max() < 1e-10 * scale


@pytest.mark.parametrize("p", [2, 3])
def test_periodic_curve_matches_unwrapped_scipy_spline_and_closes(p):
    rng = np.random.default_rng(10 + p)
    n = 9
    knots = np.concatenate([[0.0], np.sort(rng.random(n - 1)), [1.0]])
    c = BSplineCurve(rng.random((n, 3)), knots, np.ones(n + 1, int), p, True)
    ref = BSpline(c.full_knots(), c.unwrapped_poles(), p)
    u = np.linspace(0, 1, 500, endpoint=False)
    assert np.abs(curve_derivatives(c, u, 0)[:, 0] - ref(u)).max() < 1e-13
    # C^(p-1) across the seam: value and derivatives at 0 and 1 agree
    ends = curve_derivatives(c, np.array([0.0, 1.0 - 1e-15]), p - 1)
    assert np.abs(ends[0] - ends[1]).max() < 1e-9
    # parameters outside [0, 1) wrap
    assert np.allclose(curve_derivatives(c, u + 3.0, 0), curve_derivatives(c, u, 0))


def test_basis_partition_of_unity_and_derivative_sum_zero():
    rng = np.random.default_rng(3)
    c = _random_clamped(rng, n=15, p=3)
    U = c.full_knots()
    u = rng.random(1000)
    span = find_spans(U, 3, 15, u)
    N = basis_derivatives(U, 3, span, u, 2)
    assert np.allclose(N[:, 0].sum(axis=1), 1.0)
    assert np.allclose(N[:, 1].sum(axis=1), 0.0, atol=1e-9)
    assert np.all(N[:, 0] >= -1e-15)


def test_collocation_matrix_rows_are_basis_values():
    rng = np.random.default_rng(4)
    c = _random_clamped(rng, n=10, p=3)
    u = np.linspace(0, 1, 50)
    A = collocation_matrix(c.knots, c.mults, 3, False, 10, u)
    assert np.allclose(A @ c.poles, curve_derivatives(c, u, 0)[:, 0])


def test_surface_matches_tensor_product_of_scipy_curves():
    rng = np.random.default_rng(5)
    nu, nv = 8, 6
    uk = np.concatenate([[0.0], np.sort(rng.random(nu - 1)), [1.0]])
    vk = np.concatenate([[0.0], np.sort(rng.random(nv - 4)), [1.0]])
    vm = np.concatenate([[4], np.ones(nv - 4, int), [4]])
    P = rng.random((nu, nv, 3))
    s = BSplineSurface(P, uk, np.ones(nu + 1, int), vk, vm, 3, 3, True, False)
    u, v = rng.random(300), rng.random(300)
    # S(u,v) = sum_j N_j(v) C_j(u): evaluate the v-direction by scipy on poles interpolated in u
    Uu = full_knot_vector(uk, np.ones(nu + 1, int), 3, True)
    Uv = full_knot_vector(vk, vm, 3, False)
    Pw = np.concatenate([P, P[:3]], axis=0)
    ref = np.stack([BSpline(Uv, BSpline(Uu, Pw, 3)(ui), 3)(vi) for ui, vi in zip(u, v)])
    assert np.abs(evaluate_surface(s, u, v) - ref).max() < 1e-12
    # mixed derivative by finite differences
    d = surface_derivatives(s, u, v, 2)
    h = 1e-6
    fd = (evaluate_surface(s, u + h, v + h) - evaluate_surface(s, u + h, v - h)
          - evaluate_surface(s, u - h, v + h) + evaluate_surface(s, u - h, v - h)) / (4 * h * h)
    inside = (v > 2 * h) & (v < 1 - 2 * h)
    assert np.abs(d[inside, 1, 1] - fd[inside]).max() < 1e-3 * np.abs(d[:, 1, 1]).max()


def test_curvature_of_a_circle():
    from bladerecon.core.geometry.fitting import interpolate_closed_curve

    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    r = 7.5
    c = interpolate_closed_curve(np.c_[r * np.cos(t), r * np.sin(t), np.zeros_like(t)])
    k = curve_curvature(c, np.linspace(0, 1, 1000, endpoint=False))
    # cubic interpolation of a circle: relative curvature error ~ h²/12 with h = 2π/200
    assert np.abs(k * r - 1).max() < 1.5 * (2 * np.pi / 200) ** 2 / 12


def test_parameterisations():
    pts = np.array([[0, 0, 0], [1, 0, 0], [1, 4, 0], [1, 4, 9.0]])
    assert np.allclose(chord_parameters(pts), [0, 1 / 14, 5 / 14, 1])
    assert np.allclose(centripetal_parameters(pts), [0, 1 / 6, 3 / 6, 1])
    sq = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    assert np.allclose(closed_parameters(sq, "chord"), [0, 0.25, 0.5, 0.75])


def test_knot_vectors():
    u = np.array([0.0, 0.1, 0.3, 0.6, 0.8, 1.0])
    U = averaged_knots(u, 3)
    assert np.allclose(U, [0, 0, 0, 0, (0.1 + 0.3 + 0.6) / 3, (0.3 + 0.6 + 0.8) / 3, 1, 1, 1, 1])
    U2 = averaged_knots(u, 3, n_poles=8)   # with end derivatives: every window of 3
    assert U2.size == 12 and np.allclose(U2[4:8], [np.mean(u[i:i + 3]) for i in range(4)])
    # NURBS Book eq. 9.69: d = (m+1)/(n-p+1)
    uu = np.linspace(0, 1, 11)
    A = approximation_knots(uu, 3, 6)
    d = 11 / 3
    want = [(1 - (j * d - int(j * d))) * uu[int(j * d) - 1] + (j * d - int(j * d)) * uu[int(j * d)] for j in (1, 2)]
    assert np.allclose(A[4:6], want)


def test_few_parameters_give_the_vectorised_basis_bit_for_bit(monkeypatch):
    """The plain-float path for a few parameters (chord-end Newton steps) repeats the vectorised
    operations: the same numbers and memory layout, so no figure downstream moves."""
    import bladerecon.core.geometry.bspline as bs

    rng = np.random.default_rng(7)
    for _ in range(400):
        p = int(rng.integers(1, 6))
        n_poles = int(rng.integers(p + 1, p + 12))
        nk = n_poles - p + 1
        knots = np.linspace(0, 1, nk) if rng.random() < 0.3 else np.sort(np.r_[0.0, rng.random(nk - 2), 1.0])
        mults = np.ones(nk, int)
        mults[[0, -1]] = p + 1
        U = full_knot_vector(knots, mults, p, False)
        u = rng.random(int(rng.integers(1, bs._FEW + 1)))
        u[0] = knots[int(rng.integers(0, nk))] if rng.random() < 0.2 else u[0]
        span = bs.find_spans(U, p, n_poles, u)
        n_ders = int(rng.integers(0, p + 3))
        few = bs.basis_derivatives(U, p, span, u, n_ders)
        monkeypatch.setattr(bs, "_FEW", 0)
        ref = bs.basis_derivatives(U, p, span, u, n_ders)
        monkeypatch.undo()
        assert few.shape == ref.shape and few.strides == ref.strides and np.array_equal(few, ref)
