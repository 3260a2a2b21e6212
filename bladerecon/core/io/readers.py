# SPDX-License-Identifier: LGPL-2.1-or-later
"""Stage 1 of the pipeline: a measured point file -> :class:`PointSet` (units: mm).

Three text formats and two scanner formats, recognised by content (never by file extension):

``csv``
    A header row naming ``x``, ``y``, ``z`` (case-insensitive, any order, an optional
    unit suffix ``x [mm]`` / ``x_mm``; extra columns ignored) and optionally ``section``,
    a label (int or text), and a unit normal per point (``nx, ny, nz``, ``i, j, k`` or
    ``normal_x, ...``: kept when all three are there and every row's is of unit length, else
    ignored like any extra column). Delimiter ``,`` or ``;`` (detected from the header; with ``;``
    a decimal comma is accepted). Without a ``section`` column, blank lines separate
    the sections.
``xyz-blocks``
    ``x y z`` per line (or ``id x y z``, the id ignored; or ``x y z i j k``, a CMM's or
    scanner's point with its unit normal), sections separated by blank lines or ``#`` lines
    (one or more).
``section-table``
    The layout of ``shared/data/nasa_rotor37/rotor37_sections_xyz_mm.txt``: ``#`` lines,
    a line ``NPTS NSECTIONS``, then exactly NPTS*NSECTIONS lines ``x y z``.

``ply`` / ``pcd``
    Scanner files (ASCII or binary, optional normals), read by :mod:`bladerecon.core.io.scanner`:
    an unordered cloud (``require_sections=False``), one block named ``1``.

Sections are numbered 0.. in order of first appearance. CSV section labels are kept as
names (an integer label ``3.0`` or ``03`` is named ``3``); sections without a label are
named ``1``, ``2``, ... (the 1-based position, as in the NASA tables).

Every error a user can cause raises :class:`BladeReconError` with a one-line message
naming the file, the line and what to do; text from the file is shown escaped and cut
(:func:`bladerecon.core.io.outputs.shown`), and a NUL byte in the first megabyte is refused
as binary content. The input file is only ever read.
"""
from __future__ import annotations

import os
import re
import tempfile
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Sequence

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.memory import (READ_BASE, SCAN_BYTES_PER_BYTE, SCAN_BYTES_PER_LINE, careful_read_need,
                                        check_budget, check_command)
from bladerecon.core.io.outputs import shown
from bladerecon.core.io.scanner import read_scan, sniff

__all__ = ["PointSet", "check_file", "headerless_rows", "points_upper_bound", "read_headerless_cloud",
           "read_points", "write_points_csv"]

_NO_STRUCTURE = (
    "points have no section structure: add a 'section' column to the CSV or separate "
    "sections by blank lines; an unordered cloud: cut it into sections with reconstruct "
    "--slice N (planes) or --slice-radii R1,R2,.. (cylinders)"
)
_TEXT_CHECK_BYTES = 1 << 20      # NUL bytes in the first megabyte: not a text file
_BLOCK_BYTES = 4 << 20           # plain tables are scanned this much at a time
_MAX_MARKED_LINES = 100_000      # more '#' lines than this in a block: the careful parser
_MAX_LINE_BYTES = 1 << 20        # a point's line is a few numbers: a longer line is refused
_UNIT_SUFFIX = re.compile(r"[\s_]*[\[(]?\s*mm\s*[\])]?$")
_NORMAL = ("nx", "ny", "nz")
_NORMAL_NAMES = {"i": "nx", "j": "ny", "k": "nz", "normal_x": "nx", "normal_y": "ny", "normal_z": "nz"}
_UNIT_NORMAL_TOL = 0.01        # |n| - 1 allowed in a file's normals (CMM i j k printed with 3+ decimals)


@dataclass(frozen=True, eq=False)
class PointSet:
    """Measured points with their section labels, as read from one file.

    Attributes:
        points: (N, 3) float64 coordinates in mm, in file order (read-only array).
        section: (N,) int section index, 0-based, in order of first appearance.
        line: (N,) int 1-based line number of each point in the file.
        section_names: one name per section index.
        source: the path the points were read from.
        format: ``'csv'``, ``'xyz-blocks'``, ``'section-table'``, or a scan's ``'ply-ascii'``,
            ``'ply-binary'``, ``'pcd-ascii'``, ``'pcd-binary'``.
        structured: False for one block of points with no section labels (read with
            ``require_sections=False``): a cloud, not one measured section.
        normals: (N, 3) normals as the file gives them (PLY ``nx ny nz``, PCD ``normal_x ...``,
            ``x y z i j k`` lines, ``nx,ny,nz`` / ``i,j,k`` CSV columns), each within 1 % of unit
            length (files whose aren't: None, or for ``x y z i j k`` lines refused), else None.
        left_out: points of the file not in ``points`` (a PCD's NaN pixels).
    """

    points: np.ndarray
    section: np.ndarray
    line: np.ndarray
    section_names: tuple[str, ...]
    source: str
    format: str
    structured: bool = True
    normals: np.ndarray | None = None
    left_out: int = 0

    def __post_init__(self) -> None:
        for name in ("points", "section", "line", "normals"):
            if getattr(self, name) is not None:
                getattr(self, name).flags.writeable = False

    @property
    def n_sections(self) -> int:
        return len(self.section_names)

    def section_points(self, k: int) -> np.ndarray:
        """The (n, 3) points (mm) of section ``k`` in file order."""
        return self.points[self.section == k]

    def section_lines(self, k: int) -> np.ndarray:
        """The 1-based file line numbers of the points of section ``k``."""
        return self.line[self.section == k]


