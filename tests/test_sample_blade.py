# SPDX-License-Identifier: LGPL-2.1-or-later
"""The analytic sample blade: exact geometry, outward normals, sampling layouts."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from bladerecon.core.errors import BladeReconError
from bladerecon.samples.blade import (
    SampleBlade,
    dense_truth,
    nominal_grid,
    sample_sections,
    section_heights,
    t_at_length_fraction,
)

BLADE = SampleBlade()
HEIGHTS = (0.0, 0.37, 1.0)


def _polygon(h: float, n: int = 4000) -> np.ndarray:
    return BLADE.point(h, np.arange(n) / n)[:, :2]


def _inside(poly: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Even-odd ray casting, vectorised over query points and edges."""
    a, b = poly, np.roll(poly, -1, axis=0)
    qx, qy = q[:, 0:1], q[:, 1:2]
    crosses = (a[:, 1] > qy) != (b[:, 1] > qy)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_at = a[:, 0] + (qy - a[:, 1]) * (b[:, 0] - a[:, 0]) / (b[:, 1] - a[:, 1])
    return (crosses & (qx < x_at)).sum(axis=1) % 2 == 1


def _fit_circle(p: np.ndarray) -> tuple[np.ndarray, float]:
    """Algebraic (Kasa) circle fit: exact for points exactly on a circle."""
    mean = p.mean(axis=0)
    q = p - mean
    a = np.column_stack([2 * q, np.ones(len(q))])
    sol = np.linalg.lstsq(a, (q * q).sum(axis=1), rcond=None)[0]
    return mean + sol[:2], float(np.sqrt(sol[2] + sol[:2] @ sol[:2]))


@pytest.mark.parametrize("h", HEIGHTS)
def test_points_lie_on_the_section_plane(h):
    p = BLADE.point(h, np.linspace(0, 1, 500))
    assert np.all(p[:, 2] == BLADE.z_of(h))
    sections = sample_sections(BLADE, noise=0.0)
    for hk, sec in zip(section_heights(6), sections):
        assert np.all(sec[:, 2] == BLADE.z_of(hk))


def test_z_of_and_inverse():
    h = np.array([0.0, 0.25, 1.0])
    assert np.allclose(BLADE.z_of(h), [0.0, 25.0, 100.0])
    assert np.allclose(BLADE.h_of_z(BLADE.z_of(h)), h)


@pytest.mark.parametrize("h", HEIGHTS)
def test_profile_is_closed_simple_and_counter_clockwise(h):
    assert np.allclose(BLADE.point(h, 0.0), BLADE.point(h, 1.0), atol=1e-12, rtol=0)
    poly = _polygon(h, 1500)
    x, y = poly[:, 0], poly[:, 1]
    area = 0.5 * np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y)
    assert area > 0                                              # CCW about +z
    # no two non-adjacent edges intersect
    a, b = poly, np.roll(poly, -1, axis=0)
    d = b - a

    def cross(u, v):
        return u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]

    ac = a[None, :, :] - a[:, None, :]
    den = cross(d[:, None, :], d[None, :, :])
    with np.errstate(divide="ignore", invalid="ignore"):
        s = cross(ac, d[None, :, :]) / den
        u = cross(ac, d[:, None, :]) / den
    hit = (s > 0) & (s < 1) & (u > 0) & (u < 1)
    n = len(poly)
    i, j = np.nonzero(hit)
    adjacent = (np.abs(i - j) <= 1) | (np.abs(i - j) == n - 1)
    assert not np.any(hit[i[~adjacent], j[~adjacent]])


@pytest.mark.parametrize("h", HEIGHTS)
def test_edge_circle_radii_are_recovered_exactly(h):
    laws = BLADE.section_laws(h)
    b = BLADE.segment_bounds(h)
    le_t = np.concatenate([np.linspace(b[4], 1, 20, endpoint=False), np.linspace(0, b[1], 20)])
    te_t = np.linspace(b[2], b[3], 30)
    for t, radius, xi in ((le_t, laws.le_radius, 0.0), (te_t, laws.te_radius, 1.0)):
        p = BLADE.point(h, t)
        centre, r = _fit_circle(p[:, :2])
        assert abs(r - radius) < 1e-9
        assert np.allclose(centre, BLADE.camber_point(h, xi)[:2], atol=1e-9, rtol=0)


