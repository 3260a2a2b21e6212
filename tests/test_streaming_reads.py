# SPDX-License-Identifier: LGPL-2.1-or-later
"""Issue 23 §4: readers that refuse binary content before reading the file and stream the rest.

Measured as the machine sees it (total PSS of the command, :mod:`memory_probe`), not by the
reader's own accounting:

* a 2 GiB file of NUL bytes is refused by every command that reads points, in one line, with
  the memory of an idle interpreter (it used to be read whole: 2.1 GB, 6 s);
* NUL bytes after the first megabyte are found while streaming, at their exact offset;
* a plain table is held as numbers, not as text: reading it takes less than the file's size
  over an interpreter's base (the old reader held the whole file, then the numbers: more than
  the file's size by construction);
* a file only the careful parser takes is checked against the memory budget from its size and
  line count before it is read, and that estimate is an upper bound of what reading it takes.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from memory_probe import peak_memory

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io import readers
from bladerecon.core.io.memory import careful_read_need

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))
NOMINAL = str(ROOT / "resources" / "sample" / "nominal.step")
PY = [sys.executable, "-m", "bladerecon"]


@pytest.fixture(scope="module")
def nul_file(tmp_path_factory):
    """2 GiB of NUL bytes (sparse: no disk used)."""
    path = tmp_path_factory.mktemp("nul") / "scan.csv"
    with open(path, "wb") as f:
        f.truncate(2 << 30)
    return path


COMMANDS = {
    "reconstruct": lambda f, out: ["reconstruct", f, "-o", str(out / "x.step")],
    "deviation": lambda f, out: ["deviation", f, "--nominal", NOMINAL, "--csv", str(out / "d.csv")],
    "sections": lambda f, out: ["sections", f, "--plots", str(out / "plots")],
    "tspline": lambda f, out: ["tspline", f, "--tolerance", "0.05", "-o", str(out / "t.step")],
    "repair": lambda f, out: ["repair", f, "--nominal", NOMINAL, "-o", str(out / "r.step")],
    "blisk": lambda f, out: ["blisk", f, "--nominal", NOMINAL, "--blades", "3", "-o", str(out / "lot")],
}


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_a_huge_file_of_nul_bytes_is_refused_without_being_read(nul_file, tmp_path, command):
    out = tmp_path / "out"
    out.mkdir()
    rc, peak, err = peak_memory(PY + COMMANDS[command](str(nul_file), out), env=ENV, timeout=120)
    errors = [ln for ln in err.splitlines() if ln.startswith("bladerecon: error:")]
    assert rc == 2 and "Traceback" not in err and len(errors) == 1, err
    assert "NUL byte at offset 0" in errors[0], errors
    # an interpreter with numpy is ~40-60 MB; the file is 2147 MB: reading it would show
    assert peak < 250e6, peak / 1e6
    assert list(out.iterdir()) == []


def test_nul_bytes_after_the_first_megabyte_are_found_at_their_offset(tmp_path):
    rows = "x,y,z\n" + "".join(f"{k}.5,{k % 7}.25,{k % 11}.125\n" for k in range(120_000))
    body = rows.encode()
    assert len(body) > 1 << 20                 # past what the first check reads
    path = tmp_path / "late.csv"
    path.write_bytes(body + b"\0" * 64 + b"1,2,3\n")
    with pytest.raises(BladeReconError, match=f"NUL byte at offset {len(body)}:"):
        readers.read_points(path, require_sections=False)


def _reading_peak(path: Path) -> float:
    code = ("import sys; from bladerecon.core.io.readers import read_points; "
            "read_points(sys.argv[1], require_sections=False)")
    rc, peak, err = peak_memory([sys.executable, "-c", code, str(path)], env=ENV, timeout=120)
    assert rc == 0, err
    return peak


def test_a_plain_table_is_held_as_numbers_not_as_text(tmp_path):
    """300 000 rows of eight 17-digit numbers (x, y, z, normals, an intensity and an id: a
    scanner's export), 42 MB of text. Held as numbers: the table numpy parses (8 x 8 bytes a
    row), the points, line numbers and labels (48 bytes) and the line scan of one 4 MB
    block; under the file's size. Reading the whole file first would take its size alone."""
    rng = np.random.default_rng(23)
    n = 300_000
    table = np.column_stack([rng.normal(0, 100, (n, 7)), np.arange(n)])
    path = tmp_path / "scan.csv"
    with open(path, "w") as f:
        f.write("x,y,z,nx,ny,nz,intensity,id\n")
        for block in np.array_split(table, 30):
            f.write("".join(",".join(repr(float(v)) for v in row) + "\n" for row in block.tolist()))
    small = tmp_path / "small.csv"
    small.write_text("x,y,z\n1,2,3\n4,5,6\n")
    size = path.stat().st_size
    assert size > 40e6
    grown = _reading_peak(path) - _reading_peak(small)
    assert grown < size, (grown / 1e6, size / 1e6)
    ps = readers.read_points(path, require_sections=False)
    np.testing.assert_array_equal(ps.points, table[:, :3])
    assert ps.line[0] == 2 and ps.line[-1] == n + 1


