# SPDX-License-Identifier: LGPL-2.1-or-later
"""The contract of ``core/sections/fairing.py`` on shapes with known answers (circles,
ellipses, lines: closed forms), with counts and parameters made by hand. Fast (a few seconds,
the edge model left out except where it is the subject): ``make mutation`` runs it per mutant
before the slower ``tests/test_fairing.py``.
"""
from __future__ import annotations

import re

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.bspline import evaluate_curve
from bladerecon.core.sections import fairing as fr


def circle(n=400, r=10.0, start=0.0):
    th = start + np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([r * np.cos(th), r * np.sin(th), np.zeros(n)]), th


def ellipse(n=400, a=20.0, b=3.0, angle=0.0):
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    P = np.column_stack([a * np.cos(th), b * np.sin(th), np.zeros(n)])
    R = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
    return P @ R.T, th


def radial_distance(P, r=10.0):
    return np.abs(np.linalg.norm(P[:, :2], axis=1) - r)


# --------------------------------------------------------------------------- edge zones
@pytest.mark.parametrize("angle", [0.0, 0.6])
def test_edge_zones_are_the_ends_of_the_principal_direction(angle):
    P, th = ellipse(angle=angle)
    x = 20.0 * np.cos(th)                      # the coordinate along the major axis, known
    for f in (0.04, 0.1):
        want = (x < -20 + f * 40 - 1e-9) | (x > 20 - f * 40 + 1e-9)
        got = fr.edge_zones(P, f)
        border = np.abs(np.abs(x) - (20 - f * 40)) < 1e-6
        assert np.array_equal(got[~border], want[~border])
    assert fr.edge_zones(P).sum() == fr.edge_zones(P, 0.04).sum()


# --------------------------------------------------------------------------- turning
def test_turning_of_a_circle_is_its_angle_step_whatever_the_chord():
    for n, r in ((400, 10.0), (2000, 10.0), (64, 3.0)):
        P, _ = circle(n, r)
        assert np.allclose(fr._robust_turning(P), 2 * np.pi / n, rtol=1e-9)


def test_turning_of_a_noisy_line_is_measured_over_half_a_millimetre():
    # a closed, long thin loop: two straight sides 20 mm long, 0.01 mm spacing, 1 µm noise.
    # Over chords of k = 50 steps (0.5 mm) the noise reads as ~σ√6/(k·h)/k ≈ 1e-4 rad a step;
    # over single steps it would read as ~σ√6/h ≈ 0.25 rad
    x = np.arange(0, 20, 0.01)
    top = np.column_stack([x, np.full(x.size, 0.5), np.zeros(x.size)])
    bottom = np.column_stack([x[::-1], np.full(x.size, -0.5), np.zeros(x.size)])
    P = np.vstack([top, bottom])
    P[:, 1] += np.random.default_rng(0).normal(0, 0.001, len(P))
    turn = fr._robust_turning(P)
    flat = (np.abs(P[:, 0] - 10) < 8)
    assert np.median(turn[flat]) < 3e-4
    assert np.median(fr._robust_turning(P, baseline=0.01)[flat]) > 0.05


def test_turning_is_blind_to_a_short_bump():
    P, _ = circle(400)
    B = P.copy()
    B[200:203] *= 1.002                              # 20 µm out over 3 points
    assert np.allclose(fr._robust_turning(B)[190:215], 2 * np.pi / 400, rtol=0.05)


# --------------------------------------------------------------------------- knots
def test_density_knots_one_per_point_or_one_per_tenth_point():
    t = np.linspace(0, 1, 50, endpoint=False)
    k1 = fr._density_knots(t, np.ones(50))
    assert np.allclose(k1, np.concatenate([t, [1.0]]))
    k10 = fr._density_knots(t, np.full(50, 0.1))
    # cumulative density passes a whole number at points 10, 20, 30, 40 (and the first point)
    assert np.allclose(k10, np.concatenate([t[[0, 10, 20, 30, 40]], [1.0]]))
    # the order of the input does not matter
    perm = np.random.default_rng(3).permutation(50)
    assert np.array_equal(fr._density_knots(t[perm], np.full(50, 0.1)[perm]), k10)
    # a parameter at 0 is one knot, not two
    assert np.sum(k1 == 0.0) == 1 and k1[-1] == 1.0


def test_chord_parameters_of_good_share_a_gap_equally():
    P = np.array([[0, 0, 0], [1, 0, 0], [5, 7, 0], [3, 0, 0], [3, 3, 0], [0, 3, 0]], float)
    bad = np.array([False, False, True, False, False, False])
    # chords of good neighbours: 0-1: 1, 1-3: 2 (over 2 steps: 1 each), 3-4: 3, 4-5: 3, 5-0: 3
    seg = np.array([1, 1, 1, 3, 3, 3], float)
    want = np.concatenate([[0], np.cumsum(seg)[:-1]]) / seg.sum()
    assert np.allclose(fr.chord_parameters_of_good(P, bad), want, atol=1e-15)
    # the first point bad: its step is part of the last gap
    bad0 = np.array([True, False, False, False, False, False])
    P0 = P.copy()
    P0[2] = [2, 0, 0]
    # good 1..5: 1-2: 1, 2-3: 1, 3-4: 3, 4-5: 3, 5-1 (over 2 steps): |(0,3)-(1,0)| = √10
    seg0 = np.array([np.sqrt(10) / 2, 1, 1, 3, 3, np.sqrt(10) / 2])
    want0 = np.concatenate([[0], np.cumsum(seg0)[:-1]]) / seg0.sum()
    assert np.allclose(fr.chord_parameters_of_good(P0, bad0), want0, atol=1e-15)
    # none bad: plain closed chord-length
    ch = np.linalg.norm(np.roll(P0, -1, 0) - P0, axis=1)
    assert np.allclose(fr.chord_parameters_of_good(P0, np.zeros(6, bool)),
                       np.concatenate([[0], np.cumsum(ch)[:-1]]) / ch.sum(), atol=1e-15)


