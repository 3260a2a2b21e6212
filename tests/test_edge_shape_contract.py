# SPDX-License-Identifier: LGPL-2.1-or-later
"""The contract of ``core/sections/edge_shape.py`` and its helpers, judged by referees the code
does not share: exact ellipses (points, outward normals, feet), straight lines and flats of known
ends, width, direction and normal, circular arcs of known curvature, and brute force (the support
function of an ellipse as the maximum over a fine sampling). Fast (about a second): ``make
mutation`` runs it per mutant before ``tests/test_edge_shape.py``.

Frames: ``st`` is the edge frame of the module (s along the camber line into the blade from the
edge circle's centre, t across; the tip at s < 0); an ellipse is z = (cs, ct, a, b, θ).
Unless said otherwise the points are exact: the tolerances are round-off (1e-9 mm; 1e-7 for ellipse
fits, see _close; far under any figure a mutation of the code changes), or the sampling step where a length is counted in points.
"""
from __future__ import annotations

import numpy as np
import pytest

from bladerecon.core.sections import edge_shape as es


# -- closed forms ---------------------------------------------------------------------------------

def ell_point(z, e):
    """Points of the ellipse z at eccentric anomalies e."""
    cs, ct, a, b, th = z
    c, s = np.cos(th), np.sin(th)
    x, y = a * np.cos(e), b * np.sin(e)
    return np.column_stack([cs + c * x - s * y, ct + s * x + c * y])


def ell_normal(z, e):
    """Outward unit normals of the ellipse z at e (the gradient of (x/a)² + (y/b)²)."""
    _, _, a, b, th = z
    c, s = np.cos(th), np.sin(th)
    gx, gy = np.cos(e) / a, np.sin(e) / b
    g = np.column_stack([c * gx - s * gy, s * gx + c * gy])
    return g / np.linalg.norm(g, axis=1, keepdims=True)


def axes(th):
    e1 = np.array([np.cos(th), np.sin(th)])
    return e1, np.array([-e1[1], e1[0]])


def ellipse_edge(z, n_front=41, flank_len=3.0, n_flank=60):
    """An elliptic edge in the edge frame: the ellipse ahead of its minor axis, then straight flanks
    tangent to it at the minor axis' ends (parallel to the major axis). No flank point lies ahead of
    the centre's s (the window of the fit holds ellipse points only)."""
    cs, ct, a, b, th = z
    e1, e2 = axes(th)
    e = np.linspace(np.pi / 2, 3 * np.pi / 2, n_front + 2)[1:-1]
    start = abs(b * np.tan(th)) + 0.05
    along = np.linspace(start, flank_len, n_flank)
    c = np.array([cs, ct])
    top = c + along[:, None] * e1 + b * e2
    bottom = c + along[:, None] * e1 - b * e2
    return np.vstack([bottom[::-1], ell_point(z, e[::-1]), top])      # one loop: lower flank, tip, upper flank


def flat_edge(c1=(0.0, -0.5), c2=(0.0, 0.5), slopes=(-0.15, 0.1), kink=1.75, depths=None, step=0.02):
    """A blunt edge in the edge frame, its loop in order: the lower flank (from behind up to the
    corner c1), the flat c1 -> c2 on s = c1[0] (sharp corners), the upper flank back from c2. Each
    flank is straight, t' = slope·s', down to depth ``kink`` behind the flat, then turns outward
    at 45°; ``depths`` (the flank points' depths) when given, else every ``step``."""
    c1, c2 = np.asarray(c1, float), np.asarray(c2, float)
    flat = np.column_stack([np.full(int(round((c2[1] - c1[1]) / step)) + 1, c1[0]),
                            np.linspace(c1[1], c2[1], int(round((c2[1] - c1[1]) / step)) + 1)])
    dep = np.arange(step, 3.5, step) if depths is None else np.asarray(depths, float)

    def flank(c, slope, sign):
        straight = np.minimum(dep, kink)
        beyond = np.maximum(dep - kink, 0.0)
        return c + np.column_stack([dep, slope * straight + sign * beyond])

    lower = flank(c1, slopes[0], -1.0)[::-1]
    upper = flank(c2, slopes[1], 1.0)
    return np.vstack([lower, flat, upper]), len(lower), len(flat)


def to_plane(st, centre, axis):
    axis = np.asarray(axis, float)
    perp = np.array([-axis[1], axis[0]])
    st = np.asarray(st, float)
    return centre + st[..., :1] * axis + st[..., 1:2] * perp


# -- _tls_line ------------------------------------------------------------------------------------

def test_tls_line_point_direction_and_rms():
    """Pairs of points ±δ off a known line at the same abscissae: the centroid lies on the line,
    the principal direction is the line's, and the rms distance is δ exactly."""
    m0, ang, delta = np.array([0.3, -0.2]), 0.7, 0.01
    d0 = np.array([np.cos(ang), np.sin(ang)])
    n0 = np.array([-d0[1], d0[0]])
    along = np.linspace(-1.0, 1.0, 9)
    P = np.vstack([m0 + along[:, None] * d0 + delta * n0, m0 + along[:, None] * d0 - delta * n0])
    m, d, rms = es._tls_line(P)
    assert np.allclose(m, m0, atol=1e-12)
    assert abs(abs(d @ d0) - 1.0) < 1e-12
    assert abs(rms - delta) < 1e-12