def test_a_file_for_the_careful_parser_is_budgeted_before_it_is_read(tmp_path):
    """Text section labels take the careful parser (lines and cells as Python strings). Its
    need, from the file's size and line count, is an upper bound of the measured peak, within
    a factor 3 of it; a budget below it refuses the file in one line, unread; the same points
    as a plain numeric table are read in blocks under that budget."""
    rng = np.random.default_rng(5)
    n = 200_000
    P = rng.normal(0, 50, (n, 3))
    labelled = tmp_path / "labelled.csv"
    labelled.write_text("section,x,y,z\n" + "".join(f"S{k // 2000},{x!r},{y!r},{z!r}\n"
                                                    for k, (x, y, z) in enumerate(P.tolist())))
    lines, size = n + 1, labelled.stat().st_size
    need = careful_read_need(lines, size)
    peak = _reading_peak(labelled)
    assert peak <= need <= 3 * peak, (peak / 1e6, need / 1e6)
    limit_gb = 0.9 * need / 1e9
    with pytest.raises(BladeReconError, match=r"reading .*labelled\.csv needs about .* --memory-limit"):
        readers.read_points(labelled, memory_limit=limit_gb)
    plain = tmp_path / "plain.csv"
    plain.write_text("section,x,y,z\n" + "".join(f"{k // 2000},{x!r},{y!r},{z!r}\n"
                                                 for k, (x, y, z) in enumerate(P.tolist())))
    ps = readers.read_points(plain, memory_limit=limit_gb)
    np.testing.assert_array_equal(ps.points, P)
    assert ps.n_sections == n // 2000