def read_points(path: str | os.PathLike, require_sections: bool = True,
                memory_limit: float | None = None) -> PointSet:
    """Read a point file (mm); the format ('csv', 'xyz-blocks', 'section-table', see the
    module docstring) is detected from the first line that is not blank or ``#``.

    ``require_sections=False``: a file with no section structure (one block of points, a CSV
    without a ``section`` column) is one section named ``1`` instead of an error (a cloud for
    ``deviation``).

    Plain numeric tables are read by a vectorised path (numpy's C parser); anything it does not
    take (comments, quotes, text labels, a bad cell, decimal commas) goes to the careful parser,
    which names the file, line and column of what is wrong. Both give the same PointSet.

    Memory: the first megabyte is checked for binary content before anything else is read;
    plain numeric tables are scanned in blocks of 4 MB and parsed by numpy from the file, so
    only the numbers are held (32 bytes a point, plus 8 a line); a file the careful parser must
    read, or a scan, is first checked against the memory budget (``memory_limit`` GB, default
    half the available memory; :mod:`bladerecon.core.io.memory`) from its size.

    Raises:
        BladeReconError: missing/unreadable/empty file, bad header or cell, NaN/inf,
            wrong point count, points with no section structure, or a file over the budget.
    """
    source = str(path)
    try:
        return _read_points(source, require_sections, memory_limit)
    except BladeReconError as err:      # a file name with control characters: shown escaped
        if shown(source, len(source) + 1) == source:
            raise
        raise BladeReconError(str(err).replace(source, shown(source, 200))) from None


def _read_points(source: str, require_sections: bool, memory_limit: float | None) -> PointSet:
    head = _read_head(source)
    if sniff(head):                      # a scan: bodies are read whole (12-56 bytes a point in binary)
        # an ASCII body also costs per line; a binary one's newline bytes are numbers, not lines
        ascii_body = re.search(rb"\n(format|DATA)[ \t]+ascii", head[:1 << 16]) is not None
        lines = _line_stats(source, binary=True)[0] if ascii_body else 0
        check_budget(f"reading {source}", READ_BASE + SCAN_BYTES_PER_BYTE * _size(source) + SCAN_BYTES_PER_LINE * lines,
                     memory_limit, "split the scan, or raise --memory-limit")
        return _scan_point_set(source, _read_bytes(source, text=False), require_sections)
    _check_text(source, head)
    fast = _read_fast(source, require_sections)
    if fast is not None:
        return fast
    # the careful parser holds the file's lines and cells as Python strings
    _careful_budget(source, head, memory_limit,
                 "write it as a plain CSV (header x,y,z[,section], numeric section labels, no quotes or comments "
                 "after values), which is read in blocks, "
                 "or raise --memory-limit")
    raw = _read_bytes(source, text=True)
    lines = _split_lines(raw)
    first = next((i for i, ln in enumerate(lines) if ln.strip() and not _is_comment(ln)), None)
    if first is None:
        raise BladeReconError(f"{source}: no points in the file (only blank or '#' lines): "
                              "give one point per line")
    head = lines[first].strip()
    tokens = re.split(r"[,;\s]+", head)
    n_numeric = sum(_is_number(t) for t in tokens)
    if n_numeric == 0:
        return _read_csv(source, lines, first, require_sections)
    if "," in head or ";" in head:
        raise BladeReconError(
            f"{source}, line {first + 1}: comma-separated values without a header row: "
            "add a header naming the columns, e.g. 'section,x,y,z'")
    if n_numeric == len(tokens) == 2:
        return _read_section_table(source, lines, first)
    if n_numeric < len(tokens) and len(tokens) not in (3, 4, 6):
        raise BladeReconError(
            f"{source}, line {first + 1}: '{shown(head)}' is neither a header naming x, y, z nor "
            "a line of numbers: use a CSV with a header, or 'x y z' lines")
    return _read_xyz_blocks(source, lines, first, len(tokens), require_sections)


def write_points_csv(path: str | os.PathLike, points: np.ndarray, section: np.ndarray,
                     names: Sequence[str] | None = None) -> None:
    """Write points (mm) as ``section,x,y,z`` CSV, atomically (temp file + os.replace).

    ``section`` holds 0-based indices; the column gets ``names[index]`` when names are
    given, else the index. Coordinates are written with full round-trip precision.
    """
    pts = np.asarray(points, dtype=float)
    sec = np.asarray(section)
    if pts.ndim != 2 or pts.shape[1] != 3 or sec.shape != (pts.shape[0],):
        raise ValueError(f"points must be (N, 3) and section (N,), got {pts.shape} and {sec.shape}")
    if not np.all(np.isfinite(pts)):
        raise ValueError("points contain NaN or inf")
    sec = sec.astype(int)
    if sec.size and sec.min() < 0:
        raise ValueError("section indices must be >= 0")
    if names is None:
        labels = [str(k) for k in range(int(sec.max(initial=-1)) + 1)]
    else:
        labels = [str(n).strip() for n in names]
        bad = [n for n in labels if not n or n.startswith("#") or re.search(r"[,;\"\n\r]", n)]
        if bad:
            raise ValueError(f"section names must be non-empty, not start with #, and hold no "
                             f", ; \" or newlines: {bad}")
        if sec.size and sec.max() >= len(labels):
            raise ValueError(f"section index {sec.max()} but only {len(labels)} names")
    rows = [f"{labels[s]},{x!r},{y!r},{z!r}\n" for s, (x, y, z) in zip(sec.tolist(), pts.tolist())]
    _write_atomically(Path(path), "section,x,y,z\n" + "".join(rows))


