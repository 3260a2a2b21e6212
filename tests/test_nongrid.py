# SPDX-License-Identifier: LGPL-2.1-or-later
"""Seed 003 non-grid fitting: rows of different lengths -> hierarchical least-squares surface."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import make_lsq_spline

from bladerecon.core.geometry.bspline import approximation_knots, chord_parameters, evaluate_surface
from bladerecon.core.errors import BladeReconError
from bladerecon.core.surface.nongrid import (
    check_rows_overlap,
    fit_nongrid,
    fit_row_curve,
    hierarchical_surface,
    parse_poles,
    periodic_approximation_knots,
)
from bladerecon.core.geometry.projection import project_points_to_surface
from bladerecon.core.geometry.spline import BSplineSurface
from realdata_fixtures import BLADE, nongrid_counts, nongrid_rows

AXIS = np.array([0.0, 0.0, 1.0])


def test_counts_are_those_of_seed_003():
    c = nongrid_counts()
    assert len(c) == 21 and c.sum() == 2255 and c.min() >= 97 and c.max() <= 118


def test_seed_003_experiment_on_one_blade_side():
    """21 open rows of 97-118 points (2255) on the suction flank, cubic 24 x 9 poles."""
    counts = nongrid_counts()
    rows, heights = nongrid_rows(counts, closed=False)
    fit = fit_nongrid(rows, AXIS, (24, 9), closed=False)
    assert fit.surface.shape == (24, 9) and fit.surface.u_degree == 3 and fit.surface.v_degree == 3
    d = project_points_to_surface(fit.surface, np.concatenate(rows)).distance
    assert d.mean() < 2e-5 and d.max() < 5e-4          # mm: measured 5.7e-6 / 8.6e-5
    # between the rows too: true points of the flank at heights no row was measured at
    mid = []
    for h in (heights[:-1] + heights[1:]) / 2:
        b = BLADE.segment_bounds(h)
        mid.append(BLADE.point(h, np.linspace(b[3] + 0.02 * (b[4] - b[3]), b[4] - 0.02 * (b[4] - b[3]), 50)))
    dm = project_points_to_surface(fit.surface, np.concatenate(mid)).distance
    assert dm.max() < 5e-4


def test_closed_rows_of_different_lengths_give_the_requested_poles():
    counts = nongrid_counts()
    rows, _ = nongrid_rows(counts, closed=True)
    fit = fit_nongrid(rows, AXIS, (60, 9), closed=True)
    assert fit.surface.shape == (60, 9) and fit.surface.u_periodic and not fit.surface.v_periodic
    d = project_points_to_surface(fit.surface, np.concatenate(rows)).distance
    # whole profiles with 0.7-0.9 mm edge radii sampled ~1.1 mm apart: the edges dominate
    assert d.mean() < 0.02 and d.max() < 0.5
    fine = fit_nongrid(rows, AXIS, (100, 12), closed=True)
    df = project_points_to_surface(fine.surface, np.concatenate(rows)).distance
    assert df.mean() < d.mean()                        # more poles, closer


def test_open_row_curve_matches_scipy_least_squares():
    th = np.linspace(0.0, 2.5, 107)
    Q = np.c_[30 * np.cos(th), 30 * np.sin(th), 0.5 * th ** 2]
    sc = fit_row_curve(Q, 20, closed=False)
    u = chord_parameters(Q)
    U = approximation_knots(u, 3, 20)
    w = np.ones(len(u))
    w[[0, -1]] = 1e8                                   # A9.7: ends kept
    ref = make_lsq_spline(u, Q, U, k=3, w=np.sqrt(w))
    # equal up to the tiny diagonal regularisation of least_squares_curve (1e-14 of the
    # largest normal-matrix entry, which the 1e8 end weights make ~1e-6)
    assert np.abs(sc.curve.poles - ref.c).max() < 1e-4


def test_hierarchical_fit_reproduces_a_surface_of_its_own_space():
    rng = np.random.default_rng(0)
    u = np.linspace(0.0, 1.0, 80)
    v = np.linspace(0.0, 1.0, 15)
    from bladerecon.core.geometry.fitting import knots_from_full
    uk, um = knots_from_full(approximation_knots(u, 3, 12))
    vk, vm = knots_from_full(approximation_knots(v, 3, 6))
    truth = BSplineSurface(rng.normal(size=(12, 6, 3)), uk, um, vk, vm, 3, 3)
    U, V = np.meshgrid(u, v)                            # (15, 80)
    grid = evaluate_surface(truth, U.ravel(), V.ravel()).reshape(15, 80, 3)
    s = hierarchical_surface(grid, u, v, 12, 6, closed=False)
    assert np.abs(s.poles - truth.poles).max() < 1e-8


def test_periodic_knots_share_the_points_evenly():
    t = np.sort(np.random.default_rng(1).random(100))
    t[0] = 0.0
    k = periodic_approximation_knots(t, 20)
    counts = np.histogram(t, bins=k)[0]
    assert k[0] == 0.0 and k[-1] == 1.0 and counts.min() >= 4 and counts.max() <= 6


def test_bad_input_is_named():
    with pytest.raises(BladeReconError, match="NUxNV"):
        parse_poles("24,9")
    counts = nongrid_counts()
    rows, _ = nongrid_rows(counts[:6], closed=True)
    with pytest.raises(BladeReconError, match="9 poles along the span need at least 9 rows"):
        fit_nongrid(rows, AXIS, (24, 9))
    # open rows that cover different parts of the profile do not overlap
    a = BLADE.point(0.2, np.linspace(0.52, 0.62, 100))
    b = BLADE.point(0.4, np.linspace(0.85, 0.95, 100))
    with pytest.raises(BladeReconError, match="do not overlap"):
        check_rows_overlap([a, b], AXIS)
    rows, _ = nongrid_rows(counts[:4], closed=False)
    with pytest.raises(BladeReconError, match="span order"):
        check_rows_overlap([rows[0], rows[2], rows[1], rows[3]], AXIS)
