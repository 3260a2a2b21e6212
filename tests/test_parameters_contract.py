# SPDX-License-Identifier: LGPL-2.1-or-later
"""The contract of ``core/sections/parameters.py``, judged by referees it does not share (issue 26):
closed forms (circles, lines, parabolas, squares), the analytic sample blade's own truth (its
chord, LE/TE points, edge circles, camber line and disks, in closed form), brute force on fine
grids and scipy's optimisers. Fast (a few seconds): ``make mutation`` runs it per mutant before
``tests/test_section_parameters.py``.

The analytic sections are sampled exactly (no noise) at 600 points equally spaced in arc
length; measured on them the code's figures are within (hub / thin tip): chord 0.13 / 0.002 µm,
stagger 0.0013 / 0.0002°, t_max 0.013 / 0.02 µm, edge radii 0.16 / 0.04 %, metal angles 0.027 /
0.003°, LE and TE points 1.5 / 0.3 µm, thickness at a position 0.05 µm, area 5e-7 relative.
The tolerances below are a few times those, far under what a change of a few per cent makes.
"""
from __future__ import annotations

import dataclasses
import re
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.optimize import least_squares, minimize_scalar
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.core.sections import parameters as pm
from bladerecon.core.sections.segmentation import LE, PRESSURE, SUCTION, TE, signed_curvature
from bladerecon.samples.blade import SampleBlade, t_at_length_fraction
from test_section_parameters import _stadium  # the elliptic-LE profile with known edges

Z = np.array([0.0, 0.0, 1.0])
X = np.array([1.0, 0.0, 0.0])
DEFAULT = SampleBlade()
# thin, small edges, a negative stagger at the tip (-5°): another corner of the family
THIN = SampleBlade(thickness_hub=0.05, thickness_tip=0.035, le_radius_hub=0.45, le_radius_tip=0.35,
                   te_radius_hub=0.3, te_radius_tip=0.25, stagger_hub=-20.0, twist=15.0, camber_hub=30.0,
                   camber_tip=20.0)
CASES = {"default-hub": (DEFAULT, 0.0), "thin-tip": (THIN, 1.0)}


def _profile(blade, h, n=600, start=0.123):
    """n exact points of the analytic section, equally spaced in arc length, and their t."""
    t = t_at_length_fraction(blade, h, (start + np.arange(n)) / n)
    return blade.point(h, t), t


def _segment(P, span=Z, **kw):
    kw.setdefault("flow", X)
    return pm.segment_blade([P], span, **kw).sections[0]


def _truth(blade, h):
    """The analytic section: chord frame (le, u, v), its laws, and its camber line and disks on a
    fine grid of the camber fraction xi (200001 points: 0.3 µm apart)."""
    laws = blade.section_laws(h)
    le, te = blade.le_te(h)
    u = (te - le) / np.linalg.norm(te - le)
    v = np.array([-u[1], u[0], 0.0])
    xi = np.linspace(0.0, 1.0, 200001)
    cam = blade.camber_point(h, xi)
    return SimpleNamespace(laws=laws, le=le, te=te, u=u, v=v, xi=xi, cam=cam, R=blade.half_thickness(h, xi),
                           xc=(cam - le) @ u, chord=float(laws.chord), stagger=float(laws.stagger),
                           camber=float(laws.camber), r_le=float(laws.le_radius), r_te=float(laws.te_radius),
                           tmax=float(laws.max_thickness))


def _chord_normal_truth(blade, h, tr, x):
    """Width of the analytic section across the line ⟂ chord at chordwise x (mm): each flank is a
    graph y(x) there; 40000 points of the profile, interpolated side by side."""
    b = blade.segment_bounds(h)
    t = np.arange(40000) / 40000
    D = blade.point(h, t)
    Xd, Yd = (D - tr.le) @ tr.u, (D - tr.le) @ tr.v
    out = []
    for lo, hi in ((b[3], b[4]), (b[1], b[2])):               # suction, pressure flank
        s = (t >= lo) & (t < hi)
        k = np.argsort(Xd[s])
        out.append(np.interp(x, Xd[s][k], Yd[s][k]))
    return float(out[0] - out[1])


def _polygon_area_centroid(P):
    x, y = P[:, 0], P[:, 1]
    cr = x * np.roll(y, -1) - np.roll(x, -1) * y
    a = 0.5 * cr.sum()
    return a, np.array([((x + np.roll(x, -1)) * cr).sum(), ((y + np.roll(y, -1)) * cr).sum()]) / (6 * a)


# --------------------------------------------------------------------------- the analytic section (first:
# it judges most of the module at once, so most mutants end here)
def _arc_points_truth(blade, h, t, P, tr, at_le):
    """Measured points on the analytic edge arc by more than ARC_MARGIN (0.02 rad) from its joints
    (the pieces' bounds in t), counted by their angle about the true edge centre."""
    b = blade.segment_bounds(h)
    centre = tr.cam[0] if at_le else tr.cam[-1]
    j = blade.point(h, np.array([b[1], b[4]] if at_le else [b[2], b[3]]))
    ang = lambda Q: np.arctan2((Q - centre) @ tr.v, (Q - centre) @ tr.u)
    a_lo, a_hi = np.sort(np.mod(ang(j), 2 * np.pi))
    a = np.mod(ang(P), 2 * np.pi)
    if at_le:                                 # the LE arc is the long way round through π
        return int(np.sum((a > a_lo + 0.02) & (a < a_hi - 0.02)))
    a = np.mod(a + np.pi, 2 * np.pi)
    a_lo, a_hi = np.sort(np.mod(np.array([a_lo, a_hi]) + np.pi, 2 * np.pi))
    return int(np.sum((a > a_lo + 0.02) & (a < a_hi - 0.02)))


@pytest.mark.parametrize("case", sorted(CASES))
def test_measure_section_gives_the_analytic_sections_figures(case):
    blade, h = CASES[case]
    P, t = _profile(blade, h)
    tr = _truth(blade, h)
    seg = _segment(P)
    m = pm.measure_section(seg, (2.0,), fractions=(0.3, 0.7))
    L = tr.chord
    assert m.index == 0 and m.points == 600 and m.warnings == ()
    assert abs(m.chord - L) < 1e-3 and m.chord_in_plane == pytest.approx(m.chord, abs=1e-12)
    assert abs(m.stagger_deg - tr.stagger) < 0.005
    assert np.linalg.norm(m.le - tr.le) < 0.005 and np.linalg.norm(m.te - tr.te) < 0.005
    assert abs(m.le_radius / tr.r_le - 1) < 0.005 and abs(m.te_radius / tr.r_te - 1) < 0.005
    assert np.linalg.norm(m.le_center - tr.cam[0]) < 0.005 and np.linalg.norm(m.te_center - tr.cam[-1]) < 0.005
    assert abs(m.max_thickness - tr.tmax) < 0.001
    x_tmax = float((blade.camber_point(h, blade.tmax_position) - tr.le) @ tr.u)
    assert abs(m.max_thickness_pos - x_tmax) < 0.05 and abs(m.max_thickness_pos_frac - x_tmax / L) < 0.05 / L
    # circular-arc camber: the metal angles are the stagger ± half the camber angle
    assert abs(m.inlet_angle_deg - (tr.stagger + tr.camber / 2)) < 0.1
    assert abs(m.outlet_angle_deg - (tr.stagger - tr.camber / 2)) < 0.1
    # every inscribed circle is a disk of the generator: centre on the camber line, diameter 2 R
    # there (25 µm at the ends, where the stations' circles meet the edge arcs; 1 µm between)
    d, i = cKDTree(tr.cam).query(m.camber)
    x = (m.camber - tr.le) @ tr.u
    mid = (x > 0.05 * L) & (x < 0.95 * L)
    assert len(m.camber) > 1000 and np.all(np.diff(x) >= 0) and m.camber_thickness.shape == (len(m.camber),)
    assert d.max() < 0.03 and d[mid].max() < 1e-3
    assert np.abs(m.camber_thickness - 2 * tr.R[i]).max() < 0.03
    assert np.abs(m.camber_thickness - 2 * tr.R[i])[mid].max() < 1e-3
    assert np.allclose(m.camber[:, 2], blade.z_of(h), atol=1e-9)
    # thickness at 2 mm from each end and at chord fractions: the generator's disk there (camber
    # normal) and the width ⟂ chord (chord normal), 0.5 µm
    for key, xx in (("le+2", 2.0), ("te+2", L - 2.0)):
        assert abs(m.thickness_at[key] - 2 * np.interp(xx, tr.xc, tr.R)) < 5e-4, key
        assert abs(m.gauges["thickness_at_chord_normal"][key] - _chord_normal_truth(blade, h, tr, xx)) < 5e-4, key
    assert set(m.thickness_at) == {"le+2", "te+2"}
    for f in (0.3, 0.7):
        assert abs(m.gauges["thickness_at_fraction"][f"{f:g}"] - 2 * np.interp(f * L, tr.xc, tr.R)) < 5e-4
        assert abs(m.gauges["thickness_at_fraction_chord_normal"][f"{f:g}"]
                   - _chord_normal_truth(blade, h, tr, f * L)) < 5e-4
    assert set(m.gauges["thickness_at_fraction"]) == {"0.3", "0.7"}
    # camber height: the sagitta of the circular camber arc, at its middle
    th = np.radians(tr.camber)
    rho = (L - tr.r_le - tr.r_te) / (2 * np.sin(th / 2))
    assert abs(m.gauges["camber_height"] - rho * (1 - np.cos(th / 2))) < 0.005
    assert abs(m.gauges["camber_height_pos_frac"] - (tr.r_le + (L - tr.r_le - tr.r_te) / 2) / L) < 0.05 / L
    # area and centroid of a dense polygon of the true section (40000 points)
    dense = blade.point(h, np.arange(40000) / 40000)
    area, cen = _polygon_area_centroid(dense)
    assert abs(m.gauges["area"] / abs(area) - 1) < 5e-6
    assert np.linalg.norm(np.array(m.gauges["centroid"]) - [*cen, blade.z_of(h)]) < 1e-4
    # the other chord-end convention: the camber line extended through the edge circle
    for key, k, sgn, r in (("le_camber", 0, 1, tr.r_le), ("te_camber", -1, -1, tr.r_te)):
        tan = (tr.cam[k + sgn] - tr.cam[k]) / np.linalg.norm(tr.cam[k + sgn] - tr.cam[k])   # into the blade
        assert np.linalg.norm(np.array(m.gauges[key]) - (tr.cam[k] - r * tan)) < 0.005, key
    assert m.gauges["projection"] == "section_plane" and "meridional" not in m.gauges
    assert m.throat is None
    # the evidence of each edge circle: the measured points on its arc, the flanks' points, noise
    for fit, n, at_le in ((m.le_fit, m.le_fit_points, True), (m.te_fit, m.te_fit_points, False)):
        assert set(fit) == {"arc_points", "flank_points", "rms", "flank_rms", "shape"} and fit["shape"] == "circle"
        assert fit["arc_points"] == n
        # exact but on the hub's LE, where one point 0.02 rad inside the true joint lies outside the
        # fitted one (13 against 12)
        slack = 1 if (case, at_le) == ("default-hub", True) else 0
        assert abs(n - _arc_points_truth(blade, h, t, P, tr, at_le)) <= slack
        assert len(fit["flank_points"]) == 2 and min(fit["flank_points"]) >= 20
        assert 0 <= fit["rms"] < 2e-3 and 0 < fit["flank_rms"] < 2e-3