@pytest.mark.parametrize("h", HEIGHTS)
def test_points_are_on_the_boundary_of_the_union_of_disks(h):
    """Independent of the envelope formula: every profile point is on some disk and
    inside none (min over xi of |p - C(xi)| - R(xi) is 0)."""
    xi_grid = np.linspace(0, 1, 4001)
    centres = BLADE.camber_point(h, xi_grid)[:, :2]
    radii = BLADE.half_thickness(h, xi_grid)
    pts = BLADE.point(h, np.linspace(0, 1, 60, endpoint=False))[:, :2]
    gap = np.linalg.norm(pts[:, None, :] - centres[None], axis=-1) - radii
    assert gap.min() > -1e-9
    for p, k in zip(pts, gap.argmin(axis=1)):
        def gap_at(x, p=p):
            return np.linalg.norm(p - BLADE.camber_point(h, x)[:2]) - BLADE.half_thickness(h, x)

        lo, hi = xi_grid[max(k - 1, 0)], xi_grid[min(k + 1, xi_grid.size - 1)]
        res = minimize_scalar(gap_at, bounds=(lo, hi), method="bounded", options={"xatol": 1e-12})
        assert abs(min(res.fun, gap_at(lo), gap_at(hi))) < 1e-9   # edge points: at xi = 0 or 1


@pytest.mark.parametrize("h", HEIGHTS)
def test_normals_are_unit_outward_and_perpendicular_to_tangents(h):
    t = np.linspace(0, 1, 400, endpoint=False)
    t = np.concatenate([t, BLADE.segment_bounds(h)[1:5]])           # include the G1 joints
    n = BLADE.normal(h, t)
    p = BLADE.point(h, t)
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-14)
    poly = _polygon(h)
    assert not np.any(_inside(poly, p[:, :2] + 0.01 * n[:, :2]))
    assert np.all(_inside(poly, p[:, :2] - 0.01 * n[:, :2]))
    # central differences (not across the joints: the speed in t jumps there)
    t = t[:400]
    d = 1e-6
    hh = np.clip(h, d, 1 - d)
    st = (BLADE.point(hh, t + d) - BLADE.point(hh, t - d)) / (2 * d)
    sh = (BLADE.point(hh + d, t) - BLADE.point(hh - d, t)) / (2 * d)
    n = BLADE.normal(hh, t)
    for tangent in (st, sh):
        unit = tangent / np.linalg.norm(tangent, axis=1, keepdims=True)
        assert np.abs((unit * n).sum(axis=1)).max() < 1e-8
    cross = np.cross(st, sh)
    assert np.allclose(cross / np.linalg.norm(cross, axis=1, keepdims=True), n, atol=1e-8)


@pytest.mark.parametrize("h", HEIGHTS)
def test_edges_join_the_flanks_tangentially(h):
    joints = BLADE.segment_bounds(h)[1:5]
    n = BLADE.normal(h, joints)
    d = 1e-6
    for step in (d, -d):                       # second-order one-sided tangents, each side
        tangent = (-3 * BLADE.point(h, joints) + 4 * BLADE.point(h, joints + step)
                   - BLADE.point(h, joints + 2 * step)) / (2 * step)
        unit = tangent / np.linalg.norm(tangent, axis=1, keepdims=True)
        assert np.abs((unit * n).sum(axis=1)).max() < 1e-8


@pytest.mark.parametrize("h", HEIGHTS)
def test_curvature_matches_the_edge_radii_and_a_numeric_estimate(h):
    b = BLADE.segment_bounds(h)
    laws = BLADE.section_laws(h)
    assert np.allclose(BLADE.curvature(h, [0.0, b[4] + 1e-3]), 1 / laws.le_radius, rtol=1e-12)
    assert np.isclose(BLADE.curvature(h, (b[2] + b[3]) / 2), 1 / laws.te_radius, rtol=1e-12)
    t = np.linspace(b[1], b[2], 50)[1:-1]                 # pressure flank
    d = 1e-4
    p0, p1, p2 = (BLADE.point(h, t + k * d)[:, :2] for k in (-1, 0, 1))
    v, acc = (p2 - p0) / (2 * d), (p2 - 2 * p1 + p0) / d ** 2
    numeric = (v[:, 0] * acc[:, 1] - v[:, 1] * acc[:, 0]) / np.linalg.norm(v, axis=1) ** 3
    assert np.allclose(BLADE.curvature(h, t), numeric, atol=1e-5)


def test_section_length_matches_a_dense_polygon():
    for h in HEIGHTS:
        lengths = []
        for n in (40000, 80000):
            p = BLADE.point(h, np.arange(n) / n)
            lengths.append(np.linalg.norm(p - np.roll(p, -1, axis=0), axis=1).sum())
        richardson = (4 * lengths[1] - lengths[0]) / 3          # polygon error ~ 1/n^2
        assert abs(BLADE.section_length(h) - richardson) < 1e-7


