# SPDX-License-Identifier: LGPL-2.1-or-later
"""The vectorised reading path against the careful parser (its referee): on random numeric
tables both give the same PointSet bit for bit; on mutated files (a bad cell, a missing value,
NaN, a comment, quotes, a whitespace-only line) the fast path steps aside and the careful
parser's one-line error, naming the line, is what the user sees."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io import readers

# derandomize: the same examples on every run (a CI run never fails by the draw); raise
# max_examples locally to search wider
SETTINGS = settings(max_examples=60, deadline=None, derandomize=True,
                    suppress_health_check=[HealthCheck.function_scoped_fixture])


def careful(path, require_sections=True):
    """read_points with the fast path switched off."""
    saved = readers._read_fast
    readers._read_fast = lambda *a: None
    try:
        return readers.read_points(path, require_sections)
    finally:
        readers._read_fast = saved


def same(a, b):
    assert a.format == b.format and a.section_names == b.section_names
    np.testing.assert_array_equal(a.points, b.points)          # bit for bit: same float parsing
    np.testing.assert_array_equal(a.section, b.section)
    np.testing.assert_array_equal(a.line, b.line)


@st.composite
def tables(draw):
    """Text of a random numeric point file: CSV with a header (x, y, z in any order, an optional
    whole-number section column, extra columns) or x y z / id x y z blocks with blank lines."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n = draw(st.integers(1, 60))
    xyz = rng.normal(0, 10 ** draw(st.integers(-3, 4)), (n, 3))
    digits = draw(st.integers(1, 17))
    fmt = lambda v: repr(float(v)) if digits == 17 else f"{v:.{digits}g}"   # noqa: E731
    kind = draw(st.sampled_from(["csv", "csv-section", "xyz", "id-xyz"]))
    newline = draw(st.sampled_from(["\n", "\r\n"]))
    lead = draw(st.sampled_from(["", "\n", "\n\n", "  \n", "\t\n"]))      # blank lines, of spaces too
    if kind.startswith("csv"):
        cols = draw(st.permutations(["x", "y", "z"] + (["section"] if kind == "csv-section" else [])
                                    + (["i"] if draw(st.booleans()) else [])))
        rows = [",".join(cols)]
        labels = rng.integers(-2, 4, n)
        for k in range(n):
            cell = {"x": fmt(xyz[k, 0]), "y": fmt(xyz[k, 1]), "z": fmt(xyz[k, 2]),
                    "section": draw(st.sampled_from([str(labels[k]), f"{labels[k]}.0"])), "i": str(k)}
            rows.append(",".join(cell[c] for c in cols))
            if kind == "csv" and k < n - 1 and rng.random() < 0.1:
                rows.append("")                             # a blank line ends a section
    else:
        rows = []
        for k in range(n):
            cells = [fmt(v) for v in xyz[k]]
            rows.append((f"{k} " if kind == "id-xyz" else "") + draw(st.sampled_from([" ", "\t", "  "])).join(cells))
            if k < n - 1 and rng.random() < 0.15:
                rows.extend([""] * int(rng.integers(1, 3)))
    if draw(st.booleans()):        # '#' lines: comments (quotes, Latin-1 letters, indented) and separators
        for _ in range(draw(st.integers(1, 4))):
            at = draw(st.integers(0, len(rows)))
            if kind.startswith("csv") and at == 0:
                at = 1 if rows else 0             # the header stays the first line that is not a comment
            rows.insert(at, draw(st.sampled_from(["# probe 2 mm", "  # operator's note", "#", "# \"quoted\"",
                                                  "\t# mesur\u00e9 \u00b5m", "## 3 4 5"])))
        if kind.startswith("csv") and draw(st.booleans()):
            rows.insert(0, "# exported by a CMM")
    return lead + newline.join(rows) + draw(st.sampled_from(["", newline]))


@pytest.fixture(params=[4 << 20, 97, 1000], ids=["4MB", "97B", "1000B"])
def block_bytes(request, monkeypatch):
    """The fast path's block size: its own (one block) and small ones, so that files end up
    cut into many blocks at every kind of line."""
    monkeypatch.setattr(readers, "_BLOCK_BYTES", request.param)
    return request.param


