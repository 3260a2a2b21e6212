# SPDX-License-Identifier: LGPL-2.1-or-later
"""T-mesh editing: cell splits across the longer side (seed 002 §2.2.2), the strip of width mu
round [0,1]² (§2.2.3, Fig. 4), and the greedy AST conversion by T-junction extensions (§2.3).

AST conversion (§2.3): T-junction extensions (Li–Scott: two knot intervals on the side of
the missing edge, one on the other); greedy one-step extension of a T-junction that leaves
the fewest crossing extensions, until none cross.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.surface.tspline.tmesh import TMesh, crossings, t_junctions

__all__ = [
    "split_longer_side", "add_strip", "make_analysis_suitable", "CUT_ORDERS", "_split", "_split_choice",
    "_extend_one_step", "_complete_strip",
]

CUT_ORDERS = ("longer-side", "switch-side")


def _split(faces: np.ndarray, idx: np.ndarray, axis: np.ndarray, at: np.ndarray) -> np.ndarray:
    """Split faces ``idx``: axis 0 cuts at u = at (vertical new edge), 1 at v = at."""
    if len(idx) == 0:
        return faces
    keep = np.ones(len(faces), bool)
    keep[idx] = False
    f = faces[idx]
    a = f.copy()
    b = f.copy()
    ax = axis == 0
    a[ax, 1] = at[ax]
    b[ax, 0] = at[ax]
    a[~ax, 3] = at[~ax]
    b[~ax, 2] = at[~ax]
    return np.concatenate([faces[keep], a, b])


def _split_choice(faces: np.ndarray, idx: np.ndarray, uv: np.ndarray | None, loc: np.ndarray | None,
                  lengths: tuple[float, float], min_lines: int, order: str = "longer-side"
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Axis (0: cut at u = at, 1: at v = at; -1: no useful cut) and cut position for faces ``idx``.

    Seed 002 §2.2.2: across the longer side at the midpoint. Our additions, used only with
    the points ``uv`` and the face ``loc`` holding each: a cut must leave each half with
    points on at least ``min_lines`` distinct coordinate values across it (measured sections
    lie on a few span lines; a cut between two of them leaves the new poles undetermined).
    Order of preference, ``order="longer-side"`` (default, closest to the seed: the side is
    never changed while a cut on it keeps one data line per half): longer side at the
    midpoint; longer side between the two middle data lines of the cell; then the other
    side. ``order="switch-side"``: longer side at the midpoint; the other side at the
    midpoint; then cuts between middle data lines. Else no cut.
    ``lengths``: model lengths (mm) of the parameter directions, so that "longer" means
    longer on the part (seed 002's rectangular parameterisation is about isometric; a
    blade's (u, v) is not).
    """
    f = faces[idx]
    du, dv = f[:, 1] - f[:, 0], f[:, 3] - f[:, 2]
    mid = np.column_stack([0.5 * (f[:, 0] + f[:, 1]), 0.5 * (f[:, 2] + f[:, 3])])
    axis = np.where(du * lengths[0] >= dv * lengths[1], 0, 1)
    if uv is None or loc is None or not len(idx):
        return axis, np.where(axis == 0, mid[:, 0], mid[:, 1])
    pos = np.full(len(faces), -1)
    pos[idx] = np.arange(len(idx))
    k = pos[loc]
    inside = k >= 0
    k, p = k[inside], uv[inside]
    mid_ok, data_ok, data_at, n_all = [], [], [], []
    for col in (0, 1):
        lines = np.unique(np.column_stack([k, p[:, col]]), axis=0)       # sorted by face, value
        kk = lines[:, 0].astype(int)
        n = np.bincount(kk, minlength=len(idx))
        below = np.bincount(kk[lines[:, 1] < mid[kk, col]], minlength=len(idx))
        mid_ok.append((below >= min_lines) & (n - below >= min_lines))
        start = np.concatenate([[0], np.cumsum(n)[:-1]])
        half = n // 2
        lo = lines[np.clip(start + half - 1, 0, len(lines) - 1), 1] if len(lines) else np.zeros(len(idx))
        hi = lines[np.clip(start + half, 0, len(lines) - 1), 1] if len(lines) else np.zeros(len(idx))
        data_ok.append((half >= min_lines) & (n - half >= min_lines))
        data_at.append(0.5 * (lo + hi))
        n_all.append(n)
    out_axis = np.full(len(idx), -1)
    out_at = np.zeros(len(idx))
    other = 1 - axis
    rows = np.arange(len(idx))
    n_lines = np.stack(n_all)
    one_each = n_lines >= 2               # a cut between the middle lines keeps one line per half
    choices = ((axis, np.stack(mid_ok)[axis, rows], mid[rows, axis]),
               (axis, one_each[axis, rows] if order == "longer-side" else np.zeros(len(idx), bool),
                np.stack(data_at)[axis, rows]),
               (other, np.stack(mid_ok)[other, rows], mid[rows, other]),
               (axis, np.stack(data_ok)[axis, rows], np.stack(data_at)[axis, rows]),
               (other, np.stack(data_ok)[other, rows], np.stack(data_at)[other, rows]))
    for ax, ok, at in choices:
        take = ok & (out_axis < 0)
        out_axis[take] = ax[take]
        out_at[take] = at[take]
    return out_axis, out_at


