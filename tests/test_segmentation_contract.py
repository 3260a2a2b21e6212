# SPDX-License-Identifier: LGPL-2.1-or-later
"""The segmentation's small contracts judged by closed forms (issue 26): the section frame, the
lift of a non-planar section, the parameter intervals of the regions and their labels, the
curvature sign, eq. 5's defaults. The first mutation run of the module found these reached
only through whole-blade figures, where a wrong sign or a swapped joint can hide.

The second part answers the survivors of that run with profiles whose answers are known
without the module: a two-circles-and-tangent-lines profile (LE/TE points, chord and edge
joints in closed form), the analytic sample blade (its own suction side and LE/TE), planes and
saddles of known normal, hand-built segmentations with exact joints, and every refusal
message matched whole."""
from __future__ import annotations

import dataclasses
import re
import typing

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.bspline import evaluate_curve
from bladerecon.core.geometry.fitting import interpolate_closed_curve
from bladerecon.core.geometry.spline import BSplineCurve
from bladerecon.core.sections.segmentation import (
    LE, NONPLANAR_LIMIT, PRESSURE, REGION_NAMES, SUCTION, TE, Segmentation, SectionFrame, ThroatSpec,
    section_frame, segment_section, signed_curvature, throat_chord_ratio,
)
from bladerecon.samples.blade import SampleBlade, sample_sections

BLADE = SampleBlade()


def test_region_names_are_the_json_keys_in_region_order():
    assert REGION_NAMES == ("le", "suction", "te", "pressure")
    assert (LE, SUCTION, TE, PRESSURE) == (0, 1, 2, 3)


def test_frame_of_a_tilted_plane_against_its_closed_form():
    """Points on the plane through c with unit normal n: origin = centroid, e1 = +x projected,
    e2 = n x e1, normal towards the span axis, flatness the largest offset; to_plane/to_space
    are inverse and vector_to_space has no origin shift."""
    rng = np.random.default_rng(2)
    n = np.array([0.2, -0.3, 0.93])
    n /= np.linalg.norm(n)
    u = np.cross(n, [1.0, 0.0, 0.0]); u /= np.linalg.norm(u)
    w = np.cross(n, u)
    q = rng.normal(size=(50, 2)) * [30.0, 4.0]
    c = np.array([5.0, -2.0, 40.0])
    P = c + q[:, :1] * u + q[:, 1:] * w
    f = section_frame(P, span_axis=-n)                       # asked to point the other way
    assert np.allclose(f.origin, P.mean(axis=0), atol=1e-12)
    assert np.allclose(f.normal, -n, atol=1e-12)
    ex = np.array([1.0, 0.0, 0.0]) - (np.array([1.0, 0.0, 0.0]) @ n) * n
    assert np.allclose(f.e1, ex / np.linalg.norm(ex), atol=1e-12)
    assert np.allclose(f.e2, np.cross(f.normal, f.e1), atol=1e-12)
    assert f.flatness < 1e-12
    back = f.to_space(f.to_plane(P))
    assert np.allclose(back, P, atol=1e-10)
    v = np.array([[3.0, -1.0]])
    assert np.allclose(f.vector_to_space(v), 3.0 * f.e1 - 1.0 * f.e2, atol=1e-14)
    assert np.allclose(f.to_space(v) - f.origin, f.vector_to_space(v), atol=1e-12)
    with pytest.raises(dataclasses.FrozenInstanceError):
        f.flatness = 1.0


def test_frame_of_a_plane_normal_to_x_takes_y_as_its_first_axis():
    P = np.c_[np.zeros(20), np.cos(np.arange(20)), np.sin(np.arange(20)) * 3]
    f = section_frame(P, span_axis=[1.0, 0.0, 0.0])
    assert np.allclose(f.normal, [1, 0, 0]) and np.allclose(f.e1, [0, 1, 0]) and np.allclose(f.e2, [0, 0, 1])


def _section(n=400, offset=None):
    pts = sample_sections(BLADE, 6, n, "uniform", noise=0.0, seed=1)[2]
    if offset is not None:
        pts = pts + offset(pts)[:, None] * np.array([0.0, 0.0, 1.0])
    return pts


def test_lift_of_a_non_planar_section_is_the_inverse_distance_blend_of_the_two_nearest_offsets():
    """A stream-surface section (offsets up to 0.3 mm along the span): a plane point is lifted by
    (o_i d_j + o_j d_i) / (d_i + d_j) of its two nearest measured points i, j (closed form here,
    by brute force over all points); a planar one (offsets below the limit) is not lifted."""
    from scipy.spatial.distance import cdist

    pts = _section(offset=lambda p: 0.3 * np.sin(p[:, 0] / 10.0))
    seg = segment_section(pts, span_axis=np.array([0.0, 0.0, 1.0]))
    assert seg.frame.flatness > NONPLANAR_LIMIT
    rng = np.random.default_rng(3)
    q = seg.points2d[rng.choice(len(seg.points2d), 30)] + rng.normal(0, 0.05, (30, 2))
    d = cdist(q, seg.points2d)
    near = np.argsort(d, axis=1)[:, :2]
    di, dj = d[np.arange(30), near[:, 0]], d[np.arange(30), near[:, 1]]
    oi, oj = seg.offsets[near[:, 0]], seg.offsets[near[:, 1]]
    want = seg.frame.to_space(q) + ((oi * dj + oj * di) / (di + dj))[:, None] * seg.frame.normal
    assert np.allclose(seg.lift(q), want, atol=1e-12)
    flat = segment_section(_section(offset=lambda p: 0.2 * NONPLANAR_LIMIT * np.sin(p[:, 0])),
                           span_axis=np.array([0.0, 0.0, 1.0]))
    assert 0 < flat.frame.flatness <= NONPLANAR_LIMIT
    assert np.allclose(flat.lift(q), flat.frame.to_space(q), atol=1e-14)


