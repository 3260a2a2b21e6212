# SPDX-License-Identifier: LGPL-2.1-or-later
"""Scanner point files: PLY (ASCII, binary little and big endian) and PCD (ASCII, binary).

Laser scanners and structured-light systems write these, often with normals. Both are
recognised by content (:func:`sniff`: a PLY starts with the line ``ply``; a PCD has its
``FIELDS`` and ``DATA`` header lines), never by extension. The vertices are read whole by numpy
(a structured dtype over the binary body; numpy's parser over the ASCII rows): 1M binary
points in a few hundredths of a second.

What is read: ``x y z`` (any numeric type, as float64 mm) and, when present, the normals
(``nx ny nz`` in PLY, ``normal_x normal_y normal_z`` in PCD), and a binary PLY's integer
``section`` property with its ``comment section K NAME`` lines (what :func:`write_ply` writes for points
in sections): the points are then labelled sections. Other properties (colour, intensity,
curvature, faces) are skipped. A PCD point whose x, y or z is NaN (an organised
scan's empty pixel) is left out, and :attr:`Scan.left_out` counts it.

Every way a file can be wrong is a one-line :class:`BladeReconError` naming the file and the
header line or vertex: a truncated binary body (how many vertices it holds against the
header's count), fewer ASCII rows than the header says, a row with the wrong number of
values, a property type that is not one of PLY's or PCD's, a header without x, y, z, a
compressed PCD body.

``index`` gives each point's place for messages: its 1-based line in an ASCII file, its
1-based vertex number in a binary one.
"""
from __future__ import annotations

import io
import re
import warnings
from dataclasses import dataclass

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import shown

__all__ = ["Scan", "sniff", "read_scan", "write_ply"]

_HEADER_LIMIT = 1 << 16          # a header longer than this is no header
_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}
_PCD_TYPES = {("F", "4"): "f4", ("F", "8"): "f8", ("I", "1"): "i1", ("I", "2"): "i2", ("I", "4"): "i4",
              ("I", "8"): "i8", ("U", "1"): "u1", ("U", "2"): "u2", ("U", "4"): "u4", ("U", "8"): "u8"}
_NORMALS = {"ply": ("nx", "ny", "nz"), "pcd": ("normal_x", "normal_y", "normal_z")}


@dataclass(frozen=True)
class Scan:
    """The points of a scanner file (mm as written), their normals if the file has them,
    each point's line (ASCII) or vertex number (binary), 1-based, and how many were left out."""

    points: np.ndarray
    normals: np.ndarray | None
    index: np.ndarray
    format: str
    left_out: int = 0
    section: np.ndarray | None = None          # 0-based labels: an integer ``section`` property (our writer's)
    section_names: tuple[str, ...] = ()        # from ``comment section K NAME`` lines, else K


def sniff(raw: bytes) -> str | None:
    """``'ply'``, ``'pcd'`` or None from the first bytes of a file."""
    head = raw[:_HEADER_LIMIT]
    if re.match(rb"ply[ \t]*\r?\n", head):
        return "ply"
    text = head.split(b"\nDATA", 1)[0]
    if b"\nDATA" in head and re.search(rb"(^|\n)FIELDS[ \t]", text) and re.search(rb"(^|\n)POINTS[ \t]", text):
        return "pcd"
    return None


def read_scan(source: str, raw: bytes) -> Scan:
    """The points of the PLY or PCD file whose bytes are ``raw`` (see :func:`sniff`)."""
    kind = sniff(raw)
    if kind == "ply":
        return _read_ply(source, raw)
    if kind == "pcd":
        return _read_pcd(source, raw)
    raise BladeReconError(f"{source}: not a PLY or PCD file")


# --------------------------------------------------------------------------- the header
def _header_lines(source: str, raw: bytes, what: str, last: str) -> tuple[list[str], int]:
    """The header's lines (text) up to and including the one starting with ``last``, and the
    byte offset of the body after it."""
    at, lines = 0, []
    while True:
        end = raw.find(b"\n", at, _HEADER_LIMIT)
        if end < 0:
            raise BladeReconError(f"{source}: {what} header without a '{last}' line in its first "
                                  f"{_HEADER_LIMIT // 1024} KB: the file is cut short or not {what}")
        text = raw[at:end].decode("latin-1").strip()          # keywords are ASCII; a comment may not be
        lines.append(text)
        at = end + 1
        if text.split(None, 1)[:1] == [last]:
            return lines, at


