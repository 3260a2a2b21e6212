# SPDX-License-Identifier: LGPL-2.1-or-later
"""Tests that fail on plausible one-line bugs the rest of the suite let through (issue 26).

Each test has a referee the code under test does not share (scipy, a closed form, a shape
built so that the answer is known) and a tolerance derived from the noise and the method,
stated in its docstring. Next to each test: the one-line change it was checked to fail on.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.fitting import approximate_curve
from bladerecon.core.sections.parameters import _max_circle, measure_section, segment_blade, stacking
from bladerecon.core.sections.segmentation import segment_section
from bladerecon.core.surface.fairing import repair_regions
from bladerecon.samples.blade import SampleBlade, t_at_length_fraction

Z = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------- knot placement
def test_least_squares_on_eq_9_69_knots_reproduces_a_spline_of_that_space():
    """NURBS Book eq. 9.69 worked by hand for 13 uniform parameters u_k = k/12 and 7 cubic
    poles: d = 13/4 = 3.25, so the inner knots are 0.75·u2 + 0.25·u3, 0.5·u5 + 0.5·u6 and
    0.25·u8 + 0.75·u9 = 2.25/12, 5.5/12, 8.75/12. Points sampled (by scipy) from a spline
    on exactly those knots lie in the fit's space, so the least-squares fit must give them
    back; only the solver's regularisation separates the two: 1e-14 of the largest
    normal-matrix entry, which the 1e8 end weights of A9.7 make ~1e-6 of the interior entries,
    so ~1e-6 relative on poles of size ~10 mm, times the small system's conditioning (< 10):
    1e-4 mm (measured 1.6e-5). An off-by-one in the knot spacing (d = m/(n-p+1) for (m+1)/(n-p+1)) moves the
    knots by 0.25/12 and leaves the data outside the space: 0.57 mm off.

    Kills: bspline.approximation_knots ``d = m1 / (n - p + 1)`` -> ``d = (m1 - 1) / (n - p + 1)``.
    """
    u = np.arange(13) / 12.0
    inner = np.array([2.25, 5.5, 8.75]) / 12.0
    full = np.concatenate([np.zeros(4), inner, np.ones(4)])
    poles = np.random.default_rng(26).uniform(-10.0, 10.0, size=(7, 3))
    truth = BSpline(full, poles, 3)
    fit = approximate_curve(truth(u), 7, 3, params=u)
    fine = np.linspace(0.0, 1.0, 2001)
    err = np.abs(BSpline(fit.full_knots(), fit.poles, 3)(fine) - truth(fine)).max()
    assert err < 1e-4, err
    assert np.allclose(fit.full_knots(), full, atol=1e-12), fit.full_knots()


# --------------------------------------------------------------------------- stacking
def test_stacking_of_a_swept_and_leaned_prismatic_blade_is_its_sweep_and_lean():
    """A sample blade with one section shape at every height (no twist, no taper) and sweep
    4 mm, lean 3 mm at the tip: each section is the hub section moved by (4h², 3h², 100h) mm,
    so its centroid is too, and the stacking is that shift in closed form (sweep along +x,
    lean along span × axial = +y, twist 0). The sections are sampled at the same arc-length
    fractions, so they are exact translated copies; what the pipeline (segmentation, section
    curve, polygon centroid) does to one it does to all, and only rounding is left: 1e-6 mm.
    A lean of the wrong sign is off by 2·3h² (6 mm at the tip).

    Kills: parameters.stacking ``tg = np.cross(a, ax)`` -> ``tg = np.cross(ax, a)``.
    """
    blade = SampleBlade(chord_tip=56.0, camber_tip=38.0, thickness_tip=0.095, le_radius_tip=0.9,
                        te_radius_tip=0.6, twist=0.0, sweep_tip=4.0, lean_tip=3.0)
    heights = (0.0, 0.5, 1.0)
    fractions = (np.arange(300) + 0.37) / 300
    secs = [blade.point(h, t_at_length_fraction(blade, h, fractions)) for h in heights]
    segs = segment_blade(secs, Z, flow=np.array([1.0, 0.0, 0.0])).sections
    st = stacking([measure_section(s) for s in segs], Z)
    for h, row in zip(heights, st):
        assert row["sweep"] == pytest.approx(4.0 * h * h, abs=1e-6), row
        assert row["lean"] == pytest.approx(3.0 * h * h, abs=1e-6), row
        assert row["height"] == pytest.approx(100.0 * h, abs=1e-6), row
        assert abs(row["twist_deg"]) < 1e-6, row


# --------------------------------------------------------------------------- max thickness position
@pytest.mark.parametrize("offset", [-0.4, -0.1, 0.3])
def test_max_inscribed_circle_is_the_vertex_of_the_parabola_through_the_top_three(offset):
    """Radii r(x) = r0 − k (x − x0)² sampled at stations 0.1 mm apart with x0 a fraction of a
    station off the nearest one: the parabola through the top three samples is r(x) itself,
    so its vertex is (x0, r0) exactly (closed form, x0 = −b/(2a)); round-off only: 1e-9 mm.
    A vertex formula without its factor 2 puts the position off by |x0 − x_k| (0.01-0.04 mm
    here), the radius by k·(x0 − x_k)².

    Kills: parameters._max_circle ``xv = -co[1] / (2 * co[0])`` -> ``xv = -co[1] / co[0]``.
    """
    x = 10.0 + 0.1 * np.arange(60)
    x0, r0, k = x[27] + offset * 0.1, 1.9, 0.004
    r_max, x_max = _max_circle(x, r0 - k * (x - x0) ** 2)
    assert x_max == pytest.approx(x0, abs=1e-9)
    assert r_max == pytest.approx(r0, abs=1e-9)


# --------------------------------------------------------------------------- gap limit
def _section_with_gap(share: float) -> tuple[np.ndarray, float]:
    """The default sample blade's mid-span section (400 points equally spaced in arc length)
    with a run of points on the pressure flank removed so that the gap is just above
    ``share`` of the section's extent; returns the points and gap / extent (brute force)."""
    blade = SampleBlade()
    P = blade.point(0.5, t_at_length_fraction(blade, 0.5, (np.arange(400) + 0.5) / 400))
    c = P - P.mean(axis=0)
    extent = float(np.ptp(c @ np.linalg.svd(c, full_matrices=False)[2][0]))
    start = 100                                   # a quarter of the way round: mid pressure flank
    for gone in range(1, 200):
        Q = np.concatenate([P[:start], P[start + gone:]])
        gap = float(np.linalg.norm(P[start + gone] - P[start - 1]))
        if gap > share * extent:
            return Q, gap / extent
    raise AssertionError("no gap that wide")


