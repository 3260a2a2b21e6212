# SPDX-License-Identifier: LGPL-2.1-or-later
"""Scanner files (PLY, PCD) as the commands read them: every layout, files FreeCAD itself writes,
the same answers as the same points in a CSV, and a one-line error for every way a file is bad."""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.readers import read_points
from bladerecon.core.sections.slicing import read_cloud
from cli_run import run
from scan_files import write_pcd, write_ply

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "resources" / "sample"
DATA = ROOT / "tests" / "data"


def _cloud(n=500, seed=0):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(n, 3)) * [30.0, 8.0, 40.0] + [0.0, 0.0, 50.0]
    N = rng.normal(size=(n, 3))
    return P, N / np.linalg.norm(N, axis=1)[:, None]


@pytest.mark.parametrize("fmt", ["binary_little_endian", "binary_big_endian", "ascii"])
@pytest.mark.parametrize("kind", ["float", "double"])
def test_ply_layouts_read_back(tmp_path, fmt, kind):
    P, N = _cloud()
    f = write_ply(tmp_path / "c.ply", P, N, fmt=fmt, kind=kind, face=True, colour=True)
    ps = read_points(f, require_sections=False)
    want = P.astype(np.float32).astype(float) if kind == "float" else P
    wantN = N.astype(np.float32).astype(float) if kind == "float" else N
    if fmt == "ascii":                # the text is the float64 repr whatever the type says: read as written
        want, wantN = P, N
    assert ps.points.shape == (len(P), 3) and not ps.structured and ps.section_names == ("1",)
    assert np.array_equal(ps.points, want) and np.array_equal(ps.normals, wantN)
    assert ps.format == ("ply-ascii" if fmt == "ascii" else "ply-binary")
    # lines of an ASCII file: 3 header lines + vertex + 9 properties + face element (2) + end_header
    first = 17 if fmt == "ascii" else 1
    assert ps.line[0] == first and ps.line[-1] == first + len(P) - 1


@pytest.mark.parametrize("data", ["binary", "ascii"])
@pytest.mark.parametrize("kind", ["F 4", "F 8"])
def test_pcd_layouts_read_back_and_nan_pixels_are_counted(tmp_path, data, kind):
    P, N = _cloud(300, seed=1)
    P[[5, 77]] = np.nan                          # an organised scan's empty pixels
    f = write_pcd(tmp_path / "c.pcd", P, N, data=data, kind=kind)
    ps = read_points(f, require_sections=False)
    keep = np.isfinite(P).all(axis=1)
    want = P[keep].astype(np.float32).astype(float) if kind == "F 4" and data == "binary" else P[keep]
    assert np.array_equal(ps.points, want) and ps.left_out == 2
    assert ps.normals.shape == (298, 3)
    assert 6 not in ps.line.tolist() and ps.format == f"pcd-{data}"


def test_a_scan_without_normals_has_none(tmp_path):
    P, _ = _cloud(50)
    assert read_points(write_ply(tmp_path / "a.ply", P), require_sections=False).normals is None
    assert read_points(write_pcd(tmp_path / "a.pcd", P), require_sections=False).normals is None


def test_files_freecad_writes_read_as_freecad_reads_them(tmp_path):
    """FreeCAD's Points module writes PLY and PCD (its own writers) and reads them back: our
    reader gives FreeCAD's points, and the points FreeCAD was given."""
    from bladerecon.fc.freecad_env import import_freecad

    FreeCAD, _ = import_freecad()
    import Points

    P, _ = _cloud(400, seed=3)
    doc = FreeCAD.newDocument("scan_referee")
    try:
        obj = doc.addObject("Points::Feature", "cloud")
        obj.Points = Points.Points([tuple(map(float, p)) for p in P])
        for ext in ("ply", "pcd"):
            path = str(tmp_path / f"freecad.{ext}")
            Points.export([obj], path)
            ours = read_points(path, require_sections=False).points
            Points.insert(path, doc.Name)
            theirs = np.array([(v.x, v.y, v.z) for v in doc.Objects[-1].Points.Points])
            assert ours.shape == theirs.shape == P.shape, ext
            assert np.abs(ours - theirs).max() <= 1e-5 * np.abs(P).max(), ext   # FreeCAD keeps float32
            assert np.abs(ours - P).max() <= 1e-5 * np.abs(P).max(), ext
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_binary_ply_of_a_million_points_reads_fast(tmp_path):
    P, N = _cloud(1_000_000, seed=4)
    f = write_ply(tmp_path / "m.ply", P, N, kind="float")
    best = min(_timed(lambda: read_points(f, require_sections=False)) for _ in range(3))
    # speed is printed (issue 16 asks 0.1 s; bench/bench_readers.py times it beside numpy): a
    # wall-clock bound fails on a loaded machine (issue 26); the values are checked exactly
    print(f"\n1M-point binary PLY read in {best * 1e3:.0f} ms")
    ps = read_points(f, require_sections=False)
    assert np.array_equal(ps.points, P.astype(np.float32).astype(float))