def _bad_header(source: str, no: int, text: str, what: str) -> BladeReconError:
    return BladeReconError(f"{source}, line {no}: {what}: {shown(text, 80)}")


# --------------------------------------------------------------------------- PLY
@dataclass
class _Element:
    name: str
    count: int
    line: int
    props: list = None          # (name, numpy type) ; a list property: (name, (count type, item type))

    def has_lists(self) -> bool:
        return any(isinstance(t, tuple) for _, t in self.props)


def _ply_header(source: str, raw: bytes) -> tuple[str, list[_Element], int, int, dict]:
    """Format, elements, the body's offset, the header's line count and the section names of its
    ``comment section K NAME`` lines (K -> NAME)."""
    lines, body = _header_lines(source, raw, "PLY", "end_header")
    fmt, elements, named = None, [], {}
    for no, text in enumerate(lines[1:-1], 2):
        words = text.split()
        if not words or words[0] in ("comment", "obj_info"):
            if len(words) >= 4 and words[:2] == ["comment", "section"] and words[2].isdigit():
                # the header is read as Latin-1 (any byte a character); our writer puts UTF-8 names
                named[int(words[2])] = text.split(None, 3)[3].strip().encode("latin-1").decode("utf-8", "replace")
            continue
        if words[0] == "format":
            if len(words) != 3 or words[1] not in ("ascii", "binary_little_endian", "binary_big_endian"):
                raise _bad_header(source, no, text, "unknown PLY format (ascii, binary_little_endian or "
                                                    "binary_big_endian)")
            fmt = words[1]
        elif words[0] == "element":
            if len(words) != 3 or not words[2].isdigit():
                raise _bad_header(source, no, text, "a PLY element line is 'element NAME COUNT'")
            elements.append(_Element(words[1], int(words[2]), no, []))
        elif words[0] == "property":
            if not elements:
                raise _bad_header(source, no, text, "a PLY property before any element")
            if len(words) == 5 and words[1] == "list":
                types = tuple(_PLY_TYPES.get(w) for w in words[2:4])
                if None in types:
                    raise _bad_header(source, no, text, f"unknown PLY property type (one of {', '.join(_PLY_TYPES)})")
                elements[-1].props.append((words[4], types))
            elif len(words) == 3:
                if words[1] not in _PLY_TYPES:
                    raise _bad_header(source, no, text, f"unknown PLY property type (one of {', '.join(_PLY_TYPES)})")
                elements[-1].props.append((words[2], _PLY_TYPES[words[1]]))
            else:
                raise _bad_header(source, no, text, "a PLY property line is 'property TYPE NAME'")
        else:
            raise _bad_header(source, no, text, "not a PLY header line")
    if fmt is None:
        raise BladeReconError(f"{source}: PLY header without a 'format' line")
    return fmt, elements, body, len(lines), named


def _vertex_element(source: str, elements: list[_Element]) -> tuple[int, _Element]:
    k = next((i for i, e in enumerate(elements) if e.name == "vertex"), None)
    if k is None:
        raise BladeReconError(f"{source}: PLY header has no 'element vertex': no points to read")
    v = elements[k]
    names = [n for n, _ in v.props]
    missing = [c for c in "xyz" if c not in names]
    if missing:
        raise BladeReconError(f"{source}, line {v.line}: the PLY vertices have no {', '.join(missing)} property "
                              f"(found {', '.join(names) or 'none'}): a point file needs x, y, z")
    if v.has_lists():
        raise BladeReconError(f"{source}, line {v.line}: PLY vertices with a list property are not read: "
                              "save the vertices with scalar properties only")
    if v.count == 0:
        raise BladeReconError(f"{source}, line {v.line}: the PLY file has 0 vertices: no points to read")
    return k, v