# --------------------------------------------------------------------------- fair fit
def test_fair_fit_of_a_circle_is_the_circle():
    P, _ = circle(400)
    curve, t, d = fr.fair_fit(P)
    assert d.max() < 5e-6                         # mm: a cubic on ≤ 10 points a span of a 10 mm circle
    C = evaluate_curve(curve, np.linspace(0, 1, 5000, endpoint=False))
    assert radial_distance(C).max() < 5e-6
    # distances are those of the points to their feet at t
    assert np.allclose(d, np.linalg.norm(evaluate_curve(curve, t) - P, axis=1), atol=1e-15)


def test_fair_fit_knot_counts_follow_the_density_rules():
    # a circle of radius 10: turning 2π/400 = 0.0157 rad a point; with knot_turn 0.1 that asks
    # for 0.157 knots a point, above 1/points_per_pole = 0.1; the arc rule (0.157 mm / 4 mm)
    # asks for less; the edge zones (8 % of the points about each end) one a point
    P, _ = circle(400)
    curve, _, _ = fr.fair_fit(P)
    zones = fr.edge_zones(P).sum()
    expected = zones + 0.157 * (400 - zones)
    assert abs(curve.n_poles - expected) <= 3, (curve.n_poles, expected)
    # turning rule off (knot_turn huge), arc rule off: one per 10 points on the flanks
    c2, _, _ = fr.fair_fit(P, knot_turn=1e9, knot_length=1e9)
    assert abs(c2.n_poles - (zones + (400 - zones) / 10)) <= 2, c2.n_poles
    c3, _, _ = fr.fair_fit(P, knot_turn=1e9, knot_length=1e9, points_per_pole=20)
    assert abs(c3.n_poles - (zones + (400 - zones) / 20)) <= 2, c3.n_poles
    # the arc rule: a knot per 0.157 mm / knot_length = 0.5 a point
    c4, _, _ = fr.fair_fit(P, knot_turn=1e9, knot_length=0.157 * 2)
    assert abs(c4.n_poles - (zones + (400 - zones) / 2)) <= 2, c4.n_poles
    # the edge fraction
    c5, _, _ = fr.fair_fit(P, knot_turn=1e9, knot_length=1e9, edge_fraction=0.1)
    z5 = fr.edge_zones(P, 0.1).sum()
    assert abs(c5.n_poles - (z5 + (400 - z5) / 10)) <= 2, c5.n_poles
    # never fewer than 8 spans
    small, _ = circle(40)
    c6, _, _ = fr.fair_fit(small, knot_turn=1e9, knot_length=1e9, points_per_pole=1000, edge_fraction=0.0)
    assert c6.n_poles == 8


def test_a_point_of_weight_zero_does_not_pull_the_fit():
    P, nrm = flank_section()
    Q = P.copy()
    Q[100:103] += 0.1 * nrm[100:103]                 # 0.1 mm out
    w = np.ones(400)
    w[100:103] = 0.0
    curve, t, d = fr.fair_fit(Q, w)
    assert np.allclose(d[100:103], 0.1, atol=2e-3)
    assert np.delete(d, [100, 101, 102]).max() < 5e-4   # 0.5 µm: the gap of 3 points is bridged smoothly
    # weighted in: it pulls
    _, _, d1 = fr.fair_fit(Q)
    assert d1[101] < 0.08


# --------------------------------------------------------------------------- detection
A, B = 20.0, 5.0          # the test section: an ellipse, its flanks (t about 90° and 270°) far from the edge zones


def flank_section(n=400):
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    P = np.column_stack([A * np.cos(th), B * np.sin(th), np.zeros(n)])
    nrm = np.column_stack([B * np.cos(th), A * np.sin(th), np.zeros(n)])
    return P, nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


_DENSE = None


def ellipse_distance(Q):
    """Distance to the true ellipse: nearest of 400 000 samples (spacing 0.3 µm: error < 1e-8 mm)."""
    global _DENSE
    from scipy.spatial import cKDTree
    if _DENSE is None:
        th = np.linspace(0, 2 * np.pi, 400_000, endpoint=False)
        _DENSE = cKDTree(np.column_stack([A * np.cos(th), B * np.sin(th)]))
    return _DENSE.query(np.asarray(Q)[:, :2])[0]


def bumped(run=(100, 3), height=0.010, n=400):
    """The flank section with a run of points moved out along the true normal by ``height`` mm."""
    P, nrm = flank_section(n)
    first, k = run
    idx = (first + np.arange(k)) % n
    P[idx] += height * nrm[idx]
    return P, idx


def test_a_run_above_the_threshold_is_found_and_nothing_else():
    for run, h in (((100, 1), 0.010), ((90, 3), 0.015), ((298, 4), 0.010), ((60, 5), 0.030)):
        P, idx = bumped(run, h)
        bad, d, curve, t = fr.detect_bad_points(P, edges=False)
        assert np.array_equal(np.flatnonzero(bad), np.sort(idx)), (run, h, np.flatnonzero(bad))
        assert np.allclose(d[idx], h, atol=1.5e-3)                   # distance to the fit of the good points
        assert np.delete(d, idx).max() <= fr.DEFAULT_THRESHOLD
        C = evaluate_curve(curve, np.linspace(0, 1, 4000, endpoint=False))
        assert ellipse_distance(C).max() < 5e-4                      # the fit follows the ellipse, not the run


def test_threshold_decides():
    assert fr.DEFAULT_THRESHOLD == 0.003
    P, idx = bumped((110, 1), 0.0045)
    assert np.flatnonzero(fr.detect_bad_points(P, edges=False)[0]).tolist() == idx.tolist()
    assert not fr.detect_bad_points(P, threshold=0.006, edges=False)[0].any()
    P2, _ = bumped((110, 1), 0.002)
    assert not fr.detect_bad_points(P2, edges=False)[0].any()
    # a clean circle: nothing
    assert not fr.detect_bad_points(flank_section()[0], edges=False)[0].any()