def _timed(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def _error(path, require_sections=False) -> str:
    with pytest.raises(BladeReconError) as e:
        read_points(path, require_sections=require_sections)
    msg = str(e.value)
    assert "\n" not in msg and str(path) in msg
    return msg


def _mutated(tmp_path, ext: str, cases) -> None:
    """Each (file text, words the one-line message must hold)."""
    for k, (text, words) in enumerate(cases):
        path = tmp_path / f"bad{k}.{ext}"
        path.write_text(text)
        msg = _error(path)
        assert all(w in msg for w in words), (k, words, msg)


def test_bad_ply_files_are_one_line_each(tmp_path):
    P, N = _cloud(40)
    assert "cut short" in _error(write_ply(tmp_path / "t.ply", P, N, cut=7)) and "39 vertices" in \
        _error(write_ply(tmp_path / "t.ply", P, N, cut=7))
    assert "40 vertices" in _error(write_ply(tmp_path / "t.ply", P, count=41, fmt="binary_big_endian"))
    m = _error(write_ply(tmp_path / "a.ply", P, count=41, fmt="ascii"))
    assert "40 vertex rows" in m and "41 vertices" in m
    good = write_ply(tmp_path / "g.ply", P, fmt="ascii").read_text()
    lines = good.splitlines()
    lines[12] = "1.0 2.0"                                          # a row short of a value
    _mutated(tmp_path, "ply", [
        ("\n".join(lines) + "\n", ["line 13", "expected 3 numbers"]),
        (good.replace("property float z", "property quad z"), ["line 7", "unknown PLY property type"]),
        (good.replace("property float z", "property float w"), ["no z property"]),
        (good.replace("end_header", "end_head"), ["end_header"]),
        (good.replace("property float z", "property float z\nproperty list uchar int i"), ["list property"]),
        (good.replace("format ascii", "format binary_middle_endian"), ["unknown PLY format"]),
        (good.replace("element vertex 40", "element vertex 0"), ["0 vertices"]),
    ])
    bad = write_ply(tmp_path / "nan.ply", np.vstack([P[:3], [[np.nan, 0, 0]], P[3:]]))
    assert "vertex 4" in _error(bad) and "NaN" in _error(bad)
    assert "section" in _error(write_ply(tmp_path / "s.ply", P), require_sections=True)


def test_bad_pcd_files_are_one_line_each(tmp_path):
    P, N = _cloud(40)
    assert "cut short" in _error(write_pcd(tmp_path / "t.pcd", P, N, cut=5))
    good = write_pcd(tmp_path / "g.pcd", P, data="ascii").read_text()
    _mutated(tmp_path, "pcd", [
        (good.replace("DATA ascii", "DATA binary_compressed"), ["compressed PCD"]),
        (good.replace("FIELDS x y z", "FIELDS u y z"), ["no x"]),
        (good.replace("TYPE F F F", "TYPE Q F F"), ["TYPE Q"]),
        (good.replace("POINTS 40", "POINTS 45"), ["40 vertex rows"]),
        (good.split("DATA ascii\n")[0] + "DATA ascii\n" + "nan nan nan 0\n" * 40, ["every point"]),
    ])


def test_deviation_of_a_ply_scan_is_the_deviation_of_its_points(tmp_path):
    """The CLI on a binary PLY with normals and on a CSV of the same (float32) points: the same
    figures; and a truncated PLY is one line, exit 2, nothing written."""
    P = np.loadtxt(SAMPLE / "measured.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3))
    P32 = P.astype(np.float32).astype(float)
    ply = write_ply(tmp_path / "scan.ply", P32, _cloud(len(P))[1], kind="float", face=True)
    csv = tmp_path / "scan.csv"
    csv.write_text("x,y,z\n" + "".join(f"{float(a)!r},{float(b)!r},{float(c)!r}\n" for a, b, c in P32))
    out = {}
    for f in (ply, csv):
        r = run("deviation", f, "--nominal", SAMPLE / "nominal.step", "--align", "rigid", "--json", "--quiet")
        assert r.returncode == 0, r.stderr
        out[f.suffix] = json.loads(r.stdout)
    for key in ("points", "max", "min", "rms", "within_tolerance_pct"):
        assert out[".ply"][key] == out[".csv"][key], key
    cut = write_ply(tmp_path / "cut.ply", P32, kind="float", cut=100)
    r = run("deviation", cut, "--nominal", SAMPLE / "nominal.step", "--csv", tmp_path / "d.csv", "--quiet")
    assert r.returncode == 2 and "cut short" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    assert "Traceback" not in r.stderr and not (tmp_path / "d.csv").exists()


def test_a_real_cloud_as_binary_ply_slices_as_its_text(tmp_path):
    """The ParaBlade Rotor 67 cloud (metres) written as a binary PLY: read_cloud gives the same
    points as from the text file, and ``reconstruct --slice-radii`` the same surface."""
    text = DATA / "parablade_r67_cloud" / "NASA_R67_MoveSurface.txt"
    P, _ = read_cloud(str(text), 1.0)
    ply = write_ply(tmp_path / "r67.ply", P, kind="double")
    Q, idx = read_cloud(str(ply), 1000.0)
    assert np.array_equal(Q, P * 1000.0) and idx[0] == 1
    args = ["--cloud-scale", "1000", "--slice-radii", "150.8,179.6,208.6,237.0,251.6", "--slab", "12", "--slab-keep",
            "--json", "--quiet"]
    res = {}
    for f in (text, ply):
        r = run("reconstruct", f, "-o", tmp_path / f"{f.suffix}.step", *args)
        assert r.returncode == 0, r.stderr
        res[f.suffix] = json.loads(r.stdout)
    assert res[".ply"]["fit"]["n"] == res[".txt"]["fit"]["n"] > 0
    for key in ("max", "rms"):
        assert res[".ply"]["fit"][key] == res[".txt"]["fit"][key], key
    assert res[".ply"]["surface"] == res[".txt"]["surface"]


def test_what_real_writers_put_in_a_header(tmp_path):
    """Padding fields named ``_`` (PCL), a tab after DATA, a comment that is not ASCII, a line of
    spaces among the rows (its line number is skipped, as numpy skips it); a coordinate given
    twice is one line."""
    P, _ = _cloud(10)
    head = ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z _ _\nSIZE 4 4 4 1 1\nTYPE F F F U U\nCOUNT 1 1 1 4 4\n"
            "WIDTH 10\nHEIGHT 1\nPOINTS 10\nDATA\tbinary\n")
    table = np.zeros(10, np.dtype([("x", "<f4"), ("y", "<f4"), ("z", "<f4"), ("a", "u1", (4,)), ("b", "u1", (4,))]))
    table["x"], table["y"], table["z"] = P.T
    (tmp_path / "pad.pcd").write_bytes(head.encode() + table.tobytes())
    assert np.array_equal(read_points(tmp_path / "pad.pcd", require_sections=False).points,
                          P.astype(np.float32).astype(float))
    raw = write_ply(tmp_path / "c.ply", P).read_bytes().replace(b"comment written", "comment gemessen für".encode())
    (tmp_path / "c.ply").write_bytes(raw)
    assert read_points(tmp_path / "c.ply", require_sections=False).format == "ply-binary"
    lines = write_ply(tmp_path / "w.ply", P, fmt="ascii").read_text().splitlines()
    lines.insert(9, "   \t")                        # between the first and the second row
    (tmp_path / "w.ply").write_text("\n".join(lines) + "\n")
    ps = read_points(tmp_path / "w.ply", require_sections=False)
    assert np.array_equal(ps.points, P) and ps.line[:3].tolist() == [9, 11, 12]
    text = write_ply(tmp_path / "x.ply", P).read_text(encoding="latin-1")
    (tmp_path / "x.ply").write_bytes(text.replace("property float z", "property float z\nproperty float x")
                                     .encode("latin-1"))
    assert "'x' is given twice" in _error(tmp_path / "x.ply")
