# SPDX-License-Identifier: LGPL-2.1-or-later
"""bladerecon.core.io.readers: formats, bad input, speed (plain pytest, no FreeCAD)."""
from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.readers import PointSet, read_points, write_points_csv

DATA = Path(__file__).resolve().parent / "data"
ROTOR37 = DATA / "nasa_rotor37" / "rotor37_sections_xyz_mm.txt"
ROTOR67 = DATA / "nasa_rotor67" / "rotor67_sections_xyz_mm.txt"
R67_CLOUD = DATA / "parablade_r67_cloud" / "NASA_R67_MoveSurface.txt"


def need(path: Path) -> Path:
    assert path.is_file(), f"test data missing from the checkout: {path}"
    return path


def write(tmp_path: Path, text: str, name: str = "points.txt") -> Path:
    path = tmp_path / name
    path.write_bytes(text.encode("utf-8"))
    return path


def error_of(path: Path) -> str:
    with pytest.raises(BladeReconError) as info:
        read_points(path)
    message = str(info.value)
    assert "\n" not in message
    assert path.name in message
    return message


# --- csv -------------------------------------------------------------------------------

def test_csv_any_column_order_extra_columns_case_insensitive(tmp_path):
    path = write(tmp_path, "Z,id,X,Section,note,Y\n"
                           "3,1,1,0,a,2\n"
                           "6,2,4,0,b,5\n"
                           "9,3,7,1,c,8\n", "p.csv")
    ps = read_points(path)
    assert ps.format == "csv"
    np.testing.assert_array_equal(ps.points, [[1, 2, 3], [4, 5, 6], [7, 8, 9]])
    np.testing.assert_array_equal(ps.section, [0, 0, 1])
    np.testing.assert_array_equal(ps.line, [2, 3, 4])
    assert ps.section_names == ("0", "1")
    assert ps.source == str(path)


def test_csv_labels_numbered_by_first_appearance_and_names_kept(tmp_path):
    path = write(tmp_path, "section,x,y,z\n"
                           "tip,0,0,10\n"
                           "hub,1,0,0\n"
                           "tip,1,1,10\n"
                           "mid,0,0,5\n"
                           "hub,0,1,0\n", "p.csv")
    ps = read_points(path)
    assert ps.section_names == ("tip", "hub", "mid")
    np.testing.assert_array_equal(ps.section, [0, 1, 0, 2, 1])
    np.testing.assert_array_equal(ps.section_points(1), [[1, 0, 0], [0, 1, 0]])
    np.testing.assert_array_equal(ps.section_lines(1), [3, 6])


def test_csv_integer_labels_normalised(tmp_path):
    path = write(tmp_path, "section,x,y,z\n03,0,0,0\n3.0,1,0,0\n 3 ,2,0,0\n4,0,0,1\n", "p.csv")
    ps = read_points(path)
    assert ps.section_names == ("3", "4")
    np.testing.assert_array_equal(ps.section, [0, 0, 0, 1])


def test_csv_semicolon_with_decimal_comma_and_units_in_header(tmp_path):
    path = write(tmp_path, "section;x [mm];y_mm;z (mm)\n1;1,5;2,25;-3\n1;0,5;0;1e-3\n", "p.csv")
    ps = read_points(path)
    np.testing.assert_allclose(ps.points, [[1.5, 2.25, -3], [0.5, 0, 1e-3]])


def test_csv_without_section_column_uses_blank_line_blocks(tmp_path):
    path = write(tmp_path, "# sections by blank lines\nx,y,z\n0,0,0\n1,0,0\n\n\n0,0,1\n1,0,1\n",
                 "p.csv")
    ps = read_points(path)
    np.testing.assert_array_equal(ps.section, [0, 0, 1, 1])
    np.testing.assert_array_equal(ps.line, [3, 4, 7, 8])
    assert ps.section_names == ("1", "2")