@pytest.mark.parametrize("reverse", [False, True])
def test_region_intervals_tile_the_loop_in_order_and_label_their_parameters(reverse):
    """LE, suction, TE, pressure follow each other round the loop, each from the joint where the
    previous one ends; together they cover one period; labels of parameters inside each
    interval are that region; side intervals run LE -> TE. Either direction of the input."""
    pts = _section()
    seg = segment_section(pts[::-1] if reverse else pts, span_axis=np.array([0.0, 0.0, 1.0]))
    assert seg.suction_forward is not None
    order = [LE, SUCTION, TE, PRESSURE] if seg.suction_forward else [LE, PRESSURE, TE, SUCTION]
    spans = [seg.region_interval(r) for r in order]
    total = sum(b - a for a, b in spans)
    assert total == pytest.approx(seg.period, rel=1e-12)
    for (a0, b0), (a1, _) in zip(spans, spans[1:] + spans[:1]):
        assert np.mod(a1 - b0, seg.period) == pytest.approx(0.0, abs=1e-12) or \
            np.mod(a1 - b0, seg.period) == pytest.approx(seg.period, abs=1e-12)
    for r, (a, b) in zip(order, spans):
        t = np.mod(a + (b - a) * np.linspace(0.05, 0.95, 19), seg.period)
        assert np.all(seg.label_parameters(t) == r), REGION_NAMES[r]
    assert seg.chord == pytest.approx(float(np.linalg.norm(seg.te - seg.le)), rel=1e-15)
    lo, hi = seg.curve.domain
    assert seg.period == pytest.approx(hi - lo)
    for side in (SUCTION, PRESSURE):
        a, b = seg.side_interval(side)
        mid = np.mod(0.5 * (a + b), seg.period)
        assert seg.label_parameters(np.array([mid]))[0] == side
        ends = sorted([np.mod(a, seg.period), np.mod(b, seg.period)])
        assert np.allclose(ends, sorted([seg.t_le % seg.period, seg.t_te % seg.period]), atol=1e-12)
    assert seg.forward(0.9 * seg.period, 0.1 * seg.period) == pytest.approx(0.2 * seg.period)


def test_signed_curvature_of_circles_turning_either_way():
    t = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    for R, sense in ((4.0, 1.0), (0.5, -1.0)):
        loop = np.c_[R * np.cos(sense * t), R * np.sin(sense * t)]
        c = interpolate_closed_curve(loop)
        k = signed_curvature(c, np.linspace(0, 1, 50, endpoint=False))
        # a cubic through 64 points of a circle: curvature within ~h²/12 = 8e-4 (h = 2π/64)
        assert np.allclose(k, sense / R, rtol=2e-3)


def test_throat_ratio_eq5_with_its_default_lift_coefficient():
    b1, b2 = 50.0, 20.0
    want = 1.0 / (2 * np.cos(np.radians(b2)) ** 2 * (np.tan(np.radians(b1)) - np.tan(np.radians(b2))))
    assert throat_chord_ratio(ThroatSpec(b1, b2)) == pytest.approx(want, rel=1e-12)
    assert throat_chord_ratio(ThroatSpec(b1, b2, 0.8)) == pytest.approx(0.8 * want, rel=1e-12)
    with pytest.raises(BladeReconError, match=r"^throat: inlet and outlet angles \(30\.0°, 30\.0°\) give no flow turning"):
        throat_chord_ratio(ThroatSpec(30.0, 30.0))
    # a turning so small that 2 cos²β2 (tanβ1 - tanβ2) = 1.5e-6 (β1 from that in closed form) is
    # still a turning: o/b = 1/1.5e-6 (the angles' round trip through degrees costs ~1e-10 of it)
    b2 = np.radians(30.0)
    b1_deg = float(np.degrees(np.arctan(np.tan(b2) + 1.5e-6 / (2 * np.cos(b2) ** 2))))
    assert throat_chord_ratio(ThroatSpec(b1_deg, 30.0)) == pytest.approx(1 / 1.5e-6, rel=1e-6)


# ======================================================= known answers for the first run's survivors
Z = np.array([0.0, 0.0, 1.0])


# ------------------------------------------------------------------ a profile known in closed form
def _rot_z(deg):
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])


class Stadium:
    """Two circles (LE radius r1 at (0, 0), TE radius r2 at (L, 0)) joined by their outer tangent
    lines. In its own frame: LE point (-r1, 0), TE point (L + r2, 0), chord L + r1 + r2; the
    lines touch the circles at C_i + r_i (sin φ, ±cos φ), sin φ = (r1 - r2) / L (the tangent
    line u·x = r1 with u = (sin φ, cos φ) is at distance r2 from (L, 0)). Placed in 3D by a
    rotation about z (``stagger``) and a shift."""

    def __init__(self, r1=2.0, r2=0.6, L=50.0, stagger=25.0, shift=(12.0, -7.0, 30.0)):
        self.r1, self.r2, self.L = r1, r2, L
        self.phi = np.arcsin((r1 - r2) / L)
        self.R, self.shift = _rot_z(stagger), np.asarray(shift, float)

    def to3d(self, p2):
        p2 = np.atleast_2d(p2)
        return np.column_stack([p2, np.zeros(len(p2))]) @ self.R.T + self.shift

    def loop(self, n, start=0.0, reverse=False):
        """n points equally spaced in arc length, counter-clockwise from the LE point (+ start
        fraction of the perimeter), 3D."""
        r1, r2, L, f = self.r1, self.r2, self.L, self.phi
        line = L * np.cos(f)
        a1 = r1 * (np.pi + 2 * f)            # LE arc from upper to lower tangent point (through -x)
        a2 = r2 * (np.pi - 2 * f)            # TE arc
        # pieces counter-clockwise from the LE point: lower half of LE arc, lower line, TE arc,
        # upper line, upper half of LE arc
        lens = np.array([a1 / 2, line, a2, line, a1 / 2])
        cum = np.concatenate([[0.0], np.cumsum(lens)])
        s = np.mod((np.arange(n) / n + start) * cum[-1], cum[-1])
        i = np.minimum(np.searchsorted(cum, s, side="right") - 1, 4)
        u = s - cum[i]
        ang = np.where(i == 0, np.pi + u / r1, np.where(i == 4, np.pi / 2 - f + u / r1, -(np.pi / 2 - f) + u / r2))
        rad = np.where(i == 2, r2, r1)[:, None]
        cen = np.where((i == 2)[:, None], [L, 0.0], [0.0, 0.0])
        out = cen + rad * np.column_stack([np.cos(ang), np.sin(ang)])
        for k, (a, b) in ((1, (self.joint(0, -1), self.joint(1, -1))), (3, (self.joint(1, 1), self.joint(0, 1)))):
            on = i == k                       # the lines: lower from LE to TE, upper from TE to LE
            out[on] = a + (b - a) * (u[on] / line)[:, None]
        if reverse:
            out = out[::-1]
        return self.to3d(out)

    def joint(self, end, side):
        """2D tangent point of circle ``end`` (0 LE, 1 TE) on the upper (+1) or lower (-1) line."""
        c, r = ((0.0, 0.0), self.r1) if end == 0 else ((self.L, 0.0), self.r2)
        return np.array(c) + r * np.array([np.sin(self.phi), side * np.cos(self.phi)])

    @property
    def le(self):
        return self.to3d([-self.r1, 0.0])[0]

    @property
    def te(self):
        return self.to3d([self.L + self.r2, 0.0])[0]

    @property
    def chord(self):
        return self.L + self.r1 + self.r2

    @property
    def perimeter(self):
        return 2 * self.L * np.cos(self.phi) + self.r1 * (np.pi + 2 * self.phi) + self.r2 * (np.pi - 2 * self.phi)


