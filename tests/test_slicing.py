# SPDX-License-Identifier: LGPL-2.1-or-later
"""Unordered clouds cut into sections by planes and cylinders; bad input named."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.projection import project_points_to_surface
from bladerecon.core.reconstruct import reconstruct
from bladerecon.core.sections.ordering import build_sections
from bladerecon.core.sections.slicing import (
    plane_positions,
    read_cloud,
    slice_cylinders,
    slice_planes,
    slices_to_pointset,
)
from realdata_fixtures import BLADE
from bladerecon.samples.blade import t_at_length_fraction

AXIS = np.array([0.0, 0.0, 1.0])


def _cloud(n=200_000, seed=0):
    """Random points on the true blade surface, no order, no sections."""
    rng = np.random.default_rng(seed)
    h = rng.random(n)
    t = rng.random(n)
    return BLADE.point(h, t)


def _true_section(h, n=20000):
    return BLADE.point(h, t_at_length_fraction(BLADE, h, np.arange(n) / n))


def test_plane_slices_lie_on_the_true_sections():
    cloud = _cloud()
    z = np.array([20.0, 50.0, 80.0])
    slices = slice_planes(cloud, z, slab=0.1)
    for s, zk in zip(slices, z):
        assert np.allclose(s.points[:, 2], zk)
        d = cKDTree(_true_section(zk / 100.0, 50000)).query(s.points)[0]
        # moving a point 0.05 mm along the axis slides it along the surface; the surface
        # leans by up to ~0.15 mm/mm (twist at the edges): a few µm off the section
        assert d.max() < 0.010 and s.outliers.size == 0


def test_sliced_cloud_reconstructs_the_blade():
    cloud = _cloud(400_000, seed=1)
    z = np.linspace(5.0, 95.0, 7)
    slices = slice_planes(cloud, z, slab=0.1)
    ps = slices_to_pointset(slices, np.arange(len(cloud)) + 1, "cloud")
    secs = build_sections(ps)
    rec = reconstruct([s.points for s in secs.sections], secs.span_axis)
    truth = np.concatenate([_true_section(zk / 100.0, 400) for zk in z])
    d = project_points_to_surface(rec.surface, truth).distance
    # ~400 randomly spaced points per slice leave the 0.45-0.9 mm edges thinly covered: the
    # flanks are within a few µm, the worst edge point ~0.1 mm (measured 0.5 µm median,
    # 19 µm at the 99th percentile, 0.11 mm max)
    assert np.median(d) < 0.002 and np.percentile(d, 95) < 0.01 and d.max() < 0.2


def test_cylinder_slices_of_a_bent_blade():
    # the sample blade bent onto a rotor: radius = 150 + z, axial = x, tangential arc = y
    cloud = _cloud(300_000, seed=2)
    R = 150.0 + cloud[:, 2]
    rotor = np.c_[R * np.cos(cloud[:, 1] / R), R * np.sin(cloud[:, 1] / R), cloud[:, 0]]
    radii = np.array([170.0, 200.0, 230.0])
    slices = slice_cylinders(rotor, radii, slab=0.1)
    for s, rk in zip(slices, radii):
        r = np.hypot(s.points[:, 0], s.points[:, 1])
        assert np.allclose(r, rk)
        back = np.c_[s.points[:, 2], rk * np.arctan2(s.points[:, 1], s.points[:, 0]), np.full(len(r), rk - 150)]
        d = cKDTree(_true_section((rk - 150) / 100.0, 50000)).query(back)[0]
        assert d.max() < 0.010


def test_outliers_removed_and_reported():
    cloud = _cloud(100_000)
    far = np.array([[60.0, 60.0, 50.0], [-70.0, 40.0, 50.01], [0.0, 80.0, 49.99]])
    s = slice_planes(np.vstack([cloud, far]), [50.0], slab=0.1)[0]
    assert sorted(s.outliers) == [100_000, 100_001, 100_002]


def test_two_blades_in_one_slab_is_an_error():
    cloud = _cloud(100_000)
    two = np.vstack([cloud, cloud + [0.0, 45.0, 0.0]])
    with pytest.raises(BladeReconError, match="two blades"):
        slice_planes(two, [50.0], slab=0.2)


def test_too_few_points_and_overlapping_slabs_are_errors():
    cloud = _cloud(20_000)
    with pytest.raises(BladeReconError, match="slice at 50.0000 mm: .* needs at least 12"):
        slice_planes(cloud, [50.0], slab=0.001)
    s = slice_planes(cloud, [50.0, 50.5], slab=2.0)
    with pytest.raises(BladeReconError, match="share points"):
        slices_to_pointset(s, np.arange(len(cloud)) + 1, "cloud")
    with pytest.raises(BladeReconError, match="at least 2"):
        plane_positions(cloud, AXIS, 1)


def test_read_cloud_metres_and_ids(tmp_path):
    f = tmp_path / "c.txt"
    f.write_text("# id x y z\n1 0.1 0.2 0.3\n" + "".join(f"{k} 0.{k} 0.1 0.2\n" for k in range(2, 20)))
    P, lines = read_cloud(str(f), 1000.0)
    assert P.shape == (19, 3) and np.allclose(P[0], [100.0, 200.0, 300.0]) and lines[0] == 2
    f.write_text("1 2\n")
    with pytest.raises(BladeReconError, match="line 1"):
        read_cloud(str(f))


def test_rotor67_cloud_against_the_nasa_section_table():
    """The ParaBlade Rotor 67 cloud, sliced by cylinders through its mesh rows, against NASA's
    own section table (an independent source of the same blade). The two files share the
    frame up to 0.01 mm / 0.002° (bench_realdata fits it): compared here as they are."""
    from pathlib import Path

    from bladerecon.core.io.readers import read_points

    data = Path(__file__).resolve().parent / "data"
    cloud_file = data / "parablade_r67_cloud" / "NASA_R67_MoveSurface.txt"
    table_file = data / "nasa_rotor67" / "rotor67_sections_xyz_mm.txt"
    P, lines = read_cloud(str(cloud_file), 1000.0)
    radii = [150.8, 165.2, 179.6, 194.1, 208.6, 222.7, 237.0, 251.6]
    slices = slice_cylinders(P, radii, slab=12.0, project=False)
    assert [len(s.points) for s in slices] == [187] * 8
    secs = build_sections(slices_to_pointset(slices, lines, str(cloud_file)))
    surf = reconstruct([s.points for s in secs.sections], secs.span_axis).surface
    T = read_points(str(table_file)).points                  # x axial, y = R sin θ, z = R cos θ
    R, th = np.hypot(T[:, 1], T[:, 2]), np.arctan2(T[:, 1], T[:, 2])
    keep = (R > 152.8) & (R < 249.6)
    Q = np.c_[R * np.cos(th), R * np.sin(th), T[:, 0]][keep]  # the cloud's frame: z axial
    d = project_points_to_surface(surf, Q).distance
    assert np.mean(d) < 0.03 and np.percentile(d, 95) < 0.08 and d.max() < 0.2


def test_a_thick_slab_is_moved_onto_the_cut_along_the_surface():
    """A 4.5 mm slab (a quarter of the gap between six slices) of a noisy random cloud.
    Moved straight along the axis, a point ``offset`` above the cut lands ``offset x slope``
    off its section (the sample blade's walls lean up to ~0.15 mm/mm: rms over a uniform
    +-2.25 mm offset ~0.09 mm, measured 0.09-0.11 mm, max 0.4 mm). Slid along its tangent plane
    (the median drift of its neighbours), the error is the drift's noise times the offset plus
    the spanwise curvature's second-order term: measured 9-10 µm rms, 0.13 mm max at an edge.
    The straight move is the referee of the first claim and must stay as bad as the formula
    says (so the data really is hard)."""
    rng = np.random.default_rng(4)
    cloud = _cloud(200_000, seed=4) + 0.002 * rng.standard_normal((200_000, 3))
    z = np.linspace(5.0, 95.0, 6)
    for zk, s in zip(z[1:-1], slice_planes(cloud, z, slab=4.5)[1:-1]):
        true = cKDTree(_true_section(zk / 100.0, 50000))
        moved = true.query(s.points)[0]
        straight = true.query(cloud[s.index] - np.outer(cloud[s.index, 2] - zk, [0.0, 0.0, 1.0]))[0]
        rms = lambda d: float(np.sqrt(np.mean(d ** 2)))         # noqa: E731
        assert rms(straight) > 0.06, rms(straight)
        assert rms(moved) < 0.015 and np.percentile(moved, 99) < 0.04 and moved.max() < 0.2, \
            (rms(moved), np.percentile(moved, 99), moved.max())


def test_the_default_slab_of_a_dense_cloud_holds_a_few_thousand_points():
    """A quarter of the gap on a sparse cloud; on a dense one, narrowed so that a slab holds
    about SLAB_POINTS points (each point moved onto the cut adds error in proportion to its
    offset: nothing is gained by more points in a thicker slab)."""
    from bladerecon.core.sections.slicing import SLAB_POINTS

    z = np.linspace(5.0, 95.0, 6)
    sparse = slice_planes(_cloud(20_000, seed=5), z)
    assert all(abs(s.slab - 4.5) < 1e-9 for s in sparse)
    dense = slice_planes(_cloud(400_000, seed=6), z)
    counts = [len(s.points) for s in dense]
    assert dense[0].slab < 1.0 and 0.7 * SLAB_POINTS < np.median(counts) < 1.3 * SLAB_POINTS, (dense[0].slab, counts)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_sliced_50000_point_scan_reconstructs_within_its_error(tmp_path, seed):
    """``reconstruct CLOUD --slice 6`` as a user runs it, on 50 000 random points of the sample
    blade with 2 µm noise, against the nominal. The section fits used to split knot spans down
    to halves with no point, held only by the fairness term: 1500 poles on ~1500 points, the
    curves waving between them, 5.9-31 mm from the nominal (seeds 0-2). A span is now split
    only when both halves keep two points: 0.28-0.43 mm max, 0.05-0.07 mm rms (the slid points
    are 7 µm rms off; the rest is the smoothing following their slowly varying error, see
    docs/limitations.md)."""
    import json
    import subprocess
    import sys
    from pathlib import Path

    rng = np.random.default_rng(seed)
    P = BLADE.point(rng.random(50_000), rng.random(50_000)) + 0.002 * rng.standard_normal((50_000, 3))
    f = tmp_path / "scan.csv"
    f.write_text("x,y,z\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in P.tolist()))
    root = Path(__file__).resolve().parents[1]
    r = subprocess.run([sys.executable, "-m", "bladerecon", "reconstruct", str(f), "--slice", "6", "--nominal",
                        str(root / "resources" / "sample" / "nominal.step"), "--json", "--quiet"],
                       capture_output=True, text=True, timeout=300, cwd=root)
    assert r.returncode == 0, r.stderr
    shape = json.loads(r.stdout)["nominal"]
    assert shape["max"] < 0.6 and shape["rms"] < 0.08, shape


def test_scan_lines_parallel_to_the_cut_are_not_slid_on_a_guessed_normal():
    """A laser line scan of a vertical cylinder (R 20 mm, lines 0.3 mm apart, points 0.02 mm
    along them, 2 µm noise): a point's ten nearest neighbours lie on its own line and leave
    its normal to the noise. Those points are moved along the axis (exact on a vertical wall):
    within the noise (referee: the radius), not 0.17 mm rms / 1.1 mm as a slide on the guessed
    normals put them."""
    rng = np.random.default_rng(1)
    z = np.arange(-2.0, 2.0, 0.3) + 0.01
    th = np.arange(0.0, 2 * np.pi, 0.02 / 20.0)
    Z, TH = np.meshgrid(z, th)
    P = np.c_[20 * np.cos(TH.ravel()), 20 * np.sin(TH.ravel()), Z.ravel()] + 0.002 * rng.standard_normal((Z.size, 3))
    s = slice_planes(P, [0.0], slab=4.0)[0]
    err = np.abs(np.hypot(s.points[:, 0], s.points[:, 1]) - 20.0)
    assert np.allclose(s.points[:, 2], 0.0)
    assert np.sqrt(np.mean(err ** 2)) < 0.003 and err.max() < 0.012, (np.sqrt(np.mean(err ** 2)), err.max())