def test_csv_without_section_column_or_blocks_has_no_structure(tmp_path):
    path = write(tmp_path, "x,y,z\n0,0,0\n1,0,0\n2,1,0\n", "cloud.csv")
    message = error_of(path)
    assert "lines 2–4" in message
    assert "no section structure" in message and "add a 'section' column" in message


def test_csv_header_without_xyz_names_the_columns_found(tmp_path):
    message = error_of(write(tmp_path, "section,a,b,z\n0,1,2,3\n", "p.csv"))
    assert "line 1" in message
    assert "'x', 'y'" in message and "'section', 'a', 'b', 'z'" in message


def test_csv_non_numeric_cell_names_line_column_and_text(tmp_path):
    message = error_of(write(tmp_path, "section,x,y,z\n0,1,2,3\n0,1,abc,3\n", "p.csv"))
    assert "line 3" in message and "'y'" in message and "'abc'" in message


@pytest.mark.parametrize("bad", ["nan", "inf", "-Infinity"])
def test_csv_nan_or_inf_names_the_line(tmp_path, bad):
    message = error_of(write(tmp_path, f"section,x,y,z\n0,1,2,3\n\n0,1,2,{bad}\n", "p.csv"))
    assert "line 4" in message and "'z'" in message


def test_csv_short_row_and_empty_label_and_duplicate_column(tmp_path):
    assert "line 3" in error_of(write(tmp_path, "section,x,y,z\n0,1,2,3\n0,1,2\n", "a.csv"))
    assert "line 2" in error_of(write(tmp_path, "section,x,y,z\n,1,2,3\n", "b.csv"))
    assert "'x' appears twice" in error_of(write(tmp_path, "x,y,z,X\n1,2,3,4\n", "c.csv"))


def test_csv_header_only_and_headerless_csv(tmp_path):
    assert "no data rows" in error_of(write(tmp_path, "section,x,y,z\n\n", "a.csv"))
    assert "without a header row" in error_of(write(tmp_path, "1,2,3\n4,5,6\n", "b.csv"))


def test_crlf_and_byte_order_mark(tmp_path):
    path = tmp_path / "p.csv"
    path.write_bytes("\ufeffsection,x,y,z\r\n0,1,2,3\r\n1,4,5,6\r\n".encode("utf-8"))
    ps = read_points(path)
    np.testing.assert_array_equal(ps.points, [[1, 2, 3], [4, 5, 6]])
    np.testing.assert_array_equal(ps.line, [2, 3])


# --- xyz blocks ------------------------------------------------------------------------

def test_xyz_blocks_separated_by_blank_and_comment_lines(tmp_path):
    text = ("# header comment\n# more\n"
            "0 0 0\n1 0 0\n1 1 0\n"
            "\n# section 2\n\n"
            "0 0 5\n1e0\t0  5\n"
            "# section 3\n2.5 -1 10\n")
    ps = read_points(write(tmp_path, text))
    assert ps.format == "xyz-blocks"
    np.testing.assert_array_equal(ps.section, [0, 0, 0, 1, 1, 2])
    np.testing.assert_array_equal(ps.line, [3, 4, 5, 9, 10, 12])
    assert ps.section_names == ("1", "2", "3")
    np.testing.assert_array_equal(ps.points[-1], [2.5, -1, 10])


def test_xyz_single_block_has_no_structure(tmp_path):
    message = error_of(write(tmp_path, "# one block\n0 0 0\n1 0 0\n1 1 0\n"))
    assert "lines 2–4" in message and "no section structure" in message


def test_id_xyz_columns_single_block_is_an_unstructured_cloud(tmp_path):
    message = error_of(write(tmp_path, "7 0 0 0\n3 1 0 0\n9 1 1 0\n"))
    assert "no section structure" in message