def test_the_point_bound_holds_for_every_format(tmp_path):
    """The bound a command's budget uses before reading: at least the points read, for text
    (lines) and scans (the header's count)."""
    from scan_files import write_ply, write_pcd

    rng = np.random.default_rng(7)
    P = rng.normal(0, 10, (5000, 3))
    files = {"csv": tmp_path / "a.csv", "xyz": tmp_path / "a.xyz", "ply": tmp_path / "a.ply",
             "pcd": tmp_path / "a.pcd", "ply-ascii": tmp_path / "b.ply"}
    files["csv"].write_text("# c\nx,y,z\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in P.tolist()))
    files["xyz"].write_text("".join(f"{x!r} {y!r} {z!r}\n" + ("\n" if k % 500 == 499 else "")
                                    for k, (x, y, z) in enumerate(P.tolist())))
    write_ply(files["ply"], P)
    write_pcd(files["pcd"], P)
    write_ply(files["ply-ascii"], P, fmt="ascii")
    for kind, path in files.items():
        bound = readers.points_upper_bound(path)
        got = len(readers.read_points(path, require_sections=False).points)
        assert got == 5000 and got <= bound <= got + 20, (kind, bound)


def test_every_command_refuses_a_job_over_its_budget_before_reading(tmp_path):
    measured = ROOT / "resources" / "sample" / "measured.csv"
    before = measured.read_bytes()
    for command, argv in COMMANDS.items():
        out = tmp_path / command
        out.mkdir()
        r = subprocess.run(PY + argv(str(measured), out) + ["--memory-limit", "0.05"], capture_output=True,
                           text=True, env=ENV, timeout=120)
        errors = [ln for ln in r.stderr.splitlines() if ln.startswith("bladerecon: error:")]
        assert r.returncode == 2 and len(errors) == 1 and "Traceback" not in r.stderr, (command, r.stderr)
        assert f"{command} of " in errors[0] and "up to 12001 points" in errors[0] and "50 MB" in errors[0], errors
        assert list(out.iterdir()) == [], command
    assert measured.read_bytes() == before


def test_a_cloud_of_comma_rows_without_a_header_is_read_in_blocks(tmp_path, monkeypatch):
    """Scanner exports of ``x,y,z`` (or ``id;x;y;z``) rows with no header: the slicing reader
    takes them (a CSV with a header is the referee: the same numbers, the same lines), in
    blocks, and names a bad row's line."""
    from bladerecon.core.sections.slicing import read_cloud

    monkeypatch.setattr(readers, "_BLOCK_BYTES", 4096)     # many blocks
    rng = np.random.default_rng(11)
    P = rng.normal(0, 30, (3000, 3))
    rows = [f"{x!r},{y!r},{z!r}" for x, y, z in P.tolist()]
    plain, semi, header = tmp_path / "a.csv", tmp_path / "b.csv", tmp_path / "c.csv"
    plain.write_text("# scan 7\n" + "\n".join(rows) + "\n")
    semi.write_text("\n".join(f"{k};{r.replace(',', ';')}" for k, r in enumerate(rows)))
    header.write_text("x,y,z\n" + "\n".join(rows) + "\n")
    ref, ref_lines = read_cloud(str(header), 1000.0)
    for f in (plain, semi):
        got, lines = read_cloud(str(f), 1000.0)
        np.testing.assert_array_equal(got, ref)
        np.testing.assert_array_equal(lines, ref_lines if f is plain else ref_lines - 1)
    bad = rows[:]
    bad[1700] = bad[1700].replace(",", ",x", 1)
    plain.write_text("\n".join(bad) + "\n")
    with pytest.raises(BladeReconError, match=r"a\.csv, line 1701: '.*' is not a line of finite numbers"):
        read_cloud(str(plain))


# --------------------------------------------------------------------------- what the sweep found
def test_a_nul_byte_anywhere_is_refused_by_either_parser(tmp_path):
    """A NUL past the first megabyte in a file the careful parser reads (a quoted header) is
    refused at its offset, as in a plain table: the answer does not depend on the parser."""
    rows = "".join(f"{k}.5,{k % 7}.25,{k % 11}.125\n" for k in range(100_000)).encode()
    for header in (b"x,y,z\n", b'"x","y","z"\n'):
        path = tmp_path / "late.csv"
        body = header + rows
        path.write_bytes(body + b"# \0 late\n")
        with pytest.raises(BladeReconError, match=f"NUL byte at offset {len(body) + 2}:"):
            readers.read_points(path, require_sections=False)


def test_one_endless_line_is_refused_quickly(tmp_path):
    """100 MB without a newline: refused in one line before it is split (it took 12 s and
    2.2 GB, over any --memory-limit)."""
    path = tmp_path / "one.txt"
    path.write_text("1.000000 2.000000 3.000000 " * 3_800_000)
    rc, peak, err = peak_memory(PY + ["sections", str(path), "--memory-limit", "0.5"], env=ENV, timeout=60)
    errors = [ln for ln in err.splitlines() if ln.startswith("bladerecon: error:")]
    assert rc == 2 and len(errors) == 1 and "line 1: 102.6 MB in one line" in errors[0], err
    assert peak < 250e6, peak / 1e6


@pytest.mark.parametrize("row, words", [
    ("1.0,,2.0,3.0", "4 values where line 1 has 3"),
    ("1.0,2.0,3.0,", "4 values where line 1 has 3"),
    ("7,1.0,2.0,3.0", "4 values where line 1 has 3"),
    ("nan,2.0,3.0", "not a line of finite numbers"),
    ("1e400,2,3", "not a line of finite numbers"),
    ("1.0,abc,3.0", "not a line of finite numbers"),
])
def test_a_bad_row_of_a_headerless_cloud_is_named(tmp_path, row, words):
    """An empty cell is not skipped (the values would shift into the wrong columns), a row of
    another width is not mixed in, NaN and overflow name their line."""
    from bladerecon.core.sections.slicing import read_cloud

    rng = np.random.default_rng(3)
    rows = [f"{x!r},{y!r},{z!r}" for x, y, z in rng.normal(0, 10, (2000, 3)).tolist()]
    rows[1233] = row
    path = tmp_path / "cloud.csv"
    path.write_text("\n".join(rows) + "\n")
    with pytest.raises(BladeReconError, match=f"cloud.csv, line 1234: .*{re.escape(words)}"):
        read_cloud(str(path))


def test_blank_first_lines_of_spaces_are_read(tmp_path):
    """A line of spaces or a tab before the header or the first row (the fast path took it for
    the header and refused the file)."""
    from bladerecon.core.sections.slicing import read_cloud

    src = (ROOT / "resources" / "sample" / "measured.csv").read_text()
    path = tmp_path / "m.csv"
    path.write_text("\t\n" + src)
    assert readers.read_points(path).n_sections == 6
    rows = "".join(f"{k}.5,{k % 7}.25,{k % 11}.125\n" for k in range(100))
    path.write_text("   \n" + rows)
    P, lines = read_cloud(str(path))
    assert len(P) == 100 and lines[0] == 2


def test_batch_refuses_a_fifo_before_hashing_it(tmp_path):
    """A manifest row naming a FIFO: the blade fails in one line (the worker blocked for good
    opening it to hash its bytes)."""
    fifo = tmp_path / "scan.csv"
    os.mkfifo(fifo)
    manifest = tmp_path / "lot.csv"
    manifest.write_text(f"blade,file\nb1,{fifo}\n")
    r = subprocess.run(PY + ["batch", str(manifest), "--nominal", NOMINAL, "-o", str(tmp_path / "out")],
                       capture_output=True, text=True, env=ENV, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    # its only blade failed: nothing written, the one line gives the blade's error
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("bladerecon: error: all 1 blades failed") and "is a FIFO" in line, r.stderr
    assert not (tmp_path / "out").exists() and fifo.is_fifo()
