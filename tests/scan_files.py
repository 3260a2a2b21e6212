# SPDX-License-Identifier: LGPL-2.1-or-later
"""Writing PLY and PCD files the way the tests need them (ASCII or binary, with normals,
colours, a face element), independent of the reader under test: the header by hand, the body
by numpy's ``tobytes`` or Python's ``repr``."""
from __future__ import annotations

from pathlib import Path

import numpy as np

_NP = {"float": "f4", "double": "f8", "uchar": "u1", "int": "i4", "short": "i2"}


def write_ply(path: Path, P: np.ndarray, N: np.ndarray | None = None, fmt: str = "binary_little_endian",
              kind: str = "float", face: bool = False, colour: bool = False, count: int | None = None,
              cut: int = 0) -> Path:
    """``P`` (and normals ``N``) as a PLY file; ``face``: a one-triangle face element after the
    vertices; ``colour``: red, green, blue uchar properties; ``count``: the vertex count the
    header says (default len(P)); ``cut``: bytes taken off the end."""
    props = [("x", kind), ("y", kind), ("z", kind)]
    cols = [P[:, 0], P[:, 1], P[:, 2]]
    if N is not None:
        props += [("nx", kind), ("ny", kind), ("nz", kind)]
        cols += [N[:, 0], N[:, 1], N[:, 2]]
    if colour:
        props += [("red", "uchar"), ("green", "uchar"), ("blue", "uchar")]
        cols += [np.full(len(P), 200), np.full(len(P), 100), np.zeros(len(P))]
    head = ["ply", f"format {fmt} 1.0", "comment written by tests/scan_files.py",
            f"element vertex {len(P) if count is None else count}"]
    head += [f"property {t} {n}" for n, t in props]
    if face:
        head += ["element face 1", "property list uchar int vertex_indices"]
    head += ["end_header"]
    body = b""
    if fmt == "ascii":
        rows = []
        for i in range(len(P)):
            rows.append(" ".join(repr(float(c[i])) if t in ("float", "double") else str(int(c[i]))
                                 for c, (_, t) in zip(cols, props)))
        body = ("\n".join(rows) + "\n" + ("3 0 1 2\n" if face else "")).encode("ascii")
    else:
        o = "<" if "little" in fmt else ">"
        table = np.empty(len(P), np.dtype([(n, o + _NP[t]) for n, t in props]))
        for (n, _), c in zip(props, cols):
            table[n] = c
        body = table.tobytes()
        if face:
            body += np.array([3], "u1").tobytes() + np.array([0, 1, 2], o + "i4").tobytes()
    data = ("\n".join(head) + "\n").encode("ascii") + body
    Path(path).write_bytes(data[:len(data) - cut])
    return Path(path)


def write_pcd(path: Path, P: np.ndarray, N: np.ndarray | None = None, data: str = "binary",
              kind: str = "F 4", cut: int = 0) -> Path:
    """``P`` (and normals ``N``, as ``normal_x normal_y normal_z``) as a PCD v0.7 file with an
    intensity field beside them."""
    t, s = kind.split()
    fields = ["x", "y", "z"] + (["normal_x", "normal_y", "normal_z"] if N is not None else []) + ["intensity"]
    cols = [P[:, 0], P[:, 1], P[:, 2]] + ([N[:, 0], N[:, 1], N[:, 2]] if N is not None else [])
    cols += [np.arange(len(P)) % 7]
    head = ["# .PCD v0.7 - Point Cloud Data file format", "VERSION 0.7", "FIELDS " + " ".join(fields),
            "SIZE " + " ".join([s] * (len(fields) - 1) + ["4"]), "TYPE " + " ".join([t] * (len(fields) - 1) + ["F"]),
            "COUNT " + " ".join(["1"] * len(fields)), f"WIDTH {len(P)}", "HEIGHT 1", "VIEWPOINT 0 0 0 1 0 0 0",
            f"POINTS {len(P)}", f"DATA {data}"]
    if data == "ascii":
        body = "".join(" ".join(repr(float(c[i])) for c in cols) + "\n" for i in range(len(P))).encode("ascii")
    else:
        table = np.empty(len(P), np.dtype([(f, "<f" + s) for f in fields[:-1]] + [("intensity", "<f4")]))
        for f, c in zip(fields, cols):
            table[f] = c
        body = table.tobytes()
    out = ("\n".join(head) + "\n").encode("ascii") + body
    Path(path).write_bytes(out[:len(out) - cut])
    return Path(path)