# --------------------------------------------------------------------------- circles
def test_kasa_circle_is_exact_on_a_circle_and_holds_its_floor():
    a = np.linspace(0.2, 2.0, 7)
    c, r = pm.kasa_circle(np.column_stack([3.0 + 0.7 * np.cos(a), -1.0 + 0.7 * np.sin(a)]))
    assert np.allclose(c, [3.0, -1.0], atol=1e-12) and abs(r - 0.7) < 1e-12
    # points all at the origin: the centre is there and the squared radius 0, held at the floor
    c, r = pm.kasa_circle(np.zeros((3, 2)))
    assert np.allclose(c, 0.0) and abs(r / 1e-15 - 1) < 1e-12          # √1e-30 (approx's abs 1e-12 would hide it)
    assert pm.kasa_circle(np.zeros((3, 2)), floor=4.0)[1] == 2.0


def test_fit_circle_is_the_geometric_least_squares_circle():
    """Exact on an arc; on a noisy 70° arc (where Kåsa's radius is 0.15 mm off) scipy's
    least_squares on the geometric distances is the referee, to 1e-7 mm (its own stopping)."""
    a = np.linspace(0.3, 2.5, 9)
    c, r, rms = pm.fit_circle(np.column_stack([3 + 0.7 * np.cos(a), -1 + 0.7 * np.sin(a)]))
    assert np.allclose(c, [3, -1], atol=1e-10) and abs(r - 0.7) < 1e-10 and rms < 1e-10
    rng = np.random.default_rng(1)
    a = np.linspace(0.0, 1.2, 25)
    q = np.column_stack([2 + 5 * np.cos(a), 1 + 5 * np.sin(a)]) + 0.05 * rng.standard_normal((25, 2))
    c, r, rms = pm.fit_circle(q)
    ref = least_squares(lambda z: np.linalg.norm(q - z[:2], axis=1) - z[2], [2.0, 1.0, 5.0], xtol=1e-15, ftol=1e-15,
                        gtol=1e-15)
    ck, rk = pm.kasa_circle(q)
    assert abs(rk - ref.x[2]) > 1e-3                    # the algebraic start is off: the iteration matters
    assert np.allclose(c, ref.x[:2], atol=1e-7) and abs(r - ref.x[2]) < 1e-7
    assert rms == pytest.approx(np.sqrt(np.mean(ref.fun ** 2)), rel=1e-9)


# --------------------------------------------------------------------------- flank models, feet
def test_horner_evaluates_a_polynomial_from_its_constant_term():
    assert pm._horner([1.0, -2.0, 3.0], 2.0) == 1.0 - 4.0 + 12.0
    assert pm._horner([], 5.0) == 0.0


def test_flank_model_degree_follows_the_point_count_and_reproduces_the_polynomial():
    assert pm._flank_model(np.array([1.0]), np.array([2.0])) is None
    for n, deg in ((2, 1), (3, 1), (4, 2), (5, 2), (6, 3), (9, 3)):
        x = np.linspace(0.5, 2.0, n)
        y = 0.3 - 0.2 * x + (0.1 * x ** 2 if deg >= 2 else 0) + (0.05 * x ** 3 if deg >= 3 else 0)
        coef, xm, inv, (a, a1, a2, powers) = pm._flank_model(x, y)
        assert len(coef) == deg + 1 and xm == pytest.approx(x.mean(), abs=1e-15)
        assert np.allclose(np.polyval(coef, x - xm), y, atol=1e-12)
        s = 0.77
        assert pm._horner(a, s) == pytest.approx(np.polyval(coef, s), abs=1e-12)
        assert pm._horner(a1, s) == pytest.approx(np.polyval(np.polyder(coef), s), abs=1e-12)
        assert pm._horner(a2, s) == pytest.approx(np.polyval(np.polyder(coef, 2), s), abs=1e-12)
        assert list(powers) == list(range(deg, -1, -1))
        V = np.vander(x - xm, deg + 1)
        assert np.allclose(inv, np.linalg.inv(V.T @ V), rtol=1e-8, atol=1e-10)


def test_foot_on_a_parabola_is_the_nearest_point_and_its_leverage_the_hat_value():
    """y = x² (points at x = -1 .. 2): distance and foot against scipy's bounded minimiser on the
    closed form, from points with one foot (below the evolute); the leverage at a data point is the diagonal of the hat matrix Q Qᵀ (QR)."""
    x = np.linspace(-1.0, 2.0, 7)
    model = pm._flank_model(x, x ** 2)
    for c in (np.array([2.0, 3.0]), np.array([-1.5, 1.0]), np.array([1.5, -0.4]), np.array([0.2, 0.3])):
        res = minimize_scalar(lambda s: np.hypot(s - c[0], s * s - c[1]), bounds=(-3.0, 3.0), method="bounded",
                              options={"xatol": 1e-12})
        d, lev, foot = pm._foot_on_flank(c, model)
        assert abs(d - res.fun) < 1e-10 and np.allclose(foot, [res.x, res.x ** 2], atol=1e-6)
    Q, _ = np.linalg.qr(np.vander(x - x.mean(), 4))
    hat = (Q * Q).sum(axis=1)
    for k in (0, 3, 6):
        d, lev, foot = pm._foot_on_flank(np.array([x[k], x[k] ** 2]), model)
        assert d < 1e-12 and lev == pytest.approx(hat[k], rel=1e-9)


def test_touch_angle_without_a_model_and_on_a_tangent_line():
    c = np.array([1.0, 0.2])
    ang, x = pm._touch_angle(c, None, 1, 0.8)
    assert ang == pytest.approx(np.arccos(0.25), abs=1e-15) and x == pytest.approx(1.0 - 0.25 * 0.8, abs=1e-15)
    # the line y = 1.0 touches the circle of radius 0.8 about c at (1.0, 1.0): a right angle from the tip
    xs = np.linspace(0.0, 4.0, 9)
    up = pm._flank_model(xs, np.full(9, 1.0))
    ang, x = pm._touch_angle(c, up, 1, 0.8)
    assert ang == pytest.approx(np.pi / 2, abs=1e-9) and x == pytest.approx(1.0, abs=1e-9)
    # a tilted tangent on the lower side (sign -1): the foot at -(π/2 + 0.3) from +x, i.e. π/2 - 0.3
    # from the tip direction
    phi = 0.3
    foot = c + 0.8 * np.array([np.cos(-np.pi / 2 - phi), np.sin(-np.pi / 2 - phi)])
    slope = np.tan(-phi)                                  # tangent direction ⟂ radius
    lo = pm._flank_model(xs, foot[1] + slope * (xs - foot[0]))
    ang, x = pm._touch_angle(c, lo, -1, 0.8)
    assert ang == pytest.approx(np.pi / 2 - phi, abs=1e-9) and x == pytest.approx(foot[0], abs=1e-9)


def _g1_referee(pa, flank_xy, z_at):
    """The edge circle's normal equations with the weights frozen where the code stopped: scipy's
    least_squares on |p − c| − r and (dist(c, flank) − r)/sqrt(max(leverage, 1e-3)), distances by
    a bounded scalar minimiser on np.polyfit's polynomial, leverages by QR."""
    fl = []
    for x, y in flank_xy:
        deg = 3 if len(x) >= 6 else (2 if len(x) >= 4 else 1)
        xm = x.mean()
        coef = np.polyfit(x - xm, y, deg)
        _, R = np.linalg.qr(np.vander(x - xm, deg + 1))
        fl.append((xm, coef, R, deg))

    def foot(c, f):
        xm, coef, R, deg = f
        res = minimize_scalar(lambda s: np.hypot(s - (c[0] - xm), np.polyval(coef, s) - c[1]),
                              bounds=(c[0] - xm - 5.0, c[0] - xm + 5.0), method="bounded", options={"xatol": 1e-13})
        return res.fun, res.x

    w = []
    for f in fl:
        _, s = foot(z_at[:2], f)
        lev = float(np.sum(np.linalg.solve(f[2].T, s ** np.arange(f[3], -1, -1)) ** 2))
        w.append(1.0 / np.sqrt(max(lev, 1e-3)))

    def res(z):
        arc = np.linalg.norm(pa - z[:2], axis=1) - z[2]
        return np.r_[arc, [wk * (foot(z[:2], f)[0] - z[2]) for wk, f in zip(w, fl)]]
    return least_squares(res, z_at + [0.01, -0.01, 0.01], xtol=1e-14, ftol=1e-14, gtol=1e-14).x


