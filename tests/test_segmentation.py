# SPDX-License-Identifier: LGPL-2.1-or-later
"""Segmentation into LE / suction / TE / pressure against the analytic sample blade's own pieces."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from bladerecon.core.geometry.bspline import evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.readers import read_points
from bladerecon.samples.blade import SampleBlade, sample_sections
from bladerecon.core.sections.parameters import segment_sections
from bladerecon.core.sections.ordering import build_sections
from bladerecon.core.sections.segmentation import (
    LE, PRESSURE, SUCTION, TE, ThroatSpec, section_frame, segment_section, throat_chord_ratio,
)

DATA = Path(__file__).resolve().parent / "data"
BLADE = SampleBlade()
Z = np.array([0.0, 0.0, 1.0])


def _true_regions(h, points):
    """Region of each point from the analytic piece it lies on (the blade's own t bounds)."""
    t = np.arange(20000) / 20000
    dense = BLADE.point(h, t)
    b = BLADE.segment_bounds(h)
    piece = np.searchsorted(b[1:5], t, side="right")       # 0 LE low, 1 pressure, 2 TE, 3 suction, 4 LE up
    region = np.array([LE, PRESSURE, TE, SUCTION, LE])[piece]
    return region[cKDTree(dense).query(points)[1]]


@pytest.mark.parametrize("n_points,layout", [(2000, "uniform"), (65, "plan")])
def test_regions_match_the_analytic_pieces(n_points, layout):
    secs = sample_sections(BLADE, 6, n_points, layout, noise=0.002, seed=4)
    segs = segment_sections(secs, Z, first_point_is_measured=(layout == "plan"))
    for k, (seg, p) in enumerate(zip(segs, secs)):
        truth = _true_regions(k / 5, p)
        agree = np.mean(seg.labels == truth)
        # joints of a sparse plan can only fall between measured points: one point per joint may differ
        assert agree >= (0.99 if n_points == 2000 else 0.93), (k, agree)
        le, te = BLADE.le_te(k / 5)
        assert np.linalg.norm(seg.frame.to_space(seg.le)[0] - le) < 0.03
        assert np.linalg.norm(seg.frame.to_space(seg.te)[0] - te) < 0.03


def test_joints_are_at_the_circle_flank_tangent_points_on_dense_data():
    secs = sample_sections(BLADE, 6, 2000, "uniform", noise=0.002, seed=4)
    segs = segment_sections(secs, Z, False)
    for k, seg in enumerate(segs):
        tangent_points = BLADE.point(k / 5, BLADE.segment_bounds(k / 5)[1:5])
        joints = seg.frame.to_space(evaluate_curve(seg.curve, np.array(list(seg.t_joints.values()))))
        d = np.linalg.norm(joints[:, None] - tangent_points[None], axis=2).min(axis=1)
        assert d.max() < 0.25, (k, d)          # the edge arcs are 2-3 mm long


def test_tilted_and_stream_surface_sections_segment_like_planar_ones():
    p = sample_sections(BLADE, 2, 2000, "uniform", noise=0.0, seed=1)[0]
    ref = segment_section(p, 0, Z)
    # tilted by 25° about x: same section in another plane
    a = np.radians(25)
    R = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    tilted = segment_section(p @ R.T, 0, R @ Z)
    assert abs(tilted.chord - ref.chord) < 1e-3
    # wrapped onto a cylinder of radius 150 mm about x (a stream surface): small departure from a plane
    r0 = 150.0
    y, z = p[:, 1], p[:, 2]
    wrapped = np.column_stack([p[:, 0], (r0 + z) * np.sin(y / r0), (r0 + z) * np.cos(y / r0)])
    seg = segment_section(wrapped, 0, Z)
    assert seg.frame.flatness > 0.2                     # really not planar
    assert abs(seg.chord - ref.chord) < 0.1             # projected chord of the wrapped section
    assert np.bincount(seg.labels, minlength=4).min() > 10


def test_rotor37_every_section_has_four_regions_and_le_at_the_table_le():
    ss = build_sections(read_points(DATA / "nasa_rotor37" / "rotor37_sections_xyz_mm.txt"))
    segs = segment_sections([s.points for s in ss.sections], ss.span_axis, True)
    raw = read_points(DATA / "nasa_rotor37" / "rotor37_sections_xyz_mm.txt")
    for k, seg in enumerate(segs):
        assert np.bincount(seg.labels, minlength=4).min() >= 3, k
        assert np.linalg.norm(seg.lift(seg.le)[0] - raw.section_points(k)[0]) < 0.5


def test_open_section_is_refused():
    p = sample_sections(BLADE, 2, 400, "uniform", noise=0.0, seed=1)[0]
    p = np.roll(p, -int(np.argmin(p[:, 0])), axis=0)[:300]          # a quarter of the loop missing
    with pytest.raises(BladeReconError, match="section 3: the section is open: its last and first points are"):
        segment_section(p, 3, Z)


def test_gap_is_refused_with_the_point_numbers():
    p = sample_sections(BLADE, 2, 400, "uniform", noise=0.0, seed=1)[0]
    p = np.concatenate([p[:100], p[160:]])
    with pytest.raises(BladeReconError, match=r"section 0: gap of [\d.]+ mm between points 100 and 101"):
        segment_section(p, 0, Z)


def test_profile_without_edge_peak_is_refused():
    a = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    ellipse = np.column_stack([20 * np.cos(a), 15 * np.sin(a), np.zeros_like(a)])   # κ ratio 2.4
    with pytest.raises(BladeReconError, match="section 0: no clear LE/TE curvature peak"):
        segment_section(ellipse, 0, Z)


def test_throat_ratio_is_eq5_and_the_throat_point_is_on_the_suction_side():
    spec = ThroatSpec(50.0, 20.0, 1.0)
    want = 1.0 / (2 * np.cos(np.radians(20)) ** 2 * (np.tan(np.radians(50)) - np.tan(np.radians(20))))
    assert abs(throat_chord_ratio(spec) - want) < 1e-12
    p = sample_sections(BLADE, 2, 2000, "uniform", noise=0.0, seed=1)[0]
    seg = segment_section(p, 0, Z, throat=spec)
    th = seg.throat
    assert abs(th["width"] - want * seg.chord) < 1e-9
    assert seg.label_parameters(np.array([th["t"]]))[0] in (SUCTION, TE)
    # the neighbour's TE (moved by the pitch along e2) is o away from the throat point
    te_nb = seg.te + np.sign(th["point"][1] - 0.5 * (seg.le + seg.te)[1]) * th["pitch"] * np.array([0, 1.0])
    assert abs(np.linalg.norm(te_nb - th["point"]) - th["width"]) < 0.02 * th["width"]


def test_section_frame_x_axis_is_global_x_for_a_z_plane():
    p = sample_sections(BLADE, 2, 200, "uniform", noise=0.0, seed=1)[1]
    fr = section_frame(p, Z)
    assert np.allclose(fr.e1, [1, 0, 0], atol=1e-9) and np.allclose(fr.normal, [0, 0, 1], atol=1e-9)


# ----------------------------------------------------------------- segment fitting with continuity
from scipy.interpolate import BSpline  # noqa: E402

from bladerecon.core.sections.edge_fits import fit_segmented, rebuild_sections, unconstrained_segments  # noqa: E402
from bladerecon.core.geometry.spline import full_knot_vector  # noqa: E402


def _scipy_end_geometry(c, at_end):
    """Point, unit tangent, curvature at one end by scipy's BSpline (not our evaluator)."""
    U = full_knot_vector(c.knots, c.mults, c.degree, False)
    s = BSpline(U, np.asarray(c.poles), c.degree)
    x = c.domain[1] if at_end else c.domain[0]
    p, d1, d2 = s(x), s.derivative(1)(x), s.derivative(2)(x)
    k = (d1[0] * d2[1] - d1[1] * d2[0]) / np.linalg.norm(d1) ** 3
    return p, d1 / np.linalg.norm(d1), k


@pytest.mark.parametrize("n_points,layout,continuity", [(2000, "uniform", 2), (65, "plan", 2), (2000, "uniform", 3),
                                                        (65, "plan", 3)])
def test_rebuilt_joints_are_curvature_continuous(n_points, layout, continuity):
    secs = sample_sections(BLADE, 6, n_points, layout, noise=0.002, seed=7)
    for seg in segment_sections(secs, Z, layout == "plan"):
        ss = fit_segmented(seg, continuity)
        assert len(ss.joints) == 4
        for j in ss.joints:
            assert j["position"] < 1e-6 and j["tangent_deg"] < 1e-4 and j["curvature_rel"] < 0.01
        for i in range(4):   # the same figures by scipy
            pa, ta, ka = _scipy_end_geometry(ss.pieces[i], True)
            pb, tb, kb = _scipy_end_geometry(ss.pieces[(i + 1) % 4], False)
            assert np.linalg.norm(pa - pb) < 1e-6 and np.linalg.norm(ta - tb) < 1e-6
            assert abs(ka - kb) < 0.01 * max(abs(ka), abs(kb))


def test_pieces_fitted_alone_have_tangent_and_curvature_jumps():
    secs = sample_sections(BLADE, 2, 65, "plan", noise=0.002, seed=7)
    seg = segment_sections(secs, Z, True)[0]
    free = unconstrained_segments(seg)
    assert max(j["tangent_deg"] for j in free.joints) > 1.0
    assert max(j["curvature_rel"] for j in free.joints) > 0.1


@pytest.mark.parametrize("n_points,layout,limit", [(2000, "uniform", 0.01), (65, "plan", 0.03)])
def test_rebuilt_sections_stay_on_the_analytic_section(n_points, layout, limit):
    secs = sample_sections(BLADE, 6, n_points, layout, noise=0.002, seed=3)
    rebuilt, info = rebuild_sections(secs, Z, layout == "plan")
    for k, (r, i) in enumerate(zip(rebuilt, info)):
        truth = BLADE.point(k / 5, np.arange(40000) / 40000)
        assert cKDTree(truth).query(r)[0].max() < limit, k
        assert i["joint_curvature_rel_max"] < 0.01


def test_rotor37_sections_rebuild_with_continuous_joints():
    ss = build_sections(read_points(DATA / "nasa_rotor37" / "rotor37_sections_xyz_mm.txt"))
    pts = [s.points for s in ss.sections]
    rebuilt, info = rebuild_sections(pts, ss.span_axis, True, n=6000)
    for r, p, i in zip(rebuilt, pts, info):
        assert i["joint_curvature_rel_max"] < 0.01 and i["joint_position_max"] < 1e-6
        # the stream-surface offset is kept: rebuilt points are near the measured loop in 3D
        d = cKDTree(r).query(p)[0]
        assert np.median(d) < 0.005 and d.max() < 0.05


def test_cli_reconstruct_segmented_feeds_the_surface(tmp_path):
    import json
    import os
    import subprocess
    import sys
    root = Path(__file__).resolve().parents[1]
    env = dict(os.environ, PYTHONPATH=str(root))
    r = subprocess.run([sys.executable, "-m", "bladerecon", "reconstruct", str(root / "resources" / "sample" /
                        "measured_plan.csv"), "--segmented", "--json", "--quiet"], capture_output=True, text=True,
                       env=env, timeout=600)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["segmented"]["joint_curvature_rel_max"] < 0.01 and len(s["segmented"]["sections"]) == 6
    assert s["fit"]["max"] < 0.01               # measured points on the surface
    bad = subprocess.run([sys.executable, "-m", "bladerecon", "reconstruct", str(root / "resources" / "sample" /
                          "measured_plan.csv"), "--segmented", "--pairing", "angle"], capture_output=True, text=True,
                         env=env, timeout=600)
    assert bad.returncode == 2 and "--segmented" in bad.stderr
