# SPDX-License-Identifier: LGPL-2.1-or-later
"""Interpolation and least squares: exactness, end derivatives, sparse solves, scipy cross-check."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import make_interp_spline, make_lsq_spline

from bladerecon.core.geometry.bspline import centripetal_parameters, chord_parameters, closed_parameters, curve_derivatives
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.fitting import (
    approximate_curve,
    interpolate_closed_curve,
    interpolate_curve,
    interpolate_curve_with_end_derivatives,
    least_squares_curve,
    smoothing_matrix,
    uniform_periodic_knots,
)
from bladerecon.core.geometry.spline import full_knot_vector


def _helix(n):
    t = np.linspace(0, 3, n)
    return np.c_[np.cos(t), np.sin(t), 0.3 * t]


def test_clamped_interpolation_passes_through_points_and_matches_scipy():
    Q = _helix(25)
    c = interpolate_curve(Q)
    u = centripetal_parameters(Q)
    assert np.abs(curve_derivatives(c, u, 0)[:, 0] - Q).max() < 1e-12
    ref = make_interp_spline(u, Q, k=3, t=full_knot_vector(c.knots, c.mults, 3, False))
    x = np.linspace(0, 1, 400)
    assert np.abs(curve_derivatives(c, x, 0)[:, 0] - ref(x)).max() < 1e-10


def test_closed_interpolation_is_periodic_and_exact():
    t = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    Q = np.c_[30 * np.cos(t), 2.5 * np.sin(t) + 0.2 * np.cos(3 * t), 0.1 * np.sin(t)]
    c = interpolate_closed_curve(Q)
    assert c.periodic and c.n_poles == 60
    u = closed_parameters(Q)
    assert np.abs(curve_derivatives(c, u, 0)[:, 0] - Q).max() < 1e-11
    d = curve_derivatives(c, np.array([0.0, 1.0 - 1e-14]), 2)
    assert np.abs(d[0] - d[1]).max() < 1e-6 * np.abs(d).max()   # C2 across the seam


def test_end_derivative_interpolation_seed001_eqs3_4():
    Q = _helix(12)
    D0, Dn = np.array([0.5, 2.0, -1.0]), np.array([-1.0, 0.0, 3.0])
    c = interpolate_curve_with_end_derivatives(Q, D0, Dn)
    assert c.n_poles == 14
    d = curve_derivatives(c, np.array([0.0, 1.0]), 1)
    assert np.allclose(d[0, 1], D0) and np.allclose(d[1, 1], Dn)
    assert np.abs(curve_derivatives(c, chord_parameters(Q), 0)[:, 0] - Q).max() < 1e-11
    # seed 001 eq. 3 in its own form: -P0 + P1 = (u_{p+1} / p) D0
    U = full_knot_vector(c.knots, c.mults, 3, False)
    assert np.allclose(c.poles[1] - c.poles[0], U[4] / 3 * D0)
    assert np.allclose(c.poles[-1] - c.poles[-2], (1 - U[-5]) / 3 * Dn)


def test_least_squares_matches_scipy_lsq_spline():
    rng = np.random.default_rng(1)
    x = np.sort(rng.random(300))
    y = np.c_[np.sin(5 * x), np.cos(3 * x), x**2] + rng.normal(0, 0.01, (300, 3))
    t = np.r_[[0] * 4, np.linspace(0, 1, 9)[1:-1], [1] * 4]
    knots, mults = np.unique(t, return_counts=True)
    c = least_squares_curve(y, x, knots, mults, 3, False)
    ref = make_lsq_spline(x, y, t, k=3)
    assert np.abs(c.poles - ref.c).max() < 1e-8


def test_periodic_least_squares_recovers_ellipse_and_smoothing_reduces_energy():
    t = np.linspace(0, 2 * np.pi, 800, endpoint=False)
    rng = np.random.default_rng(2)
    Q = np.c_[20 * np.cos(t), 3 * np.sin(t), np.zeros_like(t)] + rng.normal(0, 0.002, (800, 3))
    knots, mults = uniform_periodic_knots(40)
    u = t / (2 * np.pi)
    c0 = least_squares_curve(Q, u, knots, mults, 3, True)
    c1 = least_squares_curve(Q, u, knots, mults, 3, True, smoothing=1e-2)
    E = smoothing_matrix(knots, mults, 3, True, 40)
    energy = [float(np.einsum("id,ij,jd->", c.poles, E.toarray(), c.poles)) for c in (c0, c1)]
    assert energy[1] < energy[0]
    truth = np.c_[20 * np.cos(t), 3 * np.sin(t), np.zeros_like(t)]
    assert np.abs(curve_derivatives(c0, u, 0)[:, 0] - truth).max() < 0.01


def test_smoothing_matrix_is_exact_bending_energy_of_a_parabola():
    # C(u) = (u, u^2, 0) as a clamped cubic: ∫|C''|² du = 4 on [0, 1]
    from bladerecon.core.geometry.fitting import interpolate_curve
    u = np.linspace(0, 1, 9)
    c = interpolate_curve(np.c_[u, u**2, 0 * u], params=u)
    E = smoothing_matrix(c.knots, c.mults, 3, False, c.n_poles).toarray()
    assert np.einsum("id,ij,jd->", c.poles, E, c.poles) == pytest.approx(4.0, rel=1e-9)


def test_approximate_curve_interpolates_ends():
    Q = _helix(200)
    c = approximate_curve(Q, 12)
    d = curve_derivatives(c, np.array([0.0, 1.0]), 0)[:, 0]
    assert np.allclose(d, Q[[0, -1]], atol=1e-6)


def test_singular_system_is_a_user_error():
    Q = np.zeros((6, 3))
    with pytest.raises(BladeReconError):
        interpolate_closed_curve(Q, params=np.zeros(6))