# -- _ellipse_distance and _ellipse_residuals -------------------------------------------------------

ELLIPSES = [(0.3, -0.1, 1.2, 0.4, 0.35), (-0.2, 0.5, 2.0, 0.5, -1.2), (0.0, 0.0, 0.6, 0.58, 2.9)]


@pytest.mark.parametrize("z, deltas, k, shift", [
    *[(z, (1e-3, 0.1, 1.0, 5.0, -0.5, -0.95), 37, 0.05) for z in ELLIPSES],
    ((0.1, 0.2, 3.0, 0.3, 0.4), (1e-3, 0.1, 1.0, 5.0, 18.0, -0.5), 361, 0.05),    # slender (10:1), far points
    ((0.0, 0.0, 1.2, 0.42, 0.0), (-0.97,), 721, 0.003),                           # deep inside, by the tips
])
def test_ellipse_distance_is_the_signed_distance_to_the_foot(z, deltas, k, shift):
    """A point δ along the outward normal from a foot is |δ| from the ellipse, outside (δ > 0)
    for any δ (the ellipse is convex) and inside for δ < 0 up to the smallest radius of curvature
    ρ = b²/a (a disk of that radius touching from inside stays inside: Blaschke's rolling theorem);
    the negative δ are given in units of ρ. The bisection ends where float64 stops halving the
    bracket: 1e-9 mm is round-off."""
    _, _, a, b, _ = z
    e = np.linspace(0.0, 2 * np.pi, k)[:-1] + shift
    foot, nrm = ell_point(z, e), ell_normal(z, e)
    rho = min(a, b) ** 2 / max(a, b)
    for delta in deltas:
        delta = delta * rho if delta < 0 else delta
        d = es._ellipse_distance(np.array(z), foot + delta * nrm)
        assert np.allclose(d, delta, atol=1e-9), (delta, np.abs(d - delta).max())


@pytest.mark.parametrize("z", [*ELLIPSES, (0.1, 0.2, 3.0, 0.3, 0.4), (0.0, 0.0, 10.0, 0.1, 1.0),
                               (0.3, -0.1, 0.4, 1.2, 0.35), (0.0, 0.0, 1.0, 1.0, 0.0)])
def test_ellipse_distance_anywhere_against_brute_force(z):
    """Points anywhere, deep inside slender ellipses (10:1, 100:1) and on their axes too, against
    a search that shares nothing with the code: the nearest of 20 000 points of the ellipse, then
    a golden-section search of |P − E(e)| over the two sample spans round it (70 steps shrink the
    bracket 0.618⁷⁰ ~ 1e-15 times: the minimum to round-off). A farther foot, a wrong branch or a
    lost digit off the axis fails by far more than the 1e-9 mm allowed; the sign from the
    implicit equation (inside: negative)."""
    cs, ct, a, b, th = z
    big, small = max(a, b), min(a, b)
    rng = np.random.default_rng(7)
    centre = np.array([cs, ct])
    P = np.vstack([centre + rng.uniform(-1.3, 1.3, (1000, 2)) * big,
                   centre + rng.uniform(-0.3, 0.3, (1000, 2)) * small,                    # by the centre
                   0.5 * ell_point(z, np.array([0.0, 0.5 * np.pi, np.pi])) + 0.5 * centre])  # on the axes
    n = 20_000
    e = np.linspace(0.0, 2 * np.pi, n + 1)[:-1]
    E = ell_point(z, e)
    best = np.concatenate([np.argmin(((P[k:k + 500, None, :] - E[None]) ** 2).sum(-1), axis=1)
                           for k in range(0, len(P), 500)])
    lo, hi = e[best] - 2 * np.pi / n, e[best] + 2 * np.pi / n
    far = lambda t: np.hypot(*(P - ell_point(z, t)).T)                                 # noqa: E731
    g = (np.sqrt(5.0) - 1.0) / 2.0
    for _ in range(70):
        m1, m2 = hi - g * (hi - lo), lo + g * (hi - lo)
        left = far(m1) < far(m2)
        lo, hi = np.where(left, lo, m1), np.where(left, m2, hi)
    truth = far(0.5 * (lo + hi))
    c, s = np.cos(th), np.sin(th)
    u, v = c * (P[:, 0] - cs) + s * (P[:, 1] - ct), -s * (P[:, 0] - cs) + c * (P[:, 1] - ct)
    inside = (u / a) ** 2 + (v / b) ** 2 < 1.0
    d = es._ellipse_distance(np.array(z), P)
    assert np.abs(np.abs(d) - truth).max() < 1e-9
    assert np.array_equal(d < 0, inside)


