# SPDX-License-Identifier: LGPL-2.1-or-later
"""The segmentation's small contracts judged by closed forms (issue 26): the section frame, the
lift of a non-planar section, the parameter intervals of the regions and their labels, the
curvature sign, eq. 5's defaults. The first mutation run of the module found these reached
only through whole-blade figures, where a wrong sign or a swapped joint can hide."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.fitting import interpolate_closed_curve
from bladerecon.core.sections.segmentation import (
    LE, NONPLANAR_LIMIT, PRESSURE, REGION_NAMES, SUCTION, TE, ThroatSpec, section_frame, segment_section,
    signed_curvature, throat_chord_ratio,
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