@SETTINGS
@given(text=tables(), require=st.booleans(), encoding=st.sampled_from(["utf-8", "latin-1"]), bom=st.booleans())
def test_fast_and_careful_paths_agree(tmp_path, block_bytes, text, require, encoding, bom):
    path = tmp_path / "p.txt"
    path.write_bytes((b"\xef\xbb\xbf" if bom else b"") + text.encode(encoding))
    try:
        expected = careful(path, require)
    except BladeReconError as err:
        with pytest.raises(BladeReconError) as got:
            readers.read_points(path, require)
        assert str(got.value) == str(err)
        return
    same(readers.read_points(path, require), expected)


MUTATIONS = {
    "bad cell": lambda v: v.replace("1", "1x", 1),
    "missing value": lambda v: v.rsplit(",", 1)[0] if "," in v else v.rsplit(None, 1)[0],
    "nan": lambda v: "nan" + v[v.index(","):] if "," in v else "nan " + v.split(None, 1)[1],
    "comment": lambda v: v + " # probe 3",
    "quotes": lambda v: '"' + v + '"',
    "spaces only": lambda v: "   ",
    "extra value": lambda v: v + (",7" if "," in v else " 7"),
}


@SETTINGS
@given(text=tables(), mutation=st.sampled_from(sorted(MUTATIONS)), where=st.floats(0, 1))
def test_mutated_files_get_the_careful_parsers_answer(tmp_path, block_bytes, text, mutation, where):
    lines = text.replace("\r\n", "\n").split("\n")
    data = [k for k, ln in enumerate(lines) if ln.strip() and any(ch.isdigit() for ch in ln[:1] + ln[-1:])]
    if not data:
        return
    k = data[min(int(where * len(data)), len(data) - 1)]
    lines[k] = MUTATIONS[mutation](lines[k])
    path = tmp_path / "m.txt"
    path.write_text("\n".join(lines))
    try:
        expected = careful(path)
    except BladeReconError as err:
        with pytest.raises(BladeReconError) as got:
            readers.read_points(path)
        assert str(got.value) == str(err)
        return
    same(readers.read_points(path), expected)


def test_a_big_table_takes_the_fast_path(tmp_path, monkeypatch):
    """100 000 points: the vectorised path reads them (the careful parser is never called)."""
    rng = np.random.default_rng(3)
    P = rng.normal(0, 50, (100_000, 3))
    path = tmp_path / "cloud.csv"
    np.savetxt(path, P, fmt="%.6f", delimiter=",", header="x,y,z", comments="")
    monkeypatch.setattr(readers, "_read_csv", lambda *a, **k: pytest.fail("the careful parser ran"))
    ps = readers.read_points(path, require_sections=False)
    np.testing.assert_allclose(ps.points, P, atol=5e-7)
    assert ps.section_names == ("1",) and ps.line[0] == 2 and ps.line[-1] == 100_001
    with pytest.raises(BladeReconError, match="no section structure"):
        readers.read_points(path)


@pytest.mark.parametrize("text", [
    "# exported by a CMM\n# operator's \"note\"\nsection,x,y,z\n1,0.5,1.5,2.5\n1,1.5,2.5,3.5\n# section 2\n2,0.5,1.5,5.5\n2,1.5,2.5,6.5\n",
    "# blade 7\n0.5 1.5 2.5\n1.5 2.5 3.5\n2.5 3.5 4.5\n# next\n0.5 1.5 5.5\n1.5 2.5 6.5\n2.5 3.5 7.5\n",
    "\ufeff# mesur\u00e9 en \u00b5m\nx,y,z\n1,2,3\n4,5,6\n\n7,8,9\n",
])
def test_comment_lines_take_the_fast_path(tmp_path, monkeypatch, text):
    """'#' lines (with quotes or accents in them) are taken by the vectorised path, not handed
    to the careful parser, and give its PointSet: the agreement tests above pass as well when
    the fast path steps aside, so this one checks that it does not."""
    path = tmp_path / "c.txt"
    path.write_bytes(text.encode("latin-1" if "\u00b5" in text and "\ufeff" not in text else "utf-8"))
    fast = readers._read_fast(str(path), False)
    assert fast is not None
    same(fast, careful(path, False))