@pytest.mark.parametrize("z", ELLIPSES)
def test_ellipse_residuals_sampson_distance_and_tangency(z):
    """Sampson distances: zero on the ellipse, δ to first order at δ along the normal (its error
    is second order, under 10·δ²·a/b² with a/b² the largest curvature); each flank line's entry is
    w × (its offset − the ellipse's support function along its normal), the support function
    taken by brute force (the maximum of n·p over 400 000 points of the ellipse: its error is
    under (a·2π/4e5)²·a/b² ~ 1e-9 mm)."""
    _, _, a, b, _ = z
    e = np.linspace(0.0, 2 * np.pi, 25)[:-1] + 0.1
    foot, nrm = ell_point(z, e), ell_normal(z, e)
    zz = np.array(z, float)
    assert np.abs(es._ellipse_residuals(zz, foot)).max() < 1e-12
    kmax = max(a, b) / min(a, b) ** 2
    for delta in (1e-5, -1e-5):
        res = es._ellipse_residuals(zz, foot + delta * nrm)
        assert np.abs(res - delta).max() <= 10 * delta ** 2 * kmax, np.abs(res - delta).max()
    dense = ell_point(z, np.linspace(0.0, 2 * np.pi, 400_000, endpoint=False))
    lines = []
    for psi, off, w in ((0.3, 0.02, 2.0), (2.0, -0.05, 1.5), (-1.1, 0.0, 3.0), (3.6, 0.1, 1.0)):
        n = np.array([np.cos(psi), np.sin(psi)])
        lines.append((n, float((dense @ n).max()) + off, w))
    res = es._ellipse_residuals(zz, foot[:3], lines)
    assert len(res) == 3 + len(lines)
    want = [w * off for (_, _, w), off in zip(lines, (0.02, -0.05, 0.0, 0.1))]
    assert np.allclose(res[3:], want, atol=1e-8), (res[3:], want)


# -- _flank_lines ---------------------------------------------------------------------------------

def _flank_cloud(n_lower=3):
    z = np.array([0.2, 0.1, 1.0, 0.4, 0.3])
    e1, e2 = axes(z[4])
    c = z[:2]
    up_along = np.linspace(0.1, 0.9, 7)
    upper = c + up_along[:, None] * e1 + (0.45 + 0.1 * up_along)[:, None] * e2
    lo_along = np.linspace(0.2, 0.8, n_lower)
    lower = c + lo_along[:, None] * e1 - (0.4 + 0.05 * lo_along)[:, None] * e2
    # outside the window (ahead of the minor axis, or beyond one major semi-axis behind it): not
    # on these lines, so a line fitted to them would come out different
    other = np.vstack([ell_point(z, np.linspace(2.0, 4.3, 9)),
                       c + np.array([1.2, 1.6, 2.0])[:, None] * e1 + 0.9 * e2,
                       c + np.array([1.3, 1.8])[:, None] * e1 - 0.2 * e2])
    return z, np.vstack([other[:4], upper, other[4:9], lower, other[9:]]), upper, lower


def test_flank_lines_are_the_flanks_beside_the_ellipse():
    """On a tilted ellipse: each flank's points between the minor axis and one major semi-axis
    behind it (7 above the major axis, 3 below) on a known line: its outward normal (away from
    the major axis), offset n·p and weight √points, the upper side first."""
    z, st, upper, lower = _flank_cloud()
    e1, e2 = axes(z[4])
    out = es._flank_lines(st, z)
    assert len(out) == 2
    for (n, off, w), pts, side in zip(out, (upper, lower), (1.0, -1.0)):
        d = pts[-1] - pts[0]
        d = d / np.linalg.norm(d)
        want = np.array([-d[1], d[0]])
        want = want if want @ e2 * side > 0 else -want
        assert np.allclose(n, want, atol=1e-12), (n, want)
        assert abs(off - want @ pts[0]) < 1e-12
        assert abs(w - np.sqrt(len(pts))) < 1e-12


def test_flank_lines_need_three_points_a_side():
    z, st, _, _ = _flank_cloud(n_lower=2)
    assert es._flank_lines(st, z) == []


# -- find_flat ------------------------------------------------------------------------------------

def _line_points(phi_deg, along, m0=(0.0, 0.0)):
    """Points of a flat whose outward normal is phi from -s: n = (-cos φ, sin φ), direction
    (sin φ, cos φ) (along +t)."""
    p = np.radians(phi_deg)
    d = np.array([np.sin(p), np.cos(p)])
    n = np.array([-np.cos(p), np.sin(p)])
    return np.asarray(m0) + np.asarray(along)[:, None] * d, d, n


FAR = np.array([[4.0, 1.0], [5.0, 0.0], [4.0, -1.0]])          # more than 3 radii behind: not the edge