def _write_atomically(target: Path, text: str) -> None:
    """Write ``text`` to a temp file beside ``target``, then rename it over ``target``:
    readers see the old file or the new one, never half of one."""
    if target.exists():
        mode = target.stat().st_mode & 0o777
    else:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.chmod(tmp, mode)             # mkstemp makes 0600 files
        os.replace(tmp, target)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# --- file level ------------------------------------------------------------------------

def _scan_point_set(source: str, raw: bytes, require_sections: bool) -> PointSet:
    """A PLY or PCD scan (:mod:`bladerecon.core.io.scanner`) as one unlabelled block: a cloud.
    ``line`` holds each point's line (ASCII) or vertex number (binary)."""
    scan = read_scan(source, raw)
    if require_sections and scan.section is None:
        raise BladeReconError(f"{source}: a {scan.format.split('-')[0].upper()} scan: {_NO_STRUCTURE}")
    n = len(scan.points)
    # its normals as a CSV's named columns: kept where every one is of unit length (a scanner may
    # write zeros or unnormalised vectors where it has none), else left out
    normals = None if scan.normals is None else _unit_normals(source, scan.index, scan.normals.T, loose=True)
    if scan.section is not None:          # a PLY with a section property (ours: --aligned FILE.ply)
        return PointSet(np.ascontiguousarray(scan.points), scan.section, np.asarray(scan.index), scan.section_names,
                        source, scan.format, structured=True, normals=normals)
    return PointSet(np.ascontiguousarray(scan.points), np.zeros(n, dtype=int), np.asarray(scan.index), ("1",),
                    source, scan.format, structured=False, normals=normals, left_out=scan.left_out)


def _open_error(source: str, err: OSError) -> BladeReconError:
    if isinstance(err, FileNotFoundError):
        return BladeReconError(f"{source}: file not found: check the path")
    if isinstance(err, IsADirectoryError):
        return BladeReconError(f"{source}: is a folder, not a point file: give the file")
    return BladeReconError(f"{source}: cannot read the file ({err.strerror}): check its permissions")


def _read_head(source: str) -> bytes:
    """The file's first megabyte (all a check for binary content or a scan header needs), read
    before anything else: a 2 GB file of NUL bytes is refused without being read."""
    try:
        with open(source, "rb") as fh:
            head = fh.read(_TEXT_CHECK_BYTES)
    except OSError as err:
        raise _open_error(source, err) from None
    if not head.strip() and len(head) < _TEXT_CHECK_BYTES:
        raise BladeReconError(f"{source}: the file is empty: give one point per line")
    return head