def test_id_xyz_columns_with_blocks_ignore_the_id(tmp_path):
    ps = read_points(write(tmp_path, "7 0 0 0\n3 1 0 0\n\n9 1 1 5\n4 2 1 5\n"))
    np.testing.assert_array_equal(ps.points[2], [1, 1, 5])
    np.testing.assert_array_equal(ps.section, [0, 0, 1, 1])


def test_parablade_cloud_has_no_structure():
    path = need(R67_CLOUD)
    message = error_of(path)
    assert "lines 1–2057" in message
    assert "--slice N (planes) or --slice-radii" in message           # the way out, named


def test_xyz_bad_cells(tmp_path):
    message = error_of(write(tmp_path, "0 0 0\n1 x1 0\n\n0 0 1\n"))
    assert "line 2" in message and "'y'" in message and "'x1'" in message
    assert "line 3" in error_of(write(tmp_path, "0 0 0\n1 0 0\n0 0 nan\n\n1 1 1\n", "b.txt"))
    assert "line 2" in error_of(write(tmp_path, "0 0 0\n1 0\n", "c.txt"))
    assert "5 values" in error_of(write(tmp_path, "0 0 0 0 0\n", "d.txt"))


# --- section table ---------------------------------------------------------------------

def test_rotor37_section_table():
    ps = read_points(need(ROTOR37))
    assert ps.format == "section-table"
    assert ps.points.shape == (198 * 13, 3)
    assert ps.section_names == tuple(str(k) for k in range(1, 14))
    np.testing.assert_array_equal(np.bincount(ps.section), [198] * 13)
    assert ps.line[0] == 5 and ps.line[-1] == 4 + 198 * 13
    np.testing.assert_array_equal(ps.points[0], [0.28109, -20.68381, 176.69725])
    radius = np.hypot(ps.points[:, 1], ps.points[:, 2])
    assert 177 < radius.min() < radius.max() < 253     # hub .. shroud, mm (SOURCE.txt)


def test_rotor67_section_table():
    ps = read_points(need(ROTOR67))
    assert ps.format == "section-table"
    assert ps.n_sections == 14
    np.testing.assert_array_equal(np.bincount(ps.section), [138] * 14)


def test_section_table_count_checked(tmp_path):
    short = write(tmp_path, "# c\n2 2\n0 0 0\n1 0 0\n0 0 1\n", "short.txt")
    message = error_of(short)
    assert "line 5" in message and "2 x 2 = 4" in message and "line 2" in message
    long = write(tmp_path, "2 2\n0 0 0\n1 0 0\n0 0 1\n1 0 1\n2 2 2\n", "long.txt")
    message = error_of(long)
    assert "line 6" in message and "point 5" in message


def test_section_table_with_bad_cell(tmp_path):
    message = error_of(write(tmp_path, "2 2\n0 0 0\n1 0 0\n0 q 1\n1 0 1\n"))
    assert "line 4" in message and "'q'" in message


# --- file level ------------------------------------------------------------------------

def test_missing_folder_empty_and_comment_only_files(tmp_path):
    assert "file not found" in error_of(tmp_path / "nope.csv")
    assert "folder" in error_of(tmp_path)
    assert "empty" in error_of(write(tmp_path, "", "empty.csv"))
    assert "empty" in error_of(write(tmp_path, "  \n\n", "blank.csv"))
    assert "no points" in error_of(write(tmp_path, "# only\n# comments\n", "c.txt"))


@pytest.mark.skipif(not hasattr(os, "geteuid") or os.geteuid() == 0,
                    reason="root can read any file")
def test_unreadable_file(tmp_path):
    path = write(tmp_path, "section,x,y,z\n")
    path.chmod(0)
    try:
        assert "cannot read" in error_of(path)
    finally:
        path.chmod(0o644)


def test_unsupported_table_is_named(tmp_path):
    message = error_of(write(tmp_path, " Table IV NASA Rotor 37 Blade Geometry\n1 2 3\n"))
    assert "line 1" in message and "neither a header" in message