@pytest.mark.parametrize("phi", [0.0, 25.0, -40.0, 45.0, -10.0])
@pytest.mark.parametrize("reverse", [False, True])
def test_find_flat_reports_the_flat_of_a_blunt_edge(phi, reverse):
    """A straight flat of known direction and ends among flank points behind it: its point (the
    middle), direction (along +t, whichever way the loop runs), outward normal, points, length and
    ends (in the direction's order)."""
    along = np.linspace(-0.6, 0.5, 56)
    pts, d, n = _line_points(phi, along, m0=(0.1, 0.05))
    # flanks leaving the flat's ends backwards (behind it: depth grows)
    back = np.linspace(0.05, 2.0, 40)[:, None]
    lo = pts[0] + back * np.array([1.0, -0.2])
    hi = pts[-1] + back * np.array([1.0, 0.2])
    st = np.vstack([lo[::-1], pts, hi, FAR])
    index = np.arange(len(lo), len(lo) + len(pts))
    if reverse:
        st, index = st[::-1], len(st) - 1 - index
    f = es.find_flat(st, 0.5, 0.005)
    assert f is not None
    assert f["points"] == len(pts) and sorted(f["index"]) == sorted(index)
    assert np.allclose(f["direction"], d, atol=1e-9) and np.allclose(f["normal"], n, atol=1e-9)
    assert np.allclose(f["point"], pts.mean(axis=0), atol=1e-9)
    assert abs(f["length"] - 1.1) < 1e-9 and f["rms"] < 1e-9
    assert np.allclose(f["ends"][0], pts[0], atol=1e-9) and np.allclose(f["ends"][1], pts[-1], atol=1e-9)


def test_find_flat_three_points_off_the_angle_grid():
    """Three collinear points (the least a flat holds) on a line whose normal (10.1°) lies between
    the 0.25° grid's angles, tol 1.5 µm: the grid's best line holds two of them (at 10.0° the three
    heights differ by sin 0.1° × 0.6 = 1.05 µm each), the line refitted to those two holds the
    third. They are the edge's only points within 3 radii of its front."""
    pts, d, n = _line_points(10.1, [-0.6, 0.0, 0.6])
    f = es.find_flat(np.vstack([pts, FAR]), 1.0, 0.0015)
    assert f is not None and f["points"] == 3
    assert np.allclose(f["direction"], d, atol=1e-9) and abs(f["length"] - 1.2) < 1e-9


def test_find_flat_looks_within_three_radii_of_the_front():
    """A straight flat leaning 50° (normal from -s), 2.5 mm long, radius 0.5: only its points within
    3 radii (1.5 mm) of the foremost one in s are the edge's; its measured length is that window's,
    1.5 / sin 50° (to the 0.01 mm point spacing)."""
    along = np.linspace(-1.25, 1.25, 251)
    pts, d, n = _line_points(50.0, along)
    f = es.find_flat(np.vstack([pts, FAR + [3.0, 0.0]]), 0.5, 0.002)
    assert f is not None
    assert abs(f["length"] - 1.5 / np.sin(np.radians(50.0))) <= 0.0101, f["length"]


@pytest.mark.parametrize("phi_a, is_a", [(60.0, True), (60.75, False), (-60.0, True), (-60.75, False)])
def test_find_flat_searches_normals_within_60_degrees(phi_a, is_a):
    """Two facets of a convex front meeting at the origin: A (151 points over 1.5 mm, its normal
    phi_a from -s) and B (101 points over 1 mm, its normal 90° from A's, on the other side of the
    camber line). The flat is the line most points lie on among normals within ±60° of -s: A at
    ±60°, B when A leans 60.75° (no grid line holds more than 16 of A's points within tol 2 µm:
    at 60° they drop from the tip by sin 0.75° = 13 µm per mm, 0.15 mm of A at 0.01 mm spacing)."""
    pa = np.radians(abs(phi_a))
    da = np.array([np.sin(pa), np.cos(pa)])                      # A: from the origin to +t (and +s)
    db = np.array([np.cos(pa), -np.sin(pa)])                     # B: to -t (and +s), normal 90° from A's
    st = np.vstack([np.linspace(0.0, 1.0, 101)[:0:-1, None] * db, np.linspace(0.0, 1.5, 151)[:, None] * da, FAR])
    if phi_a < 0:                                                # the mirror image across the camber line
        st, da, db = st * [1.0, -1.0], da * [1.0, -1.0], db * [1.0, -1.0]
    f = es.find_flat(st, 0.5, 0.002)
    assert f is not None
    want = (da, 151, 1.5) if is_a else (db, 101, 1.0)
    assert f["points"] == want[1] and abs(f["length"] - want[2]) < 1e-9
    assert abs(abs(f["direction"] @ want[0]) - 1.0) < 1e-9