def test_a_gap_is_refused_from_15_percent_of_the_section_extent():
    """The documented default (``max_gap``: 15 % of the section's extent) pinned with data on
    each side of it: gaps of ~13.5 % and ~16 % of the extent on a smooth flank (points 0.28 mm
    apart, so a gap lands within 0.5 % of the extent above the share asked). The first must
    segment, the second must be refused with the point numbers. A
    limit moved by a tenth of itself either way fails one of the two.

    Kills: segmentation._check_closed ``limit = 0.15 * extent`` -> ``limit = 0.25 * extent``.
    """
    ok, share_ok = _section_with_gap(0.135)
    bad, share_bad = _section_with_gap(0.16)
    assert 0.135 < share_ok < 0.14 and 0.16 < share_bad < 0.165, (share_ok, share_bad)
    seg = segment_section(ok, 0, Z)
    assert seg.curve is not None
    with pytest.raises(BladeReconError, match=r"section 0: gap of [\d.]+ mm between points 100 and 101"):
        segment_section(bad, 0, Z)


# --------------------------------------------------------------------------- region repair threshold
def test_region_repair_starts_at_20_micrometres():
    """Seed 004 §3 step 5: a grid cell is unfair when its measured points lie more than 0.02 mm
    from the surface. Cells at 0.022 mm (10 % above) must be rebuilt, cells at 0.018 mm (10 %
    below) left alone, so a limit moved by more than a tenth either way fails. The grid is
    11 sections x 120 true points of the sample blade; the rebuilt points stay on the true
    section within 3 µm (the fairing's own limit).

    Kills: surface.fairing ``REPAIR_THRESHOLD = 0.02`` -> ``0.03`` (no other test fails) and
    -> ``0.002`` (also failed by the ``--fair-surface`` command test, through its refusal).
    """
    blade = SampleBlade()
    H = np.linspace(0.0, 1.0, 11)
    n = 120
    G = np.stack([blade.point(h, t_at_length_fraction(blade, h, (0.013 + np.arange(n)) / n)) for h in H])
    err = np.zeros((len(H) - 1, n))
    err[2, 40:44] = 0.022                          # just above: rebuilt
    err[7, 80:84] = 0.018                          # just below: kept
    R, replaced = repair_regions(G, err)
    assert replaced[2:4, 41:44].any(), np.argwhere(replaced)
    assert not replaced[4:, :].any(), np.argwhere(replaced)
    dense = blade.point(H[2], t_at_length_fraction(blade, H[2], np.arange(100000) / 100000))
    d = np.linalg.norm(R[2, replaced[2]][:, None, :] - dense[None, :, :], axis=2).min(axis=1)
    assert d.max() < 0.003, d.max()