def test_worst_first_keeps_the_neighbours_of_a_big_bump():
    # 0.2 mm out at one point drags the first fit; its neighbours must not be flagged
    P, idx = bumped((290, 1), 0.2)
    bad = fr.detect_bad_points(P, edges=False)[0]
    assert np.flatnonzero(bad).tolist() == idx.tolist()


def test_too_few_points_and_noise_above_the_threshold_are_user_errors():
    P, _ = circle(11)
    with pytest.raises(BladeReconError) as e:
        fr.detect_bad_points(P, edges=False)
    assert re.fullmatch(r"fairing needs at least 12 points on a section, got 11", str(e.value))
    fr.detect_bad_points(circle(12)[0], edges=False)             # 12 is enough
    Q, _ = circle(400)
    Q[:, :2] *= (1 + np.random.default_rng(1).normal(0, 0.001, 400))[:, None]   # 10 µm noise
    with pytest.raises(BladeReconError) as e:
        fr.detect_bad_points(Q, name="S3", edges=False)
    m = re.fullmatch(r"section S3: more than a quarter of the points are farther than 3\.0 µm from a fair curve "
                     r"\(median distance (\d+\.\d) µm\): the threshold is below this data's noise; "
                     r"try --fair-threshold (\d\.\d{3})", str(e.value))
    assert m, str(e.value)
    med = float(m.group(1))
    assert 2.0 < med < 12.0 and float(m.group(2)) == pytest.approx(max(5 * med / 1000, 0.003), abs=6e-4)
    with pytest.raises(BladeReconError) as e:
        fr.detect_bad_points(Q, edges=False)
    assert str(e.value).startswith("more than a quarter")


# --------------------------------------------------------------------------- runs
def test_bad_runs_round_the_loop():
    assert fr.bad_runs(np.zeros(6, bool)) == []
    assert fr.bad_runs(np.ones(6, bool)) == [(0, 6)]
    b = np.array([1, 1, 0, 0, 1, 0, 1, 1], bool)
    assert fr.bad_runs(b) == [(4, 1), (6, 4)]                      # 6, 7, 0, 1 is one run across the end
    assert fr.bad_runs(np.array([0, 1, 1, 0, 0, 1], bool)) == [(1, 2), (5, 1)]


def test_replaced_points_lie_on_the_section():
    for run, h in (((100, 3), 0.05), ((298, 4), 0.02), ((80, 1), 0.3)):
        P, idx = bumped(run, h)
        clean, _ = flank_section()
        bad = np.zeros(len(P), bool)
        bad[idx] = True
        curve, t, _ = fr.fair_fit(P, (~bad).astype(float), t=fr.chord_parameters_of_good(P, bad))
        out = fr.replace_runs(P, bad, curve, t)
        # within 0.5 µm (a sixth of the 3 µm threshold) of the true section: the auxiliary cubic
        # across a gap of 2-5 steps of 0.3 mm on a flank of radius ≥ 1.25 mm
        assert ellipse_distance(out[idx]).max() < 5e-4, run
        assert np.array_equal(np.delete(out, idx, axis=0), np.delete(P, idx, axis=0))
        # at equal chord steps between the good neighbours: on the flank the points were evenly
        # spaced in angle, nearly in arc length: within 2 µm of the points they replace
        assert np.linalg.norm(out[idx] - clean[idx], axis=1).max() < 2e-3, run


def test_replacing_needs_four_good_points():
    P, _ = flank_section(20)
    bad = np.ones(20, bool)
    bad[[0, 5, 10]] = False
    curve, t, _ = fr.fair_fit(P)
    with pytest.raises(BladeReconError) as e:
        fr.replace_runs(P, bad, curve, t)
    assert re.fullmatch(r"too few good points left on the section to build the auxiliary curves", str(e.value))


# --------------------------------------------------------------------------- the whole section
def test_fair_section_reports_what_it_moved():
    P, idx = bumped((120, 2), 0.012)
    s = fr.fair_section(P, edges=False)
    assert np.array_equal(s.original, P) and s.runs == ((120, 2),)
    assert np.flatnonzero(s.bad).tolist() == [120, 121]
    assert np.array_equal(s.displacement, np.linalg.norm(s.faired - P, axis=1))
    assert np.allclose(s.displacement[idx], 0.012, atol=2e-4)
    assert np.delete(s.displacement, idx).max() == 0.0
    assert ellipse_distance(s.faired).max() < 5e-4
    assert not s.by_edge_model.any()
    # nothing bad: the points come back as they were (a copy)
    c, _ = flank_section()
    clean = fr.fair_section(c, edges=False)
    assert np.array_equal(clean.faired, c) and clean.faired is not c and clean.runs == ()


def test_a_move_beyond_the_limit_is_refused_by_name():
    P, idx = bumped((80, 1), 0.3)
    assert fr.DEFAULT_MAX_MOVE == 0.5
    fr.fair_section(P, edges=False)                                 # 0.3 mm: within 0.5
    with pytest.raises(BladeReconError) as e:
        fr.fair_section(P, max_move=0.2, name="7", edges=False)
    m = re.fullmatch(r"fairing refused: section 7, point 80 would move (\d\.\d{4}) mm \(limit 0\.2 mm\); "
                     r"remove that point or raise --fair-limit", str(e.value))
    assert m and float(m.group(1)) == pytest.approx(0.3, abs=1e-3), str(e.value)
    with pytest.raises(BladeReconError) as e:
        fr.fair_section(P, max_move=0.2, edges=False)
    assert str(e.value).startswith("fairing refused: point 80 would move")