def test_find_flat_refuses_a_line_that_points_cut():
    """The flat is the profile's outermost line: two points 3.5 tol beyond a straight flat (a burr
    by its lower end) cut it, and there is no flat; 2.5 tol beyond they do not (tol 0.01 mm), and
    the flat is the line's 201 points over 2 mm."""
    pts = np.column_stack([np.zeros(201), np.linspace(-1.0, 1.0, 201)])
    for out, want in ((0.035, None), (0.025, 201)):
        burr = np.array([[-out, -0.955], [-out, -0.945]])
        f = es.find_flat(np.vstack([pts[:5], burr, pts[5:], FAR]), 1.0, 0.01)
        assert (f if f is None else f["points"]) == want
        if f is not None:
            assert abs(f["length"] - 2.0) < 1e-9


def _arc(kappa, half, k):
    """k points of a circular arc of curvature kappa bulging to -s, its chord 2·half long across t."""
    R = 1.0 / kappa
    t = np.linspace(-half, half, k)
    return np.column_stack([R - np.sqrt(R * R - t * t), t])


def test_find_flat_refuses_a_gentle_arc_and_takes_a_straighter_one():
    """The bend test (curvature × radius below 0.3): an arc with κr = 0.35 (radius 2, 4 points over
    2 mm: its sagitta 0.088 mm within tol 0.1 of one line) is no flat; one with κr = 0.25 (radius
    1, 7 points over 1 mm, sagitta 0.031 within tol 0.05) is. A parabola through points of a circle
    gives its curvature within 1 % here (the next term, t²/R² ~ 0.03, is 1 % of the curvature)."""
    assert es.find_flat(np.vstack([_arc(0.175, 1.0, 4), FAR * 2]), 2.0, 0.1) is None
    f = es.find_flat(np.vstack([_arc(0.25, 0.5, 7), FAR]), 1.0, 0.05)
    assert f is not None and f["points"] == 7


def test_find_flat_refuses_a_flat_shorter_than_the_radius():
    pts, _, _ = _line_points(0.0, np.linspace(-0.4, 0.4, 9))
    assert es.find_flat(np.vstack([pts, FAR]), 1.0, 0.01) is None
    pts, _, _ = _line_points(0.0, np.linspace(-0.55, 0.55, 12))
    assert es.find_flat(np.vstack([pts, FAR]), 1.0, 0.01) is not None


@pytest.mark.parametrize("t0, t1, is_flat", [(-0.01, 2.0, True), (0.025, 2.0, False), (-2.0, 0.01, True),
                                              (-2.0, -0.025, False)])
def test_find_flat_must_cross_the_camber_line(t0, t1, is_flat):
    """A flat beside the camber line (t = 0) is a flank, not the edge's flat: it must reach t = 0
    within 2·tol (tol 0.01 mm here: -1 tol and 1 tol reach it, 2.5 tol do not)."""
    pts = np.column_stack([np.zeros(21), np.linspace(t0, t1, 21)])
    f = es.find_flat(np.vstack([pts, FAR]), 1.0, 0.01)
    assert (f is not None) == is_flat


def test_find_flat_tolerance_limit():
    """No flat is looked for when tol exceeds 5 % of the radius (at exactly 5 % it is)."""
    pts, _, _ = _line_points(0.0, np.linspace(-1.0, 1.0, 41))
    assert es.find_flat(np.vstack([pts, FAR]), 0.5, 0.03) is None          # 6 % of 0.5
    assert es.find_flat(np.vstack([pts, FAR * 2]), 2.0, 0.1) is not None   # 5 % of 2.0
    assert es.find_flat(np.vstack([pts, FAR]), 1.0, 0.04) is not None      # 4 % of 1.0


# -- _flat_width ----------------------------------------------------------------------------------

def _width(st, radius=0.5, tol=0.005):
    f = es.find_flat(st, radius, tol)
    assert f is not None
    return es._flat_width(st, f, radius)


@pytest.mark.parametrize("roll", [0, 30, 95])
def test_flat_width_between_the_flank_lines(roll):
    """Straight flanks (slopes -0.15 and 0.1) from sharp corners (0, -0.3) and (0, 0.7), kinked
    outward 45° at 3.5 radii behind the flat: the flank lines fitted between 1 and 3 radii meet the
    flat's line at the corners: width 1.0, midpoint (0, 0.2), whichever point starts the loop."""
    st, _, _ = flat_edge(c1=(0.0, -0.3), c2=(0.0, 0.7))
    width, mid = _width(np.roll(st, roll, axis=0))
    assert width is not None and abs(width - 1.0) < 1e-9
    assert np.allclose(mid, [0.0, 0.2], atol=1e-9)


def test_flat_width_falls_back_to_the_flats_ends():
    """Fewer than 3 flank points between 1 and 3 radii behind the flat (at depths 0.6 and 1.2 of
    radius 0.5): no width; the midpoint of the flat's measured ends, (0, 0.2). With a third point
    there (1.4) the width is measured."""
    st, _, _ = flat_edge(c1=(0.0, -0.3), c2=(0.0, 0.7), depths=[0.2, 0.6, 1.2, 2.0, 3.0])
    width, mid = _width(st)
    assert width is None and np.allclose(mid, [0.0, 0.2], atol=1e-9)
    for depths in ([0.2, 0.6, 1.0, 1.4, 2.0, 3.0], [0.6, 1.0, 1.4, 2.0, 3.0]):    # the first point already deep
        st, _, _ = flat_edge(c1=(0.0, -0.3), c2=(0.0, 0.7), depths=depths)
        width, mid = _width(st)
        assert width is not None and abs(width - 1.0) < 1e-9 and np.allclose(mid, [0.0, 0.2], atol=1e-9)