def _exact_edge():
    """Centre (1, 0.2), radius 0.8: three arc points round the tip (−x) and two flanks tangent
    at ±(90° − 0.3 rad): (arc points, flank models)."""
    c, r = np.array([1.0, 0.2]), 0.8
    ang = np.pi + np.array([-0.4, 0.0, 0.5])
    pa = c + r * np.column_stack([np.cos(ang), np.sin(ang)])
    flanks = []
    for sgn in (1, -1):
        phi = sgn * (np.pi / 2 - 0.3)
        foot = c + r * np.array([np.cos(phi), np.sin(phi)])
        xs = foot[0] + np.linspace(0.0, 3.0, 10)
        flanks.append(pm._flank_model(xs, foot[1] - (xs - foot[0]) / np.tan(phi)))
    return pa, flanks


def test_edge_circle_fit_meets_an_exact_arc_and_two_tangent_flanks():
    """Centre (1, 0.2), radius 0.8; three arc points round the tip (−x) and two flanks tangent at
    ±(90° + 0.3 rad) from the tip: the fit returns the circle to 1e-9 mm from a start 0.1 off."""
    pa, flanks = _exact_edge()
    z = pm._fit_edge_circle(pa, flanks, np.array([1.1, 0.1, 0.7]))
    assert np.allclose(z, [1.0, 0.2, 0.8], atol=1e-9)
    # one arc point and the two flanks already fix it
    z = pm._fit_edge_circle(pa[1:2], flanks, np.array([1.1, 0.1, 0.7]))
    assert np.allclose(z, [1.0, 0.2, 0.8], atol=1e-9)


def test_edge_circle_fit_on_noisy_points_solves_the_weighted_normal_equations():
    rng = np.random.default_rng(7)
    c, r = np.array([1.0, 0.2]), 0.8
    ang = np.pi + np.linspace(-0.9, 0.9, 6)
    pa = c + r * np.column_stack([np.cos(ang), np.sin(ang)]) + 0.01 * rng.standard_normal((6, 2))
    flank_xy, flanks = [], []
    for sgn, n in ((1, 8), (-1, 5)):
        phi = sgn * (np.pi / 2 - 0.3)
        foot = c + r * np.array([np.cos(phi), np.sin(phi)])
        xs = foot[0] + np.linspace(0.0, 3.0, n)
        ys = foot[1] - (xs - foot[0]) / np.tan(phi) + 0.01 * rng.standard_normal(n)
        flank_xy.append((xs, ys))
        flanks.append(pm._flank_model(xs, ys))
    z = pm._fit_edge_circle(pa, flanks, np.array([1.1, 0.1, 0.7]))
    assert np.allclose(z, _g1_referee(pa, flank_xy, z), atol=1e-7)
    assert not np.allclose(z, [1.0, 0.2, 0.8], atol=1e-3)     # the noise moved it: the weights matter


# --------------------------------------------------------------------------- small closed forms
def test_max_circle_is_the_vertex_of_the_parabola_through_the_top_three():
    x = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
    r = 3.0 - 2.0 * (x - 1.3) ** 2
    assert np.allclose(pm._max_circle(x, r), (3.0, 1.3), atol=1e-12)
    # uneven steps about x = 0 (where x3[2] + x3[0] = 0: the guard is the span of the three)
    x = np.array([-3.0, -1.0, 0.0, 1.0, 2.0])
    r = 1.0 - 0.5 * (x - 0.2) ** 2
    assert np.allclose(pm._max_circle(x, r), (1.0, 0.2), atol=1e-12)
    # the largest at the second point; a vertex far on the wide side of uneven steps (|xv| = 0.5 > 0.1)
    x = np.array([0.0, 1.0, 2.0, 3.0])
    assert np.allclose(pm._max_circle(x, 1.0 - (x - 1.2) ** 2), (1.0, 1.2), atol=1e-12)
    x = np.array([0.0, 2.0, 2.1])
    assert np.allclose(pm._max_circle(x, 1.0 - (x - 1.5) ** 2), (1.0, 1.5), atol=1e-12)
    # the largest at an end: that point itself
    assert pm._max_circle(np.array([0.0, 1.0, 2.0]), np.array([3.0, 2.0, 1.0])) == (3.0, 0.0)
    assert pm._max_circle(np.array([0.0, 1.0, 2.0]), np.array([1.0, 2.0, 3.0])) == (3.0, 2.0)


@pytest.mark.parametrize("reverse", [False, True])
def test_area_and_centroid_of_a_triangle_and_a_square(reverse):
    tri = np.array([[0.0, 0.0], [4.0, 0.0], [0.0, 3.0]])
    sq = np.array([[1.0, 2.0], [3.0, 2.0], [3.0, 4.0], [1.0, 4.0]])
    for P, area, cen in ((tri, 6.0, (4 / 3, 1.0)), (sq, 4.0, (2.0, 3.0))):
        a, c = pm._area_centroid(P[::-1] if reverse else P)
        assert a == pytest.approx(area, abs=1e-12) and np.allclose(c, cen, atol=1e-12)


def test_chord_normal_thickness_of_a_circle_a_square_and_off_the_profile():
    """A circle of radius 2 about (5, 1) in a frame turned by 30°: the width at chordwise x is
    2 √(4 − (x − 5)²), within 1e-5 mm: the polygon's sagitta (2 mm × (π/4000)² / 2 ≈ 6e-7 mm) over
    the sine of the angle the line crosses it at (down to 0.3 here)."""
    th = np.linspace(0, 2 * np.pi, 4000, endpoint=False)
    ang = np.radians(30.0)
    u = np.array([np.cos(ang), np.sin(ang)])
    v = np.array([-u[1], u[0]])
    le = np.array([-1.0, 0.5])
    loop = le + np.outer(5 + 2 * np.cos(th), u) + np.outer(1 + 2 * np.sin(th), v)
    xs = [3.5, 5.0, 6.9, 7.5, -1.0]
    got = pm._chord_normal_thickness(loop, le, u, xs)
    for x, g in zip(xs[:3], got):
        assert g == pytest.approx(2 * np.sqrt(4 - (x - 5) ** 2), abs=1e-5)
    assert got[3:] == [None, None]
    # the unit square: at x = 0 its vertical edge lies on the line (left out), the width is 1
    sq = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    assert pm._chord_normal_thickness(sq, np.zeros(2), np.array([1.0, 0.0]), [0.0, 0.5]) == [1.0, 1.0]


def test_ends_from_circles_are_the_circles_points_farthest_apart():
    seg = SimpleNamespace(le=np.array([9.0, 9.0]), te=np.array([8.0, 8.0]))
    le_c, te_c = np.array([1.0, 1.0]), np.array([4.0, 5.0])
    le, te = pm._ends_from_circles(seg, le_c, 0.5, te_c, 0.25)
    assert np.allclose(le, [1.0 - 0.3, 1.0 - 0.4]) and np.allclose(te, [4.0 + 0.15, 5.0 + 0.2])
    for radii in ((None, 0.25), (0.5, None)):
        le, te = pm._ends_from_circles(seg, le_c, radii[0], te_c, radii[1])
        assert le is seg.le and te is seg.te


def test_angle_deg_is_atan2_in_degrees():
    assert pm._angle_deg(np.array([1.0, 1.0])) == pytest.approx(45.0)
    assert pm._angle_deg(np.array([-1.0, 0.0])) == 180.0
    assert pm._angle_deg(np.array([0.0, -2.0])) == -90.0


@pytest.mark.parametrize("at_le", [True, False])
def test_metal_angle_is_the_slope_of_the_quadratic_camber_fit_at_the_edge_centre(at_le):
    """Camber points on a parabola y = 0.02 x (40 − x) in a chord frame turned by 20°: the tangent
    at the edge circle's centre (x0 = 0.9 at the LE, 39.3 at the TE) in closed form. A cubic term
    on the far half leaves the fit over 15 % of the chord exact."""
    ang = np.radians(20.0)
    u = np.array([np.cos(ang), np.sin(ang)])
    v = np.array([-u[1], u[0]])
    le = np.array([2.0, -3.0])
    L = 40.0
    seg = SimpleNamespace(le=le, te=le + L * u, chord=L)
    x = np.linspace(0.5, 39.5, 300)
    y = 0.02 * x * (L - x) + np.where(np.abs(x - 20) < 12, 0.001 * (x - 8) ** 3 * (32 - x) ** 3 / 1e3, 0.0)
    c = le + np.outer(x, u) + np.outer(y, v)
    x0 = 0.9 if at_le else 39.3
    got = pm._metal_angle(seg, c, at_le, le + x0 * u)
    want = 20.0 + np.degrees(np.arctan(0.02 * (L - 2 * x0)))
    assert got == pytest.approx(want, abs=1e-9)


def test_metal_angle_with_few_camber_points_near_the_edge_fits_the_eight_nearest():
    """Camber points only from 20 % to 80 % of the chord on a cubic: the fit takes the 8 nearest the
    edge (np.polyfit of those, here the referee) instead of an empty 15 % window."""
    L = 10.0
    seg = SimpleNamespace(le=np.zeros(2), te=np.array([L, 0.0]), chord=L)
    x = np.linspace(2.0, 8.0, 25)
    y = 0.01 * x ** 3
    c = np.column_stack([x, y])
    for at_le, idx, x0 in ((True, slice(0, 8), 0.5), (False, slice(-8, None), 9.5)):
        coef = np.polyfit(x[idx], y[idx], 2)
        want = np.degrees(np.arctan(np.polyval(np.polyder(coef), x0)))
        assert pm._metal_angle(seg, c, at_le, np.array([x0, 0.0])) == pytest.approx(want, abs=1e-9)


def test_inside_a_square_whichever_way_it_runs():
    t = np.linspace(0, 4, 400, endpoint=False)
    sq = np.column_stack([np.clip(np.abs((t + 0.5) % 4 - 2) - 0.5, 0, 1), np.clip(np.abs((t - 0.5) % 4 - 2) - 0.5, 0, 1)])
    pts = np.array([[0.5, 0.5], [0.2, 0.7], [1.5, 0.5], [0.5, -0.4], [-0.3, 0.6]])
    for loop in (sq, sq[::-1]):
        assert pm._inside(pts, loop).tolist() == [True, True, False, False, False]


# --------------------------------------------------------------------------- stacking, nominal
def _p(stagger, centroid):
    return SimpleNamespace(stagger_deg=stagger, gauges={"centroid": list(centroid)})