STADIUM = Stadium()


def _lift3(seg, q):
    return seg.frame.to_space(np.atleast_2d(q))


# ---------------------------------------------------------------- chord ends, joints, LE choice
@pytest.mark.parametrize("start,reverse", [(0.0, False), (0.31, False), (0.62, True), (0.13, True)])
def test_chord_ends_and_joints_of_the_two_circle_profile_are_its_closed_forms(start, reverse):
    """LE/TE points of a cubic through 3000 points of the profile, refined by Newton to where the
    tangent is normal to the chord: the interpolation error there (far from the curvature steps at
    the tangent points, smooth arcs, spacing 0.04 mm) is below 1e-8 mm, so 1e-6 mm is the bound.
    The LE is the blunter end (r1 > r2). Joints: the curvature steps from 1/r to 0 at the tangent
    points; the steepest drop of the curvature table (steps of P/8000 = 0.015 mm, median filter of
    a few steps) lands within 3 steps of them."""
    st = STADIUM
    seg = segment_section(st.loop(3000, start, reverse), 0, Z)
    le, te = _lift3(seg, seg.le)[0], _lift3(seg, seg.te)[0]
    assert np.linalg.norm(le - st.le) < 1e-6
    assert np.linalg.norm(te - st.te) < 1e-6
    assert seg.chord == pytest.approx(st.chord, abs=2e-6)
    # the parameters of the ends are the points' parameters on the curve
    ends = evaluate_curve(seg.curve, np.array([seg.t_le, seg.t_te]))
    assert np.allclose(ends, [seg.le, seg.te], atol=1e-12)
    lo, hi = seg.curve.domain
    assert lo <= seg.t_le < hi and lo <= seg.t_te < hi
    ds = st.perimeter / 8000
    want = {"le_suction", "le_pressure", "te_suction", "te_pressure"}
    assert set(seg.t_joints) == want
    got = {k: _lift3(seg, evaluate_curve(seg.curve, np.array([v])))[0] for k, v in seg.t_joints.items()}
    true = np.array([st.to3d(st.joint(e, s))[0] for e in (0, 1) for s in (1, -1)])
    for k, p in got.items():
        end = 0 if k.startswith("le") else 1
        d = np.linalg.norm(true[2 * end: 2 * end + 2] - p, axis=1)
        assert d.min() < 3 * ds, (k, d)
    # LE joints on the LE circle's tangent points, both of them (one per side)
    le_j = np.array([got["le_suction"], got["le_pressure"]])
    assert np.linalg.norm(le_j[0] - le_j[1]) == pytest.approx(2 * st.r1 * np.cos(st.phi), abs=6 * ds)
    te_j = np.array([got["te_suction"], got["te_pressure"]])
    assert np.linalg.norm(te_j[0] - te_j[1]) == pytest.approx(2 * st.r2 * np.cos(st.phi), abs=6 * ds)


def test_curvature_peaks_sit_on_the_edge_circles():
    """The curvature maximum near each end lies on that end's circle (curvature 1/r1, 1/r2 there,
    0 on the lines): within the circle, not out on a flank."""
    st = STADIUM
    seg = segment_section(st.loop(3000, 0.2), 0, Z)
    for t_peak, c, r in ((seg.t_le_peak, (0.0, 0.0), st.r1), (seg.t_te_peak, (st.L, 0.0), st.r2)):
        assert isinstance(t_peak, float)
        p = _lift3(seg, evaluate_curve(seg.curve, np.array([t_peak])))[0]
        assert abs(np.linalg.norm(p - st.to3d(c)[0]) - r) < 1e-4
        # on the arc beyond the tangent points (x below sin φ r for the LE, above for the TE)
        local = (p - st.shift) @ st.R
        assert (local[0] < c[0] + r * np.sin(st.phi)) if c[0] == 0 else (local[0] > c[0] + r * np.sin(st.phi))


@pytest.mark.parametrize("start,reverse", [(0.0, False), (0.5, True), (0.25, False), (0.75, True)])
def test_le_by_hint_by_flow_and_by_bluntness(start, reverse):
    """Which end is the LE: the blunter one (r1) without help; the end nearest ``le_hint``; the
    upstream end along ``flow`` (whatever the flow vector's length). Every start point and
    direction, so that either end is the first the code finds."""
    st = STADIUM
    p = st.loop(600, start, reverse)
    ax = (st.te - st.le) / st.chord

    def le_of(**kw):
        seg = segment_section(p, 0, Z, **kw)
        return _lift3(seg, seg.le)[0], _lift3(seg, seg.te)[0], seg

    # 600 points: spacing 0.2 mm; the LE/TE points are within 1e-4 mm (cubic on smooth arcs)
    le, te, _ = le_of()
    assert np.linalg.norm(le - st.le) < 1e-4 and np.linalg.norm(te - st.te) < 1e-4
    le, te, _ = le_of(le_hint=st.te + [0.5, 0.3, 0.0])
    assert np.linalg.norm(le - st.te) < 1e-4 and np.linalg.norm(te - st.le) < 1e-4
    le, te, _ = le_of(le_hint=st.le + [-0.5, 0.3, 0.0])
    assert np.linalg.norm(le - st.le) < 1e-4
    for flow, at_le in ((ax, True), (-ax, False), (1e-3 * ax, True), (-1e-3 * ax, False),
                        (ax + [0.0, 0.0, 5.0], True)):
        want, other = (st.le, st.te) if at_le else (st.te, st.le)
        # flow beats the hint
        le, te, seg = le_of(flow=flow, le_hint=other)
        assert np.linalg.norm(le - want) < 1e-4, flow
        # the LE's info travels with it: its joints are on its own circle, r sqrt(2 ± 2 sin φ) from the end
        # (2.87 mm for r1, 0.84 mm for r2), within a point spacing (0.19 mm: the cubic smears the
        # curvature step over a span)
        jl = _lift3(seg, evaluate_curve(seg.curve, np.array([seg.t_joints["le_suction"]])))[0]
        r, sg = (st.r1, 1.0) if at_le else (st.r2, -1.0)
        assert abs(np.linalg.norm(jl - want) - r * np.sqrt(2 + 2 * sg * np.sin(st.phi))) < st.perimeter / 600, flow
        tp = _lift3(seg, evaluate_curve(seg.curve, np.array([seg.t_le_peak])))[0]
        assert np.linalg.norm(tp - want) < 2 * r