def test_flat_width_walks_half_the_loop_from_each_end():
    """Each flank's points are found walking the loop from the flat's end, at most half the loop:
    a flat of 3 points, 42 points on the lower flank within a radius of the flat, then 3 between 1
    and 3 radii (0.7, 1.0, 1.3 of 0.5), one deeper; the upper flank likewise with 40: 93 points,
    the walk's 45 steps reach the lower flank's third deep point exactly. Straight flanks through
    the corners (0, ±0.5): width 1.0, midpoint (0, 0)."""
    def flank(c, slope, shallow):
        dep = np.r_[np.linspace(0.01, 0.45, shallow), 0.7, 1.0, 1.3, 2.0]
        return np.asarray(c) + np.column_stack([dep, slope * dep])

    st = np.vstack([flank((0.0, -0.5), -0.15, 42)[::-1], [[0.0, -0.5], [0.0, 0.0], [0.0, 0.5]],
                    flank((0.0, 0.5), 0.1, 40)])
    assert len(st) == 93
    width, mid = _width(st)
    assert width is not None and abs(width - 1.0) < 1e-9 and np.allclose(mid, [0.0, 0.0], atol=1e-9)


def test_flat_width_wider_than_four_radii_is_dropped():
    """Flank lines that meet the flat 2.25 mm apart (4.5 radii of 0.5): not the edge's width; the
    flat's ends' midpoint, (0, 0.025)."""
    st, _, _ = flat_edge(c1=(0.0, -1.1), c2=(0.0, 1.15))
    width, mid = _width(st)
    assert width is None and np.allclose(mid, [0.0, 0.025], atol=1e-9)


# -- _fit_ellipse_window and fit_edge_ellipse -----------------------------------------------------

def _close(z, want, tol=1e-7):
    """Ellipses equal: LM's stop (1e-14 relative steps) on half an ellipse, whose centre and major
    semi-axis it pins down less well than a whole one, leaves a few 1e-9 mm: 1e-7."""
    assert np.allclose(z[:4], want[:4], atol=tol) and abs(np.angle(np.exp(1j * (z[4] - want[4])))) < tol, (z, want)


def test_fit_ellipse_window_recovers_an_exact_ellipse():
    """Exact points of a tilted ellipse ahead of its minor axis, its flanks tangent: from a start 5 %
    off the fit is the ellipse; from the same ellipse written with its axes swapped (θ + 90°) the
    major axis is the one nearer the camber line, θ in [-90°, 90°)."""
    z = np.array([0.4, 0.05, 0.6, 0.25, 0.2])
    st = ellipse_edge(z)
    P = st[(st[:, 0] <= z[0])]
    _close(es._fit_ellipse_window(P, z * 1.05, 0.3, st), z)
    swapped = np.array([z[0], z[1], z[3], z[2], z[4] + np.pi / 2])
    _close(es._fit_ellipse_window(P, swapped, 0.3, P), z)
    six = ell_point(z, np.linspace(2.0, 4.3, 6))
    _close(es._fit_ellipse_window(six, z * 1.05, 0.3, six), z, 1e-6)        # six points: LM's stop ~1e-9
    assert es._fit_ellipse_window(six[:5], z * 1.05, 0.3, six) is None


def test_fit_ellipse_window_refuses_a_negative_semi_axis():
    """The fit only sees a² and |a| (Sampson distance, support function): from a start with a < 0
    it converges to a < 0, which is no ellipse."""
    z = np.array([0.4, 0.05, 0.6, 0.25, 0.2])
    st = ellipse_edge(z)
    P = st[(st[:, 0] <= z[0])]
    start = z * 1.05
    start[2] = -start[2]
    assert es._fit_ellipse_window(P, start, 0.3, st) is None


@pytest.mark.parametrize("z", [(0.7, 0.02, 1.2, 0.5, np.radians(5.0)), (1.0, -0.03, 1.2, 0.5, np.radians(-8.0))])
def test_fit_edge_ellipse_on_an_exact_tilted_edge(z):
    """From the edge circle (centre at the origin, radius 0.4) the window follows the centre to the
    exact ellipse: centre, semi-axes, tilt, the tip at the major axis' front end, rms 0, and the
    points ahead of the centre (s <= cs) counted."""
    z = np.array(z)
    st = ellipse_edge(z)
    assert np.abs(st[:, 0] - z[0]).min() > 1e-6                # no point on the window's edge
    r = es.fit_edge_ellipse(st, 0.4)
    assert r is not None
    _close(np.r_[r["centre"], r["a"], r["b"], r["angle"]], z)
    e1, _ = axes(z[4])
    assert np.allclose(r["tip"], z[:2] - z[2] * e1, atol=1e-9)
    assert r["rms"] < 1e-9 and r["points"] == int(np.sum(st[:, 0] <= z[0]))