def test_stacking_sweep_lean_height_and_twist_in_closed_form():
    params = [_p(170.0, (1.0, 2.0, 0.0)), _p(-170.0, (1.5, 2.25, 10.0)), _p(-10.0, (0.0, 0.0, 20.0)),
              _p(30.0, (2.0, 3.0, 5.0))]
    st = pm.stacking(params, np.array([0.0, 0.0, 2.0]))
    want = [(0.0, 0.0, 0.0, 0.0), (0.5, 0.25, 10.0, 20.0), (-1.0, -2.0, 20.0, 180.0), (1.0, 1.0, 5.0, -140.0)]
    for s, (sw, ln, ht, tw) in zip(st, want):
        assert set(s) == {"sweep", "lean", "height", "twist_deg"}
        assert (s["sweep"], s["lean"], s["height"], s["twist_deg"]) == pytest.approx((sw, ln, ht, tw), abs=1e-12)
    # an axial direction not normal to the span is made normal to it; lean is along span × axial
    st = pm.stacking(params, Z, axial=np.array([0.0, 2.0, 3.0]))
    assert (st[1]["sweep"], st[1]["lean"]) == pytest.approx((0.25, -0.5), abs=1e-12)
    # an axial direction along the span falls back to +y: lean along z × y = -x
    st = pm.stacking(params, Z, axial=np.array([0.0, 0.0, 5.0]))
    assert (st[1]["sweep"], st[1]["lean"], st[1]["height"]) == pytest.approx((0.25, -0.5, 10.0), abs=1e-12)
    # a tilted span axis with the default axial direction: +x (normal to it already), lean along a × x
    a = np.array([0.0, 0.6, 0.8])
    st = pm.stacking(params, a)
    d = np.array([0.5, 0.25, 10.0])
    assert (st[1]["sweep"], st[1]["lean"]) == pytest.approx((0.5, d @ np.cross(a, X)), abs=1e-12)
    # a tilted span axis: the fallback keeps the axial direction normal to it
    st = pm.stacking(params, a, axial=a)
    ax = np.array([0.0, 0.8, -0.6])
    d = np.array([0.5, 0.25, 10.0])
    assert (st[1]["sweep"], st[1]["lean"], st[1]["height"]) == pytest.approx((d @ ax, d @ np.cross(a, ax), d @ a),
                                                                             abs=1e-12)


def test_compare_with_nominal_adds_the_nominal_row_and_the_differences():
    keys = pm.PARAMETER_KEYS
    assert keys == ("chord", "stagger_deg", "max_thickness", "max_thickness_pos", "le_radius", "te_radius",
                    "inlet_angle_deg", "outlet_angle_deg")
    measured = {k: float(i + 1) for i, k in enumerate(keys)}
    measured.update(points=100, le=[0.0, 0.0, 0.0], te=[3.0, 4.0, 0.0], thickness_at={}, extra="kept")
    measured["te_radius"] = None
    nominal = {k: 0.5 * (i + 1) for i, k in enumerate(keys)}
    nominal.update(points=90, le=[1.0, 2.0, 2.0], te=[3.0, 4.0, 1.0], thickness_at={"le+1": 0.2}, other=1)
    nominal["le_radius"] = None
    row = pm.compare_with_nominal(measured, nominal)
    assert row["extra"] == "kept" and row["chord"] == 1.0 and "difference" not in measured
    assert row["nominal"] == {k: nominal[k] for k in ("points", "le", "te", *keys, "thickness_at")}
    want = {k: 0.5 * (i + 1) for i, k in enumerate(keys)}
    want.update(le_radius=None, te_radius=None, le_shift=3.0, te_shift=1.0)
    assert row["difference"] == pytest.approx(want)


# --------------------------------------------------------------------------- canonical loop
def test_canonical_loop_is_the_same_bits_from_any_start_and_direction():
    th = np.linspace(0, 2 * np.pi, 50, endpoint=False)
    P = np.column_stack([3 * np.cos(th + 0.3), np.sin(th + 0.3), np.full(50, 2.0)])
    ref = pm.canonical_loop(P)
    k = int(np.argmax(P[:, 0]))
    assert np.array_equal(ref, np.roll(P, -k, axis=0))            # ccw about +z, from the largest x
    for start in (0, 7, 31):
        assert np.array_equal(pm.canonical_loop(np.roll(P, -start, axis=0)), ref)
        assert np.array_equal(pm.canonical_loop(np.roll(P[::-1], -start, axis=0)), ref)
    # about -z the same loop runs the other way, still from the largest x
    down = pm.canonical_loop(P, np.array([0.0, 0.0, -1.0]))
    assert np.array_equal(down, np.roll(P[::-1], -int(np.argmax(P[::-1, 0])), axis=0))
    # ties in x are broken by y, then z, whatever their order in the file
    sq = np.array([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]])
    assert np.array_equal(pm.canonical_loop(sq)[0], [1.0, 1.0, 0.0])
    sq2 = np.array([[1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    assert np.array_equal(pm.canonical_loop(sq2), pm.canonical_loop(sq))
    assert np.array_equal(pm.canonical_loop(sq[::-1]), pm.canonical_loop(sq))
    tri = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 1.0, 0.0]])        # coarse loops: 3 and 4 points
    assert np.array_equal(pm.canonical_loop(tri), tri[[1, 2, 0]])
    assert np.array_equal(pm.canonical_loop(tri[::-1]), tri[[1, 2, 0]])
    # a small loop (area 0.03 mm²) keeps its turn
    small = 0.1 * P
    assert np.array_equal(pm.canonical_loop(small), np.roll(small, -k, axis=0))
    # a section lying along the span axis (in the x-z plane, axis z) is turned about its own normal
    Q = np.column_stack([3 * np.cos(th), np.zeros(50), np.sin(th)])
    # (about z its area is nil, and the direction would be a coin toss)
    out = pm.canonical_loop(Q)
    assert out[0, 0] == 3.0
    for start in (0, 11):
        assert np.array_equal(pm.canonical_loop(np.roll(Q[::-1], -start, axis=0)), out)


def test_as_dict_holds_every_figure_and_the_gauges():
    P, _ = _profile(DEFAULT, 0.0)
    m = pm.measure_section(_segment(P), (1.0,), n_points=1234, fractions=(0.5,))
    assert m.points == 1234
    d = m.as_dict()
    plain = ("index", "points", "chord", "stagger_deg", "max_thickness", "max_thickness_pos", "max_thickness_pos_frac",
             "le_radius", "te_radius", "inlet_angle_deg", "outlet_angle_deg", "chord_in_plane", "thickness_at",
             "le_fit_points", "te_fit_points", "le_fit", "te_fit")
    assert set(d) == {*plain, "le", "te", *m.gauges, "warnings"} and "throat" not in d
    for k in plain:
        assert d[k] == getattr(m, k), k
    assert d["le"] == m.le.tolist() and d["te"] == m.te.tolist() and d["warnings"] == []
    for k, v in m.gauges.items():
        assert d[k] == v, k
    thr = dataclasses.replace(m, throat={"point": np.array([1.0, 2.0, 3.0]), "width": 4.0})
    assert thr.as_dict()["throat"] == {"point": [1.0, 2.0, 3.0], "width": 4.0}


def test_offsets_off_the_camber_line_give_none():
    P, _ = _profile(DEFAULT, 0.0)
    m = pm.measure_section(_segment(P), (-1.0, 0.0, 100.0), fractions=(-0.1, 1.2))
    for key in ("le+-1", "te+-1", "le+100", "te+100", "le+0", "te+0"):
        assert m.thickness_at[key] is None, key
    for key in ("le+-1", "te+-1", "le+100", "te+100"):
        assert m.gauges["thickness_at_chord_normal"][key] is None, key
    assert m.gauges["thickness_at_fraction"] == {"-0.1": None, "1.2": None}
    assert m.gauges["thickness_at_fraction_chord_normal"] == {"-0.1": None, "1.2": None}


def test_inscribed_circles_are_the_generators_disks_whichever_way_the_plane_faces():
    """The section seen from below (span axis -z: its loop runs clockwise in its plane): the same
    disks. ``stations`` sets the pressure-side count (those near the ends are left out)."""
    blade, h = DEFAULT, 0.0
    P, _ = _profile(blade, h)
    tr = _truth(blade, h)
    for span in (Z, -Z):
        seg = _segment(P, span=span, canonical=False)
        c, r = pm.inscribed_circles(seg, stations=300)
        assert 280 <= len(c) <= 300
        C3 = seg.lift(c)
        d, i = cKDTree(tr.cam).query(C3)
        x = (C3 - tr.le) @ tr.u
        mid = (x > 0.05 * tr.chord) & (x < 0.95 * tr.chord)
        assert np.all(np.diff(x) >= 0)
        assert d[mid].max() < 1e-3 and np.abs(r - tr.R[i])[mid].max() < 1e-3
        assert x.min() > 0.0 and x.max() < tr.chord
        m = pm.measure_section(seg)
        assert abs(m.chord - tr.chord) < 1e-3 and abs(m.max_thickness - tr.tmax) < 1e-3


def test_side_parameters_are_equal_steps_inside_the_side():
    P, _ = _profile(DEFAULT, 0.0)
    seg = _segment(P)
    lo, hi = seg.curve.domain
    for side in (SUCTION, PRESSURE):
        t = pm._side_parameters(seg, side, 50)
        # from one end to the other (the stations next to the ends lie in the edge regions)
        assert np.all((t >= lo) & (t < hi)) and np.all(seg.label_parameters(t[5:-5]) == side)
        a, b = seg.side_interval(side)
        assert np.allclose(np.mod(t - a, hi - lo), (b - a) * (np.arange(50) + 0.5) / 50, atol=1e-12)


def test_no_inscribed_circle_raises_with_the_sections_number():
    P, _ = _profile(DEFAULT, 0.0)
    seg = dataclasses.replace(_segment(P), index=4)
    bad = dataclasses.replace(seg, te=seg.le + 0.001 * (seg.te - seg.le))
    with pytest.raises(BladeReconError) as e:
        pm.inscribed_circles(bad)
    assert re.fullmatch(r"section 4: no inscribed circles found between the suction and pressure sides: check that "
                        r"the section is one closed blade profile", str(e.value))