def _dtype(source: str, fields: list, order: str, where: str) -> np.dtype:
    """A structured dtype of ``fields`` ((name, type) or (name, type, count)); a coordinate or
    normal given twice is refused, other repeated names (PCD's ``_`` padding) are numbered."""
    seen: dict[str, int] = {}
    out = []
    for f in fields:
        name = f[0]
        if name in seen and (name in "xyz" or name in _NORMALS["ply"] + _NORMALS["pcd"]):
            raise BladeReconError(f"{source}, {where}: '{name}' is given twice: a point file needs it once")
        seen[name] = seen.get(name, 0) + 1
        unique = name if seen[name] == 1 else f"{name}#{seen[name]}"
        out.append((unique, order + f[1]) + tuple(f[2:]))
    return np.dtype(out)


def _columns(names: list[str], table, kind: str):
    P = np.column_stack([np.asarray(table[c], dtype=float) for c in "xyz"])
    normal = _NORMALS[kind]
    N = (np.column_stack([np.asarray(table[c], dtype=float) for c in normal])
         if all(c in names for c in normal) else None)
    return P, N


def _sections(names: list[str], table, types: dict, named: dict) -> tuple[np.ndarray | None, tuple[str, ...]]:
    """A PLY's integer ``section`` property as 0-based labels in order of first appearance, and
    their names (``named``: the header's ``comment section K NAME``, else K); (None, ()) without one."""
    if "section" not in names or types.get("section", "f8")[0] not in "iu":
        return None, ()
    raw = np.asarray(table["section"], dtype=np.int64)
    keys, first, labels = np.unique(raw, return_index=True, return_inverse=True)
    order = np.argsort(first)                     # sections in order of first appearance
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return rank[labels], tuple(named.get(int(k), str(int(k))) for k in keys[order])


def write_ply(path: str, points: np.ndarray, columns: dict | None = None, section: np.ndarray | None = None,
              section_names=None, comment: str = "") -> None:
    """Points (N, 3) as a binary little-endian PLY at ``path`` (written in place: the caller's
    temporary), with per-point ``columns`` (name -> (N,) array: doubles, or ``int`` for integer
    arrays) and, for points in sections, an ``int section`` property (labels 0 <= K < 2**31,
    ``section_names[K]`` their names) with a ``comment section K NAME`` line per label used (names
    in UTF-8, their whitespace runs made single spaces), which :func:`read_scan` reads back."""
    P = np.asarray(points, dtype="<f8")
    n = len(P)
    fields = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
    data = {"x": P[:, 0], "y": P[:, 1], "z": P[:, 2]}
    for name, values in (columns or {}).items():
        v = np.asarray(values)
        kind = "<i4" if v.dtype.kind in "iub" else "<f8"
        fields.append((name, kind))
        data[name] = v
    if section is not None:
        section = np.asarray(section)
        if section.shape != (n,) or section.dtype.kind not in "iu" or (n and (section.min() < 0 or section.max() >= 2 ** 31)):
            raise ValueError("section: one label 0 <= k < 2**31 per point")
        if section_names is not None and n and section.max() >= len(section_names):
            raise ValueError(f"section label {int(section.max())} but {len(section_names)} names")
        fields.append(("section", "<i4"))
        data["section"] = section
    table = np.empty(n, dtype=fields)
    for name, _ in fields:
        table[name] = data[name]
    head = ["ply", "format binary_little_endian 1.0", "comment written by BladeRecon (mm)"]
    if comment:
        head.append(f"comment {comment}")
    if section is not None:
        used = np.unique(section).tolist()
        head += [f"comment section {k} {' '.join(str(section_names[k] if section_names is not None else k).split())}"
                 for k in used]
    head.append(f"element vertex {n}")
    head += [f"property {'int' if t == '<i4' else 'double'} {name}" for name, t in fields]
    head.append("end_header")
    with open(path, "wb") as fh:
        fh.write(("\n".join(head) + "\n").encode("utf-8"))
        fh.write(table.tobytes())