def test_fit_edge_ellipse_window_holds_at_least_six_points():
    """Sparse: only 4 points ahead of the centre; the window is the 6 foremost points (all on the
    ellipse, the 6th at s = 0.43), from the first round on: not the two next ones (at s = 0.6, off the
    ellipse), nor those beyond one semi-axis behind it (2 a side at most between: no flank lines)."""
    z = np.array([0.3, 0.0, 0.6, 0.3, 0.0])
    front = ell_point(z, np.array([2.2, 2.8, 3.5, 4.1]))
    behind = ell_point(z, np.array([1.35, 4.8]))
    far = np.array([[0.6, 0.5], [0.6, -0.5], [2.0, 0.3], [2.0, -0.3]])
    st = np.vstack([far[:2], behind[:1], front, behind[1:], far[2:]])
    r = es.fit_edge_ellipse(st, 0.3)
    assert r is not None and r["points"] == 6
    # six points on a quarter of the ellipse pin it down loosely: LM's stop leaves ~1e-9 there
    _close(np.r_[r["centre"], r["a"], r["b"], r["angle"]], z, 1e-6)


@pytest.mark.parametrize("a, b, radius, ok", [(1.2, 0.5, 0.5, True), (0.6, 0.5, 0.5 / 3.5, False),
                                              (2.0, 0.5, 2.0 / 10.5, False), (2.0, 0.5, 2.0 / 9.5, True)])
def test_fit_edge_ellipse_sanity_bounds(a, b, radius, ok):
    """An edge's ellipse is about as wide as its circle (b within 0.3-3 radii) and not too long
    (a at most 10 radii): b = 3.5 r and a = 10.5 r are refused, a = 9.5 r (b = 2.4 r) taken."""
    z = np.array([a - 0.8 * radius, 0.0, a, b, 0.0])
    r = es.fit_edge_ellipse(ellipse_edge(z), radius)
    assert (r is not None) == ok
    if ok:
        _close(np.r_[r["centre"], r["a"], r["b"], r["angle"]], z)


def test_fit_edge_ellipse_refuses_a_tilted_ellipse():
    """A designed edge ellipse lies within 10° of the camber line: an exact one tilted 10.5° is
    refused, one tilted 9.5° taken."""
    for deg, ok in ((10.5, False), (9.5, True)):
        z = np.array([0.7, 0.02, 1.2, 0.5, np.radians(deg)])
        r = es.fit_edge_ellipse(ellipse_edge(z), 0.5)
        assert (r is not None) == ok
        if ok:
            _close(np.r_[r["centre"], r["a"], r["b"], r["angle"]], z)


@pytest.mark.parametrize("ahead, t", [(0.3, 0.0), (0.4, 0.3), (0.5, -0.45)])
def test_fit_edge_ellipse_tip_must_be_the_front(ahead, t):
    """A point 0.3-0.5 mm (0.6-1 radius of 0.5) ahead of an exact ellipse's tip: the ellipse's tip
    is not at the foremost point (one stray point among some 40 on the ellipse leaves the fit near
    it): refused."""
    z = np.array([0.7, 0.0, 1.2, 0.5, 0.0])
    st = np.vstack([ellipse_edge(z), [[z[0] - z[2] - ahead, t]]])
    assert es.fit_edge_ellipse(st, 0.5) is None


def test_fit_edge_ellipse_tip_near_the_front_across_t():
    """The tip's s lies within half a radius of the foremost point's s: here 0.0 from it while the
    flanks reach t = -0.5 (0.3 from the tip's s, more than half the radius 0.4)."""
    z = np.array([1.0, 0.0, 1.2, 0.5, 0.0])
    r = es.fit_edge_ellipse(ellipse_edge(z), 0.4)
    assert r is not None
    _close(np.r_[r["centre"], r["a"], r["b"], r["angle"]], z)


# -- edge_shape -----------------------------------------------------------------------------------

CENTRE, AXIS = np.array([5.0, -2.0]), np.array([np.cos(np.radians(30.0)), np.sin(np.radians(30.0))])
PERP = np.array([-AXIS[1], AXIS[0]])