def test_symmetric_profile_takes_the_suction_side_forward():
    """Without camber (a mirror-symmetric profile, 600 points placed symmetrically: the 8000 table
    samples split 4000/4000 between the sides) no side bulges: the convention is the dataclass
    default, suction side forward from the LE."""
    seg = segment_section(STADIUM.loop(600, 0.0), 0, Z)
    assert seg.suction_forward is True


class Kinked:
    """A symmetric profile drawn by arcs and lines (turtle geometry, closed form): from the LE
    point (0, 0) heading -y, the lower half is an LE arc (radius r1, turning τ1), a line g, a
    flank kink (radius rk, turning δ, sharper than the LE), a line L, the TE arc (r2, τ2), with
    τ1 + δ + τ2 = 180° and L chosen to bring the TE point back to y = 0; the upper half is its
    mirror image. The LE region ends where the LE arc meets the line (arc length r1 τ1 from the
    LE point); the kink, g further on, is a flank feature."""

    def __init__(self, r1=1.5, t1=55.0, g=0.9, rk=0.5, dk=36.5, r2=0.5, pieces=None):
        """``pieces``: the lower half as ("arc", radius, turning in degrees) and ("line", length)
        entries, one line of length None (solved for); default the LE arc, line, kink, line, TE."""
        self.r1, self.t1 = r1, np.radians(t1)
        if pieces is None:
            pieces = [("arc", r1, t1), ("line", g), ("arc", rk, dk), ("line", None), ("arc", r2, 180.0 - t1 - dk)]
        pieces = [[p[0], p[1], np.radians(p[2]) if p[0] == "arc" else 0.0] for p in pieces]
        head = np.radians(-90.0)
        # y of the end without the unknown line, then its length from the sine of its heading
        y, h = 0.0, head
        for k, (kind, a, b) in enumerate(pieces):
            if kind == "arc":
                y += a * (np.cos(h) - np.cos(h + b)); h += b
            elif a is not None:
                y += a * np.sin(h)
            else:
                k_line, h_line = k, h
        pieces[k_line][1] = -y / np.sin(h_line)
        assert pieces[k_line][1] > 0
        self.pieces, self.head0 = pieces, head
        self.lengths = np.array([a * b if kind == "arc" else a for kind, a, b in pieces])
        self.half = self.lengths.sum()

    def _lower(self, s):
        """Points of the lower half at arc lengths s (0 at the LE point)."""
        out = np.empty((s.size, 2))
        p, h, s0 = np.zeros(2), self.head0, 0.0
        for (kind, a, b), ln in zip(self.pieces, self.lengths):
            on = (s >= s0) & (s <= s0 + ln)
            u = s[on] - s0
            if kind == "arc":
                c = p + a * np.array([-np.sin(h), np.cos(h)])
                hh = h + u / a
                out[on] = c + a * np.column_stack([np.sin(hh), -np.cos(hh)])
                p, h = c + a * np.array([np.sin(h + b), -np.cos(h + b)]), h + b
            else:
                out[on] = p + u[:, None] * np.array([np.cos(h), np.sin(h)])
                p = p + ln * np.array([np.cos(h), np.sin(h)])
            s0 += ln
        self.te_x = p[0]
        return out

    def loop(self, n, start=0.0):
        s = np.mod((np.arange(n) / n + start), 1.0) * 2 * self.half
        low = s <= self.half
        out = np.empty((n, 2))
        out[low] = self._lower(s[low])
        out[~low] = self._lower(2 * self.half - s[~low]) * [1.0, -1.0]
        return np.column_stack([out, np.zeros(n)])

    def le_joints(self):
        """The two ends of the LE arc (2D): centre (r1, 0) + r1 (-cos τ1, ∓sin τ1)."""
        c = np.array([self.r1, 0.0])
        return np.array([c + self.r1 * np.array([-np.cos(self.t1), -np.sin(self.t1)]),
                         c + self.r1 * np.array([-np.cos(self.t1), np.sin(self.t1)])])


@pytest.mark.parametrize("start,bad_point", [(0.0, False), (0.37, False), (0.0, True)])
def test_a_sharper_flank_kink_beyond_the_edge_takes_neither_joint_nor_peak(start, bad_point):
    """The LE arc (curvature 1/1.5) meets the flank 1.44 mm from the LE point; 0.9 mm further a
    kink of curvature 1/0.5 ends in a steeper curvature drop. The LE joints are the LE arc's ends
    (closed form) within 3 table steps (P/8000 = 0.014 mm: the cubic through points 0.02 mm apart
    smears the curvature step over a span, the median filter keeps it), not the kink's (0.9 mm
    away); the LE curvature peak is on the LE arc (1e-3 mm: the cubic's error on the arc), not on
    the kink; the LE/TE points are (0, 0) and (x_TE, 0). With one point 5 µm off the flank 0.26 mm
    past the LE arc (a spike of the interpolant some 7 table steps wide, removed by the median
    filter over 0.5 % of the chord) nothing changes."""
    k = Kinked()
    p = k.loop(5000, start)
    if bad_point:
        i = int(round((k.r1 * k.t1 + 0.26) / (2 * k.half) * 5000))
        p[i, 1] -= 0.005
    seg = segment_section(p, 0, Z)
    assert np.linalg.norm(seg.frame.to_space(seg.le)[0, :2]) < 1e-6
    assert np.linalg.norm(seg.frame.to_space(seg.te)[0, :2] - [k.te_x, 0.0]) < 1e-6
    ds = 2 * k.half / 8000
    got = seg.frame.to_space(evaluate_curve(seg.curve, np.array([seg.t_joints["le_suction"],
                                                                 seg.t_joints["le_pressure"]])))[:, :2]
    want = k.le_joints()
    d = np.linalg.norm(got[:, None] - want[None], axis=2).min(axis=1)
    assert d.max() < 3 * ds, d
    assert np.linalg.norm(got[0] - got[1]) > 1.5 * k.r1          # one on each side
    peak = seg.frame.to_space(evaluate_curve(seg.curve, np.array([seg.t_le_peak])))[0, :2]
    assert abs(np.linalg.norm(peak - [k.r1, 0.0]) - k.r1) < 1e-3 and peak[0] < want[0, 0]