def test_le_te_points_and_chord():
    h = np.array([0.0, 0.5, 1.0])
    le, te = BLADE.le_te(h)
    assert np.allclose(le, BLADE.point(h, 0.0), atol=1e-12, rtol=0)
    assert np.allclose(te, BLADE.point(h, BLADE.te_parameter(h)), atol=1e-12, rtol=0)
    assert np.allclose(np.linalg.norm(te - le, axis=1), BLADE.section_laws(h).chord)


def test_max_thickness_is_at_the_given_position():
    h = 0.3
    xi = np.linspace(0, 1, 100001)
    r = BLADE.half_thickness(h, xi)
    assert abs(xi[r.argmax()] - BLADE.tmax_position) < 1e-4
    assert np.isclose(2 * r.max(), BLADE.section_laws(h).max_thickness, rtol=1e-9)


def test_noise_has_the_requested_sigma():
    clean = np.vstack(sample_sections(BLADE, noise=0.0, seed=3))
    noisy = np.vstack(sample_sections(BLADE, noise=0.002, seed=3))
    diff = noisy - clean
    assert np.allclose(diff.std(axis=0), 0.002, rtol=0.05)
    assert np.all(np.abs(diff.mean(axis=0)) < 1e-4)


def test_uniform_layout_is_equally_spaced_with_a_random_start():
    sections = sample_sections(BLADE, noise=0.0, seed=1)
    assert len(sections) == 6 and all(s.shape == (2000, 3) for s in sections)
    for h, sec in zip(section_heights(6), sections):
        gaps = np.linalg.norm(sec - np.roll(sec, -1, axis=0), axis=1)
        assert np.allclose(gaps, BLADE.section_length(h) / 2000, rtol=1e-3)
    first = [sample_sections(BLADE, noise=0.0, seed=s)[0][0] for s in (1, 2)]
    assert not np.allclose(first[0], first[1])


def test_plan_layout_is_sparse_and_dense_at_the_edges():
    sections = sample_sections(BLADE, layout="plan", noise=0.0)
    for h, sec in zip(section_heights(6), sections):
        assert sec.shape == (65, 3)
        assert np.allclose(sec[0], BLADE.le_te(h)[0], atol=1e-9)
        laws = BLADE.section_laws(h)
        gaps = np.linalg.norm(sec - np.roll(sec, -1, axis=0), axis=1)
        on_edge = np.zeros(len(sec), dtype=bool)
        for xi, r in ((0.0, laws.le_radius), (1.0, laws.te_radius)):
            dist = np.linalg.norm(sec[:, :2] - BLADE.camber_point(h, xi)[:2], axis=1)
            on_edge |= np.abs(dist - r) < 1e-9
        edge_pair = on_edge & np.roll(on_edge, -1)
        flank_pair = ~on_edge & ~np.roll(on_edge, -1)
        assert edge_pair.sum() >= 4
        assert gaps[edge_pair].max() <= gaps[flank_pair].min()


def test_scramble_shuffles_the_same_points():
    ordered = sample_sections(BLADE, n_points=300, noise=0.0, seed=5)
    mixed = sample_sections(BLADE, n_points=300, noise=0.0, seed=5, scramble=True)
    for a, b in zip(ordered, mixed):
        assert not np.array_equal(a, b)
        assert np.array_equal(np.unique(a, axis=0), np.unique(b, axis=0))


def test_t_at_length_fraction_starts_at_the_le_point():
    t = t_at_length_fraction(BLADE, 0.5, [0.0, 0.5])
    assert t[0] == 0.0 and 0.4 < t[1] < 0.6


def test_dense_truth_and_nominal_grid():
    grid = nominal_grid(BLADE, n_span=5, n_profile=50)
    assert grid.shape == (50, 5, 3)
    assert np.allclose(grid[0], BLADE.le_te(np.linspace(0, 1, 5))[0], atol=1e-9)
    truth = dense_truth(BLADE)
    assert truth.shape == (41 * 400, 3)
    z_levels = np.unique(truth[:, 2])
    assert z_levels.size == 41
    assert np.all(np.isin(BLADE.z_of(section_heights(6)), z_levels))


@pytest.mark.parametrize("change", [dict(camber_hub=0.0), dict(thickness_tip=0.01),
                                    dict(chord_tip=1.0), dict(tmax_position=0.95),
                                    dict(le_radius_hub=3.0),
                                    dict(camber_hub=110.0, thickness_hub=0.3)])
def test_impossible_parameters_raise(change):
    with pytest.raises(BladeReconError):
        SampleBlade(**change)