def points_upper_bound(path: str | os.PathLike) -> int:
    """At most this many points are in the file, found without reading it whole (for a memory
    budget before the work): a scan's header count, else the text file's line count. A file
    that cannot be read, or binary content, is the usual one-line error."""
    source = str(path)
    head = _read_head(source)
    kind = sniff(head)
    if kind is not None:
        pattern = rb"\nelement[ \t]+vertex[ \t]+(\d{1,15})\s" if kind == "ply" else rb"\nPOINTS[ \t]+(\d{1,15})\s"
        found = re.search(pattern, head[:1 << 16])
        if found:   # no more than the file can hold (3 bytes a vertex): an absurd count is the reader's to name
            return min(int(found.group(1)), _size(source) // 3 + 1)
        return _size(source) // 12 + 1         # the smallest record: three float32
    _check_text(source, head)
    return _line_stats(source)[0]


def check_file(command: str, path: str | os.PathLike, limit_gb: float | None, **kwargs) -> None:
    """The memory budget of ``command`` (:func:`~bladerecon.core.io.memory.check_command`) on a
    point file, before it is read: its points bounded by :func:`points_upper_bound`."""
    check_command(command, points_upper_bound(path), limit_gb, str(path), **kwargs)


def _line_stats(source: str, binary: bool = False) -> tuple[int, int, int]:
    """One pass over the file a block at a time: its line count, its longest line (bytes) and
    that line's number (for the memory budget and the long-line check). A NUL byte anywhere is
    refused here, at its offset (``binary``: a scan's body, where NUL bytes are numbers)."""
    n, run, longest, longest_at, offset = 0, 0, 0, 1, 0
    try:
        with open(source, "rb") as fh:
            for block in iter(lambda: fh.read(_BLOCK_BYTES), b""):
                nul = -1 if binary else block.find(b"\0")
                if nul >= 0:
                    raise _nul_error(source, offset + nul)
                offset += len(block)
                end = 10 if b"\n" in block or b"\r" not in block else 13      # CR-only line ends
                ends = np.flatnonzero(np.frombuffer(block, np.uint8) == end)
                if ends.size:
                    lengths = np.diff(np.concatenate([[-1], ends])) - 1
                    lengths[0] += run
                    k = int(np.argmax(lengths))
                    if lengths[k] > longest:
                        longest, longest_at = int(lengths[k]), n + k + 1
                    run = len(block) - int(ends[-1]) - 1
                    n += ends.size
                else:
                    run += len(block)
                if run > longest:
                    longest, longest_at = run, n + 1
    except OSError as err:
        raise _open_error(source, err) from None
    return n + (run > 0), longest, longest_at


def _careful_budget(source: str, head: bytes, memory_limit: float | None, advice: str) -> None:
    """Before the careful parser reads a file whole: no line longer than a point's line can be
    (a file of one endless line holds no points, and splitting it took 2 GB), and the need of
    its lines and bytes within the budget."""
    n_lines, longest, at = _line_stats(source)
    if longest > _MAX_LINE_BYTES:
        raise BladeReconError(f"{source}, line {at}: {longest / 1e6:.1f} MB in one line: a point is one line of a "
                              "few numbers; give a point file with one point per line")
    first = _first_line(head)              # the header, or the first row: its cells
    columns = len([c for c in re.split(rb"[,;\s]+", first) if c]) if first else 3
    check_budget(f"reading {source}", careful_read_need(n_lines, _size(source), columns), memory_limit, advice)


def _first_line(head: bytes) -> bytes | None:
    """The first line of a file's head that is not blank or a '#' comment, stripped (no BOM)."""
    if head.startswith(b"\xef\xbb\xbf"):
        head = head[3:]
    # CR-only line ends (old Mac exports): otherwise the whole head is one "line" of every cell
    newline = b"\n" if b"\n" in head or b"\r" not in head else b"\r"
    for line in head.split(newline, 10_000)[:10_000]:
        text = line.strip()
        if text and not text.startswith(b"#"):
            return text
    return None


def _size(source: str) -> int:
    try:
        return os.stat(source).st_size
    except OSError:
        return 0


def _read_bytes(source: str, text: bool = True) -> bytes:
    """The file's bytes; a missing, unreadable or empty file is a one-line error, and so is
    binary content when ``text``."""
    try:
        raw = Path(source).read_bytes()
    except OSError as err:
        raise _open_error(source, err) from None
    if not raw[:4096].strip() and not raw.strip():      # the whole file copied only when its start is blank
        raise BladeReconError(f"{source}: the file is empty: give one point per line")
    if text:
        _check_text(source, raw)
    return raw


def _check_text(source: str, raw: bytes) -> None:
    """NUL bytes anywhere in ``raw`` (the first megabyte, or the whole file): not a text file."""
    nul = raw.find(b"\0")
    if nul >= 0:
        raise _nul_error(source, nul, raw[:2] in (b"\xff\xfe", b"\xfe\xff"))


def _nul_error(source: str, offset: int, utf16: bool = False) -> BladeReconError:
    hint = " (UTF-16 text? save it as UTF-8)" if utf16 else ""
    return BladeReconError(f"{source}: not a text point file: a NUL byte at offset {offset}{hint}: give a CSV, "
                           "'x y z' text, PLY or PCD file")


def _split_lines(raw: bytes) -> list[str]:
    """File text split into lines (1-based line k is ``lines[k-1]``), newline style agnostic."""
    if raw.startswith(b"\xef\xbb\xbf"):       # a BOM, whatever the comments' encoding
        raw = raw[3:]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def _is_comment(line: str) -> bool:
    return line.lstrip().startswith("#")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _blocks(lines: list[str], first: int) -> tuple[list[int], np.ndarray]:
    """Indices of data lines from ``first`` on, and each one's block number.

    A block is a run of data lines; blank and ``#`` lines end it (any number of them).
    """
    stripped = [ln.strip() for ln in lines[first:]]
    is_data = np.array([s[:1] not in ("", "#") for s in stripped], dtype=bool)
    idx = np.flatnonzero(is_data) + first
    block = np.concatenate([[0], np.cumsum(np.diff(idx) > 1)]) if idx.size else idx
    return idx.tolist(), block.astype(int)


def _split_rows(source: str, lines: list[str], idx: list[int], sep: str | None,
                ncol: int, at_least: bool = False) -> list[list[str]]:
    """Split data lines into cells; every row must have ``ncol`` cells (or more)."""
    rows = [lines[i].split(sep) for i in idx]
    for i, row in zip(idx, rows):
        if len(row) != ncol and not (at_least and len(row) > ncol):
            want = f"at least {ncol}" if at_least else str(ncol)
            raise BladeReconError(f"{source}, line {i + 1}: expected {want} columns, found "
                                  f"{len(row)}: give every point the same columns")
    return rows


def _to_float(source: str, idx: list[int], cells: list[str], column: str,
              decimal_comma: bool = False) -> np.ndarray:
    """One column of cells -> float array; a bad cell names its line, column and text."""
    if decimal_comma:
        cells = [c.replace(",", ".") for c in cells]
    try:
        values = np.array(list(map(float, cells)), dtype=float)
    except ValueError:
        values = np.empty(len(cells))
        for k, (i, c) in enumerate(zip(idx, cells)):
            try:
                values[k] = float(c.strip().strip("\"'"))
            except ValueError:
                raise BladeReconError(
                    f"{source}, line {i + 1}: column '{shown(column)}' has '{shown(c.strip())}', which is "
                    "not a number: correct or delete that line") from None
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise BladeReconError(f"{source}, line {idx[bad[0]] + 1}: column '{shown(column)}' is "
                              f"'{shown(cells[bad[0]].strip())}' (NaN or infinite): correct or delete "
                              "that line")
    return values


def _point_set(source: str, fmt: str, xyz: np.ndarray, section: np.ndarray,
               idx: list[int], names: Sequence[str], structured: bool = True,
               normals: np.ndarray | None = None) -> PointSet:
    return PointSet(points=np.ascontiguousarray(xyz, dtype=float), section=section.astype(int, copy=False),
                    line=np.asarray(idx, dtype=int) + 1, section_names=tuple(names),
                    source=source, format=fmt, structured=structured,
                    normals=None if normals is None else np.ascontiguousarray(normals, dtype=float))


def _require_structure(source: str, idx: list[int], block: np.ndarray) -> None:
    if block.size and block[-1] == 0:
        raise BladeReconError(f"{source}, lines {idx[0] + 1}–{idx[-1] + 1}: {_NO_STRUCTURE}")


# --- the vectorised path ----------------------------------------------------------------

def read_headerless_cloud(path: str | os.PathLike, memory_limit: float | None = None) -> PointSet:
    """An unordered cloud of ``x,y,z`` / ``id,x,y,z`` rows separated by commas or semicolons
    with no header (as scanners and CAD programs export them; :func:`read_points` asks for a
    header there, where four columns could be ``section,x,y,z``). Read in blocks like a plain
    table; a bad row is named by its line."""
    source = str(path)
    head = _read_head(source)
    _check_text(source, head)
    fast = _read_fast(source, False, headerless=True)
    if fast is not None:
        return fast
    _careful_budget(source, head, memory_limit,
                    "give it a header x,y,z (then it is read in blocks), or raise --memory-limit")
    pts, lines, width, first = [], [], None, 0
    try:
        fh = open(source, encoding="utf-8", errors="replace")     # any line ends, CR-only too
    except OSError as err:
        raise _open_error(source, err) from None
    with fh:
        for no, raw in enumerate(fh, 1):
            text = raw.lstrip("\ufeff").strip()
            if not text or text.startswith("#"):
                continue
            cells = [c.strip() for c in re.split(r"[,;]", text)] if ("," in text or ";" in text) else text.split()
            if width is None:
                width, first = len(cells), no
                if width not in (3, 4):
                    raise BladeReconError(f"{source}, line {no}: expected 'x,y,z' or 'id,x,y,z', got {width} values: "
                                          "give one point per line")
            elif len(cells) != width:
                raise BladeReconError(f"{source}, line {no}: {len(cells)} values where line {first} has {width}: "
                                      "give every point the same columns")
            try:
                xyz = [float(c) for c in cells[-3:]]
                if not all(np.isfinite(xyz)):
                    raise ValueError
            except ValueError:
                raise BladeReconError(f"{source}, line {no}: '{shown(text, 60)}' is not a line of finite numbers "
                                      "(an empty cell, a decimal comma, text?): correct or remove the line") from None
            pts.append(xyz)
            lines.append(no - 1)
    if not pts:
        raise BladeReconError(f"{source}: no points in the file: give one point per line")
    return _point_set(source, "xyz-blocks", np.asarray(pts, float), np.zeros(len(pts), dtype=int),
                      np.asarray(lines), ["1"], structured=False)


def headerless_rows(path: str | os.PathLike) -> bool:
    """Whether the file's first line that is not blank or ``#`` is a row of 3 or 4 numbers
    separated by commas or semicolons (a cloud for :func:`read_headerless_cloud`). Reads the
    first megabyte only."""
    source = str(path)
    head = _read_head(source)
    first = None if sniff(head) else _first_line(head)
    if first is None or (b"," not in first and b";" not in first):
        return False
    cells = re.split(r"[,;]", first.decode("latin-1"))
    return len(cells) in (3, 4) and all(_is_number(c.strip()) for c in cells)


def _read_fast(source: str, require_sections: bool, headerless: bool = False) -> PointSet | None:
    """A plain numeric CSV (``,`` with a header) or ``x y z`` / ``id x y z`` blocks, read with
    numpy's C parser and the line structure found on the bytes, a block of 4 MB at a time;
    None for anything else (the careful parser then reads it, and names what is wrong).
    ``#`` lines (comments, section separators) are taken; a ``#`` after a value is not."""
    scan = _scan_lines(source)
    if scan is None:
        return None
    data, head, encoding = scan
    first = int(data[0])
    try:
        head_text = head.decode("ascii").strip()
    except UnicodeDecodeError:
        return None
    if not head_text:             # a line of spaces: numpy skips it, the careful parser reads the file
        return None
    tokens = re.split(r"[,;\s]+", head_text)
    n_numeric = sum(_is_number(t) for t in tokens)
    if n_numeric == 0:                                   # a CSV header
        sep, names, col = _header(source, head_text, first)
        if sep != "," or data.size < 2:
            return None
        idx, skip, ncol = data[1:], first + 1, len(names)
        pick = [col[c] for c in "xyz"] + ([col["section"]] if "section" in col else [])
        normal_cols = [col[c] for c in _NORMAL if c in col]
    elif n_numeric == len(tokens) in (3, 4, 6) and "," not in head_text and ";" not in head_text:
        sep, idx, skip, ncol = None, data, first, len(tokens)
        pick = [0, 1, 2] if ncol == 6 else list(range(ncol - 3, ncol))
        normal_cols = [3, 4, 5] if ncol == 6 else []
    elif headerless and n_numeric == len(tokens) in (3, 4):
        sep = ";" if ";" in head_text else ","
        idx, skip, ncol = data, first, len(tokens)
        pick, normal_cols = list(range(ncol - 3, ncol)), []
    else:
        return None
    try:   # numpy's C parser reads the file itself, in chunks
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            # every column: a row with more or fewer values than the first goes to the careful parser
            table = np.loadtxt(source, delimiter=sep, ndmin=2, dtype=float, comments="#",
                               skiprows=skip, encoding=encoding)
    except (ValueError, UnicodeDecodeError, IndexError, OSError):
        return None
    if table.shape != (idx.size, ncol) or not np.isfinite(table).all():
        return None
    normals = None
    if normal_cols:    # judged on the table's columns in place: no copy of them unless they are normals
        normals = _unit_normals(source, idx, [table[:, k] for k in normal_cols], loose=sep is not None)
    if pick != list(range(ncol)):                        # only the columns kept (no copy of x,y,z alone)
        table = table[:, pick]
    xyz = table[:, :3]                                   # idx: 0-based line of each row (an array)
    fmt = "xyz-blocks" if sep is None or headerless else "csv"
    if headerless:
        return _point_set(source, fmt, xyz, np.zeros(idx.size, dtype=int), idx, ["1"], structured=False)
    if sep == "," and "section" in col:
        labels = table[:, 3]
        if not np.all(labels == np.floor(labels)) or np.abs(labels).max() >= 2 ** 53:
            return None                                  # text-like labels: kept as written
        section, names_found = _section_labels_of_numbers(labels)
        return _point_set(source, fmt, xyz, section, idx, names_found, normals=normals)
    block = np.zeros(idx.size, dtype=int)                # a new block after every gap in the lines
    block[np.flatnonzero(np.diff(idx) > 1) + 1] = 1
    np.cumsum(block, out=block)
    if require_sections:
        _require_structure(source, idx, block)
    return _point_set(source, fmt, xyz, block, idx, [str(b + 1) for b in range(block[-1] + 1)],
                      structured=bool(block[-1] > 0), normals=normals)


def _line_blocks(fh) -> Iterator[bytes | None]:
    """The open file's bytes in blocks of about 4 MB, each ending at a newline (the last at
    the end of the file); None for a stretch of 16 MB without a newline (not a point file's
    line: the careful parser says what it is)."""
    tail = b""
    while True:
        chunk = fh.read(_BLOCK_BYTES)
        if not chunk:
            if tail:
                yield tail
            return
        buf = tail + chunk
        cut = buf.rfind(b"\n") + 1
        if cut == 0 and len(buf) < 4 * _BLOCK_BYTES:
            tail = buf
            continue
        if cut == 0:
            yield None
            return
        tail = buf[cut:]
        yield buf[:cut]


def _scan_lines(source: str) -> tuple[np.ndarray, bytes, str] | None:
    """One pass over the file in blocks: the 0-based numbers of its data lines (not blank, not
    ``#``), the first one's bytes and the encoding numpy should read it with; None when the
    file is not for the vectorised path (quotes, a ``#`` after a value, CR-only line ends,
    no data line). NUL bytes anywhere are refused here, as in the first megabyte."""
    found, head, line0, offset, utf8 = [], None, 0, 0, True
    try:
        with open(source, "rb") as fh:
            for k, block in enumerate(_line_blocks(fh)):
                if block is None:
                    return None
                nul = block.find(b"\0")
                if nul >= 0:
                    raise _nul_error(source, offset + nul)
                offset += len(block)
                if k == 0 and block.startswith(b"\xef\xbb\xbf"):
                    block = block[3:]
                if b"\r" in block:
                    block = block.replace(b"\r\n", b"\n")
                    if b"\r" in block:
                        return None
                if utf8 and not block.isascii():
                    try:
                        block.decode("utf-8")
                    except UnicodeDecodeError:   # Latin-1 comments: numbers are ASCII either way
                        utf8 = False
                lines = _data_lines(block)
                if lines is None:
                    return None
                if lines.size:
                    if head is None:
                        starts = np.concatenate([[0], np.flatnonzero(np.frombuffer(block, np.uint8) == 10) + 1])
                        at = int(starts[lines[0]])
                        end = block.find(b"\n", at)
                        head = block[at:] if end < 0 else block[at:end]
                    found.append(lines + line0)
                line0 += block.count(b"\n")
    except OSError as err:
        raise _open_error(source, err) from None
    if head is None:
        return None
    return np.concatenate(found), head, "utf-8-sig" if utf8 else "latin-1"


def _data_lines(body: bytes) -> np.ndarray | None:
    """0-based numbers of the lines of ``body`` that are neither empty nor ``#`` comments
    (both separate sections); None when a quote or a ``#`` stands on a line with values. A
    line of only spaces counts here but not for numpy's parser: the row counts then differ
    and the careful parser reads the file."""
    b = np.frombuffer(body, dtype=np.uint8)
    newline = np.flatnonzero(b == 10)
    starts = np.concatenate([[0], newline + 1])
    ends = np.concatenate([newline, [len(body)]])
    keep = ends > starts
    if b"#" in body or b'"' in body or b"'" in body:
        marks = np.flatnonzero((b == 35) | (b == 34) | (b == 39))      # '#', '"', "'"
        marked = np.unique(np.searchsorted(newline, marks))              # lines holding one
        if marked.size > _MAX_MARKED_LINES:
            return None
        for line in marked.tolist():      # a comment: '#' first; a quote only inside a comment
            if not body[starts[line]:ends[line]].lstrip(b" \t").startswith(b"#"):
                return None
        keep[marked] = False
    return np.flatnonzero(keep)


def _section_labels_of_numbers(labels: np.ndarray) -> tuple[np.ndarray, list[str]]:
    """Whole-number section labels -> 0-based index per row in order of first appearance, and
    the names ('3.0' and '03' are both '3', as the careful parser names them)."""
    values, first_row, inverse = np.unique(labels, return_index=True, return_inverse=True)
    order = np.argsort(first_row)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return rank[inverse.ravel()], [str(int(values[k])) for k in order]


# --- formats ---------------------------------------------------------------------------

def _header(source: str, header: str, first: int) -> tuple[str | None, list[str], dict[str, int]]:
    """A CSV header line -> (separator, column names, {x, y, z[, section][, nx, ny, nz]: column});
    normal columns may also be named i, j, k or normal_x, normal_y, normal_z, and are kept only
    when all three are there."""
    sep = ";" if header.count(";") > header.count(",") else ","
    if sep not in header:
        sep = None  # one header cell, or whitespace-separated: reported below if unusable
    names = [c.strip().strip("\"'").strip().lower() for c in header.split(sep)]
    plain = [_UNIT_SUFFIX.sub("", n) for n in names]
    col: dict[str, int] = {}
    for k, n in enumerate(plain):
        n = _NORMAL_NAMES.get(n, n)
        if n in ("x", "y", "z", "section", "nx", "ny", "nz"):
            if n in col:
                raise BladeReconError(f"{source}, line {first + 1}: column '{n}' appears twice "
                                      "in the header: keep one")
            col[n] = k
    if not all(c in col for c in _NORMAL):
        for c in _NORMAL:      # a normal needs all three (i, j alone may be a grid's indices): ignored
            col.pop(c, None)
    missing = [c for c in "xyz" if c not in col]
    if missing:
        found = ", ".join(f"'{shown(n, 30)}'" for n in names[:12]) + (", …" if len(names) > 12 else "")
        raise BladeReconError(
            f"{source}, line {first + 1}: header has no column {', '.join(map(repr, missing))} "
            f"(found {found}): name the coordinate columns x, y, z")
    return sep, names, col


def _read_csv(source: str, lines: list[str], first: int, require_sections: bool = True) -> PointSet:
    sep, names, col = _header(source, lines[first], first)
    idx, block = _blocks(lines, first + 1)
    if not idx:
        raise BladeReconError(f"{source}, line {first + 1}: header but no data rows: "
                              "give one point per line below the header")
    rows = _split_rows(source, lines, idx, sep, len(names), at_least=True)
    decimal_comma = sep == ";"
    xyz = np.column_stack([_to_float(source, idx, [r[col[c]] for r in rows], names[col[c]],
                                     decimal_comma) for c in "xyz"])
    normals = None
    if "nx" in col:
        cells = [[r[col[c]] for r in rows] for c in _NORMAL]
        try:
            values = [_to_float(source, idx, v, names[col[c]], decimal_comma) for v, c in zip(cells, _NORMAL)]
        except BladeReconError:
            values = None      # text in them: not a normal, an extra column
        normals = None if values is None else _unit_normals(source, idx, values, loose=True)
    if "section" in col:
        section, names_found = _section_labels(source, idx, [r[col["section"]] for r in rows])
        return _point_set(source, "csv", xyz, section, idx, names_found, normals=normals)
    if require_sections:
        _require_structure(source, idx, block)
    return _point_set(source, "csv", xyz, block, idx, [str(b + 1) for b in range(block[-1] + 1)],
                      structured=bool(block[-1] > 0), normals=normals)


def _unit_normals(source: str, idx, columns, loose: bool = False) -> np.ndarray | None:
    """A file's normals (N, 3) from their three ``columns`` (views of the table: not copied unless
    kept), each checked to be of unit length (within _UNIT_NORMAL_TOL), as written (who uses them
    scales them to 1). A row that is not names its line (``x y z i j k`` lines, where the six
    columns say they are normals); ``loose`` (a CSV's named columns or a scan's: they may hold
    something else, and such files were read before normals were): None, the columns ignored."""
    a, b, c = columns
    length = np.sqrt(a * a + b * b + c * c)
    bad = np.flatnonzero(~(np.abs(length - 1.0) <= _UNIT_NORMAL_TOL))
    if bad.size and loose:
        return None
    if bad.size:
        k = int(bad[0])
        raise BladeReconError(
            f"{source}, line {int(idx[k]) + 1}: the normal ({', '.join(f'{v[k]:.6g}' for v in (a, b, c))}) has length "
            f"{length[k]:.4g}, not 1 ({bad.size} row(s) like it): give unit normals (nx ny nz or i j k) after "
            "x y z, or the coordinates alone")
    return np.column_stack([a, b, c])


def _section_labels(source: str, idx: list[int], cells: list[str]) -> tuple[np.ndarray, list[str]]:
    """Section column -> 0-based index per row (order of first appearance) and the names.

    Integer-valued labels are normalised ('03', '3.0' -> '3'); work is per distinct label.
    """
    raw, first_row, inverse = np.unique(np.asarray(cells), return_index=True, return_inverse=True)
    norm = [_label(c) for c in raw]
    empty = [first_row[k] for k, n in enumerate(norm) if not n]
    if empty:
        raise BladeReconError(f"{source}, line {idx[min(empty)] + 1}: empty 'section' cell: "
                              "give every point a section label")
    names, code = np.unique(np.asarray(norm), return_inverse=True)
    first_of_name = np.full(names.size, len(cells))
    np.minimum.at(first_of_name, code, first_row)
    order = np.argsort(first_of_name)
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    return rank[code][inverse], [str(names[k]) for k in order]


def _label(cell: str) -> str:
    s = cell.strip().strip("\"'").strip()
    try:
        v = float(s)
    except ValueError:
        return s
    return str(int(v)) if np.isfinite(v) and v == int(v) else s


def _read_xyz_blocks(source: str, lines: list[str], first: int, ncol: int,
                     require_sections: bool = True) -> PointSet:
    if ncol not in (3, 4, 6):
        raise BladeReconError(f"{source}, line {first + 1}: expected 'x y z' (3 numbers), "
                              f"'id x y z' (4 numbers) or 'x y z i j k' (6: a unit normal after the point), "
                              f"found {ncol} values: use one of these layouts or a CSV with a header")
    idx, block = _blocks(lines, first)
    rows = _split_rows(source, lines, idx, None, ncol)
    names = {3: ["x", "y", "z"], 4: ["id", "x", "y", "z"], 6: ["x", "y", "z", "i", "j", "k"]}[ncol]
    if ncol == 4:  # ids are not used, but must be numbers for the layout to make sense
        _to_float(source, idx, [r[0] for r in rows], "id")
    at = 0 if ncol == 6 else ncol - 3
    xyz = np.column_stack([_to_float(source, idx, [r[k] for r in rows], names[k]) for k in range(at, at + 3)])
    normals = None
    if ncol == 6:
        normals = _unit_normals(source, idx, [_to_float(source, idx, [r[k] for r in rows], names[k])
                                              for k in range(3, 6)])
    if require_sections:
        _require_structure(source, idx, block)
    return _point_set(source, "xyz-blocks", xyz, block, idx, [str(b + 1) for b in range(block[-1] + 1)],
                      structured=bool(block[-1] > 0), normals=normals)


def _read_section_table(source: str, lines: list[str], first: int) -> PointSet:
    head = lines[first].split()
    try:
        npts, nsec = int(head[0]), int(head[1])
    except ValueError:
        raise BladeReconError(f"{source}, line {first + 1}: expected 'NPTS NSECTIONS' (two "
                              f"whole numbers), found '{shown(lines[first].strip())}': fix the "
                              "header line") from None
    if npts < 1 or nsec < 1:
        raise BladeReconError(f"{source}, line {first + 1}: 'NPTS NSECTIONS' must be positive, "
                              f"found {npts} {nsec}: fix the header line")
    want = npts * nsec
    idx, _ = _blocks(lines, first + 1)
    if len(idx) < want:
        last = idx[-1] + 1 if idx else first + 1
        raise BladeReconError(
            f"{source}, line {last}: the file ends after {len(idx)} points but the header on "
            f"line {first + 1} promises {npts} x {nsec} = {want}: fix the header or add the "
            "missing points")
    if len(idx) > want:
        raise BladeReconError(
            f"{source}, line {idx[want] + 1}: point {want + 1} is more than the header on line "
            f"{first + 1} promises ({npts} x {nsec} = {want}): fix the header or remove the "
            "extra lines")
    rows = _split_rows(source, lines, idx, None, 3)
    xyz = np.column_stack([_to_float(source, idx, [r[k] for r in rows], c)
                           for k, c in enumerate("xyz")])
    section = np.repeat(np.arange(nsec), npts)
    return _point_set(source, "section-table", xyz, section, idx,
                      [str(k + 1) for k in range(nsec)])