def test_the_le_curvature_peak_is_the_sharpest_point_near_the_end_not_the_end_itself():
    """An LE drawn by a flat arc (radius 4, 10°, 0.70 mm from the LE point each way) then a sharp
    one (radius 1, 82°): the curvature maximum near the end is on the sharp arcs, 0.7-2.1 mm from
    the LE point (inside 3 % of the 45 mm chord): the peak's point is 1 mm from its arc's centre
    (the centre: the flat arc's end moved by 1 along its inward normal), within the cubic's error."""
    k = Kinked(pieces=[("arc", 4.0, 10.0), ("arc", 1.0, 82.0), ("line", None), ("arc", 0.5, 88.0)])
    p = k.loop(4000, 0.1)
    seg = segment_section(p, 0, Z)
    a = np.radians(10.0)
    end = np.array([4.0 * (1 - np.cos(a)), -4.0 * np.sin(a)])       # flat arc's end, centre (4, 0)
    centres = [end + 1.0 * np.array([np.cos(a), np.sin(a)])]        # towards the centre (4, 0)
    centres.append(centres[0] * [1.0, -1.0])                        # the upper (mirror) one
    peak = seg.frame.to_space(evaluate_curve(seg.curve, np.array([seg.t_le_peak])))[0, :2]
    assert min(abs(np.linalg.norm(peak - c) - 1.0) for c in centres) < 1e-3, peak
    assert np.linalg.norm(peak) > 0.6


# -------------------------------------------------------------------- suction side of a real blade
def _true_regions(h, points, mirror=False):
    t = np.arange(20000) / 20000
    dense = BLADE.point(h, t)
    if mirror:
        dense = dense * [1.0, -1.0, 1.0]
    b = BLADE.segment_bounds(h)
    piece = np.searchsorted(b[1:5], t, side="right")       # 0 LE low, 1 pressure, 2 TE, 3 suction, 4 LE up
    region = np.array([LE, PRESSURE, TE, SUCTION, LE])[piece]
    return region[cKDTree(dense).query(points)[1]]


@pytest.mark.parametrize("reverse,mirror,le_at", [(False, False, None), (True, False, None), (False, True, None),
                                                  (True, True, None), (False, False, 0.25), (True, True, 0.75)])
def test_suction_side_is_the_blade_suction_flank_either_way_round_and_mirrored(reverse, mirror, le_at):
    """The analytic blade's own suction flank is labelled suction whatever the direction of the
    points, on the mirror image (where the camber bulges the other way about the plane), and
    wherever the LE falls in the loop's parameter (``le_at``: the points rolled to put it there):
    at least 97 % of 400 points agree with the blade's pieces (joints fall between points)."""
    h = 0.4
    p = sample_sections(BLADE, 6, 400, "uniform", noise=0.0, seed=5)[2]
    if mirror:
        p = p * [1.0, -1.0, 1.0]
    if reverse:
        p = p[::-1]
    if le_at is not None:
        le0 = BLADE.le_te(h)[0] * ([1, -1, 1] if mirror else 1)
        p = np.roll(p, int(round(le_at * len(p))) - int(np.argmin(np.linalg.norm(p - le0, axis=1))), axis=0)
    seg = segment_section(p, 0, Z)
    truth = _true_regions(h, p, mirror)
    assert np.mean(seg.labels == truth) > 0.97
    le, te = BLADE.le_te(h)
    if mirror:
        le, te = le * [1, -1, 1], te * [1, -1, 1]
    assert np.linalg.norm(_lift3(seg, seg.le)[0] - le) < 0.01
    assert np.linalg.norm(_lift3(seg, seg.te)[0] - te) < 0.01


# ----------------------------------------------------------------------------------- throat point
ROT_THROAT = _rot_z(-55.0)     # the blade turned so that its suction side faces the neighbour (+-e2)


def _suction_flank(h, mirror):
    """The suction side from the TE point (upper half of the TE circle, the flank, upper LE arc),
    turned and mirrored like the test's points."""
    t = np.linspace(float(BLADE.te_parameter(h)), 1.0, 60001)
    pts = BLADE.point(h, t) @ ROT_THROAT.T
    return pts * [1.0, -1.0, 1.0] if mirror else pts


@pytest.mark.parametrize("mirror", [False, True])
def test_throat_point_and_pitch_against_brute_force_on_the_analytic_suction_flank(mirror):
    """Eq. 5's width o = (o/b) b; the neighbour is this blade's TE moved along +-e2 (here +-y)
    towards the suction side; its distance to the suction side equals o at the pitch s (brentq on
    the analytic suction side, 60001 points, 1 µm apart); the throat point is the foot, here
    some 18 mm up the suction side from the TE (the blade turned by -55° about z, so that the
    suction side faces the neighbour). The module walks s on a grid of 0.01 b and interpolates
    linearly, then snaps the foot to its table (0.014 mm steps): the pitch within the linear
    interpolation's error and the point within 0.05 mm; a grid step off (0.5 mm) or a wrong side
    fails."""
    h = 0.4
    spec = ThroatSpec(55.0, 25.0, 1.1)
    p = sample_sections(BLADE, 6, 1500, "uniform", noise=0.0, seed=5)[2] @ ROT_THROAT.T
    if mirror:
        p = p * [1.0, -1.0, 1.0]
    seg = segment_section(p, 0, Z, throat=spec)
    th = seg.throat
    ratio = spec.lift_coefficient / abs(2 * np.cos(np.radians(25.0)) ** 2
                                        * (np.tan(np.radians(55.0)) - np.tan(np.radians(25.0))))
    assert set(th) == {"t", "point", "width", "ratio", "pitch", "lift_coefficient", "beta1_deg", "beta2_deg"}
    assert th["ratio"] == pytest.approx(ratio, rel=1e-12)
    assert (th["lift_coefficient"], th["beta1_deg"], th["beta2_deg"]) == (1.1, 55.0, 25.0)
    le, te = (x @ ROT_THROAT.T for x in BLADE.le_te(h))
    if mirror:
        le, te = le * [1, -1, 1], te * [1, -1, 1]
    chord = np.linalg.norm(te - le)
    o = ratio * chord
    assert th["width"] == pytest.approx(o, abs=1e-5 * o)
    side = _suction_flank(h, mirror)
    flank = cKDTree(side[:, :2])
    # the suction side faces +y for the turned blade, -y mirrored
    sgn = -1.0 if mirror else 1.0
    dist = lambda s: flank.query(te[:2] + [0.0, sgn * s])[0]
    s_true = brentq(lambda s: dist(s) - o, 0.02 * chord, 4 * chord)
    # linear interpolation on the module's grid (step h = 0.01 chord) is off by at most h²/8 |dist''|
    # (dist'' by central differences on the analytic side), and by 1e-3 for chord and TE of the fit
    step = 0.01 * chord
    d2 = abs(dist(s_true + step) - 2 * dist(s_true) + dist(s_true - step)) / step ** 2
    assert th["pitch"] == pytest.approx(s_true, abs=1.5 * step * step / 8 * d2 + 1e-3)
    foot = side[flank.query(te[:2] + [0.0, sgn * s_true])[1]]
    assert np.linalg.norm(foot - te) > 10.0                      # a foot on the flank, not at the TE
    assert np.linalg.norm(_lift3(seg, th["point"])[0] - foot) < 0.05
    assert np.allclose(evaluate_curve(seg.curve, np.array([th["t"]]))[0], th["point"], atol=1e-9)
    # the TE region starts at the throat point on the suction side
    assert set(seg.t_joints) == {"le_suction", "le_pressure", "te_suction", "te_pressure"}
    assert seg.t_joints["te_suction"] == th["t"]
    assert seg.label_parameters(np.array([th["t"]]))[0] == SUCTION


