# SPDX-License-Identifier: LGPL-2.1-or-later
"""Rows of numbers as CSV text, formatted by numpy, not one Python format call per value.

A deviation table of 1M points has 8M numbers; ``%``-formatting them, even a block at a time,
takes 1.3 s, as long as the whole measurement. Here each column is written in fixed decimals
(``decimals[k]``: 7 → 0.1 nm for lengths in mm, 0 → an integer) by integer arithmetic on whole
columns into a byte matrix, one fixed-width field per column; the unused leading bytes of each
field are zero and are dropped in one boolean-mask pass. The text is what ``"%.*f" % v`` gives,
except where ``v * 10**decimals`` lies within a rounding error of a half (the last digit may then
differ by one: both are within half a unit of the last place of ``v``).

Only for finite values whose scaled magnitude fits exactly in a float (``|v| * 10**decimals <
2**52``); :func:`can_format` says so, and the caller formats the rest another way.
"""
from __future__ import annotations

import numpy as np

__all__ = ["can_format", "format_rows"]

_EXACT = float(2 ** 52)
_ZERO, _MINUS, _DOT, _COMMA, _NL = ord("0"), ord("-"), ord("."), ord(","), ord("\n")


def _scaled(column: np.ndarray, decimals: int) -> np.ndarray:
    return np.abs(column) * (10.0 ** decimals)


def can_format(columns: list[np.ndarray], decimals: list[int]) -> bool:
    """True when every value is finite and its scaled magnitude is an exact integer range."""
    for col, d in zip(columns, decimals):
        a = np.asarray(col, dtype=float)
        if a.size and not (np.isfinite(a).all() and _scaled(a, d).max() < _EXACT):
            return False
    return True


_QUADS = np.frombuffer("".join("%04d" % k for k in range(10_000)).encode("ascii"), dtype="<u4")


def _digits(value: np.ndarray, width: int) -> np.ndarray:
    """``value`` (int64, 0 <= value < 10**width) as (n, width) ASCII digits with leading zeros,
    four digits per integer division (a table of the 10 000 quadruples)."""
    quads = (width + 3) // 4
    out = np.empty((len(value), quads), dtype="<u4")
    rest = value
    for j in range(quads):
        rest, r = np.divmod(rest, 10_000)
        out[:, quads - 1 - j] = _QUADS[r]
    return out.view(np.uint8)[:, 4 * quads - width:]


def _field(column: np.ndarray, decimals: int, out: np.ndarray) -> None:
    """Write the column into ``out`` ((n, width) uint8, width from :func:`_width`): sign and
    integer digits right-aligned with unused leading bytes 0, then ``.`` and ``decimals`` digits
    when decimals > 0."""
    v = np.asarray(column, dtype=float)
    a = np.rint(_scaled(v, decimals)).astype(np.int64)
    whole, frac = np.divmod(a, np.int64(10) ** decimals)
    head = out.shape[1] - (1 + decimals if decimals else 0)        # sign slot + integer digits
    out[:, 1:head] = _digits(whole, head - 1)
    length = np.ones(len(v), dtype=np.intp)                         # digits of the integer part
    for k in range(1, head - 1):
        length += whole >= 10 ** k
    lead = head - length                                            # first digit's column
    keep = (np.arange(head) >= np.arange(head + 1)[:, None]).astype(np.uint8)[lead]   # 0 before the lead
    out[:, :head] *= keep
    negative = (v < 0) & (a > 0)                    # "-0.000" never: what rounds to zero is 0
    rows = np.nonzero(negative)[0]
    out[rows, lead[rows] - 1] = _MINUS
    if decimals:
        out[:, head] = _DOT
        out[:, head + 1:] = _digits(frac, decimals)


def _width(column: np.ndarray, decimals: int) -> int:
    top = int(np.rint(_scaled(np.asarray(column, dtype=float), decimals)).max() // 10 ** decimals) if len(column) else 0
    return 1 + len(str(top)) + (1 + decimals if decimals else 0)


def format_rows(columns: list[np.ndarray], decimals: list[int]) -> bytes:
    """The rows ``columns[0][i],columns[1][i],...\\n`` as ASCII bytes (see the module text)."""
    if len(columns) != len(decimals) or not columns:
        raise ValueError("one decimals entry per column, and at least one column")
    n = len(columns[0])
    if any(len(c) != n for c in columns):
        raise ValueError("columns of different lengths")
    widths = [_width(c, d) for c, d in zip(columns, decimals)]
    table = np.empty((n, sum(widths) + len(widths)), dtype=np.uint8)
    at = 0
    for k, (col, d, w) in enumerate(zip(columns, decimals, widths)):
        _field(col, d, table[:, at:at + w])
        table[:, at + w] = _NL if k == len(columns) - 1 else _COMMA
        at += w + 1
    return table.tobytes().translate(None, b"\0")        # the unused bytes out, in C
