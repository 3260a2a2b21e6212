# SPDX-License-Identifier: LGPL-2.1-or-later
"""Issue 16 §4, writers: `deviation --csv FILE.ply` and `--aligned FILE.ply` write binary PLY
that other tools read (checked here with a parser written from the PLY format, not ours) and
that BladeRecon reads back: the per-point values equal to the CSV's, the aligned points in their
sections bit for bit."""
from __future__ import annotations

import json

import numpy as np
import pytest

from cli_run import ROOT, run

SAMPLE = ROOT / "resources" / "sample"
_TYPES = {"double": "<f8", "float": "<f4", "int": "<i4", "uchar": "u1"}


def parse_ply(path):
    """A binary little-endian PLY's vertex table and header comments, by the format's rules."""
    raw = path.read_bytes()
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    head = raw[:end].decode("ascii").splitlines()
    assert head[0] == "ply" and head[1] == "format binary_little_endian 1.0"
    count = next(int(h.split()[2]) for h in head if h.startswith("element vertex"))
    fields = [(h.split()[2], _TYPES[h.split()[1]]) for h in head if h.startswith("property")]
    table = np.frombuffer(raw, np.dtype(fields), count=count, offset=end)
    assert len(raw) == end + count * table.dtype.itemsize          # nothing after the vertices
    return table, [h[len("comment "):] for h in head if h.startswith("comment ")]


def test_deviation_per_point_ply_equals_the_csv(tmp_path):
    args = ["deviation", SAMPLE / "measured.csv", "--nominal", SAMPLE / "nominal.step", "--align", "rigid", "--quiet",
            "--json"]
    r1 = run(*args, "--csv", tmp_path / "d.csv")
    r2 = run(*args, "--csv", tmp_path / "d.PLY")
    assert r1.returncode == 0 and r2.returncode == 0, r1.stderr + r2.stderr
    csv = np.loadtxt(tmp_path / "d.csv", delimiter=",", skiprows=1)
    table, comments = parse_ply(tmp_path / "d.PLY")
    assert table.dtype.names == ("x", "y", "z", "deviation", "nx", "ny", "nz", "face")
    got = np.column_stack([table[n].astype(float) for n in table.dtype.names])
    assert got.shape == csv.shape == (12000, 8)
    assert np.abs(got - csv).max() <= 5.1e-8                 # the CSV's 7 decimals
    assert np.array_equal(table["face"], csv[:, 7].astype(int))
    assert comments[1].startswith("signed deviation from nominal.step (mm, + outside)")
    # the summaries agree, and the PLY reads back as a scan with its normals
    s1, s2 = json.loads(r1.stdout), json.loads(r2.stdout)
    assert s1["max"] == s2["max"] and s1["rms"] == s2["rms"]
    from bladerecon.core.io.readers import read_points
    ps = read_points(tmp_path / "d.PLY", require_sections=False)
    assert ps.format == "ply-binary" and not ps.structured
    assert np.array_equal(ps.points, got[:, :3]) and np.array_equal(ps.normals, got[:, 4:7])


def test_aligned_points_as_ply_keep_their_sections(tmp_path):
    """Named sections (a name with spaces too) come back named, in order, the same bits: the
    sections command gives the same JSON from the PLY as from the CSV."""
    from bladerecon.core.io.readers import read_points

    src = read_points(SAMPLE / "measured.csv")
    names = ["hub", "span 20", "40 %", "c", "d", "tip"]
    f = tmp_path / "named.csv"
    f.write_text("section,x,y,z\n" + "".join(f"{names[s]},{x!r},{y!r},{z!r}\n" for s, (x, y, z)
                                              in zip(src.section.tolist(), (src.points + [0.3, -0.2, 0.1]).tolist())))
    outs = {}
    for ext in ("csv", "ply"):
        r = run("deviation", f, "--nominal", SAMPLE / "nominal.step", "--align", "translate", "--aligned",
                tmp_path / f"al.{ext}", "--quiet")
        assert r.returncode == 0, r.stderr
        outs[ext] = read_points(tmp_path / f"al.{ext}")
    a, b = outs["ply"], outs["csv"]
    assert a.structured and a.format == "ply-binary" and a.section_names == b.section_names == tuple(names)
    assert np.array_equal(a.points, b.points) and np.array_equal(a.section, b.section)
    assert np.abs(a.points - src.points).max() < 1e-3      # moved back onto the nominal
    table, comments = parse_ply(tmp_path / "al.ply")
    assert table.dtype.names == ("x", "y", "z", "section") and comments[2:] == [f"section {k} {n}" for k, n in
                                                                                 enumerate(names)]
    j = [run("sections", tmp_path / f"al.{ext}", "--flow", "1,0,0", "--json", "--quiet") for ext in ("csv", "ply")]
    assert j[0].returncode == 0 and j[0].stdout == j[1].stdout


def test_a_ply_whose_section_property_is_not_an_integer_is_a_cloud(tmp_path):
    """Only an integer `section` labels sections (a float one is some scanner's own property)."""
    from bladerecon.core.io.readers import read_points
    from bladerecon.core.io.scanner import write_ply

    P = np.random.default_rng(0).normal(size=(50, 3))
    write_ply(tmp_path / "f.ply", P, {"section": np.linspace(0, 1, 50)})
    ps = read_points(tmp_path / "f.ply", require_sections=False)
    assert not ps.structured and np.array_equal(ps.points, P)
    write_ply(tmp_path / "i.ply", P, section=np.repeat([2, 0, 1], [20, 20, 10]), section_names=["a", "b", "c"])
    ps = read_points(tmp_path / "i.ply")
    assert ps.structured and ps.section_names == ("c", "a", "b")       # in order of first appearance
    assert ps.section.tolist() == [0] * 20 + [1] * 20 + [2] * 10


def test_section_names_in_utf8_and_labels_checked(tmp_path):
    from bladerecon.core.io.readers import read_points
    from bladerecon.core.io.scanner import write_ply

    P = np.arange(60, dtype=float).reshape(20, 3)
    write_ply(tmp_path / "u.ply", P, section=np.repeat([0, 1], 10), section_names=["hub é", "tip  ∅ 1"])
    assert read_points(tmp_path / "u.ply").section_names == ("hub é", "tip ∅ 1")
    write_ply(tmp_path / "n.ply", P, section=np.repeat([0, 7], 10))           # unnamed: one comment a label used
    assert read_points(tmp_path / "n.ply").section_names == ("0", "7")
    for bad in (np.repeat([0, 2 ** 31 + 5], 10), np.repeat([-1, 0], 10), np.linspace(0, 1, 20)):
        with pytest.raises(ValueError):
            write_ply(tmp_path / "b.ply", P, section=bad)
    with pytest.raises(ValueError, match="label 2 but 2 names"):
        write_ply(tmp_path / "b.ply", P, section=np.repeat([0, 2], 10), section_names=["a", "b"])