def split_longer_side(faces: np.ndarray, idx: np.ndarray, uv: np.ndarray | None = None,
                      loc: np.ndarray | None = None, lengths: tuple[float, float] = (1.0, 1.0),
                      min_lines: int = 2, order: str = "longer-side") -> np.ndarray:
    """Split faces ``idx`` across their longer side at the midpoint (seed 002 §2.2.2), with
    the data-aware choice of :func:`_split_choice` when the points are given (faces with no
    useful cut are left as they are)."""
    idx = np.asarray(idx, int)
    axis, at = _split_choice(faces, idx, uv, loc, lengths, min_lines, order)
    keep = axis >= 0
    return _split(faces, idx[keep], axis[keep], at[keep])


def _extend_one_step(faces: np.ndarray, node: np.ndarray, missing: int) -> np.ndarray:
    """Add the missing edge of a T-junction up to the next edge: split the face it enters."""
    s, t = node
    f = faces
    if missing == 0:
        hit = (f[:, 0] == s) & (f[:, 2] < t) & (t < f[:, 3])
    elif missing == 1:
        hit = (f[:, 1] == s) & (f[:, 2] < t) & (t < f[:, 3])
    elif missing == 2:
        hit = (f[:, 2] == t) & (f[:, 0] < s) & (s < f[:, 1])
    else:
        hit = (f[:, 3] == t) & (f[:, 0] < s) & (s < f[:, 1])
    idx = np.flatnonzero(hit)
    axis = np.full(len(idx), 1 if missing <= 1 else 0)
    at = np.full(len(idx), t if missing <= 1 else s)
    return _split(faces, idx, axis, at)


def _complete_strip(faces: np.ndarray, mu: float) -> np.ndarray:
    """Carry every node on the boundary of [0,1]² straight through the outer strip
    (seed 002 Fig. 4: each boundary node is extended outward by mu)."""
    while True:
        f = faces
        strip_l = np.flatnonzero(f[:, 1] == 0)
        strip_r = np.flatnonzero(f[:, 0] == 1)
        strip_b = np.flatnonzero(f[:, 3] == 0)
        strip_t = np.flatnonzero(f[:, 2] == 1)
        inner = (f[:, 0] >= 0) & (f[:, 1] <= 1) & (f[:, 2] >= 0) & (f[:, 3] <= 1)
        cuts = []
        for strip, side_col, val, along in ((strip_l, 0, 0.0, (2, 3)), (strip_r, 1, 1.0, (2, 3)),
                                           (strip_b, 2, 0.0, (0, 1)), (strip_t, 3, 1.0, (0, 1))):
            touching = inner & (f[:, side_col] == val)
            marks = np.unique(f[touching][:, list(along)])
            for k in strip:
                lo, hi = f[k, along[0]], f[k, along[1]]
                inside = marks[(marks > lo) & (marks < hi)]
                if inside.size:
                    cuts.append((k, 1 if along == (2, 3) else 0, inside[0]))
        if not cuts:
            return faces
        # one cut per face per pass (a face may need several)
        seen: dict[int, tuple[int, float]] = {}
        for k, ax, at in cuts:
            seen.setdefault(k, (ax, at))
        idx = np.array(list(seen))
        faces = _split(faces, idx, np.array([seen[k][0] for k in idx]), np.array([seen[k][1] for k in idx]))


def add_strip(inner_faces: np.ndarray, mu: float) -> np.ndarray:
    """Faces over [-mu, 1+mu]²: the inner faces plus one strip face per boundary edge of
    [0,1]² and the four corner squares (seed 002 §2.2.3, Fig. 4)."""
    f = inner_faces
    out = [f]
    for col, val, along, build in (
            (0, 0.0, (2, 3), lambda a, b: [-mu, 0.0, a, b]), (1, 1.0, (2, 3), lambda a, b: [1.0, 1.0 + mu, a, b]),
            (2, 0.0, (0, 1), lambda a, b: [a, b, -mu, 0.0]), (3, 1.0, (0, 1), lambda a, b: [a, b, 1.0, 1.0 + mu])):
        marks = np.unique(f[f[:, col] == val][:, list(along)])
        out.append(np.array([build(a, b) for a, b in zip(marks[:-1], marks[1:])]))
    out.append(np.array([[-mu, 0, -mu, 0], [1, 1 + mu, -mu, 0], [-mu, 0, 1, 1 + mu], [1, 1 + mu, 1, 1 + mu]], float))
    return np.concatenate(out)


def make_analysis_suitable(mesh: TMesh, max_candidates: int = 40, max_steps: int = 100000) -> tuple[TMesh, int]:
    """Greedy AST conversion (seed 002 §2.3): while extensions cross, try extending each
    T-junction in a crossing one step in its missing direction, keep the mesh with the
    fewest crossings. Returns the AS mesh and the number of extension steps.

    To bound the cost on large meshes only the ``max_candidates`` T-junctions involved in
    most crossings are tried per step (all of them when fewer). The loop always ends: each
    step adds an edge and the tensor mesh (no T-junctions) is the worst case.
    """
    faces = _complete_strip(mesh.faces, mesh.mu)
    steps = 0
    while steps < max_steps:
        tj = t_junctions(TMesh(faces, mesh.mu))
        cr = crossings(tj)
        if len(cr) == 0:
            return TMesh(faces, mesh.mu), steps
        involved, counts = np.unique(cr.ravel(), return_counts=True)
        order = involved[np.argsort(-counts, kind="stable")][:max_candidates]
        best, best_n = None, None
        for k in order:
            cand = _complete_strip(_extend_one_step(faces, tj.nodes[k], int(tj.missing[k])), mesh.mu)
            n = len(crossings(t_junctions(TMesh(cand, mesh.mu))))
            if best_n is None or n < best_n:
                best, best_n = cand, n
                if n == 0:
                    break
        faces = best
        steps += 1
    raise BladeReconError("AST conversion did not finish; the T-mesh is too large")