def test_describe_runs_gives_lines_and_chord_fractions():
    P, th = ellipse(400)                          # LE at x = 20 (the first point), TE at x = -20
    x = 20 * np.cos(th)
    bad = np.zeros(400, bool)
    bad[[5, 6, 7, 200]] = True
    disp = np.zeros(400)
    disp[[5, 6, 7, 200]] = [0.01, 0.03, 0.02, 0.05]
    lines = np.arange(400) * 2 + 10
    runs = fr.describe_runs(P, bad, disp, lines)
    frac = (20 - x) / 40                          # 0 at the first point's end
    assert runs == [
        {"first_line": 20, "last_line": 24, "points": 3,
         "chord_fraction": [round(float(frac[5]), 4), round(float(frac[7]), 4)], "displacement_mm": 0.03},
        {"first_line": 410, "last_line": 410, "points": 1,
         "chord_fraction": [round(float(frac[200]), 4)] * 2, "displacement_mm": 0.05}]
    # without lines: indices; a loop starting at the other end counts from there
    rolled = np.roll(P, -200, axis=0)
    r2 = fr.describe_runs(rolled, np.roll(bad, -200), np.roll(disp, -200))
    assert [r["first_line"] for r in r2] == [205, 0]        # found from the first good point on
    assert r2[1]["chord_fraction"] == [0.0, 0.0] and r2[0]["chord_fraction"][0] == round(float(1 - frac[5]), 4)


# --------------------------------------------------------------------------- the edge model's part
def test_edge_runs_go_to_the_edge_model_and_flank_runs_to_the_fair_fit():
    # the analytic sample blade (round LE and TE, known profile): one run of 2 points 15 µm out
    # on the LE, one of 2 points on the flank; 400 points at even spacing, no noise
    from scipy.spatial import cKDTree

    from bladerecon.samples.blade import SampleBlade, t_at_length_fraction
    blade = SampleBlade()
    h = 0.5                                          # mid-span fraction
    f = (0.37 + np.arange(400)) / 400
    t = t_at_length_fraction(blade, h, f)
    P = blade.point(h, t)
    N = blade.normal(h, t)
    N[:, 2] = 0.0
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    le, te = blade.le_te(h)
    chord = (P - le) @ (te - le) / ((te - le) @ (te - le))
    le_run = np.array([2, 3])                       # chord fractions 0.0016 and 0.0047: on the LE arc
    assert np.all(chord[le_run] < 0.01)
    flank_run = np.array([100, 101])
    Q = P.copy()
    Q[le_run] += 0.015 * N[le_run]
    Q[flank_run] += 0.015 * N[flank_run]
    s = fr.fair_section(Q, name="LE")
    assert np.flatnonzero(s.bad).tolist() == sorted(le_run.tolist() + flank_run.tolist())
    assert np.flatnonzero(s.by_edge_model).tolist() == sorted(le_run.tolist())
    assert len(s.edges) == 2
    # every faired point back on the true profile (dense samples of it: spacing 1 µm)
    dense = blade.point(h, t_at_length_fraction(blade, h, np.linspace(0, 1, 200_000, endpoint=False)))
    back = cKDTree(dense[:, :2]).query(s.faired[:, :2])[0]
    assert back.max() < 2e-3, back.max()                # 2 µm: within the 3 µm threshold
    assert np.array_equal(s.faired[~s.bad], Q[~s.bad])
    # the distances reported in the edge zones are the edge model's: 15 µm at the run
    assert np.allclose(s.distance[le_run], 0.015, atol=2e-3)
    # without the edge model the fair fit alone follows the LE run (a knot at every edge point)
    alone = fr.fair_section(Q, edges=False)
    assert not alone.bad[le_run].all()



# --------------------------------------------------------------------------- the record
def test_section_fairing_is_a_frozen_record_whose_edge_fields_are_optional():
    import dataclasses

    P, _ = flank_section(40)
    z = np.zeros(40)
    s = fr.SectionFairing(P, P.copy(), z.astype(bool), z, z, ())
    # built without the edge fields (as a caller without the edge model does): none judged
    assert s.by_edge_model is None and s.edges == ()
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.runs = ((0, 1),)


# --------------------------------------------------------------------------- the weighted, smoothed solve
def _periodic_reference_fit(points, t, w, knots, smoothing):
    """The fit _fit documents, built on scipy's B-splines: minimise Σ w_i |C(t_i) - p_i|²
    + λ ∫_0^1 |C''|² over periodic cubics on ``knots``, λ = smoothing · tr(AᵀWA) / tr(E)
    (A the collocation matrix, E the Gram matrix of the second derivatives). The periodic
    basis is the clamped-free basis on the knots continued by one period each way, its last
    three functions folded onto the first three; E by 2-point Gauss-Legendre per span
    (exact: B'' is linear on a span). Returns a callable u -> C(u)."""
    from scipy.interpolate import BSpline

    m = knots.size - 1
    T = np.concatenate([knots[m - 3:m] - 1.0, knots, knots[1:4] + 1.0])
    nb = T.size - 4                                      # m + 3 functions, the last 3 = the first 3
    fold = np.zeros((nb, m))
    fold[np.arange(m), np.arange(m)] = 1.0
    fold[m + np.arange(3), np.arange(3)] = 1.0
    A = BSpline.design_matrix(np.mod(t, 1.0), T, 3).toarray() @ fold
    gx, gw = np.polynomial.legendre.leggauss(2)
    a, h = knots[:-1], np.diff(knots)
    ug = (a[:, None] + 0.5 * h[:, None] * (gx + 1.0)).ravel()
    wg = (0.5 * h[:, None] * gw).ravel()
    D2 = np.column_stack([BSpline(T, np.eye(nb)[j], 3).derivative(2)(ug) for j in range(nb)]) @ fold
    E = D2.T @ (wg[:, None] * D2)
    AtWA = A.T @ (w[:, None] * A)
    lam = smoothing * np.trace(AtWA) / np.trace(E)
    poles = np.linalg.solve(AtWA + lam * E, A.T @ (w[:, None] * points))
    coef = np.vstack([poles, poles[:3]])
    return lambda u: BSpline(T, coef, 3)(np.mod(u, 1.0))