def _read_ply(source: str, raw: bytes) -> Scan:
    fmt, elements, body, header_lines, named = _ply_header(source, raw)
    k, v = _vertex_element(source, elements)
    names = [n for n, _ in v.props]
    _dtype(source, [(n, "f8") for n in names], "<", f"line {v.line}")       # a coordinate given twice: refused
    if fmt == "ascii":
        before = sum(e.count for e in elements[:k])               # one row per item, lists included
        return _ascii_rows(source, raw, body, header_lines, before, v.count, len(names), names, "ply",
                           f"line {v.line} says {v.count} vertices")
    if any(e.has_lists() for e in elements[:k]):
        raise BladeReconError(f"{source}: binary PLY with a list element ('{elements[0].name}') before the "
                              "vertices is not read: write the vertex element first")
    order = "<" if fmt == "binary_little_endian" else ">"
    dtype = _dtype(source, v.props, order, f"line {v.line}")
    start = body + sum(e.count * _dtype(source, e.props, order, f"line {e.line}").itemsize for e in elements[:k])
    need = v.count * dtype.itemsize
    have = len(raw) - start
    if have < need:
        raise BladeReconError(
            f"{source}: the binary PLY body is cut short: line {v.line} says {v.count} vertices "
            f"({need} bytes), the file holds {max(have, 0)} bytes after the header ({max(have, 0) // dtype.itemsize} "
            "vertices): the file was not written to the end")
    table = np.frombuffer(raw, dtype=dtype, count=v.count, offset=start)
    P, N = _columns(names, table, "ply")
    sec, sec_names = _sections(names, table, dict(v.props), named)
    return _finite(source, Scan(P, N, np.arange(1, v.count + 1), "ply-binary", section=sec, section_names=sec_names),
                   "vertex")


def _ascii_rows(source: str, raw: bytes, body: int, header_lines: int, skip: int, count: int, ncol: int,
                names: list[str], kind: str, says: str) -> Scan:
    """``count`` rows of ``ncol`` numbers after ``skip`` rows of the body (numpy's parser; on a
    bad row, the row is found and named)."""
    tail = raw[body:].replace(b"\r\n", b"\n").replace(b"\r", b"\n")
    byte = np.frombuffer(tail, dtype=np.uint8)
    newline = np.flatnonzero(byte == 10)
    starts = np.concatenate([[0], newline + 1])
    ends = np.concatenate([newline, [len(tail)]])
    # a line with nothing but spaces or tabs is blank (numpy's parser skips it too): no row
    # (one byte of mask a byte of file: a running count would take eight)
    ink = (byte != 32) & (byte != 9) & (byte != 10)
    nonempty = np.flatnonzero(ends > starts)
    filled = nonempty[np.logical_or.reduceat(ink, starts[nonempty])] if nonempty.size else nonempty
    del ink
    if len(filled) < skip + count:
        raise BladeReconError(f"{source}: the {kind.upper()} file has {max(len(filled) - skip, 0)} vertex rows, "
                              f"but {says}: the file was cut short or the count is wrong")
    idx = filled[skip:skip + count]
    chosen = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if idx[-1] - idx[0] == count - 1:      # one block of rows: numpy's C parser on the bytes
                table = np.loadtxt(source, dtype=float, ndmin=2, comments=None, encoding="ascii",
                                   skiprows=header_lines + int(idx[0]), max_rows=count)
            else:
                chosen = [tail[starts[i]:ends[i]].decode("ascii", errors="replace") for i in idx]
                table = np.loadtxt(io.StringIO("\n".join(chosen)), dtype=float, ndmin=2, comments=None)
        if table.shape != (count, ncol):
            raise ValueError
    except (ValueError, UnicodeDecodeError):
        if chosen is None:
            chosen = [tail[starts[i]:ends[i]].decode("ascii", errors="replace") for i in idx]
        for i, r in zip(idx, chosen):
            cells = r.split()
            bad = len(cells) != ncol
            if not bad:
                try:
                    [float(c) for c in cells]
                except ValueError:
                    bad = True
            if bad:
                raise BladeReconError(
                    f"{source}, line {header_lines + i + 1}: expected {ncol} numbers ({' '.join(names)}), "
                    f"got {shown(r.strip(), 60)}") from None
        raise BladeReconError(f"{source}: the vertex rows could not be read") from None
    line = np.asarray(idx) + header_lines + 1
    cols = {n: table[:, j] for j, n in enumerate(names)}
    P, N = _columns(names, cols, kind)
    return _finite(source, Scan(P, N, line, f"{kind}-ascii"), "line")


def _finite(source: str, scan: Scan, where: str) -> Scan:
    bad = ~np.isfinite(scan.points).all(axis=1)
    if scan.format.startswith("pcd"):                  # an organised scan's empty pixels: left out
        if bad.all():
            raise BladeReconError(f"{source}: every point of the PCD file is NaN: no points to read")
        if bad.any():
            keep = ~bad
            return Scan(scan.points[keep], None if scan.normals is None else scan.normals[keep],
                        scan.index[keep], scan.format, int(bad.sum()))
        return scan
    if bad.any():
        i = int(np.argmax(bad))
        raise BladeReconError(f"{source}, {where} {int(scan.index[i])}: a coordinate is NaN or infinite: "
                              "remove the point")
    return scan


