# SPDX-License-Identifier: LGPL-2.1-or-later
"""Contract tests of :mod:`bladerecon.core.geometry.projection.grid`: the start grids and the
bounds that prune the global search, checked against referees that share no code with it.

* documented rules checked exactly: grid sizes ``ceil(length / spacing) + 1``, the spacing
  (a sixth of the finer median span, coarser by 1.25 until the grid holds 60 000 samples),
  grid steps per span (one per spacing, one per 20 degrees, at most 256), sample parameters
  spread evenly in that measure with both piece ends, cell covers (0.55 x the longer
  diagonal / chord), the largest cover round a sample, neighbour reductions, ``close``;
* closed forms: planes (exact unit normals, thin covers of a flat grid), a parabolic
  cylinder z = a x^2 (chord distances and sagittas of a parabola), a vee (the two arms'
  normals), a collapsed triangle (the apex samples moved a quarter step into the surface);
* brute force: the separation of every sample from the rest of the spline (all pairs, the
  documented window rule), and the thin-cover bound against the true distance to the four
  cells round a sample, sampled on a fine parameter grid by scipy's BSpline.

Tolerances: exact rules are compared exactly or to 1e-12 relative (one or two roundings of
numbers ~1..100); geometric bounds to the sampling error stated at each test. Each test runs
well under a second; no timing asserts.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from bladerecon.core.geometry.projection import grid as G
from bladerecon.core.geometry.projection.evaluation import _CurveModel, _SpanPolynomials, _SurfaceModel
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

REL = 1e-12


# ---------------------------------------------------------------- splines built here
from spline_referees import basis as _basis, fresh_cache, full_knots as _full  # noqa: F401 (fresh_cache: autouse)
from spline_referees import greville as _greville, interpolated_surface as _interpolated_surface



def _ref_surface(s: BSplineSurface, u, v, du=0, dv=0):
    """S (or a partial derivative) at the pairs (u, v) by scipy (clamped surfaces)."""
    tu, tv = _full(s.u_knots, s.u_mults, s.u_degree), _full(s.v_knots, s.v_mults, s.v_degree)
    Bu, Bv = _basis(tu, s.u_degree, u, du), _basis(tv, s.v_degree, v, dv)
    return np.einsum("mi,mj,ijd->md", Bu, Bv, s.poles)


def small_plane() -> BSplineSurface:
    """S = (0.5 u, 0.5 v, 3) + offset, bilinear on [0, 1]^2: |S_u x S_v| = 0.25 < 1."""
    poles = np.array([[[1.0, 2.0, 3.0], [1.0, 2.5, 3.0]], [[1.5, 2.0, 3.0], [1.5, 2.5, 3.0]]])
    return BSplineSurface(poles, np.array([0.0, 1.0]), np.array([2, 2]), np.array([0.0, 1.0]), np.array([2, 2]), 1, 1)


A_PC, L_PC, W_PC = 0.05, 10.0, 4.0


def parabolic_cylinder() -> BSplineSurface:
    """z = a x^2, x = L (2u - 1), y = W v: cubic in u, linear in v (exact)."""
    def f(u, v):
        x, y = np.broadcast_arrays(L_PC * (2 * u - 1), W_PC * v)
        return np.stack([x, y, A_PC * x * x], axis=-1)
    return _interpolated_surface(f, np.array([0.0, 0.5, 1.0]), np.array([4, 1, 4]),
                                 np.array([0.0, 1.0]), np.array([2, 2]), 3, 1)


def vee() -> BSplineSurface:
    """z = |x| on x in [-10, 10], y in [0, 8]: a crease (mult 2 = degree) at u = 0.5."""
    x, y = np.array([-10.0, -5.0, 0.0, 5.0, 10.0]), np.array([0.0, 4.0, 8.0])
    X, Y = np.meshgrid(x, y, indexing="ij")
    return BSplineSurface(np.stack([X, Y, np.abs(X)], axis=-1), np.array([0, 0.5, 1.0]), np.array([3, 2, 3]),
                          np.array([0.0, 1.0]), np.array([3, 3]), 2, 2)


TRI_A, TRI_B, TRI_C = np.array([0.0, 0.0, 0.0]), np.array([10.0, 0.0, 0.0]), np.array([5.0, 10.0, 0.0])


def collapsed_triangle() -> BSplineSurface:
    """(1 - w)((1 - u) A + u B) + w C with w = v (1 + v) / 2: the edge v = 1 collapses to the
    apex C (S_u = 0 there, S_v not), and the v grid is not uniform in v (w is not linear)."""
    def f(u, v):
        u, v = np.broadcast_arrays(u, v)
        w = (0.5 * v * (1 + v))[..., None]
        u = u[..., None]
        return (1 - w) * ((1 - u) * TRI_A + u * TRI_B) + w * TRI_C
    return _interpolated_surface(f, np.array([0.0, 1.0]), np.array([3, 3]), np.array([0.0, 0.3, 0.99, 1.0]),
                                 np.array([3, 1, 1, 3]), 2, 2)


def thin_blade() -> BSplineSurface:
    """A thin closed section (20 x 1.6 mm) swept along z: periodic cubic in u, clamped in v."""
    n = 24
    th = 2 * np.pi * (np.arange(n) + 0.3 * np.sin(np.arange(n))) / n
    sec = np.column_stack([10 * np.cos(th), 0.8 * np.sin(th)])
    v_knots, v_mults = np.array([0.0, 0.5, 1.0]), np.array([4, 1, 4])
    gv = _greville(_full(v_knots, v_mults, 3), 3)
    poles = np.stack([np.column_stack([sec[:, 0] + 0.5 * g, sec[:, 1], np.full(n, 12 * g)]) for g in gv], axis=1)
    steps = 1 + 0.25 * np.cos(np.arange(n))
    u_knots = np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()
    return BSplineSurface(poles, u_knots, np.ones(n + 1, int), v_knots, v_mults, 3, 3, True, False)


C_PAR, L_CURVE = 0.08, 10.0


def parabola_curve() -> BSplineCurve:
    """y = c x^2, x = L (2t - 1): clamped cubic with interior knots (exact)."""
    knots, mults = np.array([0.0, 0.25, 0.6, 1.0]), np.array([4, 1, 1, 4])
    t = _full(knots, mults, 3)
    g = _greville(t, 3)
    x = L_CURVE * (2 * g - 1)
    poles = np.linalg.solve(_basis(t, 3, g), np.column_stack([x, C_PAR * x * x, np.zeros_like(x)]))
    return BSplineCurve(poles, knots, mults, 3, False)


def ellipse_curve() -> BSplineCurve:
    """A closed periodic cubic round an ellipse 6 x 2 mm (non-uniform knots)."""
    n = 12
    th = 2 * np.pi * np.arange(n) / n
    poles = np.column_stack([6 * np.cos(th), 2 * np.sin(th), np.zeros(n)])
    knots = np.concatenate([[0.0], np.cumsum(1 + 0.3 * np.sin(np.arange(n)))])
    return BSplineCurve(poles, knots / knots[-1], np.ones(n + 1, int), 3, True)


def kinked_curve() -> BSplineCurve:
    """Two quadratic arcs meeting at a crease (knot of multiplicity 2 = degree) at t = 0.5,
    folding back so that the arms come close to each other."""
    poles = np.array([[0.0, 0, 0], [5, 0.5, 0], [10, 0, 0], [5, -0.5, 0], [0.5, -0.3, 0]])
    return BSplineCurve(poles, np.array([0.0, 0.5, 1.0]), np.array([3, 2, 3]), 2, False)


def _span(knots, mults, degree, periodic=False) -> _SpanPolynomials:
    n_poles = int(np.sum(mults[:-1])) if periodic else int(np.sum(mults)) - degree - 1
    return _SpanPolynomials(np.asarray(knots, float), np.asarray(mults), degree, periodic, n_poles)


# ---------------------------------------------------------------- small functions, exact

def test_segment_distance_beyond_the_far_end_is_the_distance_to_that_end():
    # foot parameter t = 3 on A -> B: clamped to B, the distance is |P - B| = 2 exactly
    A, B = np.zeros((3, 1)), np.array([[1.0], [0.0], [0.0]])
    P = np.array([[3.0], [0.0], [0.0]])
    assert G._segment_distance(P, A, B)[0] == pytest.approx(2.0, rel=REL)
    P = np.array([[0.5], [0.0], [4.0]])                     # inside: the height
    assert G._segment_distance(P, A, B)[0] == pytest.approx(4.0, rel=REL)


def test_grid_parameters_spread_evenly_in_cost_with_both_piece_ends():
    d = _span([0.0, 1.0, 2.0, 4.0], [4, 1, 1, 4], 3)
    # costs 1.5, 0.5, 2: 4 steps, targets 0, 1, 2, 3, 4 of the cumulated cost
    t, pieces = G._grid_parameters(d, np.array([1.5, 0.5, 2.0]))
    np.testing.assert_allclose(t, [0.0, 1.0 / 1.5, 2.0, 3.0, 4.0], rtol=REL, atol=1e-15)
    assert np.all(pieces == 0)
    # a fraction of a step gets a step: 3 + 1.5e-9 steps are 4 (the 1e-9 only absorbs the
    # rounding of the cumulated sum, ~1e-15)
    t, _ = G._grid_parameters(d, np.array([1.0, 1.0, 1.0 + 1.5e-9]))
    assert t.size == 5
    # an integer number of steps is that many, not one more
    t, _ = G._grid_parameters(d, np.array([1.0, 1.0, 2.0]))
    assert t.size == 5
    # a piece worth less than a step still has its two ends, and only those
    t, _ = G._grid_parameters(d, np.array([0.1, 0.2, 0.3]))
    np.testing.assert_array_equal(t, [0.0, 4.0])
    # no cost at all (a degenerate piece): its two ends
    t, _ = G._grid_parameters(d, np.zeros(3))
    np.testing.assert_array_equal(t, [0.0, 4.0])
    # a first span of no cost: the steps still follow the whole piece (n + 1 samples, to its end)
    t, _ = G._grid_parameters(d, np.array([0.0, 1.0, 1.0]))
    assert t.size == 3 and t[-1] == 4.0


def test_grid_parameters_of_creased_and_wrapping_directions():
    # two pieces (crease at 1): each gets its ends, the crease sample twice
    d = _span([0.0, 1.0, 2.0], [3, 2, 3], 2)
    t, pieces = G._grid_parameters(d, np.array([2.0, 3.0]))
    np.testing.assert_allclose(t, [0.0, 0.5, 1.0, 1.0, 4 / 3, 5 / 3, 2.0], rtol=REL)
    np.testing.assert_array_equal(pieces, [0, 0, 0, 1, 1, 1, 1])
    # both pieces of no cost: each its own two ends (knots 0, 1 and 1, 2)
    t, pieces = G._grid_parameters(d, np.zeros(2))
    np.testing.assert_array_equal(t, [0.0, 1.0, 1.0, 2.0])
    # a wrapping direction: n steps give n samples (the end is the start)
    d = _span([0.0, 1.0, 2.0, 3.0, 4.0], [1, 1, 1, 1, 1], 3, periodic=True)
    assert d.wraps
    t, _ = G._grid_parameters(d, np.full(4, 2.0))
    np.testing.assert_allclose(t, np.arange(8) * 0.5, rtol=REL)


def test_polyline_measures_of_a_closed_polygon_and_a_reversal():
    # closed quadrilateral (0,0) (2,0) (2,1) (0,3): lengths 2, 1, sqrt 8, 3 and the turns at
    # the starts of the segments (angle to the next segment)
    X = np.array([[0.0, 0, 0], [2, 0, 0], [2, 1, 0], [0, 3, 0]])
    L, A = G._polyline_measures(X, True)
    np.testing.assert_allclose(L, [2, 1, np.sqrt(8), 3], rtol=REL)
    np.testing.assert_allclose(A, np.radians([90, 45, 135, 90]), rtol=1e-12)
    # a segment that turns straight back: 180 degrees, even where rounding puts the
    # cosine a hair below -1
    e = np.array([0.21, 0.46, 0.09])          # |e/|e||^2 rounds to a hair above 1
    X = np.array([np.zeros(3), e, np.zeros(3)])
    L, A = G._polyline_measures(X, False)
    assert np.all(np.isfinite(A)) and A[0] == np.pi           # the cosine clipped to -1


def test_sample_spacing_is_a_sixth_of_the_finer_median_span():
    # medians 1.5 and 0.3 (zeros left out): 0.3 / 6
    s = G._sample_spacing([np.array([0.0, 0.0, 0.0, 1.0, 2.0]), np.array([0.2, 0.3, 0.4])])
    assert s == pytest.approx(0.05, rel=REL)
    # a direction of no length is left out; spans shorter than 1 mm count
    assert G._sample_spacing([np.zeros(3), np.array([1.0, 2.0, 3.0])]) == pytest.approx(2 / 6, rel=REL)
    assert G._sample_spacing([np.array([0.1, 0.2, 0.3])]) == pytest.approx(0.2 / 6, rel=REL)
    assert G._sample_spacing([np.zeros(3)]) == 1.0                       # nothing to measure


def test_sample_spacing_grows_by_a_quarter_until_the_grid_holds_60000_samples():
    # spans 1, 1, x: median 1, spacing 1/6, grid size ceil(6 (2 + x)) + 1
    def lengths(size):               # x with 6 (2 + x) half a step below size - 1
        return [np.array([1.0, 1.0, (size - 1.5) / 6 - 2])]
    assert G._grid_size(lengths(60_000)[0], 1 / 6) == 60_000
    assert G._sample_spacing(lengths(60_000)) == pytest.approx(1 / 6, rel=REL)        # fits: kept
    assert G._grid_size(lengths(60_001)[0], 1 / 6) == 60_001
    assert G._sample_spacing(lengths(60_001)) == pytest.approx(1.25 / 6, rel=REL)     # one step coarser
    # two directions multiply: 250 x 250 = 62 500 > 60 000, at 1.25 x: 201 x 201 = 40 401
    two = [np.array([1.0, 1.0, 249.5 / 6 - 2])] * 2
    assert G._sample_spacing(two) == pytest.approx(1.25 / 6, rel=REL)
    # a grid that cannot fit is given up after 64 steps of 1.25
    s = G._sample_spacing([np.array([1e-12, 1e-12, 1e-12, 1e12])])
    assert s == pytest.approx(1e-12 / 6 * 1.25 ** 64, rel=1e-12)


def test_grid_size_and_span_costs():
    assert G._grid_size(np.array([1.0, 2.0]), 0.5) == 7
    assert G._grid_size(np.array([1.0, 2.2]), 0.5) == 8
    costs = G._span_costs(np.array([1.0, 0.1, 1e6, 0.0]), np.radians([0.0, 40.0, 0.0, 10.0]), 0.5)
    # one step per 0.5 mm; one per 20 degrees; at most 256; fractions kept
    np.testing.assert_allclose(costs, [2.0, 2.0, 256.0, 0.5], rtol=REL)


def test_cell_cover_is_0_55_of_the_chord_or_longer_diagonal():
    rng = np.random.default_rng(3)
    X = rng.normal(size=(5, 3))
    np.testing.assert_allclose(G._cell_cover(X, (False,)),
                               [0.55 * np.linalg.norm(X[i + 1] - X[i]) for i in range(4)], rtol=REL)
    np.testing.assert_allclose(G._cell_cover(X, (True,)),
                               [0.55 * np.linalg.norm(X[(i + 1) % 5] - X[i]) for i in range(5)], rtol=REL)
    S = rng.normal(size=(4, 3, 3))

    def ref(closed_u, closed_v):
        nu, nv = 4 if closed_u else 3, 3 if closed_v else 2
        out = np.empty((nu, nv))
        for i in range(nu):
            for j in range(nv):
                a, b = S[i, j], S[(i + 1) % 4, (j + 1) % 3]
                c, e = S[(i + 1) % 4, j], S[i, (j + 1) % 3]
                out[i, j] = 0.55 * max(np.linalg.norm(b - a), np.linalg.norm(e - c))
        return out
    for closed in ((False, False), (True, False), (False, True), (True, True)):
        np.testing.assert_allclose(G._cell_cover(S, closed), ref(*closed), rtol=REL)


def test_neighbour_reduce_shifts_wraps_and_repeats_the_edges():
    A = np.array([3.0, 1.0, 4.0, 1.0, 5.0, 9.0, 2.0])
    prev = np.r_[A[0], A[:-1]]
    nxt = np.r_[A[1:], A[-1]]
    np.testing.assert_array_equal(G._neighbour_reduce(A, (False,), np.maximum, (-1,)), np.maximum(A, prev))
    np.testing.assert_array_equal(G._neighbour_reduce(A, (False,), np.minimum, (1,)), np.minimum(A, nxt))
    np.testing.assert_array_equal(G._neighbour_reduce(A, (True,), np.minimum, (1,)), np.minimum(A, np.roll(A, -1)))
    np.testing.assert_array_equal(G._neighbour_reduce(A, (True,), np.maximum, (-1,)), np.maximum(A, np.roll(A, 1)))
    B = np.arange(12.0).reshape(3, 4) % 5
    ref = np.empty_like(B)
    for i in range(3):
        for j in range(4):
            ref[i, j] = min(B[a, b] for a in (i, min(i + 1, 2)) for b in (j, (j + 1) % 4))
    np.testing.assert_array_equal(G._neighbour_reduce(B, (False, True), np.minimum, (1,)), ref)


# ---------------------------------------------------------------- grid attributes

def test_param_cells_name_the_lower_corner_and_the_last_cell_holds_the_end():
    g = G._CurveGrid(_CurveModel(parabola_curve()))
    t = g.params[0]
    n = t.size
    assert t[0] == 0.0 and t[-1] == 1.0
    cells = g.param_cells([np.r_[t, 1.0, 0.5 * (t[:-1] + t[1:])]])[0]
    np.testing.assert_array_equal(cells, np.r_[np.arange(n - 1), n - 2, n - 2, np.arange(n - 1)])
    # a closed curve: the cell after the last sample wraps to the start (cell n - 1)
    g = G._CurveGrid(_CurveModel(ellipse_curve()))
    t = g.params[0]
    n = t.size
    assert t[-1] < 1.0
    cells = g.param_cells([np.array([0.5 * (t[-1] + 1.0), t[-1], t[0]])])[0]
    np.testing.assert_array_equal(cells, [n - 1, n - 1, 0])


def test_on_end_marks_clamped_ends_and_creases_only():
    g = G._CurveGrid(_CurveModel(kinked_curve()))
    t = g.params[0]
    np.testing.assert_array_equal(g.on_end([t]), np.isin(t, [0.0, 0.5, 1.0]))
    g = G._CurveGrid(_CurveModel(ellipse_curve()))           # wraps: no ends at all
    assert g.ends[0].size == 0
    assert not g.on_end([np.r_[g.params[0], 0.0, 1.0]]).any()
    # a surface: an end in either direction
    s = G._SurfaceGrid(_SurfaceModel(thin_blade()))
    u, v = np.array([0.0, 0.3, 0.3, 0.0]), np.array([0.5, 0.0, 0.5, 1.0])
    np.testing.assert_array_equal(s.on_end([u, v]), [False, True, False, True])
    u, v = np.array([0.3, 0.3]), np.array([1.0, 0.2])
    np.testing.assert_array_equal(s.on_end([u, v]), [True, False])
    s = G._SurfaceGrid(_SurfaceModel(parabolic_cylinder()))      # clamped both ways
    u, v = np.array([0.0, 1.0, 0.3, 0.3, 0.0]), np.array([0.5, 0.5, 0.5, 0.0, 1.0])
    np.testing.assert_array_equal(s.on_end([u, v]), [True, True, False, True, True])


def _close_ref(g, a, b):
    """Cells a, b (n_dirs, m) next to each other: lower corners -1..2 apart along every
    axis (any period added where closed) and in the same piece."""
    out = np.ones(a.shape[1], dtype=bool)
    for axis, (n, closed) in enumerate(zip(g.sizes, g.periodic)):
        diff = a[axis] - b[axis]
        ok = np.zeros_like(out)
        for m in ((-1, 0, 1) if closed else (0,)):
            ok |= np.isin(diff + m * n, [-1, 0, 1, 2])
        out &= ok & (g.segments[axis][a[axis]] == g.segments[axis][b[axis]])
    return out


def test_close_cells_on_closed_clamped_and_creased_grids():
    for g in (G._CurveGrid(_CurveModel(ellipse_curve())), G._CurveGrid(_CurveModel(kinked_curve()))):
        n = g.sizes[0]
        a, b = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        a, b = a.ravel()[None], b.ravel()[None]
        np.testing.assert_array_equal(g.close(a, b), _close_ref(g, a, b))
    g = G._SurfaceGrid(_SurfaceModel(thin_blade()))
    rng = np.random.default_rng(5)
    a = np.stack([rng.integers(0, n, 4000) for n in g.sizes])
    b = (a + np.stack([rng.integers(-4, 5, 4000), rng.integers(-4, 5, 4000)])) % np.array(g.sizes)[:, None]
    np.testing.assert_array_equal(g.close(a, b), _close_ref(g, a, b))


def test_cover_is_the_largest_cell_cover_round_each_sample():
    for curve in (parabola_curve(), ellipse_curve()):
        g = G._CurveGrid(_CurveModel(curve))
        X, n = g.tree.data, g.sizes[0]
        closed = g.periodic[0]
        chord = [0.55 * np.linalg.norm(X[(i + 1) % n] - X[i]) for i in range(n if closed else n - 1)]
        ref = [max(chord[(i - 1) % n] if closed or i > 0 else 0.0, chord[i] if i < len(chord) else 0.0)
               for i in range(n)]
        np.testing.assert_allclose(g.cover, ref, rtol=REL)
        assert g.reach == pytest.approx(max(chord), rel=REL)
    s = G._SurfaceGrid(_SurfaceModel(parabolic_cylinder()))
    X = s.tree.data.reshape(s.sizes + (3,))
    nu, nv = s.sizes
    cell = np.array([[0.55 * max(np.linalg.norm(X[i + 1, j + 1] - X[i, j]), np.linalg.norm(X[i + 1, j] - X[i, j + 1]))
                      for j in range(nv - 1)] for i in range(nu - 1)])
    ref = np.array([[max(cell[a, b] for a in (i - 1, i) for b in (j - 1, j) if 0 <= a < nu - 1 and 0 <= b < nv - 1)
                     for j in range(nv)] for i in range(nu)])
    np.testing.assert_allclose(s.cover.reshape(s.sizes), ref, rtol=REL)
    np.testing.assert_allclose(s.cell_cover.reshape(s.sizes)[:-1, :-1], cell, rtol=REL)


def _separation_ref(g):
    """Per sample i: least |X_i - X_j| - cover[j] over all samples j more than 2 grid steps
    from i along some axis (round a closed one) or in another piece along some axis."""
    X = g.tree.data
    idx = np.stack(np.unravel_index(np.arange(X.shape[0]), g.sizes))
    same = np.ones((X.shape[0], X.shape[0]), dtype=bool)
    for axis, (n, closed) in enumerate(zip(g.sizes, g.periodic)):
        diff = np.abs(idx[axis][:, None] - idx[axis][None, :])
        if closed:
            diff = np.minimum(diff, n - diff)
        pieces = g.segments[axis]
        same &= (diff <= 2) & (pieces[idx[axis]][:, None] == pieces[idx[axis]][None, :])
    gap = np.linalg.norm(X[:, None] - X[None, :], axis=-1) - g.cover[None, :]
    gap[same] = np.inf
    return gap.min(axis=1)


def _cell_min(g, per_sample):
    """Least of per_sample over the corners of each cell (lower corner c, wrapped/held)."""
    A = per_sample.reshape(g.sizes)
    out = A
    for axis, (n, closed) in enumerate(zip(g.sizes, g.periodic)):
        nxt = np.roll(out, -1, axis=axis)
        if not closed:
            last = [slice(None)] * out.ndim
            last[axis] = -1
            nxt[tuple(last)] = out[tuple(last)]
        out = np.minimum(out, nxt)
    return out.ravel()


@pytest.mark.parametrize("make", [parabola_curve, ellipse_curve, kinked_curve])
def test_curve_cell_separation_is_a_lower_bound_and_exact_where_all_samples_are_seen(make):
    g = G._CurveGrid(_CurveModel(make()))
    sep = _separation_ref(g)
    ref = _cell_min(g, sep)
    got = g.cell_separation
    assert np.all(np.isfinite(got))
    # a lower bound of the documented least gap (rounding of distances ~10 mm: 1e-12)
    assert np.all(got <= ref + 1e-12)
    # and what the nearest 6 samples (2 x 2 + 1 window + 1) show exactly, the rest bounded by
    # the 6th nearest minus the reach
    X = g.tree.data
    D = np.sort(np.linalg.norm(X[:, None] - X[None, :], axis=-1), axis=1)
    beyond = D[:, 5] - g.reach if X.shape[0] > 6 else np.full(X.shape[0], np.inf)
    assert np.all(got >= _cell_min(g, np.minimum(sep, beyond)) - 1e-12)
    np.testing.assert_allclose(got, _cell_min(g, np.minimum(g._separation(X), np.inf)), rtol=0, atol=0)


def test_kinked_curve_crease_samples_are_across_a_c0_knot():
    g = G._CurveGrid(_CurveModel(kinked_curve()))
    t = g.params[0]
    k = np.flatnonzero(t == 0.5)
    assert k.size == 2                                      # the crease sample twice, one per piece
    # the two copies are the same point in different pieces: the gap is -cover there
    sep = g._separation(g.tree.data)
    assert sep[k[0]] <= -g.cover[k[1]] + 1e-12


@pytest.mark.parametrize("make", [vee, parabolic_cylinder, collapsed_triangle])
def test_surface_cell_separation_is_a_lower_bound(make):
    g = G._SurfaceGrid(_SurfaceModel(make()))
    ref = _cell_min(g, _separation_ref(g))
    assert np.all(np.isfinite(g.cell_separation))
    assert np.all(g.cell_separation <= ref + 1e-12)
    # the near part is exact: where the documented least gap is under the reach bound of
    # the 26th nearest sample, the two agree
    X = g.tree.data
    D = np.sort(np.linalg.norm(X[:, None] - X[None, :], axis=-1), axis=1)
    beyond = D[:, 25] - g.reach
    np.testing.assert_allclose(g.cell_separation, _cell_min(g, np.minimum(_separation_ref(g), beyond)),
                               rtol=0, atol=1e-12)


# ---------------------------------------------------------------- normals, starts, promise

def test_surface_axes_are_unit_normals_and_starts_match_scipy():
    s = small_plane()
    g = G._SurfaceGrid(_SurfaceModel(s))
    np.testing.assert_allclose(g.axis, np.tile([[0.0], [0.0], [1.0]], (1, g.size)), atol=1e-15)
    np.testing.assert_allclose(g.offset, 3.0, rtol=REL)
    s = parabolic_cylinder()
    g = G._SurfaceGrid(_SurfaceModel(s))
    k = np.arange(g.size)
    u, v, su, sv, D = g.start(k)
    for n, (du, dv) in enumerate(((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))):
        np.testing.assert_allclose(D[n].T, _ref_surface(s, u, v, du, dv), rtol=1e-12, atol=1e-11)
    x = L_PC * (2 * u - 1)
    n = np.stack([-2 * A_PC * x, np.zeros_like(x), np.ones_like(x)])
    np.testing.assert_allclose(g.axis, n / np.linalg.norm(n, axis=0), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(g.offset, np.sum(g.axis * D[0], axis=0), rtol=1e-12, atol=1e-12)


def test_vee_crease_samples_carry_the_normal_of_their_own_arm():
    g = G._SurfaceGrid(_SurfaceModel(vee()))
    gu = g.params[0]
    ks = np.flatnonzero(gu == 0.5)
    assert ks.size == 2 and np.array_equal(g.segments[0][ks], [0, 1])
    h = np.sqrt(0.5)
    for k, normal in zip(ks, ([h, 0, h], [-h, 0, h])):       # x < 0 arm, x > 0 arm (S_u x S_v)
        cells = np.flatnonzero(np.ravel_multi_index((np.full(g.sizes[1], k), np.arange(g.sizes[1])), g.sizes) >= 0)
        kk = np.ravel_multi_index((np.full(cells.size, k), cells), g.sizes)
        np.testing.assert_allclose(g.axis[:, kk].T, np.tile(normal, (kk.size, 1)), atol=1e-12)


def test_surface_promise_closed_form_on_a_plane():
    g = G._SurfaceGrid(_SurfaceModel(small_plane()))
    k = np.array([g.size // 2, g.size // 2, 3, 3])
    X = g.tree.data[k].T
    cover = g.cover[k]
    # height h over the plane, in-plane offset r: sqrt(max(r - cover, 0)^2 + h^2)
    r = np.array([3.0 * cover[0], 0.5 * cover[1], 2.0 * cover[2], 4.0 * cover[3]])
    h = np.array([0.7, -0.4, 0.0, 1.3])
    P = X + np.stack([r * 0.6, r * 0.8, h])
    dist = np.linalg.norm(P - X, axis=0)
    ref = np.sqrt(np.maximum(r - cover, 0.0) ** 2 + h * h)
    np.testing.assert_allclose(g.promise(P, k, dist), ref, rtol=1e-12, atol=1e-15)


def test_curve_promise_closed_form_on_a_parabola():
    c = parabola_curve()
    g = G._CurveGrid(_CurveModel(c))
    k = np.arange(g.size)
    tt, _, D = g.start(k)
    x = L_CURVE * (2 * tt - 1)
    t_unit = np.stack([np.ones_like(x), 2 * C_PAR * x, np.zeros_like(x)])
    t_unit /= np.linalg.norm(t_unit, axis=0)
    np.testing.assert_allclose(g.axis, t_unit, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(D[0].T, np.column_stack([x, C_PAR * x * x, 0 * x]), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(D[1].T, np.column_stack([2 * L_CURVE + 0 * x, 4 * L_CURVE * C_PAR * x, 0 * x]),
                               rtol=1e-12, atol=1e-11)
    np.testing.assert_allclose(D[2].T, np.column_stack([0 * x, 8 * L_CURVE ** 2 * C_PAR + 0 * x, 0 * x]),
                               rtol=1e-12, atol=1e-10)
    X = D[0]
    nrm = np.stack([-t_unit[1], t_unit[0], np.zeros_like(x)])
    along = np.where(k % 2 == 0, 3.0, 0.3) * g.cover[k] * np.where(k % 3 == 0, -1, 1)
    across = 0.5 + 0.1 * k
    P = X + along * t_unit + across * nrm + 0.2 * np.array([[0.0], [0.0], [1.0]])
    dist = np.linalg.norm(P - X, axis=0)
    ref = np.sqrt(across ** 2 + 0.04 + np.maximum(np.abs(along) - g.cover[k], 0.0) ** 2)
    np.testing.assert_allclose(g.promise(P, k, dist), ref, rtol=1e-10)


def test_curve_with_a_stationary_end_has_a_zero_axis_there_not_nan():
    poles = np.array([[0.0, 0, 0], [0.0, 0, 0], [1.0, 0, 0], [2.0, 1.0, 0]])
    g = G._CurveGrid(_CurveModel(BSplineCurve(poles, np.array([0.0, 1.0]), np.array([4, 4]), 3, False)))
    assert np.all(np.isfinite(g.axis)) and np.all(g.axis[:, 0] == 0.0)
    P = np.array([[0.5], [0.5], [0.0]])
    assert np.isfinite(g.promise(P, np.array([0]), np.array([np.sqrt(0.5)])))[0]


# ---------------------------------------------------------------- collapsed edges

def test_collapsed_apex_samples_move_a_quarter_step_into_the_surface():
    s = collapsed_triangle()
    g = G._SurfaceGrid(_SurfaceModel(s))
    gv = g.params[1]
    steps = np.diff(gv)
    assert steps[-1] != steps[-2] and steps[-1] != steps[1]           # v steps not uniform
    uu, vv = g.state[0].reshape(g.sizes), g.state[1].reshape(g.sizes)
    moved = gv[-1] - 0.25 * (gv[-1] - gv[-2])                         # back from the apex v = 1
    np.testing.assert_allclose(vv[:, -1], moved, rtol=REL)
    np.testing.assert_array_equal(vv[:, :-1], np.broadcast_to(gv[:-1], (g.sizes[0], gv.size - 1)))
    np.testing.assert_array_equal(uu, np.broadcast_to(g.params[0][:, None], g.sizes))
    # the moved samples are distinct points of the surface, and no thin covers are kept
    X = g.tree.data.reshape(g.sizes + (3,))
    np.testing.assert_allclose(X[:, -1], _ref_surface(s, uu[:, -1], vv[:, -1]), atol=1e-12)
    assert g.strips is None
    k = np.arange(g.size)
    assert np.all(g.strip_gap(np.zeros((3, g.size)), k) == -np.inf)
    assert g.may_reach(np.zeros((3, g.size)), k, np.zeros(g.size)).all()


def test_collapsed_first_row_moves_forward_a_quarter_of_a_nonuniform_step():
    # the apex at v = 0: w = (1 - v)(2 - v) / 2 (w' = -1.5 there), steps not uniform
    def f(u, v):
        u, v = np.broadcast_arrays(u, v)
        w = (0.5 * (1 - v) * (2 - v))[..., None]
        return (1 - w) * ((1 - u[..., None]) * TRI_A + u[..., None] * TRI_B) + w * TRI_C
    s = _interpolated_surface(f, np.array([0.0, 1.0]), np.array([3, 3]), np.array([0.0, 1.0]), np.array([3, 3]), 2, 2)
    g = G._SurfaceGrid(_SurfaceModel(s))
    gv = g.params[1]
    vv = g.state[1].reshape(g.sizes)
    np.testing.assert_allclose(vv[:, 0], gv[0] + 0.25 * (gv[1] - gv[0]), rtol=REL)


def test_collapsed_marks_derivatives_below_1e_9_of_the_median():
    shape = (2, 3)
    Su = np.tile([[100.0], [0.0], [0.0]], (1, 6))
    Sv = np.tile([[0.0], [50.0], [0.0]], (1, 6))
    Su[:, 1] = [1e-8, 0, 0]            # 1e-10 of the median 100: vanished
    Su[:, 2] = [2e-7, 0, 0]            # 2e-9: not
    Sv[:, 4] = 0.0
    in_u, in_v = G._SurfaceGrid._collapsed([None, Su, Sv], shape)
    # first: where S_v vanishes, second: where S_u vanishes
    np.testing.assert_array_equal(in_u.ravel(), [0, 0, 0, 0, 1, 0])
    np.testing.assert_array_equal(in_v.ravel(), [0, 1, 0, 0, 0, 0])
    Su[:, 2] = [1.5e-7, 0, 0]          # 1.5e-9 of the median: not vanished either
    assert not G._SurfaceGrid._collapsed([None, Su, Sv], shape)[1].ravel()[2]
    Su[:, 2] = [1e-9 * 100.0, 0, 0]    # exactly at the threshold: vanished (<=)
    assert G._SurfaceGrid._collapsed([None, Su, Sv], shape)[1].ravel()[2]


# ---------------------------------------------------------------- thin covers (strips)

def test_flat_grid_thin_covers_are_one_step_and_infinite_past_clamped_ends():
    g = G._SurfaceGrid(_SurfaceModel(small_plane()))
    nu, nv = g.sizes
    gu, gv = g.params
    a, b = 0.5 * np.diff(gu), 0.5 * np.diff(gv)              # steps in mm (uniform here)
    np.testing.assert_allclose(a, a[0], rtol=1e-12)
    np.testing.assert_allclose(b, b[0], rtol=1e-12)
    st = g.strips.reshape(2, 2, nu, nv)
    # along u, the other corners lie one v step off the chord (flat: no sagitta); past the
    # clamped end (i = 0 backwards, i = nu - 1 forwards) there is no cell: inf
    ref_u = np.full((2, nu, nv), b[0])
    ref_u[0, 0, :] = np.inf
    ref_u[1, -1, :] = np.inf
    np.testing.assert_allclose(st[0], ref_u, rtol=1e-9)
    ref_v = np.full((2, nu, nv), a[0])
    ref_v[0, :, 0] = np.inf
    ref_v[1, :, -1] = np.inf
    np.testing.assert_allclose(st[1], ref_v, rtol=1e-9)
    # a point at height h over an inner sample: the chords are within h, so the bound is
    # h - one step (both axes), and the cells are within h: the bound is below
    k = np.ravel_multi_index((np.array([2, 3]), np.array([3, 2])), g.sizes)
    h = np.array([0.4, 0.05])
    P = g.tree.data[k].T + np.stack([0 * h, 0 * h, h])
    np.testing.assert_allclose(g.strip_gap(P, k), h - b[0], rtol=1e-9)
    np.testing.assert_allclose(g._axis_gap(P, k, 0), h - b[0], rtol=1e-9)
    np.testing.assert_allclose(g._axis_gap(P, k, 1), h - a[0], rtol=1e-9)
    # off to one side along v by 3 steps: the v chords are 2 steps away (flat: exactly), the
    # u chords 3 - 1
    P = g.tree.data[k].T + np.stack([0 * h, 3 * b[0] + 0 * h, 0 * h])
    np.testing.assert_allclose(g._axis_gap(P, k, 1), 2 * b[0] - a[0], rtol=1e-9)
    np.testing.assert_allclose(g._axis_gap(P, k, 0), 3 * b[0] - b[0], rtol=1e-9)
    np.testing.assert_allclose(g.strip_gap(P, k), 2 * b[0], rtol=1e-9)       # the larger of the two
    # pruned by the u chords alone (the v chords leave it open): may_reach looks at both
    np.testing.assert_array_equal(g.may_reach(P, k, np.full(2, 1.5 * b[0])), [False, False])
    np.testing.assert_array_equal(g.may_reach(P, k, np.full(2, 2.5 * b[0])), [True, True])
    # 3 steps back along v: the nearer chord is the one to the previous sample, 2 steps off
    P = g.tree.data[k].T - np.stack([0 * h, 3 * b[0] + 0 * h, 0 * h])
    np.testing.assert_allclose(g._axis_gap(P, k, 1), 2 * b[0] - a[0], rtol=1e-9)
    # may_reach: pruned exactly where the bound reaches d (inclusive)
    P = g.tree.data[k].T + np.stack([0 * h, 0 * h, np.array([0.3, 0.3])])
    bound = g.strip_gap(P, k)
    d = np.array([bound[0], bound[1] + 1e-6])
    np.testing.assert_array_equal(g.may_reach(P, k, d), [False, True])


def _parabola_sag(x1, x2):
    """Distance of the parabola point half way in x from the chord (x1, a x1^2) - (x2, a x2^2)."""
    xm = 0.5 * (x1 + x2)
    A, B, M = (np.array([x, A_PC * x * x]) for x in (x1, x2, xm))
    AB = B - A
    t = np.clip(np.dot(M - A, AB) / np.dot(AB, AB), 0, 1)
    return np.linalg.norm(M - A - t * AB)


def test_thin_covers_of_a_parabolic_cylinder_closed_form():
    g = G._SurfaceGrid(_SurfaceModel(parabolic_cylinder()))
    nu, nv = g.sizes
    x = L_PC * (2 * g.params[0] - 1)
    st = g.strips.reshape(2, 2, nu, nv)
    # along v (straight rulings): the other corners are the neighbouring rulings, at the
    # chord lengths of the parabola; plus 1.5 x the largest sagitta of the u edges of both
    # cells (the edges along v are straight)
    chord = np.hypot(np.diff(x), A_PC * np.diff(x * x))
    sag = np.array([_parabola_sag(x[i], x[i + 1]) for i in range(nu - 1)])
    for i in range(nu):
        near = [j for j in (i - 1, i) if 0 <= j < nu - 1]
        r = max(chord[j] for j in near) + 1.5 * max(sag[j] for j in near)
        for side in (0, 1):
            for j in range(nv):
                if (side == 0 and j == 0) or (side == 1 and j == nv - 1):
                    assert st[1, side, i, j] == np.inf
                else:
                    assert st[1, side, i, j] == pytest.approx(r, rel=1e-9)
    # along u: the chord X_i -> X_i+s; the other corners one v step off (same x): their
    # distance to the chord, plus 1.5 x the sagitta of the chord's own edge
    step_v = W_PC * np.diff(g.params[1])[0]
    for i in range(nu):
        for side, s in enumerate((-1, 1)):
            if not 0 <= i + s < nu:
                assert np.all(st[0, side, i] == np.inf)
                continue
            j0 = min(i, i + s)
            np.testing.assert_allclose(st[0, side, i], step_v + 1.5 * sag[j0], rtol=1e-9)
    # the bound along u: the least over both sides of (distance to the chord to the
    # neighbour on that side) - (that side's cover), the covers of the closed form above
    rng = np.random.default_rng(2)
    X = g.tree.data.reshape(nu, nv, 3)
    for i in (3, nu // 2, nu - 4):
        j = 2
        P = X[i, j] + rng.normal(scale=0.3, size=3)
        ref = np.inf
        for s in (-1, 1):
            A, B = X[i, j], X[i + s, j]
            t = np.clip(np.dot(P - A, B - A) / np.dot(B - A, B - A), 0, 1)
            ref = min(ref, np.linalg.norm(P - A - t * (B - A)) - (step_v + 1.5 * sag[min(i, i + s)]))
        got = g._axis_gap(P[:, None], np.array([np.ravel_multi_index((i, j), g.sizes)]), 0)[0]
        assert got == pytest.approx(ref, rel=1e-9, abs=1e-12)


def _cells_min_distance(s, g, P, k, fine=24):
    """Least distance from P (3,) to the (up to) four cells round sample k, by scipy on a
    fine parameter grid of each cell, and the sampling error: the longest diagonal of a fine
    sub-cell (a point of the cell is within it of a fine sample)."""
    i, j = np.unravel_index(k, g.sizes)
    gu, gv = g.params
    lo_u, hi_u = s.u_knots[0], s.u_knots[-1]
    best, err = np.inf, 0.0
    for a in (i - 1, i):
        for b in (j - 1, j):
            if not (0 <= b < g.sizes[1] - 1):
                continue
            if g.periodic[0]:
                u0, u1 = gu[a % g.sizes[0]], (gu[(a + 1) % g.sizes[0]] if a + 1 < g.sizes[0] else hi_u)
                if a < 0:
                    u0, u1 = gu[-1] - (hi_u - lo_u), gu[0]
            else:
                if not (0 <= a < g.sizes[0] - 1):
                    continue
                u0, u1 = gu[a], gu[a + 1]
            uu = np.linspace(u0, u1, fine + 1)
            vv = np.linspace(gv[b], gv[b + 1], fine + 1)
            U, V = np.meshgrid(uu, vv, indexing="ij")
            Xs = _ref_periodic_u(s, U.ravel(), V.ravel()).reshape(fine + 1, fine + 1, 3)
            best = min(best, np.linalg.norm(Xs - P, axis=-1).min())
            diag = np.maximum(np.linalg.norm(Xs[1:, 1:] - Xs[:-1, :-1], axis=-1),
                              np.linalg.norm(Xs[1:, :-1] - Xs[:-1, 1:], axis=-1))
            err = max(err, diag.max())
    return best, err


def _ref_periodic_u(s, u, v):
    """S by scipy for a surface periodic in u (unwrapped poles) and clamped in v."""
    if not s.u_periodic:
        return _ref_surface(s, u, v)
    p = s.u_degree
    tu = _full(s.u_knots, s.u_mults, p, True)
    poles = np.concatenate([s.poles, s.poles[:p]], axis=0)
    lo, hi = s.u_knots[0], s.u_knots[-1]
    u = lo + np.mod(u - lo, hi - lo)
    tv = _full(s.v_knots, s.v_mults, s.v_degree)
    Bu = _basis(tu, p, u)
    Bv = _basis(tv, s.v_degree, v)
    return np.einsum("mi,mj,ijd->md", Bu, Bv, poles)


def test_thin_blade_strip_gap_never_exceeds_the_distance_to_the_cells():
    s = thin_blade()
    g = G._SurfaceGrid(_SurfaceModel(s))
    assert g.strips is not None
    rng = np.random.default_rng(11)
    nu, nv = g.sizes
    X = g.tree.data
    # samples round both noses and on the flanks, points near them and across the section
    iu = np.r_[np.argsort(X.reshape(nu, nv, 3)[:, nv // 2, 0])[[0, 1, -1, -2]], rng.integers(0, nu, 4)]
    ks = np.ravel_multi_index((iu, rng.integers(0, nv, iu.size)), g.sizes)
    checked = 0
    for k in ks:
        for P in (X[k] + rng.normal(scale=0.5, size=(3, 3))):
            lb = g.strip_gap(P[:, None], np.array([k]))[0]
            true, err = _cells_min_distance(s, g, P, k)
            assert lb <= true + err, (k, lb, true, err)
            # per axis too (each is a bound by itself)
            for axis in (0, 1):
                assert g._axis_gap(P[:, None], np.array([k]), axis)[0] <= true + err
            checked += 1
    assert checked == 3 * ks.size


H_PRISM = 3.0


def prism():
    """A closed section (periodic cubic, non-uniform knots on [1, 3]: the domain does not start
    at 0) swept straight up by H: S(u, v) = (C(u), H v), linear in v."""
    n = 10
    th = 2 * np.pi * (np.arange(n) + 0.2 * np.sin(np.arange(n))) / n
    sec = np.column_stack([4 * np.cos(th), 1.5 * np.sin(th)])
    knots = np.concatenate([[0.0], np.cumsum(1 + 0.4 * np.cos(np.arange(n)))])
    knots = 1.0 + 2.0 * knots / knots[-1]
    poles = np.stack([np.column_stack([sec, np.full(n, H_PRISM * z)]) for z in (0.0, 1.0)], axis=1)
    return BSplineSurface(poles, knots, np.ones(n + 1, int), np.array([0.0, 1.0]), np.array([2, 2]), 3, 1, True, False)


def _prism_section(s, u):
    """C(u) by scipy (periodic: extended knots, unwrapped poles, u wrapped into the domain)."""
    lo, hi = s.u_knots[0], s.u_knots[-1]
    t = _full(s.u_knots, s.u_mults, 3, True)
    P = np.concatenate([s.poles[:, 0, :2], s.poles[:3, 0, :2]])
    return BSpline(t, P, 3)(lo + np.mod(u - lo, hi - lo))


def test_thin_covers_of_a_closed_prism_wrap_round_the_seam():
    s = prism()
    g = G._SurfaceGrid(_SurfaceModel(s))
    assert g.periodic == (True, False) and g.strips is not None
    nu, nv = g.sizes
    gu, gv = g.params
    period = s.u_knots[-1] - s.u_knots[0]
    C = _prism_section(s, gu)
    nxt = np.r_[gu[1:], gu[0] + period]
    M = _prism_section(s, 0.5 * (gu + nxt))                  # half way along each u edge, the seam's too
    A, B = C, np.roll(C, -1, axis=0)
    t = np.clip(np.sum((M - A) * (B - A), axis=1) / np.sum((B - A) ** 2, axis=1), 0, 1)
    sag = np.linalg.norm(M - A - t[:, None] * (B - A), axis=1)   # sag[i]: edge i -> i + 1 (cyclic)
    chord = np.linalg.norm(B - A, axis=1)                          # chord[i]: |C_i+1 - C_i|
    st = g.strips.reshape(2, 2, nu, nv)
    dz = H_PRISM * np.diff(gv)
    np.testing.assert_allclose(dz, dz[0], rtol=1e-12)
    for i in range(nu):
        # along v (straight rulings): the neighbouring rulings' distance + 1.5 x the sagitta
        # of the u edges of both cells; infinite past the clamped ends of v
        r = max(chord[i], chord[i - 1]) + 1.5 * max(sag[i], sag[i - 1])
        np.testing.assert_allclose(st[1, 0, i, 1:], r, rtol=1e-9)
        np.testing.assert_allclose(st[1, 1, i, :-1], r, rtol=1e-9)
        assert st[1, 0, i, 0] == np.inf and st[1, 1, i, -1] == np.inf
        # along u, round the seam too: one v step + 1.5 x the sagitta of the chord's edge
        np.testing.assert_allclose(st[0, 0, i], dz[0] + 1.5 * sag[i - 1], rtol=1e-9)
        np.testing.assert_allclose(st[0, 1, i], dz[0] + 1.5 * sag[i], rtol=1e-9)