@pytest.mark.parametrize("smoothing", [0.0, 1e-6, 1e-2])
def test_fit_is_the_penalised_least_squares_curve_of_a_scipy_reference(smoothing):
    # an ellipse at uneven parameters, uneven knots, weights 0, 1 and 2
    rng = np.random.default_rng(5)
    P, _ = flank_section(120)
    t = np.sort(rng.uniform(0, 1, 120))
    t[0] = 0.0
    knots = np.concatenate([[0.0], np.sort(rng.choice(t[1:], 24, replace=False)), [1.0]])
    w = rng.choice([0.0, 1.0, 2.0], 120, p=[0.1, 0.6, 0.3])
    curve = fr._fit(P, t, w, knots, smoothing)
    u = np.linspace(0, 1, 1000, endpoint=False)
    ref = _periodic_reference_fit(P, t, w, knots, smoothing)(u)
    # both solve the same well-posed system in double precision: agreement to ~1e-12 of the
    # 20 mm size, 1e-9 mm leaves the conditioning of the uneven knots room
    assert np.abs(evaluate_curve(curve, u) - ref).max() < 1e-9
    # the smoothing is relative to the data term: scaling every weight changes nothing
    assert np.abs(evaluate_curve(fr._fit(P, t, 7.0 * w, knots, smoothing), u) - ref).max() < 1e-9


# --------------------------------------------------------------------------- turning, by brute force
def rounded_rectangle(W, H, rc, h, start=0.3):
    """A W x H rectangle with quarter-circle corners of radius rc, sampled every h mm of arc
    length (to the nearest whole number of steps round the loop), counter-clockwise from
    ``start`` steps past the left end of the bottom side (closed form). Returns (points, step)."""
    pieces = []                  # (length, start point, start direction angle, radius or 0)
    x0, y0 = -W / 2 + rc, -H / 2
    for side, (lx, ang) in enumerate(((W - 2 * rc, 0.0), (H - 2 * rc, np.pi / 2), (W - 2 * rc, np.pi),
                                      (H - 2 * rc, 1.5 * np.pi))):
        pieces.append((lx, (x0, y0), ang, 0.0))
        x0, y0 = x0 + lx * np.cos(ang), y0 + lx * np.sin(ang)
        pieces.append((0.5 * np.pi * rc, (x0, y0), ang, rc))
        cx, cy = x0 - rc * np.sin(ang), y0 + rc * np.cos(ang)
        x0, y0 = cx + rc * np.sin(ang + np.pi / 2), cy - rc * np.cos(ang + np.pi / 2)
    per = sum(p[0] for p in pieces)
    n = int(round(per / h))
    s = (start + np.arange(n)) * per / n
    P = np.zeros((n, 3))
    ends = np.cumsum([p[0] for p in pieces])
    for i, si in enumerate(s):
        j = int(np.searchsorted(ends, si, side="right"))
        length, (px, py), ang, rad = pieces[j]
        d = si - (ends[j] - length)
        if rad == 0.0:
            P[i, :2] = [px + d * np.cos(ang), py + d * np.sin(ang)]
        else:
            cx, cy = px - rad * np.sin(ang), py + rad * np.cos(ang)
            a = ang - np.pi / 2 + d / rad
            P[i, :2] = [cx + rad * np.cos(a), cy + rad * np.sin(a)]
    return P, per / n


def brute_turning(P, k, w):
    """Turning a step: the angle between the chords P[i-k]->P[i] and P[i]->P[i+k] (atan2 of
    their cross and dot products), over k; then scipy's running median over w points."""
    from scipy.ndimage import median_filter

    a = np.roll(P, -k, axis=0) - P
    b = P - np.roll(P, k, axis=0)
    ang = np.arctan2(np.linalg.norm(np.cross(b, a), axis=1), np.einsum("ij,ij->i", a, b)) / k
    return median_filter(ang, size=w, mode="wrap")


@pytest.mark.parametrize("W,H,rc,h,k", [
    (60.0, 30.0, 6.0, 2.0, 1),        # sparse: chords of one step (0.5 / 2 rounds to 0, at least 1)
    (8.0, 5.0, 0.5, 0.05, 10),        # 0.5 mm chords = 10 steps: window 21 = 2k + 1
    (8.0, 5.0, 0.5, 0.03125, 16),     # 16 steps: window 2k + 1 = 33 > 21
])
def test_turning_is_the_running_median_of_the_turning_over_half_millimetre_chords(W, H, rc, h, k):
    # the straight sides hold most of the steps, so the median step is the arc-length step;
    # 0.5 mm over it rounds to k (not near a half). Each corner turns over fewer points than
    # the window: the running median's width shows
    P, step = rounded_rectangle(W, H, rc, h)
    assert 2 * (W + H - 4 * rc) > 2 * np.pi * rc
    assert max(1, round(0.5 / step)) == k and abs(0.5 / step - round(0.5 / step)) < 0.3
    got = fr._robust_turning(P)
    want = brute_turning(P, k, max(21, 2 * k + 1))
    # the two angle formulas agree to rounding: arccos near 1 loses half the digits (1e-8)
    assert np.abs(got - want).max() < 1e-7
    assert np.isclose(np.median(got), 0.0, atol=1e-7)            # the sides are straight
    assert 0.1 * step / rc < got.max() <= step / rc * (1 + 1e-9)   # chords over an arc turn h/rc a step


