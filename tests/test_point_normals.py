# SPDX-License-Identifier: LGPL-2.1-or-later
"""Points that come with their normals (issue 16 items 4 and 5): ``x y z i j k`` lines (a CMM's
ball centres with the measured surface's normal, an ASC scan), ``nx,ny,nz`` / ``i,j,k`` CSV
columns; and ``deviation --probe-radius`` on such a cloud moving each point along its own normal.

The referee of the compensation is the analytic sample blade (resources/sample/nominal.step is its
surface), twisted 2 degrees as a real part may be: its surface points S and unit normals n are
known exactly, the ball centres are S + r n, and the deviation of S itself (no compensation) is
what the compensated run must give.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.readers import read_points
from bladerecon.samples.blade import SampleBlade, t_at_length_fraction
from cli_run import run

ROOT = Path(__file__).resolve().parents[1]
NOMINAL = ROOT / "resources" / "sample" / "nominal.step"


def _rows(P, N=None, sep=" "):
    cols = P if N is None else np.column_stack([P, N])
    return "".join(sep.join(repr(float(v)) for v in row) + "\n" for row in cols)


# --------------------------------------------------------------------------- reading
def _cloud(seed=0, n=50):
    rng = np.random.default_rng(seed)
    P = rng.uniform(-30, 30, (n, 3))
    N = rng.normal(size=(n, 3))
    return P, N / np.linalg.norm(N, axis=1)[:, None]


def test_xyz_ijk_lines_give_points_and_normals_fast_and_careful_alike(tmp_path):
    P, N = _cloud()
    fast = tmp_path / "fast.xyz"
    fast.write_text(_rows(P, N))
    careful = tmp_path / "careful.xyz"          # CR-only line ends: the careful parser's path
    careful.write_text(_rows(P, N).replace("\n", "\r"))
    a = read_points(fast, require_sections=False)
    b = read_points(careful, require_sections=False)
    for ps in (a, b):
        assert np.array_equal(ps.points, P) and np.allclose(ps.normals, N, atol=1e-15)
        assert ps.line.tolist() == list(range(1, len(P) + 1))
    assert a.format == b.format == "xyz-blocks"


@pytest.mark.parametrize("names", ["nx,ny,nz", "i,j,k", "normal_x,normal_y,normal_z", "NX [mm],NY,NZ"])
def test_csv_normal_columns_in_any_place(tmp_path, names):
    P, N = _cloud(1)
    f = tmp_path / "n.csv"
    a, b, c = names.split(",")
    f.write_text(f"{a},section,x,{b},y,z,{c}\n" + "".join(
        f"{n[0]!r},{1 + k // 25},{p[0]!r},{n[1]!r},{p[1]!r},{p[2]!r},{n[2]!r}\n"
        for k, (p, n) in enumerate(zip(P.tolist(), N.tolist()))))
    ps = read_points(f)
    assert np.array_equal(ps.points, P) and np.allclose(ps.normals, N, atol=1e-15)
    assert ps.section_names == ("1", "2") and ps.section.tolist() == [0] * 25 + [1] * 25


def test_a_normal_that_is_not_unit_names_its_line(tmp_path):
    """``x y z i j k`` lines say the last three are a normal: one that is not is refused."""
    P, N = _cloud(2, 10)
    N[6] *= 1.5
    f = tmp_path / "bad.xyz"
    f.write_text(_rows(P, N))
    with pytest.raises(BladeReconError, match=r"bad.xyz, line 7: the normal .* has length 1.5, not 1"):
        read_points(f, require_sections=False)


def test_csv_columns_that_are_no_normals_are_ignored_as_before(tmp_path):
    """Named columns may hold something else (files read before normals were): not unit, text,
    or not all three (a grid's i, j, k indices; nx, ny alone) -- ignored, the points read."""
    P, N = _cloud(2, 10)
    N[6] *= 1.5
    cases = {"not_unit.csv": "x,y,z,nx,ny,nz\n" + _rows(P, N, ","),
             "grid.csv": "i,j,k,x,y,z\n" + "".join(f"1,{k},1,{x!r},{y!r},{z!r}\n" for k, (x, y, z) in enumerate(P.tolist())),
             "two.csv": "x,y,z,nx,ny\n" + "".join(f"{x!r},{y!r},{z!r},0,1\n" for x, y, z in P.tolist()),
             "text.csv": "x,y,z,i,j,k\n" + "".join(f"{x!r},{y!r},{z!r},a,b,c\n" for x, y, z in P.tolist())}
    for name, text in cases.items():
        f = tmp_path / name
        f.write_text(text)
        ps = read_points(f, require_sections=False)
        assert ps.normals is None and np.array_equal(ps.points, P), name


# --------------------------------------------------------------------------- compensation
@pytest.fixture(scope="module")
def twisted(tmp_path_factory):
    """Surface points S of the sample blade twisted 2 degrees about z, their unit normals n
    (outward), and the deviation of S from the nominal (the truth), per point."""
    tmp = tmp_path_factory.mktemp("normals")
    blade = SampleBlade()
    S, N = [], []
    for h in np.linspace(0.05, 0.95, 9):
        t = t_at_length_fraction(blade, h, (np.arange(120) + 0.5) / 120)
        S.append(blade.point(h, t))
        N.append(blade.normal(h, t))
    S, N = np.concatenate(S), np.concatenate(N)
    a = np.radians(2.0)
    R = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    S, N = S @ R.T, N @ R.T
    surface = tmp / "surface.xyz"
    surface.write_text(_rows(S))
    r = run("deviation", surface, "--nominal", NOMINAL, "--csv", tmp / "truth.csv", "--quiet")
    assert r.returncode == 0, r.stderr
    truth = np.loadtxt(tmp / "truth.csv", delimiter=",", skiprows=1, usecols=3)
    return tmp, S, N, truth


def _compensated(tmp, name, text, radius="1.5"):
    f = tmp / name
    f.write_text(text)
    out = tmp / (name + ".dev.csv")
    r = run("deviation", f, "--nominal", NOMINAL, "--probe-radius", radius, "--csv", out, "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout), np.loadtxt(out, delimiter=",", skiprows=1, usecols=3)


def test_ball_centres_with_their_normals_come_back_exactly(twisted):
    tmp, S, N, truth = twisted
    assert np.abs(truth).max() > 0.3                      # the twist is a real deviation
    centres = S + 1.5 * N
    for name, text in (("balls.xyz", _rows(centres, N)),                     # x y z i j k, outward
                       ("inward.xyz", _rows(centres, -N)),                   # a CMM giving them inward
                       ("balls.csv", "x,y,z,i,j,k\n" + _rows(centres, N, ","))):
        summary, dev = _compensated(tmp, name, text)
        assert summary["compensation"]["normals"] == "file", name
        assert np.abs(dev - truth).max() < 2e-7, (name, np.abs(dev - truth).max())   # the CSV's 7 decimals


def test_without_the_files_normals_the_twist_costs_accuracy(twisted):
    """The nominal's normals are the fallback: off the twisted part's by 2 degrees, they miss the
    true surface point (the reason to use the file's)."""
    tmp, S, N, truth = twisted
    summary, dev = _compensated(tmp, "plain.xyz", _rows(S + 1.5 * N))
    assert summary["compensation"]["normals"] == "nominal"
    assert np.abs(dev - truth).max() > 1e-3, np.abs(dev - truth).max()


def test_a_scans_zero_normals_are_not_taken(tmp_path):
    """A scanner that has no normal for its points may write zeros: not normals (a compensation
    along them would not move the point); unit ones, float32 or double, are kept as written."""
    from scan_files import write_ply
    P, N = _cloud(3)
    zero = read_points(write_ply(tmp_path / "zero.ply", P, np.zeros_like(N)), require_sections=False)
    assert zero.normals is None and np.array_equal(zero.points, P.astype(np.float32).astype(float))
    kept = read_points(write_ply(tmp_path / "unit.ply", P, N, kind="float"), require_sections=False)
    assert np.array_equal(kept.normals, N.astype(np.float32).astype(float))