# --------------------------------------------------------------------------- PCD
def _read_pcd(source: str, raw: bytes) -> Scan:
    lines, body = _header_lines(source, raw, "PCD", "DATA")
    head: dict[str, tuple[int, list[str]]] = {}
    for no, text in enumerate(lines, 1):
        words = text.split()
        if words and not words[0].startswith("#"):
            head[words[0].upper()] = (no, words[1:])
    for key in ("FIELDS", "POINTS", "DATA"):
        if key not in head:
            raise BladeReconError(f"{source}: PCD header without a {key} line")
    fields = head["FIELDS"][1]
    n = len(fields)
    count = head.get("COUNT", (0, ["1"] * n))[1]
    size = head.get("SIZE", (0, ["4"] * n))[1]
    types = head.get("TYPE", (0, ["F"] * n))[1]
    for key, vals in (("COUNT", count), ("SIZE", size), ("TYPE", types)):
        if len(vals) != n:
            no = head[key][0]
            raise _bad_header(source, no, lines[no - 1], f"PCD {key} has {len(vals)} entries for {n} FIELDS")
    missing = [c for c in "xyz" if c not in fields]
    if missing:
        no = head["FIELDS"][0]
        raise _bad_header(source, no, lines[no - 1], f"the PCD fields have no {', '.join(missing)}: a point file "
                                                      "needs x, y, z")
    several = [f for f, c in zip(fields, count) if f in "xyz" and c != "1"]
    if several:
        no = head["COUNT"][0]
        raise _bad_header(source, no, lines[no - 1], f"PCD field '{several[0]}' with COUNT above 1: x, y, z "
                                                      "must be single numbers")
    no_points, words = head["POINTS"]
    if len(words) != 1 or not words[0].isdigit() or int(words[0]) == 0:
        raise _bad_header(source, no_points, lines[no_points - 1], "PCD POINTS must be a positive count")
    points = int(words[0])
    np_types = []
    for f, t, s, c in zip(fields, types, size, count):
        nt = _PCD_TYPES.get((t.upper(), s))
        if nt is None or not c.isdigit() or int(c) < 1:
            no = head["TYPE"][0] if "TYPE" in head else head["FIELDS"][0]
            raise _bad_header(source, no, lines[no - 1], f"PCD field '{f}': TYPE {t} SIZE {s} COUNT {c} is not "
                                                          "one PCD has (F 4/8, I or U 1/2/4/8)")
        np_types.append((f, nt, int(c)))
    data = head["DATA"][1][0].lower() if head["DATA"][1] else ""
    if data == "ascii":
        names = [f if c == 1 else f"{f}_{j}" for f, _, c in np_types for j in range(c)]
        return _ascii_rows(source, raw, body, len(lines), 0, points, len(names), names, "pcd",
                           f"line {no_points} says {points} points")
    if data == "binary_compressed":
        raise BladeReconError(f"{source}: compressed PCD (DATA binary_compressed) is not read: save it as "
                              "binary or ascii (e.g. pcl_convert_pcd_ascii_binary FILE OUT 1)")
    if data != "binary":
        raise _bad_header(source, len(lines), lines[-1], "PCD DATA must be ascii, binary or binary_compressed")
    dtype = _dtype(source, [(f, t) if c == 1 else (f, t, (c,)) for f, t, c in np_types], "<",
                   f"line {head['FIELDS'][0]}")
    need = points * dtype.itemsize
    have = len(raw) - body
    if have < need:
        raise BladeReconError(
            f"{source}: the binary PCD body is cut short: line {no_points} says {points} points ({need} bytes), "
            f"the file holds {have} bytes after the header ({have // dtype.itemsize} points): the file was not "
            "written to the end")
    table = np.frombuffer(raw, dtype=dtype, count=points, offset=body)
    P, N = _columns(fields, table, "pcd")
    return _finite(source, Scan(P, N, np.arange(1, points + 1), "pcd-binary"), "point")