def test_turning_chords_span_at_most_an_eighth_of_a_small_loop():
    # 48 points round a 2.26 mm stadium: 0.5 mm chords would be 10 steps, the cap 48 // 8 = 6
    P, h = rounded_rectangle(0.9, 0.4, 0.2, (1.0 + 0.4 * np.pi) / 48)
    assert P.shape[0] == 48 and round(0.5 / h) > 6
    assert np.abs(fr._robust_turning(P) - brute_turning(P, 6, 21)).max() < 1e-7


def test_turning_is_finite_where_the_chords_are_parallel_or_reversed():
    # a needle: 30 mm out along a line at 0.3 rad and back, a point every 2 mm (k = 1). The
    # chords along it are parallel (cosine 1, or a rounding past it) and at the two tips
    # reversed (cosine -1, or past it); the turning is 0 along the line, and the running
    # median over 21 of the 30 points hides the two single tips
    d = np.array([np.cos(0.3), np.sin(0.3), 0.0])
    P = np.vstack([np.arange(16)[:, None] * 2.0 * d, np.arange(14, 0, -1)[:, None] * 2.0 * d])
    got = fr._robust_turning(P)
    assert np.all(np.isfinite(got))
    assert np.abs(got - brute_turning(P, 1, 21)).max() < 1e-7 and np.abs(got).max() < 1e-7


# --------------------------------------------------------------------------- knot rules, by hand
def test_edge_zones_of_fraction_zero_are_empty():
    # fraction 0 switches the one-knot-a-point rule off (the knot tests below): not even the
    # two extreme points are "within 0 of the chord from an end" in the strict sense used
    for angle in (0.0, 0.6):
        P, _ = ellipse(angle=angle)
        assert not fr.edge_zones(P, 0.0).any()


def test_density_knots_take_every_point_whatever_the_first_parameter():
    # density 1: a knot at every point, also when no point sits at parameter 0 (a caller's t)
    t = (np.arange(50) + 0.5) / 50
    assert np.allclose(fr._density_knots(t, np.ones(50)), np.concatenate([[0.0], t, [1.0]]), atol=0)


def test_density_knots_ignore_parameters_outside_the_period():
    # periodic knots live in [0, 1]: parameters a caller took past the period give none
    t = np.array([-0.1, 0.0, 0.2, 0.5, 1.3, 1.6])
    k = fr._density_knots(t, np.ones(t.size))
    assert np.array_equal(k, np.array([0.0, 0.2, 0.5, 1.0]))


def arc_blocks(long_step, short_step, shorts, blocks):
    """A circle whose points come in blocks: one step of ``long_step`` mm, then ``shorts``
    steps of ``short_step`` mm (so the circle's radius follows)."""
    steps = np.tile(np.concatenate([[long_step], np.full(shorts, short_step)]), blocks)
    R = steps.sum() / (2 * np.pi)
    th = np.concatenate([[0.0], np.cumsum(steps)[:-1]]) / R
    return np.column_stack([R * np.cos(th), R * np.sin(th), np.zeros(th.size)])


def test_a_long_step_asks_for_one_knot_at_its_point_not_more():
    # 20 blocks of one 6 mm step (asks 6 / 4 = 1.5 knots: a point holds one) and five 0.3 mm
    # steps (0.075 a point, under the 1 / points_per_pole = 0.1 of the flanks). With every
    # point's density at most 1 each whole number the cumulative density passes is a knot of
    # its own: 20 · (1 + 5 · 0.1) = 30 knots; turning and edge rules off
    P = arc_blocks(6.0, 0.3, 5, 20)
    curve, _, _ = fr.fair_fit(P, knot_turn=1e9, edge_fraction=0.0)
    assert abs(curve.n_poles - 30) <= 1, curve.n_poles


def test_the_arc_rule_asks_a_knot_per_4_mm_by_default():
    # 300 steps of 0.6 mm: 0.6 / 4 = 0.15 knots a point (above the flanks' 0.1): 45 knots
    P = arc_blocks(0.6, 0.6, 0, 300)
    curve, _, _ = fr.fair_fit(P, knot_turn=1e9, edge_fraction=0.0)
    assert abs(curve.n_poles - 45) <= 1, curve.n_poles


def test_points_of_weight_zero_carry_no_knot():
    # in an edge zone every point carries a knot, except those of weight zero (knots at data
    # that counts: every span keeps data, Schoenberg-Whitney)
    P, _ = ellipse(200)
    t = np.arange(200) / 200
    zone = np.flatnonzero(fr.edge_zones(P))
    w = np.ones(200)
    out = zone[2:5]
    w[out] = 0.0
    curve, _, _ = fr.fair_fit(P, w, t=t, knot_turn=1e9)
    assert not np.isin(t[out], curve.knots).any()
    assert np.isin(t[np.setdiff1d(zone, out)], curve.knots).all()


def test_eight_spans_from_the_density_rule_are_kept_fewer_become_eight_uniform_ones():
    # 40 points at uneven parameters, one knot per 5 points: knots at points 0, 5, ..., 35
    # (the cumulative density passes 1, 2, ... at them) and 1: 8 spans, not the uniform ones
    P, _ = circle(40)
    t = (np.arange(40) / 40) ** 1.3
    c8, _, _ = fr.fair_fit(P, t=t, knot_turn=1e9, knot_length=1e9, points_per_pole=5, edge_fraction=0.0)
    assert np.allclose(c8.knots, np.concatenate([t[::5], [1.0]]), atol=1e-15)
    # one per 6 points: 7 spans, too few: 8 uniform spans of the period [0, 1] instead
    c7, _, d = fr.fair_fit(P, t=t, knot_turn=1e9, knot_length=1e9, points_per_pole=6, edge_fraction=0.0)
    assert np.array_equal(c7.knots, np.linspace(0.0, 1.0, 9))