# --------------------------------------------------------------------------- edge evidence, warnings
def _cut_le(d, n=300):
    """The hub section, 300 points, without those less than d mm behind the LE along the chord."""
    P, _ = _profile(DEFAULT, 0.0, n=n, start=0.5)
    tr = _truth(DEFAULT, 0.0)
    return P[(P - tr.le) @ tr.u > d]


def test_an_edge_with_one_point_on_its_arc_says_so():
    seg = dataclasses.replace(_segment(_cut_le(0.5)), index=3)
    m = pm.measure_section(seg)
    assert m.le_fit["arc_points"] == 1 and m.le_fit_points == 1 and m.te_fit["arc_points"] > 2
    assert abs(m.le_radius / 0.9 - 1) < 0.01
    assert m.warnings == ("section 3: the leading edge radius rests on 1 measured point on its arc and the flanks' "
                          "tangency: measure more points round the edge",)


def test_an_edge_with_no_point_on_its_arc_gives_the_largest_circle_the_flanks_allow():
    seg = dataclasses.replace(_segment(_cut_le(1.0)), index=2)
    m = pm.measure_section(seg)
    assert m.le_fit["arc_points"] == 0 and m.le_fit_points == 0
    assert 0.9 < m.le_radius < 1.0                         # an upper bound of the true 0.9 mm
    assert m.warnings == ("section 2: no measured point lies on the leading edge's arc: its radius is that of the "
                          "largest circle tangent to both flanks that the points allow (an upper bound; the chord "
                          "end as uncertain): measure points round the edge",)


def test_a_failed_edge_raises_or_with_strict_radius_false_becomes_a_warning(monkeypatch):
    P, _ = _profile(DEFAULT, 0.0)
    seg = dataclasses.replace(_segment(P), index=5)
    monkeypatch.setattr(pm, "_edge_circle", lambda *a: None)
    with pytest.raises(BladeReconError) as e:
        pm.measure_section(seg)
    assert re.fullmatch(r"section 5: no measured point on the leading edge beyond its circle's centre: measure "
                        r"points round the leading edge", str(e.value))
    m = pm.measure_section(seg, strict_radius=False)
    assert m.le_radius is None and m.te_radius is None and m.le_fit is None and m.te_fit is None
    assert m.le_fit_points == 0 and m.te_fit_points == 0
    assert m.warnings == tuple(f"section 5: no measured point on the {n} beyond its circle's centre: measure points "
                               f"round the {n}" for n in ("leading edge", "trailing edge"))
    # the chord ends are then the segmentation's, the camber-line ends unknown
    assert np.allclose(m.le, seg.lift(seg.le)[0], atol=1e-12) and np.allclose(m.te, seg.lift(seg.te)[0], atol=1e-12)
    assert m.gauges["le_camber"] is None and m.gauges["te_camber"] is None


def test_only_the_te_failing_keeps_the_le_circle(monkeypatch):
    P, _ = _profile(DEFAULT, 0.0)
    seg = _segment(P)
    real = pm._edge_circle
    monkeypatch.setattr(pm, "_edge_circle", lambda s, region, c, r: real(s, region, c, r) if region == LE else None)
    m = pm.measure_section(seg, strict_radius=False)
    assert abs(m.le_radius / 0.9 - 1) < 0.005 and m.te_radius is None
    assert m.gauges["le_camber"] is not None and m.gauges["te_camber"] is None
    assert len(m.warnings) == 1 and m.warnings[0].startswith("section 0: no measured point on the trailing edge")


def test_an_elliptic_edge_is_reported_not_round_in_so_many_words():
    seg = _segment(_stadium(0.0))
    m = pm.measure_section(seg)
    assert len(m.warnings) == 1
    w = re.fullmatch(r"section 0: the leading edge is not a circle: its arc points scatter (\d+\.\d) µm rms about the "
                     r"fitted circle against (\d+\.\d) µm on the flanks \(an ellipse fits it: semi-axes (\d+\.\d{3}) × "
                     r"(\d+\.\d{3}) mm, (\d+\.\d) µm rms; see shape in the edge's fit\)", m.warnings[0])
    assert w and float(w[1]) == round(m.le_fit["rms"] * 1000, 1) and float(w[2]) == round(m.le_fit["flank_rms"] * 1000, 1)
    ell = m.le_fit["ellipse"]
    assert m.le_fit["shape"] == "ellipse" and float(w[3]) == round(ell["a_mm"], 3) and float(w[4]) == round(ell["b_mm"], 3)
    assert float(w[5]) == round(ell["rms_mm"] * 1000, 1)
    assert m.le_fit["rms"] > 4 * m.le_fit["flank_rms"] + pm.NOT_ROUND
    assert abs(m.te_radius / 0.5 - 1) < 0.005


# --------------------------------------------------------------------------- segment_blade
def _blade(n=200, hs=(0.0, 0.5, 1.0)):
    return [_profile(DEFAULT, h, n=n)[0] for h in hs]


def _le_end(seg):
    """Which end the LE is at: -1 upstream (smaller x along the chord of the sample blade), +1 downstream."""
    return -1 if (seg.te - seg.le)[0] > 0 else 1


def test_segment_blade_rules_and_their_warnings():
    secs = _blade()
    bs = pm.segment_blade(secs, Z, flow=np.array([2.0, 0.0, 0.0]))
    assert bs.le_rule == "flow" and bs.warning is None and [_le_end(s) for s in bs.sections] == [-1, -1, -1]
    bs = pm.segment_blade(secs, Z, flow=np.array([-1.0, 0.0, 0.0]))
    assert [_le_end(s) for s in bs.sections] == [1, 1, 1]
    # the nominal's LE points: each section's LE is its end nearest its own point
    tes = [DEFAULT.le_te(h)[1] for h in (0.0, 0.5, 1.0)]
    bs = pm.segment_blade(secs, Z, le_points=tes)
    assert bs.le_rule == "nominal" and bs.warning is None and [_le_end(s) for s in bs.sections] == [1, 1, 1]
    mixed = [DEFAULT.le_te(0.0)[1], DEFAULT.le_te(0.5)[0], DEFAULT.le_te(1.0)[1]]
    assert [_le_end(s) for s in pm.segment_blade(secs, Z, le_points=mixed).sections] == [1, -1, 1]
    # the file's first point at the TE: the TE end is taken as the LE on every section
    at_te = [np.roll(p, -int(np.argmax((p - DEFAULT.le_te(0.0)[0]) @ X)), axis=0) for p in secs]
    bs = pm.segment_blade(at_te, Z, first_point_is_measured=True, canonical=False)
    assert bs.le_rule == "first_point" and [_le_end(s) for s in bs.sections] == [1, 1, 1]
    assert bs.warning == ("leading edge guessed: the end where the first section's first point lies; give the flow "
                          "direction (--flow X,Y,Z) to be sure")
    bs = pm.segment_blade(secs, Z)
    assert bs.le_rule == "blunter_edge" and [_le_end(s) for s in bs.sections] == [-1, -1, -1]
    assert bs.warning == ("leading edge guessed: the blunter end on most sections; give the flow direction "
                          "(--flow X,Y,Z) to be sure")
    assert pm.LE_RULES == ("flow", "nominal", "first_point", "blunter_edge")


def test_segment_blade_turns_every_section_when_most_say_the_other_end_is_blunter():
    """The first section mirrored (its blunt end downstream): alone it would set the LE there for
    all; the vote of the other two turns the blade back, the first section with it."""
    secs = _blade()
    first = secs[0] * np.array([-1.0, 1.0, 1.0])
    first += np.array([secs[0][:, 0].max() + secs[0][:, 0].min(), 0.0, 0.0])
    assert [_le_end(s) for s in pm.segment_blade([first], Z).sections] == [1]     # alone: its blunt end
    bs = pm.segment_blade([first, secs[1], secs[2]], Z)
    assert bs.le_rule == "blunter_edge" and [_le_end(s) for s in bs.sections] == [-1, -1, -1]
    cur = [pm._region_mean_curvature(s, LE) - pm._region_mean_curvature(s, TE) for s in bs.sections]
    assert cur[0] > 0 > max(cur[1:])           # mean curvature: lower (blunter) at the LE on the last two


def test_region_mean_curvature_is_the_mean_over_the_region():
    """Against the mean of the signed curvature over 20000 points of the region (midpoints): the
    64-point midpoint rule is within 6e-4 of it here (measured), 1e-3 allowed; 65 or one step
    shifted points are 2e-3 to 9e-3 off. The LE region of the hub section averages about
    1/0.9 mm⁻¹ (its arc) and the TE region more."""
    P, _ = _profile(DEFAULT, 0.0)
    seg = _segment(P)
    lo, hi = seg.curve.domain
    for region in (LE, TE):
        a, b = seg.region_interval(region)
        t = a + (b - a) * (np.arange(20000) + 0.5) / 20000
        ref = float(np.mean(signed_curvature(seg.curve, lo + np.mod(t - lo, hi - lo))))
        assert pm._region_mean_curvature(seg, region) == pytest.approx(ref, rel=1e-3)
    assert 0 < pm._region_mean_curvature(seg, LE) < pm._region_mean_curvature(seg, TE)


def test_segment_blade_refuses_a_bad_flow_and_a_wrong_number_of_le_points():
    secs = _blade(hs=(0.0, 1.0))
    for flow, shown in (([0.0, 0.0, 0.0], r"\[0\.0, 0\.0, 0\.0\]"), ([1.0, np.nan, 0.0], r"\[1\.0, nan, 0\.0\]"),
                        ([1.0, 0.0], r"\[1\.0, 0\.0\]")):
        with pytest.raises(BladeReconError) as e:
            pm.segment_blade(secs, Z, flow=np.array(flow))
        assert re.fullmatch(rf"flow direction {shown}: give three numbers X,Y,Z, not all zero", str(e.value))
    with pytest.raises(BladeReconError) as e:
        pm.segment_blade(secs, Z, le_points=[np.zeros(3)])
    assert re.fullmatch(r"1 leading-edge points for 2 sections", str(e.value))