def test_throat_wider_than_any_neighbour_distance_is_refused_with_its_figures():
    """A turning of 0.5° makes o/b = 1/(2 cos²β2 (tanβ1 - tanβ2)) about 50: o is far beyond 4 chords."""
    spec = ThroatSpec(30.5, 30.0)
    ratio = 1.0 / abs(2 * np.cos(np.radians(30.0)) ** 2 * (np.tan(np.radians(30.5)) - np.tan(np.radians(30.0))))
    h = 0.4
    le, te = BLADE.le_te(h)
    o = ratio * np.linalg.norm(te - le)
    p = sample_sections(BLADE, 6, 400, "uniform", noise=0.0, seed=5)[2]
    with pytest.raises(BladeReconError) as e:
        segment_section(p, 4, Z, throat=spec)
    m = re.fullmatch(r"section 4: throat width ([\d.]+) mm \(eq\. 5, o/b=([\d.]+)\) is larger than any neighbour "
                     r"distance: check the inlet/outlet angles and C_L", str(e.value))
    assert m, str(e.value)
    # the chord of the cubic through 400 points is within 5e-4 mm of the blade's (of 53 mm): o to 1e-5
    assert float(m.group(1)) == pytest.approx(o, rel=1e-5) and float(m.group(2)) == pytest.approx(ratio, abs=1e-3)


# ------------------------------------------------------------------------------- refusal messages
def test_too_few_points_message_names_the_count():
    p = STADIUM.loop(7)
    with pytest.raises(BladeReconError) as e:
        segment_section(p, 5, Z)
    assert re.fullmatch(r"section 5: 7 points, segmentation needs at least 8: measure more points on the section",
                        str(e.value)), str(e.value)
    with pytest.raises(BladeReconError) as e:
        segment_section(np.zeros(30), 2, Z)
    assert re.fullmatch(r"section 2: 0 points, segmentation needs at least 8: measure more points on the section",
                        str(e.value)), str(e.value)


def test_eight_points_pass_the_count_check():
    """Eight points of a blade-like ellipse (a/b = 8: end curvature 64x the flanks') are enough."""
    a = np.arange(8) * 2 * np.pi / 8
    p = np.column_stack([40 * np.cos(a), 5 * np.sin(a), np.zeros(8)])
    seg = segment_section(p, 0, Z, max_gap=100.0)          # 8 points are 28 mm apart
    assert seg.chord == pytest.approx(80.0, rel=0.02)     # a cubic through 8 points of the ellipse


def _closed_gap_case():
    p = sample_sections(BLADE, 2, 400, "uniform", noise=0.0, seed=1)[0]
    return np.concatenate([p[:100], p[160:]])


def test_gap_message_whole_and_its_figures():
    """The gap is the distance of points 100 and 101 (1-based); the limit 15 % of the extent along
    the principal axis (the points' own SVD here)."""
    p = _closed_gap_case()
    gap = np.linalg.norm(p[100] - p[99])
    c = p[:, :2] - p[:, :2].mean(0)
    ext = np.ptp(c @ np.linalg.svd(c)[2][0])
    with pytest.raises(BladeReconError) as e:
        segment_section(p, 6, Z)
    m = re.fullmatch(r"section 6: gap of ([\d.]+) mm between points 100 and 101 \(limit ([\d.]+) mm\); "
                     r"measure points in the gap or raise the gap limit", str(e.value))
    assert m, str(e.value)
    assert float(m.group(1)) == pytest.approx(gap, abs=1e-3) and float(m.group(2)) == pytest.approx(0.15 * ext, abs=1e-3)


def test_open_message_whole_and_a_gap_equal_to_the_limit_passes():
    p = sample_sections(BLADE, 2, 400, "uniform", noise=0.0, seed=1)[0]
    p = np.roll(p, -int(np.argmin(p[:, 0])), axis=0)[:300]
    gap = np.linalg.norm(p[0] - p[-1])
    with pytest.raises(BladeReconError) as e:
        segment_section(p, 3, Z, max_gap=2.0)
    m = re.fullmatch(r"section 3: the section is open: its last and first points are ([\d.]+) mm apart "
                     r"\(limit 2\.000 mm\); measure the whole profile round to the start", str(e.value))
    assert m, str(e.value)
    assert float(m.group(1)) == pytest.approx(gap, abs=1e-3)
    # the limit is inclusive: a gap exactly at it passes the check (the plane coordinates of the
    # points, the module's own projection, give the gap to the last bit)
    q = section_frame(p, Z).to_plane(p)
    g = np.linalg.norm(np.roll(q, -1, axis=0) - q, axis=1).max()
    segment_section(p, 3, Z, max_gap=g)
    with pytest.raises(BladeReconError, match=r"^section 3: the section is open"):
        segment_section(p, 3, Z, max_gap=np.nextafter(g, 0.0))


def _ellipse_by_length(a, b, n):
    """n points of the ellipse equally spaced in arc length (so that the curve's centripetal
    parameter, and the module's curvature table, run with arc length)."""
    th = np.linspace(0, 2 * np.pi, 200001)
    ds = np.sqrt(a * a * np.sin(th) ** 2 + b * b * np.cos(th) ** 2)
    s = np.concatenate([[0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(th))])
    tk = np.interp(np.arange(n) / n * s[-1], s, th)
    return np.column_stack([a * np.cos(tk), b * np.sin(tk), np.zeros(n)])


def _ellipse_median_ratio(a, b):
    """End curvature a/b² over the median curvature along arc length (brute force, 40000 steps)."""
    th = np.linspace(0, 2 * np.pi, 40001)[:-1]
    k = a * b / (a * a * np.sin(th) ** 2 + b * b * np.cos(th) ** 2) ** 1.5
    ds = np.sqrt(a * a * np.sin(th) ** 2 + b * b * np.cos(th) ** 2)
    order = np.argsort(k)
    cum = np.cumsum(ds[order]) / ds.sum()
    med = k[order][np.searchsorted(cum, 0.5)]
    return (a / b ** 2) / med, med