def test_describe_runs_counts_from_the_end_nearer_the_first_point_wherever_the_section_lies():
    # an ellipse far from the origin, turned, started at either end or just either side of
    # the middle of the chord: the chord fraction of a point is its distance from the end
    # nearer the first point along the major axis over the major axis (closed form)
    a, b = 20.0, 3.0
    for angle in (0.0, 0.4, 2.0, -1.1):
        for th0 in (0.0, np.pi, 0.5 * np.pi - 0.004, 0.5 * np.pi + 0.004, 1.5 * np.pi + 0.004):
            th = th0 + np.linspace(0, 2 * np.pi, 400, endpoint=False)
            x = a * np.cos(th)
            P = np.column_stack([x, b * np.sin(th), np.zeros(400)])
            R = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0], [0, 0, 1]])
            P = P @ R.T + [150.0, -80.0, 40.0]
            frac = (x + a) / (2 * a) if x[0] < 0 else (a - x) / (2 * a)
            bad = np.zeros(400, bool)
            bad[[0, 1, 150]] = True
            disp = np.zeros(400)
            disp[[0, 1, 150]] = [0.0123456789, 0.02, 0.0031415926]
            runs = sorted(fr.describe_runs(P, bad, disp), key=lambda r: r["first_line"])
            # fractions to 4 decimals, displacements to the nanometre (6 decimals of a mm)
            assert runs == [
                {"first_line": 0, "last_line": 1, "points": 2,
                 "chord_fraction": [round(float(frac[0]), 4), round(float(frac[1]), 4)], "displacement_mm": 0.02},
                {"first_line": 150, "last_line": 150, "points": 1,
                 "chord_fraction": [round(float(frac[150]), 4)] * 2, "displacement_mm": 0.003142}], (angle, th0, runs)
            # counted from the end nearer the first point: its own fraction is at most a half
            assert frac[0] <= 0.5


# --------------------------------------------------------------------------- the auxiliary cubic, by scipy
def aux_reference(curve, t, a2, a1, b1, b2, k):
    """Seed 001's auxiliary cubic as replace_runs documents it, built by scipy: through the
    feet Q of a2, a1, b1, b2 on ``curve`` at chord-length parameters u in [0, 1], first
    derivatives at a2 and b2 along the curve's tangent with length L (the chord length of the
    four), knots by averaging (NURBS Book §9.2.2: 0⁴, (u0+u1+u2)/3, (u1+u2+u3)/3, 1⁴); the k
    new points at equal parameter steps strictly between a1 and b1."""
    from scipy.interpolate import make_interp_spline

    from bladerecon.core.geometry.bspline import curve_derivatives

    Q = evaluate_curve(curve, t[[a2, a1, b1, b2]])
    c = np.linalg.norm(np.diff(Q, axis=0), axis=1)
    L = c.sum()
    u = np.concatenate([[0.0], np.cumsum(c)]) / L
    tan = curve_derivatives(curve, t[[a2, b2]], 1)[:, 1]
    tan = L * tan / np.linalg.norm(tan, axis=1, keepdims=True)
    knots = np.concatenate([[0.0] * 4, [u[:3].mean(), u[1:].mean()], [1.0] * 4])
    spl = make_interp_spline(u, Q, k=3, t=knots, bc_type=([(1, tan[0])], [(1, tan[1])]))
    return spl(u[1] + (u[2] - u[1]) * np.arange(1, k + 1) / (k + 1))


def test_replaced_runs_are_the_auxiliary_cubics_of_their_two_nearest_good_neighbours():
    # three runs on the ellipse: one across the loop's end, two one good point apart (each
    # then reaches past the other for its second neighbour)
    P, nrm = flank_section()
    bad = np.zeros(400, bool)
    bad[[398, 399, 0, 100, 101, 102, 104, 105]] = True
    Pb = P.copy()
    Pb[bad] += 0.02 * nrm[bad]
    curve, t, _ = fr.fair_fit(Pb, (~bad).astype(float), t=fr.chord_parameters_of_good(Pb, bad))
    out = fr.replace_runs(Pb, bad, curve, t)
    # neighbours counted by hand: (a2, a1 | b1, b2) for each run
    for run, (a2, a1, b1, b2) in (([398, 399, 0], (396, 397, 1, 2)), ([100, 101, 102], (98, 99, 103, 106)),
                                  ([104, 105], (99, 103, 106, 107))):
        want = aux_reference(curve, t, a2, a1, b1, b2, len(run))
        # the same interpolation solved twice in double precision on a 20 mm section
        assert np.abs(out[run] - want).max() < 1e-10, run
    assert np.array_equal(out[~bad], Pb[~bad])


def test_four_good_points_are_enough_to_replace_the_rest():
    # 20 points, 4 good: every run's auxiliary cubic runs through all four
    P, _ = flank_section(20)
    bad = np.ones(20, bool)
    bad[[0, 5, 10, 15]] = False
    curve, t, _ = fr.fair_fit(P)
    out = fr.replace_runs(P, bad, curve, t)
    assert np.abs(out[1:5] - aux_reference(curve, t, 15, 0, 5, 10, 4)).max() < 1e-10
    assert np.abs(out[16:20] - aux_reference(curve, t, 10, 15, 0, 5, 4)).max() < 1e-10
    assert np.array_equal(out[~bad], P[~bad])