def test_segment_blade_measures_canonical_loops_and_segment_sections_keeps_the_order():
    P = _profile(DEFAULT, 0.0, n=200)[0]
    Q = np.roll(P[::-1], -37, axis=0)
    a = pm.segment_blade([P], Z).sections[0]
    b = pm.segment_blade([Q], Z).sections[0]
    assert np.array_equal(a.points2d, b.points2d) and a.t_le == b.t_le
    kept = pm.segment_sections([Q], Z)[0]
    assert np.allclose(kept.frame.to_space(kept.points2d), Q, atol=1e-9)
    assert np.allclose(pm.segment_sections([Q], Z, canonical=True)[0].points2d, a.points2d, atol=0)
    # segment_sections takes the first point as measured by default: here at the TE
    at_te = np.roll(P, -int(np.argmax(P @ X)), axis=0)
    assert _le_end(pm.segment_sections([at_te], Z)[0]) == 1
    assert _le_end(pm.segment_sections([at_te], Z, flow=X)[0]) == -1


def test_a_throat_is_carried_into_the_parameters_in_space():
    from bladerecon.core.sections.segmentation import ThroatSpec
    P = _profile(DEFAULT, 0.5, n=400)[0]
    seg = pm.segment_blade([P], Z, flow=X, throat=ThroatSpec(40.0, 10.0)).sections[0]
    m = pm.measure_section(seg)
    assert m.throat is not None and set(m.throat) == set(seg.throat)
    assert np.allclose(m.throat["point"], seg.lift(seg.throat["point"])[0], atol=1e-12)
    assert m.throat["point"][2] == pytest.approx(DEFAULT.z_of(0.5), abs=1e-9)
    d = m.as_dict()
    assert d["throat"]["point"] == m.throat["point"].tolist()


# --------------------------------------------------------------------------- stream-surface sections
def _cone_section(n=400, r0=150.0, phi=np.radians(25.0), theta0=0.3):
    """The hub section placed in the conformal plane (x, y) = (r0 m′, r0 θ) of a cone of half-angle
    phi about z: r = r0 exp(m′ sin phi), axial = 10 + (r − r0) / tan phi (closed form)."""
    xy = _profile(DEFAULT, 0.0, n=n)[0][:, :2]
    mp, th = xy[:, 0] / r0, xy[:, 1] / r0
    r = r0 * np.exp(mp * np.sin(phi))
    return np.column_stack([r * np.cos(th + theta0), r * np.sin(th + theta0), 10.0 + (r - r0) / np.tan(phi)])


def test_a_stream_surface_section_gets_its_m_theta_block_and_a_wrong_axis_a_warning():
    P = _cone_section()
    span = np.array([np.cos(0.3), np.sin(0.3), 0.0])
    seg = dataclasses.replace(pm.segment_blade([P], span).sections[0], index=6)
    m = pm.measure_section(seg)
    # projected on the plane normal to the span the edges are sheared out of round (the two
    # warnings); in m′–θ the section is the planar one: stagger 30°, inlet metal angle 49°
    assert m.gauges["projection"] == "span_normal" and len(m.warnings) == 2
    assert all(" edge is not a circle: " in w for w in m.warnings)
    mb = m.gauges["meridional"]
    assert abs(mb["stagger_deg"] - 30.0) < 0.005 and abs(mb["le_metal_angle_deg"] - 49.0) < 0.1
    # the axis passed through: off by 20 mm, no surface of revolution, the block null and the reason given
    m = pm.measure_section(seg, axis=(0.0, 0.0, 1.0), axis_point=(0.0, 20.0, 0.0))
    assert m.gauges["meridional"] is None and len(m.warnings) == 3
    assert m.warnings[2].startswith("section 6: not on a surface of revolution about the axis [0.0, 0.0, 1.0] through "
                                    "[0.0, 20.0, 0.0]: ")
    m = pm.measure_section(seg, axis=(1.0, 0.0, 0.0))
    assert m.gauges["meridional"] is None and "about the axis [1.0, 0.0, 0.0]" in m.warnings[2]


# --------------------------------------------------------------------------- the public surface
def test_the_public_names_and_constants():
    assert pm.__all__ == ["SectionParameters", "measure_section", "segment_sections", "fit_circle", "kasa_circle",
                          "inscribed_circles", "MIN_EDGE_POINTS", "PARAMETER_KEYS", "compare_with_nominal", "LE_RULES",
                          "BladeSegmentation", "canonical_loop", "segment_blade", "stacking", "EdgeCircle"]
    assert all(hasattr(pm, name) for name in pm.__all__)
    assert pm.MIN_EDGE_POINTS == 5


def test_section_parameters_defaults():
    """What a caller that builds a row itself (a nominal table) gets for the optional fields."""
    p = pm.SectionParameters(index=1, points=2, le=np.zeros(3), te=np.ones(3), chord=3.0, stagger_deg=4.0,
                             max_thickness=5.0, max_thickness_pos=6.0, max_thickness_pos_frac=0.5, le_radius=None,
                             te_radius=0.1, inlet_angle_deg=7.0, outlet_angle_deg=8.0, camber=np.zeros((0, 3)),
                             camber_thickness=np.zeros(0))
    assert (p.thickness_at, p.le_fit_points, p.te_fit_points, p.le_center, p.te_center, p.throat, p.warnings,
            p.chord_in_plane, p.le_fit, p.te_fit, p.gauges) == ({}, 0, 0, None, None, None, (), 0.0, None, None, {})
    e = pm.EdgeCircle(np.zeros(2), 1.0, 3, (4, 5), 0.1, np.array([1.0, 0.0]))
    assert np.isnan(e.flank_rms)
    with pytest.raises(dataclasses.FrozenInstanceError):
        e.radius = 2.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        pm.BladeSegmentation([], "flow", None).le_rule = "nominal"
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.chord = 1.0


def test_default_stations_are_two_per_point_between_600_and_2000():
    """The default count against the count given: the same circles, bit for bit."""
    for n, stations in ((200, 600), (400, 800), (1100, 2000)):
        seg = _segment(_profile(DEFAULT, 0.0, n=n)[0])
        c, r = pm.inscribed_circles(seg)
        c2, r2 = pm.inscribed_circles(seg, stations)
        assert np.array_equal(c, c2) and np.array_equal(r, r2), n


def _with_edge(monkeypatch, **changes):
    """The real edge circles with some of their evidence replaced (the warnings' inputs)."""
    real = pm._edge_circle
    monkeypatch.setattr(pm, "_edge_circle", lambda *a: dataclasses.replace(real(*a), **changes))


@pytest.mark.parametrize("arc, rms, flank, warned", [
    (5, 4 * 0.07 + pm.NOT_ROUND, 0.07, False),             # at the limit: not beyond it
    (5, 0.3, 0.07, True), (4, 0.3, 0.07, False), (5, 0.3, float("nan"), False),
    (6, 0.0039, 0.0002, True), (6, 0.0041, 0.0003, False)])
def test_not_round_needs_five_arc_points_and_a_scatter_beyond_four_times_the_flanks_plus_3_um(
        monkeypatch, arc, rms, flank, warned):
    P, _ = _profile(DEFAULT, 0.0)
    seg = dataclasses.replace(_segment(P), index=8)
    _with_edge(monkeypatch, arc_points=arc, rms=rms, flank_rms=flank)
    m = pm.measure_section(seg)
    # the edge is round: judged (when warned), no ellipse nor flat fits the scatter claimed better
    assert m.le_fit == {"arc_points": arc, "flank_points": m.le_fit["flank_points"], "rms": rms,
                        "flank_rms": None if np.isnan(flank) else flank, "shape": "irregular" if warned else "circle"}
    want = tuple(f"section 8: the {n} is not a circle: its arc points scatter {rms * 1000:.1f} µm rms about the fitted "
                 f"circle against {flank * 1000:.1f} µm on the flanks (an elliptic, square or damaged edge?)"
                 for n in ("leading edge", "trailing edge")) if warned else ()
    assert m.warnings == want
    if rms == 0.3 and warned:
        assert "scatter 300.0 µm rms" in m.warnings[0] and "against 70.0 µm" in m.warnings[0]


@pytest.mark.parametrize("arc", [0, 1, 2])
def test_arc_point_warnings_by_count(monkeypatch, arc):
    P, _ = _profile(DEFAULT, 0.0)
    seg = _segment(P)
    _with_edge(monkeypatch, arc_points=arc)
    m = pm.measure_section(seg)
    assert m.le_fit_points == arc and m.te_fit_points == arc
    if arc == 0:
        assert len(m.warnings) == 2 and all(re.fullmatch(
            r"section 0: no measured point lies on the (leading|trailing) edge's arc: its radius is that of the "
            r"largest circle tangent to both flanks that the points allow \(an upper bound; the chord end as "
            r"uncertain\): measure points round the edge", w) for w in m.warnings)
    elif arc == 1:
        assert m.warnings == tuple(f"section 0: the {n} radius rests on 1 measured point on its arc and the flanks' "
                                   "tangency: measure more points round the edge" for n in ("leading edge", "trailing edge"))
    else:
        assert m.warnings == ()


# --------------------------------------------------------------------------- second round
def test_every_inscribed_circle_touches_the_sampled_suction_side():
    """The root of dist(p + r n, S) − r to round-off: S the suction side sampled at 2.5 times
    the stations (the documented sampling, rebuilt here), distances by a fresh KD-tree."""
    from bladerecon.core.geometry.bspline import evaluate_curve
    seg = _segment(_profile(DEFAULT, 0.0, n=400)[0])
    for stations in (300, 800):
        c, r = pm.inscribed_circles(seg, stations)
        S = evaluate_curve(seg.curve, pm._side_parameters(seg, SUCTION, int(2.5 * stations)))
        d = cKDTree(S).query(c)[0]
        # converged to round-off at nearly every station; a few stop within the 1e-7 mm step where the
        # nearest sample changes (seen: 2e-7 mm)
        assert np.median(np.abs(d - r)) < 1e-12 and np.quantile(np.abs(d - r), 0.9) < 1e-10, stations
        assert np.abs(d - r).max() < 1e-6, stations


