# SPDX-License-Identifier: LGPL-2.1-or-later
"""Fairness numbers (seed 004 criteria) on shapes with known answers."""
from __future__ import annotations

import numpy as np

from bladerecon.core.analysis.fairness import (
    count_inflections,
    gaussian_evenness,
    knot_curvature_jumps,
    strain_energy,
)
from bladerecon.core.geometry.fitting import interpolate_closed_curve, interpolate_curve
from bladerecon.core.geometry.spline import BSplineCurve
from bladerecon.core.surface.skinning import interpolate_grid

Z = np.array([0.0, 0.0, 1.0])


def _loop(r_of_theta, n=400):
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = r_of_theta(th)
    return np.c_[r * np.cos(th), r * np.sin(th), np.zeros(n)]


def test_strain_energy_of_a_circle_is_two_pi_over_r():
    c = interpolate_closed_curve(_loop(lambda t: np.full_like(t, 7.0)))
    assert abs(strain_energy(c) - 2 * np.pi / 7.0) < 1e-6


def test_inflections_of_a_convex_and_a_wavy_loop():
    # edge_fraction=0: no edge zones on these loops
    assert count_inflections(interpolate_closed_curve(_loop(lambda t: 10 + 0 * t)), Z, edge_fraction=0) == 0
    # r = 10 + 1.5 cos(5θ): 5 lobes, concave between them -> 10 sign changes
    wavy = interpolate_closed_curve(_loop(lambda t: 10 + 1.5 * np.cos(5 * t)))
    assert count_inflections(wavy, Z, edge_fraction=0) == 10


def test_curvature_jump_at_a_double_knot_and_none_for_c2():
    Q = np.c_[np.linspace(0, 10, 30), np.sin(np.linspace(0, 3, 30)), np.zeros(30)]
    c = interpolate_curve(Q)
    assert knot_curvature_jumps(c).max() < 1e-5
    # a double interior knot makes the cubic only C1: compare the jump with scipy's BSpline
    from scipy.interpolate import BSpline
    rng = np.random.default_rng(4)
    poles = np.c_[np.arange(6.0), rng.normal(size=6), np.zeros(6)]
    knots, mults = np.array([0.0, 0.5, 1.0]), np.array([4, 2, 4])
    c = BSplineCurve(poles, knots, mults, 3)
    ref = BSpline(np.repeat(knots, mults), poles, 3)

    def kappa(t):
        d1, d2 = ref(t, 1), ref(t, 2)
        return np.linalg.norm(np.cross(d1, d2)) / np.linalg.norm(d1) ** 3

    expected = abs(kappa(0.5 + 1e-9) - kappa(0.5 - 1e-9))
    assert expected > 0.01
    assert abs(knot_curvature_jumps(c)[0] - expected) < 1e-6


def test_gaussian_curvature_of_a_cylinder_is_even_and_zero():
    th = np.linspace(0, 2 * np.pi, 60, endpoint=False)
    grid = np.stack([np.c_[5 * np.cos(th), 5 * np.sin(th), np.full(60, z)] for z in np.linspace(0, 10, 8)])
    g = gaussian_evenness(interpolate_grid(grid, "chord"))
    assert abs(g["k_min"]) < 1e-4 and abs(g["k_max"]) < 1e-4