def test_fairing_refuses_where_the_auxiliary_cubic_strays_more_than_five_thresholds():
    # a 10 mm circle, a point every 0.9° except a stretch of 7 points 15° apart, the middle
    # one 0.1 mm out: around it the points are too sparse for the auxiliary cubic to follow
    # the fair fit of the good points. The stray (brute force: the replaced points against
    # 200 001 samples of that fit, 0.3 µm apart, so within 0.3²/8/R ≈ 1e-9 mm and a nearest-
    # sample error ~(0.15 µm)²/(2·stray) ≈ 3e-7 mm) decides against AUX_AGREEMENT = 5
    # thresholds, here at 0.008 mm, where the stray is 5-6 thresholds
    from scipy.spatial import cKDTree

    R, thr = 10.0, 0.008
    dense = np.deg2rad(np.arange(0.0, 360.0 - 7 * 15.0, 0.9))
    sparse = np.deg2rad(360.0 - 7 * 15.0 + 15.0 * np.arange(7))
    th = np.concatenate([dense, sparse])
    P = np.column_stack([R * np.cos(th), R * np.sin(th), np.zeros(th.size)])
    P[dense.size + 3] *= 1.0 + 0.1 / R
    bad, _, curve, t = fr.detect_bad_points(P, thr, edges=False)
    idx = np.flatnonzero(bad)
    assert dense.size + 3 in idx
    out = fr.replace_runs(P, bad, curve, t)
    stray = cKDTree(evaluate_curve(curve, np.linspace(0, 1, 200001))).query(out[idx])[0]
    assert 5.0 * thr < stray.max() < 6.0 * thr, stray.max() / thr
    with pytest.raises(BladeReconError) as e:
        fr.fair_section(P, thr, name="S9", edges=False)
    m = re.fullmatch(r"fairing refused: section S9, the auxiliary curve at point (\d+) strays (\d\.\d{4}) mm from the "
                     r"fair fit of the good points \(points around it too sparse or too uneven to rebuild it\): "
                     r"raise --fair-threshold or leave this data unfaired", str(e.value))
    assert m, str(e.value)
    assert int(m.group(1)) == idx[np.argmax(stray)]
    assert abs(float(m.group(2)) - stray.max()) <= 5e-5 + 1e-6        # printed to 0.1 µm


# --------------------------------------------------------------------------- the quarter rule and its message
def test_a_quarter_of_the_points_bad_is_still_fairable_one_more_is_not():
    # a 10 mm circle, every fourth point 20 µm out: a fit with a knot per 20 points (turning
    # and edge rules off) cannot follow a bump per 4 points, it rises by their mean, 5 µm.
    # The bumps then sit 15 µm off, the others 5 µm: above the 3 µm threshold but under half
    # the worst, so the first round rejects exactly the bumps, 100 of 400: a quarter, not
    # more than a quarter. One more bump next to one of them: 101, more than a quarter
    R, n = 10.0, 400
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    P = np.column_stack([R * np.cos(th), R * np.sin(th), np.zeros(n)])
    opts = dict(edges=False, edge_fraction=0.0, knot_turn=1e9, points_per_pole=20)
    for extra in ([], [2]):
        sel = np.concatenate([np.arange(0, n, 4), extra]).astype(int)
        Q = P.copy()
        Q[sel] *= 1.0 + 0.02 / R
        if not extra:
            bad = fr.detect_bad_points(Q, **opts)[0]
            assert np.array_equal(np.flatnonzero(bad), np.sort(sel))
        else:
            with pytest.raises(BladeReconError, match="more than a quarter"):
                fr.detect_bad_points(Q, **opts)


def test_the_quarter_message_prints_threshold_and_median_distance_in_micrometres():
    # a 10 mm circle with its points alternately 0.2 mm out and in: the fit (a knot per 10
    # points, turning and edge rules off) cannot follow an alternation of period 2 points, it
    # is the circle, every point 0.2 mm from it; every point is rejected at once. The median
    # distance is then 200 µm (the fit's leftover ripple is orders under the 0.05 µm the
    # message's decimal resolves), the threshold 60 µm; the suggestion 5 × 0.2 mm
    R, n, dl = 10.0, 400, 0.2
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = R + dl * np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    P = np.column_stack([r * np.cos(th), r * np.sin(th), np.zeros(n)])
    with pytest.raises(BladeReconError) as e:
        fr.detect_bad_points(P, 0.06, name="S1", edges=False, edge_fraction=0.0, knot_turn=1e9)
    assert str(e.value) == ("section S1: more than a quarter of the points are farther than 60.0 µm from a fair "
                            "curve (median distance 200.0 µm): the threshold is below this data's noise; "
                            "try --fair-threshold 1.000")


def test_noisy_circular_edges_are_judged_against_the_noise_of_the_flanks():
    # a 40 x 2 mm stadium (semicircular edges of radius 1 mm tangent to straight flanks,
    # seed 004's round edge exactly), a point every 0.2 mm, each moved along its normal by
    # N(0, 0.8 µm) noise. The edge model may miss its clean points by 1.5 × the flanks' noise
    # about the fair fit (~0.8 µm): both edges are judged, nothing is flagged (the noise
    # stays under the 3 µm threshold: 3.75 σ). Judged by the noise of the edge zones instead,
    # where the fair fit has a knot a point and follows the noise, they would not be
    P, _ = rounded_rectangle(40.0, 2.0, 1.0, 0.2)
    T = np.roll(P, -1, axis=0) - np.roll(P, 1, axis=0)
    N = np.column_stack([T[:, 1], -T[:, 0], np.zeros(len(P))])
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    sigma = 0.0008
    e = np.random.default_rng(1).normal(0.0, sigma, len(P))
    Q = P + e[:, None] * N
    s = fr.fair_section(Q)
    assert [j.judged for j in s.edges] == [True, True] and not s.bad.any()
    # detect_bad_points judges the edges too by default: in the edge zones its distances are
    # those to the edge model, a circle and two flanks of 11 numbers over ~40 points a zone,
    # which keeps the noise: |d| - |e| has an rms about σ √(11/40) ≈ 0.52 σ (the fair fit,
    # a knot a point there, would follow the noise: d ≈ 0, rms ≈ σ)
    from bladerecon.core.sections.edge_bad_points import EDGE_FRACTION

    zone = fr.edge_zones(P, EDGE_FRACTION)
    bad, d, _, _ = fr.detect_bad_points(Q)
    assert not bad.any()
    assert np.sqrt(np.mean((d[zone] - np.abs(e[zone])) ** 2)) < 0.65 * sigma