def test_edge_shape_reports_a_tilted_ellipse_in_the_plane():
    """An exact 2.4:1 ellipse tilted 5° from the camber line, the section plane's camber axis at 30°:
    the record in the plane (centre, tip, major axis, tilt in degrees, ratio, tip radius b²/a)."""
    z = np.array([0.7, 0.02, 1.2, 0.5, np.radians(5.0)])
    r = es.edge_shape(to_plane(ellipse_edge(z), CENTRE, AXIS), CENTRE, 0.5, AXIS, 0.0, 0.003, 0.04)
    assert r["shape"] == "ellipse"
    assert abs(r["a"] - 1.2) < 1e-9 and abs(r["b"] - 0.5) < 1e-9 and abs(r["ratio"] - 2.4) < 1e-8
    assert abs(r["tip_radius"] - 0.25 / 1.2) < 1e-9 and abs(r["axis_angle_deg"] - 5.0) < 1e-7
    assert np.allclose(r["major_axis"], np.cos(z[4]) * AXIS + np.sin(z[4]) * PERP, atol=1e-9)
    assert np.allclose(r["centre"], CENTRE + z[0] * AXIS + z[1] * PERP, atol=1e-9)
    e1, _ = axes(z[4])
    assert np.allclose(r["tip"], to_plane(z[:2] - z[2] * e1, CENTRE, AXIS), atol=1e-9)


@pytest.mark.parametrize("a, want", [(0.75, "ellipse"), (0.515, "irregular")])
def test_edge_shape_ellipse_axes_must_differ_by_five_percent(a, want):
    z = np.array([a - 0.2, 0.0, a, 0.5, 0.0])
    r = es.edge_shape(to_plane(ellipse_edge(z), CENTRE, AXIS), CENTRE, 0.5, AXIS, 0.0, 0.003, 0.04)
    assert r["shape"] == want, r


def _zigzag_ellipse(delta):
    """The 2.4:1 ellipse's 80 front points moved ±δ along the normal in turn, the flanks exact:
    the true ellipse is δ from each of the 80 window points; the fit's five parameters absorb at
    most five of their squared offsets, so its rms lies between δ·√(1 - 5/80) = 0.97δ and δ, to
    first order (the Sampson distance it minimises differs from the orthogonal one by about
    δ·a/b² = 2 %)."""
    z = np.array([0.7, 0.0, 1.2, 0.5, 0.0])
    st = ellipse_edge(z, n_front=80)
    e = np.linspace(np.pi / 2, 3 * np.pi / 2, 82)[1:-1]
    sign = np.where(np.arange(80) % 2 == 0, 1.0, -1.0)
    moved = ell_point(z, e) + delta * sign[:, None] * ell_normal(z, e)
    st[60:140] = moved[::-1]
    return to_plane(st, CENTRE, AXIS)


@pytest.mark.parametrize("flank_rms, roundness, circle_rms, want", [
    (0.22, 0.0, 100.0, "irregular"),     # allowed 4 × 0.22δ = 0.88δ: below the rms
    (0.30, 0.0, 100.0, "ellipse"),       # allowed 1.2δ: above it
    (0.0, 10.0, 4.0, "irregular"),       # a fifth of the circle's rms 4δ: 0.8δ
    (0.0, 10.0, 5.5, "ellipse"),         # a fifth of 5.5δ: 1.1δ
])
def test_edge_shape_ellipse_must_pass_roundness_and_beat_the_circle(flank_rms, roundness, circle_rms, want):
    """The ellipse is taken when its rms (0.97δ to δ here, see _zigzag_ellipse) is at most both
    4 × flank_rms + roundness and a fifth of the circle's rms (figures in units of δ = 5 µm)."""
    delta = 0.005
    r = es.edge_shape(_zigzag_ellipse(delta), CENTRE, 0.5, AXIS, flank_rms * delta, roundness * delta,
                      circle_rms * delta)
    assert r["shape"] == want, r


def test_edge_shape_reports_a_flat_in_the_plane():
    """The blunt edge of test_flat_width_between_the_flank_lines in the plane: width, length,
    direction (along +t: the plane's perpendicular) and the corners' midpoint as the tip; a
    flank_rms that is not finite counts as no noise."""
    st, _, _ = flat_edge(c1=(0.0, -0.3), c2=(0.0, 0.7))
    for flank_rms in (0.0, np.nan, np.inf):
        r = es.edge_shape(to_plane(st, CENTRE, AXIS), CENTRE, 0.5, AXIS, flank_rms, 0.003)
        assert r["shape"] == "flat", (flank_rms, r)
        assert abs(r["width"] - 1.0) < 1e-9 and abs(r["length"] - 1.0) < 1e-9 and r["rms"] < 1e-9
        assert np.allclose(r["direction"], PERP, atol=1e-9)
        assert np.allclose(r["tip"], to_plane(np.array([0.0, 0.2]), CENTRE, AXIS), atol=1e-9)


@pytest.mark.parametrize("flank_rms, is_flat", [(0.0075, True), (0.0082, False)])
def test_edge_shape_looks_for_a_flat_within_its_noise(flank_rms, is_flat):
    """The flat's tolerance is 3 × flank_rms + 1 µm and none is looked for beyond 5 % of the radius
    (0.025 mm of 0.5): 0.0235 looks, 0.0256 does not."""
    st, _, _ = flat_edge(c1=(0.0, -0.3), c2=(0.0, 0.7))
    r = es.edge_shape(to_plane(st, CENTRE, AXIS), CENTRE, 0.5, AXIS, flank_rms, 0.003)
    assert (r["shape"] == "flat") == is_flat, r
