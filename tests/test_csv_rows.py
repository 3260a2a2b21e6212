# SPDX-License-Identifier: LGPL-2.1-or-later
"""The numpy CSV row formatter (core/io/csv_rows) against Python's own ``%.*f`` and ``float``."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bladerecon.core.io.csv_rows import can_format, format_rows


def _python(columns, decimals) -> str:
    return "".join(",".join("%.*f" % (d, c[i]) for c, d in zip(columns, decimals)) + "\n"
                   for i in range(len(columns[0])))


def _near_half(v: float, d: int) -> bool:
    """``v * 10**d`` within a rounding error of a half: the last digit may honestly differ."""
    x = abs(v) * 10.0 ** d
    return abs(x - np.floor(x) - 0.5) < 1e-6 * max(1.0, x) * 1e-3 + 1e-9 * max(1.0, x)


def _check(columns, decimals):
    ours = format_rows(columns, decimals).decode("ascii")
    theirs = _python(columns, decimals)
    ours_rows, theirs_rows = ours.splitlines(), theirs.splitlines()
    assert len(ours_rows) == len(theirs_rows) == len(columns[0])
    for i, (a, b) in enumerate(zip(ours_rows, theirs_rows)):
        if a == b:
            continue
        # a different text is allowed only at a half, one unit in the last place, and must read back
        # within half a unit of the value
        for k, (fa, fb, d) in enumerate(zip(a.split(","), b.split(","), decimals)):
            if fa == fb or (fb == "-" + fa and float(fa) == 0.0):      # no "-0.000": by design
                continue
            v = float(columns[k][i])
            assert _near_half(v, d) and abs(float(fa) - v) <= 0.5 * 10.0 ** -d + 2 * np.spacing(abs(v)) + 1e-15, (i, k, fa, fb, v)


def test_edge_values_read_as_python_writes_them():
    v = np.array([0.0, -0.0, 1.5, -1.5, 123.4567891234, -4e-8, -6e-8, 9.99999996, -1000.25, 7.0,
                  99.99999999, -0.5, 1e8, -123456789.0, 10.0, 100.0, 1000.0, 9.0, 99.0, 999.0])
    _check([v, -v, np.arange(len(v))], [7, 3, 0])
    # what rounds to zero is written without a sign, as a measurement table shows it
    assert format_rows([np.array([-4e-8])], [7]) == b"0.0000000\n"


def test_a_deviation_sized_table_matches_python_row_by_row():
    rng = np.random.default_rng(7)
    n = 20_000
    columns = [rng.normal(scale=s, size=n) for s in (30, 30, 300, 0.05, 1, 1, 1)] + [rng.integers(0, 7, n)]
    _check(columns, [7] * 7 + [0])
    text = format_rows(columns, [7] * 7 + [0])
    back = np.loadtxt(text.decode().splitlines(), delimiter=",")
    assert np.abs(back[:, :7] - np.column_stack(columns[:7])).max() <= 0.5e-7 + 1e-12
    assert np.array_equal(back[:, 7], columns[7])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(min_value=-4e8, max_value=4e8, allow_nan=False, allow_infinity=False),
                min_size=1, max_size=40),
       st.integers(min_value=0, max_value=9))
def test_any_finite_values(values, decimals):
    v = np.array(values)
    if not can_format([v], [decimals]):
        return
    _check([v], [decimals])


def test_what_cannot_be_formatted_is_said():
    assert not can_format([np.array([1.0, np.nan])], [7])
    assert not can_format([np.array([np.inf])], [0])
    assert not can_format([np.array([5e8])], [7])           # 5e15 > 2**52: not exact
    assert can_format([np.array([4e8])], [7])
    assert can_format([np.array([], dtype=float)], [7])
    with pytest.raises(ValueError):
        format_rows([np.zeros(2), np.zeros(3)], [1, 1])


# --------------------------------------------------------------------------- the deviation table
def _table(n, seed=0):
    from bladerecon.fc.deviation import PointDeviation
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(n, 3)) * 40.0
    signed = rng.normal(size=n) * 0.05
    signed[n - 5] = np.nan                    # a block the numpy formatter cannot take, in the second half
    N = rng.normal(size=(n, 3))
    N /= np.linalg.norm(N, axis=1)[:, None]
    return P, PointDeviation(signed, P, N, rng.integers(0, 6, n), ("core",))


def _written(tmp_path, name, P, dev):
    from bladerecon.fc.deviation import write_deviation_csv
    out = tmp_path / name
    write_deviation_csv(str(out), P, dev)
    return out.read_bytes()


def test_the_deviation_table_split_over_a_child_is_the_same_file(tmp_path, monkeypatch):
    """From _CSV_SPLIT rows a forked child formats the second half: the file is byte for byte the
    one this process alone writes, also when the child fails; no hidden part is left."""
    import os

    import bladerecon.fc.deviation as fd
    n = fd._CSV_SPLIT + 12_345
    P, dev = _table(n)
    monkeypatch.setenv("BLADERECON_PROCESSES", "0")             # no fork: one process writes it all
    alone = _written(tmp_path, "alone.csv", P, dev)
    monkeypatch.setenv("BLADERECON_PROCESSES", "1")
    # the split taken whatever threads earlier tests (or the test runner's worker) left running:
    # the child only formats numbers into its own file
    import bladerecon.core.geometry.projection.parallel as parallel
    monkeypatch.setattr(parallel, "_can_fork", lambda: True)
    split = _written(tmp_path, "split.csv", P, dev)
    assert split == alone
    assert alone.count(b"\n") == n + 1 and b",nan," in alone
    # a child that fails: its half is formatted here
    parent = os.getpid()
    original = fd._write_rows

    def failing_in_a_child(fh, points, d, start, stop):
        if os.getpid() != parent:
            raise RuntimeError("the child fails")
        return original(fh, points, d, start, stop)

    monkeypatch.setattr(fd, "_write_rows", failing_in_a_child)
    assert _written(tmp_path, "failed_child.csv", P, dev) == alone
    assert sorted(p.name for p in tmp_path.iterdir()) == ["alone.csv", "failed_child.csv", "split.csv"]