def test_no_peak_message_whole_with_default_index_and_ratio():
    """Ellipse 20 x 15: end curvature a/b² = 0.0889/mm; median curvature along the loop by brute
    force; the ratio 4 is the default."""
    a_, b_ = 20.0, 15.0
    ellipse = _ellipse_by_length(a_, b_, 200)
    _, med = _ellipse_median_ratio(a_, b_)
    with pytest.raises(BladeReconError) as e:
        segment_section(ellipse, span_axis=Z)
    m = re.fullmatch(r"section 0: no clear LE/TE curvature peak \(end curvature ([\d.e+-]+)/mm is not 4x the median "
                     r"([\d.e+-]+)/mm\): is this a blade profile\? check the section", str(e.value))
    assert m, str(e.value)
    # 4 significant digits printed; the spline through 200 points and the median filter: 0.5 %
    assert float(m.group(1)) == pytest.approx(a_ / b_ ** 2, rel=5e-3)
    assert float(m.group(2)) == pytest.approx(med, rel=5e-3)


def test_default_peak_ratio_is_four():
    """An ellipse whose end curvature is 4.5x its median curvature (brute force) passes with the
    default ratio and is refused at 5."""
    a_ = brentq(lambda a: _ellipse_median_ratio(a, 10.0)[0] - 4.5, 12.0, 40.0)
    p = _ellipse_by_length(a_, 10.0, 400)
    seg = segment_section(p, 0, Z)
    assert seg.chord == pytest.approx(2 * a_, rel=1e-4)
    with pytest.raises(BladeReconError, match=r"^section 0: no clear LE/TE curvature peak"):
        segment_section(p, 0, Z, peak_ratio=5.0)


# ------------------------------------------------------------------------------------ section frame
def _plane_points(n_vec, center, seed=2, scale=(30.0, 4.0), m=60):
    n = np.asarray(n_vec, float) / np.linalg.norm(n_vec)
    u = np.cross(n, [0.3, 0.5, 0.8]); u /= np.linalg.norm(u)
    w = np.cross(n, u)
    q = np.random.default_rng(seed).normal(size=(m, 2)) * scale
    return np.asarray(center) + q[:, :1] * u + q[:, 1:] * w, n


def _expect_e1(n, ref):
    e = ref - (ref @ n) * n
    return e / np.linalg.norm(e)


def test_frame_normal_is_the_plane_normal_when_the_span_axis_leans_20_degrees():
    """A planar section whose span axis is 20° off its normal: the normal is the plane's (not the
    axis), signed towards the axis; e1 = +x projected; flat to rounding."""
    P, n = _plane_points([0.2, -0.3, 0.93], [5.0, -2.0, 40.0])
    axis = n * np.cos(np.radians(20)) + np.cross(n, [1.0, 0, 0]) / np.linalg.norm(np.cross(n, [1.0, 0, 0])) \
        * np.sin(np.radians(20))
    f = section_frame(P, axis)
    assert np.allclose(f.normal, n, atol=1e-12)
    assert np.allclose(f.e1, _expect_e1(n, np.array([1.0, 0, 0])), atol=1e-12)
    assert f.flatness < 1e-12
    f = section_frame(P, -axis)
    assert np.allclose(f.normal, -n, atol=1e-12)


def test_frame_without_span_axis_points_the_normal_to_plus_z():
    """Default span axis +z: the normal (-0.8, -0.8, 0.3)/|.| is kept (its z > 0), its opposite
    is turned round."""
    for sgn in (1.0, -1.0):
        P, n = _plane_points(sgn * np.array([-0.8, -0.8, 0.3]), [1.0, 2.0, 3.0])
        f = section_frame(P)
        assert np.allclose(f.normal, np.array([-0.8, -0.8, 0.3]) / np.linalg.norm([-0.8, -0.8, 0.3]), atol=1e-12)


def test_frame_of_a_plane_12_degrees_from_normal_to_x_takes_y_projected():
    """|n x x| = sin 12° = 0.21 < 0.3: e1 is +y projected on the plane, not +x (nor any other
    vector: with n tilted towards z, y is in the plane and is e1 itself)."""
    n = np.array([np.cos(np.radians(12)), 0.0, np.sin(np.radians(12))])
    P, n = _plane_points(n, [0.0, 0.0, 0.0])
    f = section_frame(P, [1.0, 0.0, 0.0])
    assert np.allclose(f.normal, n, atol=1e-12)
    assert np.allclose(f.e1, [0.0, 1.0, 0.0], atol=1e-12)
    # 20° from normal to x (|n x x| = 0.34): +x projected again
    n = np.array([np.cos(np.radians(20)), np.sin(np.radians(20)), 0.0])
    P, n = _plane_points(n, [0.0, 0.0, 0.0])
    assert np.allclose(section_frame(P, [1.0, 0.0, 0.0]).e1, _expect_e1(n, np.array([1.0, 0, 0])), atol=1e-12)


def test_the_curve_table_kept_for_measuring_is_the_curve_at_8000_equal_steps():
    """Measuring (sections.parameters, 8000 samples) reuses the table: it must be this curve at
    8000 equal parameter steps (our evaluator at i/8000 as referee), and nothing else."""
    seg = segment_section(STADIUM.loop(400), 0, Z)
    lo, hi = seg.curve.domain
    tab = seg.table_points(8000)
    assert tab is not None and tab.shape == (8000, 2)
    assert np.allclose(tab, evaluate_curve(seg.curve, lo + (hi - lo) * np.arange(8000) / 8000), atol=1e-12)
    assert seg.table_points(4000) is None
    other = dataclasses.replace(seg, curve=_circle_curve())
    assert other.table_points(8000) is None
    assert "table=" not in repr(seg)             # 8000 points are not printed with the record
    # a cache: not part of the record's value (its field compares nothing; the records' own ==
    # compares arrays field by field on Python 3.13, so it is not used here)
    assert next(f for f in dataclasses.fields(seg) if f.name == "table").compare is False


def _saddle(n_vec, amp, m=90):
    """A circle of radius 20 in the plane of normal n, lifted by amp cos 2θ along n: its best-fit
    plane is that plane (the lift has no mean and no first harmonic); largest offset amp."""
    n = np.asarray(n_vec, float) / np.linalg.norm(n_vec)
    u = np.cross(n, [1.0, 0.0, 0.0]); u /= np.linalg.norm(u)
    w = np.cross(n, u)
    th = 2 * np.pi * np.arange(m) / m
    return np.array([4.0, -3.0, 20.0]) + 20 * np.cos(th)[:, None] * u + 20 * np.sin(th)[:, None] * w \
        + amp * np.cos(2 * th)[:, None] * n, n


