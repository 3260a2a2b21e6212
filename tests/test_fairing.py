# SPDX-License-Identifier: LGPL-2.1-or-later
"""Bad-point detection and fairing (seed 001 §1.1): checked against the analytic blade's truth."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from bladerecon.core.geometry.bspline import evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.sections.fairing import edge_zones, bad_runs, detect_bad_points, fair_fit, fair_section, replace_runs
from bladerecon.core.analysis.fairness import count_inflections
from bladerecon.core.geometry.fitting import interpolate_closed_curve
from bladerecon.core.geometry.projection import project_points_to_surface
from bladerecon.core.reconstruct import reconstruct
from realdata_fixtures import RUNS, clean_section, with_bad_runs

AXIS = np.array([0.0, 0.0, 1.0])


@pytest.mark.parametrize("n,noise", [(200, 0.0), (360, 0.0), (360, 0.0005), (600, 0.0005)])
def test_clean_sections_have_no_bad_points(n, noise):
    pts, _, _ = clean_section(0.5, n, noise=noise, seed=n)
    bad, d, _, _ = detect_bad_points(pts)
    assert not bad.any(), f"clean points flagged: {np.flatnonzero(bad)}, worst {d.max() * 1000:.2f} µm"


@pytest.mark.parametrize("h,n,noise", [(0.5, 360, 0.0), (0.2, 300, 0.0), (0.8, 500, 0.0005)])
def test_every_injected_run_found_and_no_clean_point_flagged(h, n, noise):
    clean, normals, _ = clean_section(h, n, noise=noise, seed=7)
    bad_pts, injected = with_bad_runs(clean, normals)
    f = fair_section(bad_pts)
    assert np.array_equal(f.bad, injected), (np.flatnonzero(f.bad & ~injected), np.flatnonzero(injected & ~f.bad))
    expected = sorted((int(fr * n), k) for fr, k, _ in RUNS)
    assert sorted(f.runs) == expected
    # replaced points land back on the true section (distance to a dense sampling of it)
    dense, _, _ = clean_section(h, 200000)
    assert cKDTree(dense).query(f.faired[injected])[0].max() < 0.003
    # the reported displacement is the injected one, give or take the slide along the section
    for fr, k, dd in RUNS:
        i = int(fr * n)
        assert np.allclose(f.displacement[i:i + k], abs(dd), atol=0.005)
    assert np.all(f.displacement[~injected] == 0.0)
    assert np.array_equal(f.original, bad_pts), "the original points must be kept as given"


@pytest.mark.parametrize("h", [0.1, 0.5, 0.9])
def test_inflections_back_to_the_clean_sections(h):
    # the section curve through the points (the interpolation path of the reconstruction)
    clean, normals, _ = clean_section(h, 360)
    bad_pts, _ = with_bad_runs(clean, normals)
    n_clean = count_inflections(interpolate_closed_curve(clean), AXIS)
    n_bad = count_inflections(interpolate_closed_curve(bad_pts), AXIS)
    n_faired = count_inflections(interpolate_closed_curve(fair_section(bad_pts).faired), AXIS)
    # the true section: convex edges, a concave stretch on the pressure side -> 2 changes
    assert n_clean == 2
    assert n_bad > n_clean + 10
    assert n_faired == n_clean


def test_surface_from_faired_sections_within_3um_of_the_truth():
    heights = np.linspace(0.0, 1.0, 6)
    clean, bad = [], []
    for k, h in enumerate(heights):
        c, nrm, _ = clean_section(h, 300, start=0.011 + 0.01 * k)
        clean.append(c)
        bad.append(with_bad_runs(c, nrm)[0] if k in (1, 3, 4) else c)
    faired = [fair_section(p).faired for p in bad]
    truth = np.concatenate(clean)
    d_bad = project_points_to_surface(reconstruct(bad, AXIS, method="interpolate").surface, truth).distance
    d_fair = project_points_to_surface(reconstruct(faired, AXIS, method="interpolate").surface, truth).distance
    assert d_bad.max() > 0.1          # the 0.2 mm point is interpolated without fairing
    assert d_fair.max() < 0.003, f"{d_fair.max() * 1000:.2f} µm"


def test_auxiliary_cubic_puts_replaced_points_back_on_a_circle():
    th = np.linspace(0, 2 * np.pi, 600, endpoint=False)    # 0.21 mm apart, as on a measured flank
    R = 20.0
    circle = np.c_[R * np.cos(th), R * np.sin(th), np.zeros_like(th)]
    bad = np.zeros(600, dtype=bool)
    bad[40:45] = True
    moved = circle.copy()
    moved[bad] *= 1.002
    curve, t, _ = fair_fit(moved, (~bad).astype(float))
    out = replace_runs(moved, bad, curve, t)
    r = np.linalg.norm(out[bad], axis=1)
    assert np.abs(r - R).max() < 2e-4
    # equal parameter steps between the good neighbours: replaced points spread evenly
    gaps = np.linalg.norm(np.diff(out[39:46], axis=0), axis=1)
    assert gaps.max() / gaps.min() < 1.05


def test_runs_wrap_around_the_loop():
    b = np.zeros(10, dtype=bool)
    b[[0, 1, 8, 9, 4]] = True
    assert sorted(bad_runs(b)) == [(4, 1), (8, 4)]


def test_fairing_refuses_a_gross_move():
    clean, normals, _ = clean_section(0.5, 300)
    pts = clean.copy()
    pts[100] += 2.0 * normals[100]
    with pytest.raises(BladeReconError, match="refused.*point 100"):
        fair_section(pts, max_move=0.5, name="S3")
    f = fair_section(pts, max_move=3.0)
    assert f.runs == ((100, 1),)


def test_fair_fit_is_close_to_the_truth_on_clean_points():
    pts, _, _ = clean_section(0.3, 400)
    curve, t, d = fair_fit(pts)
    assert d.max() < 0.001
    # and midway between the points along the flanks (the edges are barely resolved by
    # 400 points: a cubic through them rings around the curvature jumps between samples)
    step = np.mod(np.roll(t, -1) - t, 1.0)
    flank = ~edge_zones(pts)
    mid = evaluate_curve(curve, np.mod(t + 0.5 * step, 1.0))[flank]
    dense, _, _ = clean_section(0.3, 200000)          # 0.6 µm apart: nearest sample within 0.3 µm
    assert cKDTree(dense).query(mid)[0].max() < 0.002


def test_nasa_rotor67_design_table_has_no_bad_points():
    """NASA's Rotor 67 sections (a design table, uneven spacing 0.03-8 mm): nothing to fair
    at 0.01 mm, and at the default 3 µm nothing in sections 2-14 (the hub section refuses)."""
    from pathlib import Path

    from bladerecon.core.io.readers import read_points
    from bladerecon.core.sections.ordering import build_sections

    f = Path(__file__).resolve().parent / "data" / "nasa_rotor67" / "rotor67_sections_xyz_mm.txt"
    secs = build_sections(read_points(str(f))).sections
    for s in secs:
        assert not fair_section(s.points, 0.01).bad.any()
    for s in secs[1:]:
        assert not fair_section(s.points).bad.any()
    with pytest.raises(BladeReconError, match="refused"):
        fair_section(secs[0].points)