def test_ten_inscribed_circles_are_enough_and_nine_are_not():
    seg = _segment(_profile(DEFAULT, 0.0, n=400)[0])
    c, r = pm.inscribed_circles(seg, 10)
    assert len(c) == 10 and len(r) == 10
    with pytest.raises(BladeReconError, match=r"^section 0: no inscribed circles found"):
        pm.inscribed_circles(seg, 9)


@pytest.mark.parametrize("at_le", [True, False])
def test_metal_angle_fits_the_camber_points_within_15_percent_of_the_chord(at_le):
    """A cubic camber line (the fit's window shows): np.polyfit over exactly the points with
    x ≤ 0.15 L (LE) or x ≥ 0.85 L (TE), boundary points included, is the referee."""
    L = 10.0
    seg = SimpleNamespace(le=np.zeros(2), te=np.array([L, 0.0]), chord=L)
    x = np.r_[0.2, 0.6, 1.0, 1.5, np.linspace(2.0, 8.0, 13), 8.5, 9.0, 9.4, 9.8]
    y = 0.004 * x ** 3 - 0.05 * x ** 2 + 0.3 * x
    c = np.column_stack([x, y])
    w = (x <= 1.5) if at_le else (x >= 8.5)
    assert w.sum() == 4                                      # exactly the fit's least
    x0 = 0.4 if at_le else 9.6
    want = np.degrees(np.arctan(np.polyval(np.polyder(np.polyfit(x[w], y[w], 2)), x0)))
    assert pm._metal_angle(seg, c, at_le, np.array([x0, 0.3])) == pytest.approx(want, abs=1e-9)


def test_a_tied_vote_keeps_the_first_sections_end():
    """Two sections, the first mirrored: one says its LE is the blunter end, one the sharper: no majority."""
    secs = _blade(hs=(0.0, 0.5))
    first = secs[0] * np.array([-1.0, 1.0, 1.0]) + np.array([secs[0][:, 0].max() + secs[0][:, 0].min(), 0.0, 0.0])
    bs = pm.segment_blade([first, secs[1]], Z)
    assert [_le_end(s) for s in bs.sections] == [1, 1]


def test_failed_edges_fall_back_to_the_segmentations_ends_in_their_place(monkeypatch):
    P, _ = _profile(DEFAULT, 0.0)
    seg = _segment(P)
    monkeypatch.setattr(pm, "_edge_circle", lambda *a: None)
    m = pm.measure_section(seg, strict_radius=False)
    assert np.allclose(m.le_center, seg.lift(seg.le)[0], atol=1e-12)
    assert np.allclose(m.te_center, seg.lift(seg.te)[0], atol=1e-12)
    assert m.le_fit is None and m.te_fit is None
    # the figures that do not need the circles are still those of the section
    assert abs(m.max_thickness - DEFAULT.section_laws(0.0).max_thickness) < 1e-3


def _sparse_flank_section(placed=(2.0, 4.0, 7.0, 11.0, 16.0, 23.0, 27.0)):
    """The hub section, 600 points, with the points from 0.3 to 30 mm behind the LE (the LE arc's
    joints are at 0.46 and 1.04 mm) replaced by seven on each flank, at x = 2, 4, 7, 11, 16, 23 and
    27 mm: five of them within the 35 % window (19.6 mm behind the touching point), seven within
    the 50 % one. Returns the points and, per
    flank (pressure, suction), which of them lie on it within 30 mm of the LE."""
    B, h = DEFAULT, 0.0
    tr = _truth(B, h)
    b = B.segment_bounds(h)
    P, t = _profile(B, h)
    x = (P - tr.le) @ tr.u
    tt = np.arange(200000) / 200000
    xd = (B.point(h, tt) - tr.le) @ tr.u
    extra = []
    both = placed if isinstance(placed[0], tuple) else (placed, placed)       # (pressure, suction)
    for (lo, hi), xs in zip(((b[1], b[2]), (b[3], b[4])), both):
        s = (tt >= lo) & (tt < hi)
        extra += [tt[s][np.argmin(np.abs(xd[s] - xx))] for xx in xs]
    T = np.sort(np.r_[t[~((x > 0.3) & (x < 30.0))], extra])
    Q = B.point(h, T)
    xq = (Q - tr.le) @ tr.u
    flanks = [(T >= lo) & (T < hi) & (xq < 30.0) for lo, hi in ((b[1], b[2]), (b[3], b[4]))]
    return Q, flanks


def test_a_flank_with_five_points_in_its_window_keeps_it_and_its_noise_is_the_far_halfs_residual():
    """Five points in the 35 % window are enough (none from the 50 % one); the flank rms is the rms
    of the residuals of each flank's polynomial (degree by count: 2 for five, 3 for six or more)
    over the far half of its window, scaled by √(n / (n − coefficients)): np.polyfit in the edge
    circle's own frame (its axis) is the referee, to 1e-9 mm."""
    Q, flanks = _sparse_flank_section()
    seg = _segment(Q)
    m = pm.measure_section(seg)
    assert abs(m.le_radius / 0.9 - 1) < 0.02          # quadratic flanks from 2 to 16 mm: 1 % (measured)
    ec = pm._edge_circle(seg, LE, *pm.inscribed_circles(seg))
    q2 = seg.frame.to_plane(Q)
    ay = np.array([-ec.axis[1], ec.axis[0]])
    win = []
    for f in flanks:
        Xf, Yf = q2[f] @ ec.axis, q2[f] @ ay
        inside = Xf <= Xf.min() + 20.0                      # the points within the 35 % window
        win.append((Xf[inside], Yf[inside]))
    counts = sorted(len(w[0]) for w in win)
    assert counts == [5, 5] and list(ec.flank_points) == counts and m.le_fit["flank_points"] == list(ec.flank_points)
    sq = []
    for Xf, Yf in win:
        deg = 3 if len(Xf) >= 6 else 2
        res = np.polyval(np.polyfit(Xf, Yf, deg), Xf) - Yf
        far = Xf >= np.median(Xf)
        sq.append(res[far] * np.sqrt(len(Xf) / (len(Xf) - deg - 1)))
    want = float(np.sqrt(np.mean(np.concatenate(sq) ** 2)))
    assert ec.flank_rms == pytest.approx(want, abs=1e-9) and m.le_fit["flank_rms"] == pytest.approx(want, abs=1e-9)


def test_a_flank_with_four_points_in_its_window_takes_the_wider_one():
    """Four placed points within the 35 % window (3, 8, 13, 18 mm; it ends 19.6 mm behind the
    touching point, at 20.1 to 20.6 mm), one more within the 50 % one (24 mm; it ends at 28.5 mm),
    the measured points again from 30 mm: each flank model takes the five of the 50 % window."""
    Q, _ = _sparse_flank_section((3.0, 8.0, 13.0, 18.0, 24.0))
    m = pm.measure_section(_segment(Q))
    assert m.le_fit["flank_points"] == [5, 5]
    assert abs(m.le_radius / 0.9 - 1) < 0.05          # quadratic flanks from 3 to 24 mm: 3 % (measured)


def test_the_loop_for_area_and_widths_is_the_segmentations_table_or_the_same_samples_anew():
    """Area and centroid from the segmentation's 8000-sample table (shoelace here, to round-off);
    without the table the curve is sampled anew at the same 8000 parameters: the same figures."""
    P, _ = _profile(DEFAULT, 0.0)
    seg = _segment(P)
    m = pm.measure_section(seg, (3.0,))
    assert seg.table is not None and len(seg.table[1]) == 8000
    area, cen = _polygon_area_centroid(seg.table[1])
    assert m.gauges["area"] == pytest.approx(abs(area), rel=1e-12)
    assert np.allclose(m.gauges["centroid"], seg.lift(cen)[0], atol=1e-10)
    m2 = pm.measure_section(dataclasses.replace(seg, table=None), (3.0,))
    assert m2.gauges["area"] == pytest.approx(m.gauges["area"], rel=1e-12)
    assert m2.gauges["thickness_at_chord_normal"]["le+3"] == pytest.approx(m.gauges["thickness_at_chord_normal"]["le+3"],
                                                                         abs=1e-10)


def test_a_point_at_the_centre_of_curvature_of_a_flanks_vertex_has_its_foot_at_the_vertex():
    """y = x² seen from (0, 0.5), its vertex's centre of curvature: Newton's derivative vanishes
    there (a triple root); the foot stays at the vertex, the distance is the radius 0.5 exactly."""
    x = np.linspace(-1.0, 1.0, 5)
    model = pm._flank_model(x, x ** 2)
    d, lev, foot = pm._foot_on_flank(np.array([0.0, 0.5]), model)
    assert abs(d - 0.5) < 1e-12 and np.allclose(foot, 0.0, atol=1e-12)


def test_the_stations_kept_are_those_between_half_a_percent_and_99_5_percent_of_the_chord():
    """Every pressure-side station (the documented equal steps of the side) whose point lies within
    0.5 %..99.5 % of the chord gives one circle on this clean section, no other does."""
    from bladerecon.core.geometry.bspline import evaluate_curve
    seg = _segment(_profile(DEFAULT, 0.0, n=400)[0])
    for stations in (300, 800):
        p = evaluate_curve(seg.curve, pm._side_parameters(seg, PRESSURE, stations))
        x = (p - seg.le) @ ((seg.te - seg.le) / seg.chord)
        keep = (x > 0.005 * seg.chord) & (x < 0.995 * seg.chord)
        assert 0 < keep.sum() < stations
        c, r = pm.inscribed_circles(seg, stations)
        assert len(c) == keep.sum(), stations


def test_a_circle_centre_outside_the_loop_is_dropped(monkeypatch):
    seg = _segment(_profile(DEFAULT, 0.0, n=400)[0])
    c0, r0 = pm.inscribed_circles(seg, 300)
    real = pm._inside

    def inside(pts, loop):
        out = real(pts, loop)
        return out & (np.arange(len(out)) % 3 != 0)              # every third centre "outside"
    monkeypatch.setattr(pm, "_inside", inside)
    c, r = pm.inscribed_circles(seg, 300)
    assert len(c) == len(c0) - (len(c0) + 2) // 3
    assert np.isin(c[:, 0], c0[:, 0]).all()