def test_input_file_is_not_modified(tmp_path):
    path = write(tmp_path, "section,x,y,z\n0,1,2,3\n0,1,bad,3\n", "p.csv")
    before = (path.read_bytes(), path.stat().st_mtime_ns)
    with pytest.raises(BladeReconError):
        read_points(path)
    assert (path.read_bytes(), path.stat().st_mtime_ns) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.csv"]


def test_point_set_is_read_only(tmp_path):
    ps = read_points(write(tmp_path, "section,x,y,z\n0,1,2,3\n"))
    with pytest.raises(ValueError):
        ps.points[0, 0] = 5.0
    with pytest.raises(ValueError):
        ps.section[0] = 3


# --- writing ---------------------------------------------------------------------------

def test_write_points_csv_round_trip_exact(tmp_path):
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(50, 3)) * 100
    sec = np.repeat([0, 1], 25)
    path = tmp_path / "out.csv"
    write_points_csv(path, pts, sec, names=["hub", "tip"])
    assert path.read_text().startswith("section,x,y,z\nhub,")
    ps = read_points(path)
    np.testing.assert_array_equal(ps.points, pts)
    np.testing.assert_array_equal(ps.section, sec)
    assert ps.section_names == ("hub", "tip")
    umask = os.umask(0)
    os.umask(umask)
    assert path.stat().st_mode & 0o777 == 0o666 & ~umask      # not mkstemp's 0600
    write_points_csv(path, pts[:3], [0, 0, 0])            # replaces, index labels
    assert path.read_text().splitlines()[1].startswith("0,")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


def test_write_points_csv_is_atomic(tmp_path, monkeypatch):
    path = tmp_path / "out.csv"
    path.write_text("old content\n")

    def broken_replace(src, dst):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", broken_replace)
    with pytest.raises(OSError):
        write_points_csv(path, np.zeros((2, 3)), [0, 1])
    assert path.read_text() == "old content\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.csv"]


def test_write_points_csv_rejects_bad_names(tmp_path):
    for bad in (["a,b"], ["#1"], [" "]):
        with pytest.raises(ValueError):
            write_points_csv(tmp_path / "o.csv", np.zeros((1, 3)), [0], names=bad)
    with pytest.raises(ValueError):
        write_points_csv(tmp_path / "o.csv", np.zeros((1, 3)), [-1])
    assert not (tmp_path / "o.csv").exists()


# --- speed and isolation ---------------------------------------------------------------

def test_12000_line_csv_reads_fast(tmp_path):
    rng = np.random.default_rng(1)
    path = tmp_path / "big.csv"
    write_points_csv(path, rng.normal(size=(12000, 3)) * 80, np.repeat(np.arange(6), 2000))
    best = min(_timed(read_points, path) for _ in range(3))
    # Speed is printed (make bench times reading end to end); the values are checked against numpy.
    print(f"\n12 000-line CSV read in {best * 1e3:.0f} ms")
    ps = read_points(path)
    ref = np.loadtxt(path, delimiter=",", skiprows=1, usecols=(1, 2, 3), ndmin=2)
    assert ps.points.shape == (12000, 3) and np.array_equal(ps.points, ref)


def _timed(fn, *args) -> float:
    t0 = time.perf_counter()
    fn(*args)
    return time.perf_counter() - t0


def test_core_modules_do_not_import_freecad():
    code = ("import sys, bladerecon.core.io.readers, bladerecon.core.sections.ordering; "
            "bad = [m for m in sys.modules "
            "       if m.split('.')[0] in ('FreeCAD', 'FreeCADGui', 'Part')]; "
            "print(bad); sys.exit(1 if bad else 0)")
    root = Path(__file__).resolve().parents[1]
    run = subprocess.run([sys.executable, "-c", code], cwd=root, capture_output=True, text=True)
    assert run.returncode == 0, run.stdout + run.stderr