def test_non_planar_section_takes_the_plane_normal_to_the_span_axis_and_only_when_one_is_given():
    n_tilt = np.array([np.sin(np.radians(10)), 0.0, np.cos(np.radians(10))])
    P, n = _saddle(n_tilt, 0.3)
    f = section_frame(P, [0.0, 0.0, 5.0])          # a span axis of any length
    assert np.allclose(f.normal, [0.0, 0.0, 1.0], atol=1e-15)
    assert np.allclose(f.e1, [1.0, 0.0, 0.0], atol=1e-15)
    # flatness measured from that plane: the tilt of 10° over a radius of 20 mm plus the lift
    d = (P - P.mean(0)) @ np.array([0.0, 0.0, 1.0])
    assert f.flatness == pytest.approx(np.abs(d).max(), rel=1e-12)
    g = section_frame(P)                            # no span axis: the best-fit plane
    assert np.allclose(g.normal, n, atol=1e-12)
    assert g.flatness == pytest.approx(0.3, rel=1e-9)


# -------------------------------------------------------------------- hand-built segmentation data
def _circle_curve(knot_shift=0.0, knot_scale=1.0):
    t = np.linspace(0, 2 * np.pi, 16, endpoint=False)
    c = interpolate_closed_curve(np.c_[10 * np.cos(t), 10 * np.sin(t)])
    return BSplineCurve(c.poles, c.knots * knot_scale + knot_shift, c.mults, c.degree, c.periodic)


def _frame(flatness=0.0):
    return SectionFrame(np.zeros(3), np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]), flatness)


def _hand_seg(curve=None, **kw):
    curve = curve or _circle_curve()
    q = evaluate_curve(curve, np.linspace(*curve.domain, 16, endpoint=False))
    base = dict(index=0, frame=_frame(), points2d=q, curve=curve, method="interpolate", t_points=np.zeros(16),
                t_le=0.0, t_te=0.5, le=q[0], te=q[8], t_le_peak=0.0, t_te_peak=0.5)
    base.update(kw)
    return Segmentation(**base)


def test_segmentation_defaults_and_frozen_records():
    seg = _hand_seg()
    assert seg.t_joints == {} and isinstance(seg.t_joints, dict)
    assert seg.suction_forward is True
    assert seg.labels is None and seg.throat is None and seg.offsets is None and seg.table is None
    assert _hand_seg().t_joints is not seg.t_joints                # a fresh dict each
    with pytest.raises(dataclasses.FrozenInstanceError):
        seg.t_le = 0.1
    spec = ThroatSpec(40.0, 10.0)
    with pytest.raises(dataclasses.FrozenInstanceError):
        spec.beta1_deg = 1.0
    # the annotations are types (documentation tools evaluate them)
    hints = typing.get_type_hints(Segmentation)
    assert hints["labels"] == (np.ndarray | None) and hints["throat"] == (dict | None)
    assert hints["offsets"] == (np.ndarray | None)


def test_period_and_forward_on_a_curve_whose_domain_does_not_start_at_zero():
    seg = _hand_seg(_circle_curve(knot_shift=2.0, knot_scale=3.0))   # domain [2, 5]
    assert seg.curve.domain == (2.0, 5.0)
    assert seg.period == 3.0
    assert seg.forward(4.5, 2.5) == pytest.approx(1.0)


@pytest.mark.parametrize("forward", [True, False])
def test_a_parameter_on_a_joint_belongs_to_the_first_region_whose_closed_interval_holds_it(forward):
    """Joints at binary-exact parameters; regions are closed intervals tested in the order LE,
    suction, TE, pressure: the LE takes both its joints, each side the joint it shares with the
    region after it in that order. A NaN parameter is in no region (-1)."""
    j = {"le_pressure": 0.875, "le_suction": 0.125, "te_suction": 0.375, "te_pressure": 0.625}
    if not forward:    # suction going -t from the LE: the same loop with the sides' names swapped
        j = {"le_suction": 0.875, "le_pressure": 0.125, "te_pressure": 0.375, "te_suction": 0.625}
    seg = _hand_seg(t_joints=j, suction_forward=forward)
    side_a, side_b = (SUCTION, PRESSURE) if forward else (PRESSURE, SUCTION)
    t = np.array([0.125, 0.375, 0.625, 0.875, 0.0, 0.25, 0.5, 0.75, np.nan])
    # the regions as closed intervals of [0, 1), in the order they are tried
    spans = {LE: (0.875, 1.125), side_a: (0.125, 0.375), TE: (0.375, 0.625), side_b: (0.625, 0.875)}
    want = [next((r for r in (LE, SUCTION, TE, PRESSURE) if spans[r][0] <= x <= spans[r][1]
                   or spans[r][0] <= x + 1.0 <= spans[r][1]), -1) for x in t]
    assert want[:4] == ([LE, SUCTION, TE, LE] if forward else [LE, TE, SUCTION, LE]) and want[-1] == -1
    assert seg.label_parameters(t).tolist() == want


def test_lift_at_exactly_the_non_planar_limit_is_planar():
    """'More than NONPLANAR_LIMIT' is non-planar: a frame whose flatness equals it lifts nothing."""
    off = np.full(16, 0.04)
    seg = _hand_seg(frame=_frame(NONPLANAR_LIMIT), offsets=off)
    q = np.array([[3.0, 4.0], [-10.0, 0.5]])
    assert np.array_equal(seg.lift(q), seg.frame.to_space(q))
    seg = _hand_seg(frame=_frame(np.nextafter(NONPLANAR_LIMIT, 1.0)), offsets=off)
    assert np.allclose(seg.lift(q)[:, 2], 0.04, atol=1e-12)


def test_curvature_filtered_round_the_ends_only_is_the_whole_tables_filter():
    """The median filter run only on the stretches the edge analysis reads (issue 24's time)
    gives those samples exactly the whole table's values, ties and wrapped stretches included."""
    from bladerecon.core.sections import segmentation as sg

    rng = np.random.default_rng(11)
    for n, ends in ((8000, (5, 4100)), (8000, (7990, 3000)), (8000, (1000, 1500)), (2000, (0, 999))):
        kappa = np.round(rng.standard_normal(n), 2) + np.where(rng.random(n) < 0.01, 50.0, 0.0)
        perimeter, chord = 85.0, 40.0
        full, w = sg._smoothed_curvature(kappa, perimeter, chord)
        part, w2 = sg._smoothed_curvature(kappa, perimeter, chord, ends)
        reach = sg._reach(perimeter, chord, n)
        need = np.unique(np.concatenate([(i + np.arange(-reach, reach + 1)) % n for i in ends]))
        assert w == w2 and np.array_equal(part[need], full[need])
        assert np.isnan(np.delete(part, need)).all()