def _lens(b, n=200):
    """A symmetric lens (n, 3): two circular arcs through (±10, 0) and (0, ±b), sharp ends."""
    R = (100 + b * b) / (2 * b)
    a = np.arcsin(10 / R)
    t = np.linspace(-a, a, n, endpoint=False)
    up = np.column_stack([R * np.sin(t), b - R + R * np.cos(t)])[::-1]
    lo = np.column_stack([R * np.sin(t), -(b - R + R * np.cos(t))])
    return np.column_stack([np.vstack([lo, up]), np.zeros(2 * n)])


def test_no_inscribed_circle_larger_than_a_quarter_chord():
    """A lens 11 mm thick on a 20 mm chord: its middle circles (radius up to 5.5 mm) are no blade's
    and are left out; a 6 mm lens keeps them all."""
    seg = _segment(_lens(5.5))
    c, r = pm.inscribed_circles(seg, 400)
    assert r.max() < 0.25 * seg.chord and len(c) < 300
    seg = _segment(_lens(3.0))
    c, r = pm.inscribed_circles(seg, 400)
    assert abs(r.max() - 3.0) < 1e-3 and len(c) > 380


def test_a_small_section_measures_to_scale():
    """The hub section shrunk 20 times (chord 2.8 mm, area 0.5 mm²): the figures shrink with it."""
    P, _ = _profile(DEFAULT, 0.0)
    big = pm.measure_section(_segment(P))
    small = pm.measure_section(_segment(0.05 * P))
    assert small.gauges["area"] < 1.0
    for key in ("chord", "max_thickness", "le_radius", "te_radius", "max_thickness_pos"):
        assert getattr(small, key) == pytest.approx(0.05 * getattr(big, key), rel=1e-3), key
    for key in ("stagger_deg", "inlet_angle_deg", "outlet_angle_deg"):
        assert getattr(small, key) == pytest.approx(getattr(big, key), abs=0.01), key


def test_edge_circle_fit_from_a_far_start_still_meets_the_circle():
    """The exact arc and flanks of the first edge-circle test, started 0.5 mm and 0.3 mm in radius
    away (farther, the flanks' feet jump to other branches): the circle to 1e-9 mm."""
    pa, flanks = _exact_edge()
    for start in ([1.5, 0.5, 0.5], [0.6, -0.1, 1.1]):
        assert np.allclose(pm._fit_edge_circle(pa, flanks, np.array(start)), [1.0, 0.2, 0.8], atol=1e-9), start


@pytest.mark.parametrize("region", [LE, TE])
def test_edge_frame_axis_is_the_quadratic_camber_fit_within_15_percent(region):
    """The edge circle's axis: the tangent of np.polyfit(…, 2) over the camber points within 15 % of
    the chord from the edge (at least 4; else the 8 nearest), at x = the frontmost circle's radius,
    pointing into the blade. All the camber points, exactly four in the window, and three (the 8
    nearest then) against that referee to 1e-12."""
    seg = _segment(_profile(DEFAULT, 0.0, n=400)[0])
    cam, rad = pm.inscribed_circles(seg, 300)
    u = (seg.te - seg.le) / seg.chord
    e, d0 = (seg.le, u) if region == LE else (seg.te, -u)
    perp = np.array([-d0[1], d0[0]])
    xc, yc = (cam - e) @ d0, (cam - e) @ perp
    win = np.flatnonzero(xc <= 0.15 * seg.chord)
    for keep_in_window in (None, 4, 3):
        sel = np.ones(len(cam), bool)
        if keep_in_window is not None:
            sel[win] = False
            sel[win[np.argsort(xc[win])][:keep_in_window]] = True
        near = (xc[sel] <= 0.15 * seg.chord) if keep_in_window != 3 else np.argsort(xc[sel])[:8]
        slope = np.polyval(np.polyder(np.polyfit(xc[sel][near], yc[sel][near], 2)), rad[sel][np.argmin(xc[sel])])
        want = (d0 + slope * perp) / np.hypot(1.0, slope)
        ec = pm._edge_circle(seg, region, cam[sel], rad[sel])
        assert np.allclose(ec.axis, want, atol=1e-12, rtol=0), keep_in_window


def test_a_flank_of_two_points_sets_its_line_but_no_noise():
    """Two placed points on one flank (3 and 24 mm, the measured points again from 30 mm; the gap
    limit raised), five on the other: the line through two points says nothing of the noise, the
    flank rms is the other flank's alone (as in the five-point test); with two on both, None."""
    for placed, want in ((((3.0, 24.0), (2.0, 4.0, 7.0, 11.0, 16.0, 23.0, 27.0)), 2),
                         (((2.0, 4.0, 7.0, 11.0, 16.0, 23.0, 27.0), (3.0, 24.0)), 2), ((3.0, 24.0), None)):
        Q, _ = _sparse_flank_section(placed)
        seg = pm.segment_blade([Q], Z, flow=X, max_gap=50.0).sections[0]
        m = pm.measure_section(seg)
        assert sorted(m.le_fit["flank_points"]) == ([2, 5] if want else [2, 2]), placed
        assert (m.le_fit["flank_rms"] is None) == (want is None), placed
        if want:
            assert 0 < m.le_fit["flank_rms"] < 0.01


@pytest.mark.parametrize("bad", ["zero", "half_chord", "0.6_chord", "nan", "negative"])
def test_an_edge_circle_not_between_zero_and_half_the_chord_is_no_circle(monkeypatch, bad):
    seg = _segment(_profile(DEFAULT, 0.0, n=400)[0])
    cam, rad = pm.inscribed_circles(seg, 300)
    L = seg.chord
    r = {"zero": 0.0, "half_chord": 0.5 * L, "0.6_chord": 0.6 * L, "nan": float("nan"), "negative": -0.9}[bad]
    def forced(pa, flanks, z, report=False):
        z = np.array([z[0], z[1], r])
        return (z, True) if report else z
    monkeypatch.setattr(pm, "_fit_edge_circle", forced)
    assert pm._edge_circle(seg, LE, cam, rad) is None


def test_the_arc_rms_is_that_of_the_arc_points_a_quarter_radius_ahead_of_the_centre():
    """The stadium's elliptic LE (its points known by construction): the rms of |p − c| − r over
    the ellipse's points more than r/4 ahead of the fitted centre along the edge axis, to 1e-12."""
    P = _stadium(0.0)
    seg = _segment(P)
    cam, rad = pm.inscribed_circles(seg)
    ec = pm._edge_circle(seg, LE, cam, rad)
    q = seg.frame.to_plane(P)
    on_ellipse = P[:, 0] < 1.2                               # the LE piece: x < a
    ahead = on_ellipse & ((q - ec.centre) @ ec.axis <= -0.25 * ec.radius)
    assert 20 < ahead.sum() < on_ellipse.sum()
    res = np.linalg.norm(q[ahead] - ec.centre, axis=1) - ec.radius
    assert ec.rms == pytest.approx(float(np.sqrt(np.mean(res ** 2))), rel=1e-9, abs=1e-15)
    assert ec.rms > 0.01                                     # an ellipse: far from its best circle


def test_thickness_is_given_from_the_first_to_the_last_circle_centre():
    """Offsets and fractions between the first two and the last two circle centres along the chord
    get a thickness (interpolated), not None."""
    P, _ = _profile(DEFAULT, 0.0, n=400)
    seg = _segment(P)
    m = pm.measure_section(seg)
    le2, te2 = seg.frame.to_plane(m.le[None])[0], seg.frame.to_plane(m.te[None])[0]
    chord2 = float(np.linalg.norm(te2 - le2))
    x = np.sort((seg.frame.to_plane(m.camber) - le2) @ ((te2 - le2) / chord2))
    gaps = [(x[0] + x[1]) / 2, (x[-2] + x[-1]) / 2]
    assert x[1] - x[0] > 1e-9 and x[-1] - x[-2] > 1e-9
    lo, hi = gaps[0], chord2 - gaps[1]
    m2 = pm.measure_section(seg, (lo, hi), fractions=(gaps[0] / chord2, gaps[1] / chord2))
    assert m2.thickness_at[f"le+{lo:g}"] is not None and m2.thickness_at[f"te+{hi:g}"] is not None
    assert all(v is not None for v in m2.gauges["thickness_at_fraction"].values())


@pytest.mark.parametrize("normal", [(-0.8, 0.0, 0.6), (0.0, -0.8, 0.6)])
def test_canonical_loop_of_a_tilted_section_runs_counter_clockwise_about_plus_z(normal):
    """A circle in a plane tilted 53° from z (normal n, n·z = 0.6 > 0.2): the default axis is +z, so
    the loop runs counter-clockwise seen from +z (positive area of its xy projection)."""
    n = np.array(normal)
    e1 = np.cross(n, [0.0, 1.0, 0.0] if abs(n[1]) < 0.5 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    th = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    P = 5.0 * (np.outer(np.cos(th), e1) + np.outer(np.sin(th), e2))
    for Q in (P, P[::-1]):
        out = pm.canonical_loop(Q)
        assert _polygon_area_centroid(out[:, :2])[0] > 0


def test_nearest_with_a_hint_is_the_trees_answer():
    """The bounded search of the inscribed circles (issue 24's time) answers as the full one,
    from good hints (a neighbour a step before) and poor ones alike."""
    from scipy.spatial import cKDTree

    rng = np.random.default_rng(5)
    t = np.sort(rng.random(1500)) * 2 * np.pi
    pts = np.column_stack([20 * np.cos(t), 1.5 * np.sin(t)])
    tree = cKDTree(pts, compact_nodes=False)
    q = rng.normal(scale=[15.0, 1.0], size=(600, 2))
    d_ref, i_ref = tree.query(q)
    for hint in (i_ref, tree.query(q + 0.01)[1], rng.integers(0, 1500, 600)):
        d, i = pm._nearest(tree, pts, q, hint)
        assert np.array_equal(d, d_ref) and np.array_equal(i, i_ref)
