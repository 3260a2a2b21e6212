# SPDX-License-Identifier: LGPL-2.1-or-later
"""Adaptive analysis-suitable T-spline (ASTS) fitting, seed 002 (Lu et al. 2020).

Everything here is numpy/scipy. The pieces, with the seed's section numbers:

* :class:`TMesh` — a T-mesh over the reduced domain [0,1]² extended by ``mu`` on every side
  (seed 002 §2.2.3, Fig. 4), stored as its faces (axis-aligned rectangles that tile
  [-mu, 1+mu]²). Nodes are the face corners; edges are the face sides.
* Local knot vectors by ray casting (§1.1, Sederberg et al. 2003): from node (u_i2, v_i2)
  the first two edges hit in +u give u_i3, u_i4, and so on; where a ray leaves the mesh the
  last knot is repeated (so the outer boundary carries triple knots and the blending
  functions sum to one on the reduced domain [0,1]²).
* Cubic blending functions ``B_i(u,v) = N[u_i](u) N[v_i](v)`` (eq. 2), evaluated by the
  Cox–de Boor recursion vectorised over all points into a sparse basis matrix A.
* Initial mesh (§2.2.2): split a cell across its longer side at the midpoint while it holds
  more than N_d parameter points or more than N_f feature points (the 10 % of points with
  the largest |Gaussian curvature|, §2.2.1).
* AST conversion (§2.3): T-junction extensions (Li–Scott: two knot intervals on the side of
  the missing edge, one on the other); greedy one-step extension of a T-junction that
  leaves the fewest crossing extensions, until none cross.
* Least squares for all poles (eqs. 5–8, sparse normal equations), then local refinement
  (§2.5): split the cells holding a point with error > eps, convert to AST, re-solve only
  the poles of new nodes and nodes whose knot vectors changed, over the points in their
  support (eq. 10), until max error <= eps or a documented limit.
* Bézier extraction (:func:`bezier_patches`): the 4x4 Bernstein control points of every
  Bézier element — a T-mesh face cut by any blending-function knot line that crosses it, so
  that every blending function is one polynomial on it.
* Closed seam for blades (our addition; ``fit_tspline(seam="closed-c1")``): u is periodic
  with period 1, but the T-mesh is not a periodic T-mesh. :func:`mirror_seam` gives both
  u-ends the same v lines, and every solve is over the null space of the seam equations
  S(0,v) = S(1,v), ∂S/∂u(0,v) = ∂S/∂u(1,v) (:func:`seam_reduction`). Seam elements are cut
  at the same v values on both ends, so the exported patches meet there.

Values may have any dimension: a z-map fits z over (x, y) (one column); a blade fits
x, y, z over the (u, v) of the section reconstruction (three columns). Errors are the
Euclidean norm of S(u_j, v_j) - V_j (eq. 8): the vertical error for a z-map, a parametric
upper bound of the point-to-surface distance for a blade. Units: those of the values (mm).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError

__all__ = [
    "TMesh", "TSplineFit", "FitLimits", "bspline_basis_1d", "gaussian_curvature",
    "feature_mask", "initial_mesh", "make_analysis_suitable", "fit_tspline", "evaluate",
    "basis_matrix", "bezier_patches", "BezierPatch", "tensor_mesh", "duplicate_parameters",
    "normalise_parameters", "zmap_patches", "evaluate_patches", "partition_of_unity",
    "is_analysis_suitable", "t_junctions", "crossings", "local_knots", "tensor_least_squares", "parameter_lengths", "greville",
    "SEAMS", "mirror_seam", "seam_rows", "seam_reduction",
]

_INF = np.inf
_RIDGE = 1e-10
SEAMS = ("open", "closed", "closed-c1")
CUT_ORDERS = ("longer-side", "switch-side")


# ----------------------------------------------------------------------------- T-mesh
@dataclass(frozen=True, eq=False)
class TMesh:
    """A T-mesh: ``faces`` (F, 4) rows ``[u0, u1, v0, v1]`` tiling [-mu, 1+mu]².

    The reduced domain is [0, 1]²; the strip of width ``mu`` outside it carries only the
    boundary layer of nodes (seed 002 Fig. 4).
    """

    faces: np.ndarray
    mu: float

    # ---- topology
    def nodes(self) -> np.ndarray:
        """(n, 2) distinct face corners (the T-mesh vertices), sorted by v then u."""
        f = self.faces
        corners = np.concatenate([f[:, [0, 2]], f[:, [1, 2]], f[:, [0, 3]], f[:, [1, 3]]])
        uniq = np.unique(corners[:, ::-1], axis=0)[:, ::-1]
        return np.ascontiguousarray(uniq)

    def vertical_segments(self) -> np.ndarray:
        """(S, 3) rows ``[u, v0, v1]``: the vertical face sides (duplicates removed)."""
        f = self.faces
        seg = np.concatenate([f[:, [0, 2, 3]], f[:, [1, 2, 3]]])
        return np.unique(seg, axis=0)

    def horizontal_segments(self) -> np.ndarray:
        """(S, 3) rows ``[v, u0, u1]``: the horizontal face sides (duplicates removed)."""
        f = self.faces
        seg = np.concatenate([f[:, [2, 0, 1]], f[:, [3, 0, 1]]])
        return np.unique(seg, axis=0)

    @property
    def lo(self) -> float:
        return -self.mu

    @property
    def hi(self) -> float:
        return 1.0 + self.mu

    def reduced_faces(self) -> np.ndarray:
        """Indices of the faces inside the reduced domain [0,1]²."""
        f = self.faces
        return np.flatnonzero((f[:, 0] >= 0) & (f[:, 1] <= 1) & (f[:, 2] >= 0) & (f[:, 3] <= 1))


def _edge_presence(nodes: np.ndarray, vseg: np.ndarray, hseg: np.ndarray) -> np.ndarray:
    """(n, 4) bool: node has an edge in direction +u, -u, +v, -v."""
    out = np.zeros((len(nodes), 4), bool)
    for lo in range(0, len(nodes), 512):
        s = nodes[lo:lo + 512, 0:1]
        t = nodes[lo:lo + 512, 1:2]
        on_h = hseg[None, :, 0] == t
        out[lo:lo + 512, 0] = np.any(on_h & (hseg[None, :, 1] <= s) & (s < hseg[None, :, 2]), axis=1)
        out[lo:lo + 512, 1] = np.any(on_h & (hseg[None, :, 1] < s) & (s <= hseg[None, :, 2]), axis=1)
        on_v = vseg[None, :, 0] == s
        out[lo:lo + 512, 2] = np.any(on_v & (vseg[None, :, 1] <= t) & (t < vseg[None, :, 2]), axis=1)
        out[lo:lo + 512, 3] = np.any(on_v & (vseg[None, :, 1] < t) & (t <= vseg[None, :, 2]), axis=1)
    return out


def _ray_knots(pos: np.ndarray, across: np.ndarray, seg: np.ndarray) -> np.ndarray:
    """Knots from rays along one axis (seed 002 §1.1, T-spline rule).

    ``pos``: node coordinate along the ray axis; ``across``: the other coordinate; ``seg``:
    segments perpendicular to the ray ``[position, lo, hi]``. Returns (n, 5) knots
    ``[k0, k1, pos, k3, k4]``: the first two distinct segments hit backwards/forwards;
    a ray that leaves the mesh repeats its last knot.
    """
    n = len(pos)
    knots = np.empty((n, 5))
    knots[:, 2] = pos
    for lo in range(0, n, 512):
        p = pos[lo:lo + 512, None]
        a = across[lo:lo + 512, None]
        hit = (seg[None, :, 1] <= a) & (a <= seg[None, :, 2])
        x = seg[None, :, 0]
        fwd = np.where(hit & (x > p), x, _INF)
        k3 = fwd.min(axis=1)
        k4 = np.where(fwd > k3[:, None], fwd, _INF).min(axis=1)
        bwd = np.where(hit & (x < p), x, -_INF)
        k1 = bwd.max(axis=1)
        k0 = np.where(bwd < k1[:, None], bwd, -_INF).max(axis=1)
        pp = p[:, 0]
        k3 = np.where(np.isfinite(k3), k3, pp)
        k4 = np.where(np.isfinite(k4), k4, k3)
        k1 = np.where(np.isfinite(k1), k1, pp)
        k0 = np.where(np.isfinite(k0), k0, k1)
        knots[lo:lo + 512, 0], knots[lo:lo + 512, 1] = k0, k1
        knots[lo:lo + 512, 3], knots[lo:lo + 512, 4] = k3, k4
    return knots


class _Topology:
    """The mesh on its fine grid: all distinct u lines U, v lines V; which grid points are
    vertices; which unit intervals of each line are covered by edges. Ray casting and edge
    tests become index look-ups (cost O(len(U) len(V)), no per-node loop)."""

    def __init__(self, faces: np.ndarray) -> None:
        U = np.unique(faces[:, :2])
        V = np.unique(faces[:, 2:])
        nu, nv = len(U), len(V)
        iu0, iu1 = np.searchsorted(U, faces[:, 0]), np.searchsorted(U, faces[:, 1])
        iv0, iv1 = np.searchsorted(V, faces[:, 2]), np.searchsorted(V, faces[:, 3])
        vert = np.zeros((nu, nv), int)       # vert[i, j]: edge on u = U[i] over (V[j], V[j+1])
        for col in (iu0, iu1):
            np.add.at(vert, (col, iv0), 1)
            np.add.at(vert, (col, iv1), -1)
        self.vert = np.cumsum(vert, axis=1)[:, :-1] > 0
        horiz = np.zeros((nu, nv), int)      # horiz[i, j]: edge on v = V[j] over (U[i], U[i+1])
        for row in (iv0, iv1):
            np.add.at(horiz, (iu0, row), 1)
            np.add.at(horiz, (iu1, row), -1)
        self.horiz = np.cumsum(horiz, axis=0)[:-1, :] > 0
        vertex = np.zeros((nu, nv), bool)
        for a, b in ((iu0, iv0), (iu1, iv0), (iu0, iv1), (iu1, iv1)):
            vertex[a, b] = True
        self.U, self.V, self.vertex = U, V, vertex
        jj, ii = np.nonzero(vertex.T)        # nodes sorted by v, then u
        self.i, self.j = ii, jj

    def nodes(self) -> np.ndarray:
        return np.column_stack([self.U[self.i], self.V[self.j]])

    def has_edges(self) -> np.ndarray:
        """(n, 4) bool: node has an edge towards +u, -u, +v, -v."""
        i, j = self.i, self.j
        nu, nv = len(self.U), len(self.V)
        out = np.zeros((len(i), 4), bool)
        out[:, 0] = np.where(i < nu - 1, self.horiz[np.minimum(i, nu - 2), j], False)
        out[:, 1] = np.where(i > 0, self.horiz[np.maximum(i - 1, 0), j], False)
        out[:, 2] = np.where(j < nv - 1, self.vert[i, np.minimum(j, nv - 2)], False)
        out[:, 3] = np.where(j > 0, self.vert[i, np.maximum(j - 1, 0)], False)
        return out

    @staticmethod
    def _hits(cover: np.ndarray) -> np.ndarray:
        """A ray along a grid line at position j meets line i where an edge of line i
        covers the point j (closed intervals: the interval below or above it)."""
        hit = np.zeros((cover.shape[0], cover.shape[1] + 1), bool)
        hit[:, :-1] |= cover
        hit[:, 1:] |= cover
        return hit

    @staticmethod
    def _knots(hit: np.ndarray, lines: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Two nearest hit lines either side of index i along axis 0 at row j; repeated at
        the mesh boundary (seed 002 §1.1)."""
        n = hit.shape[0]
        ar = np.arange(n)[:, None]
        fwd_idx = np.where(hit, ar, n)
        nxt = np.full(hit.shape, n)
        nxt[:-1] = np.minimum.accumulate(fwd_idx[::-1], axis=0)[::-1][1:]      # first hit > i
        bwd_idx = np.where(hit, ar, -1)
        prv = np.full(hit.shape, -1)
        prv[1:] = np.maximum.accumulate(bwd_idx, axis=0)[:-1]                  # last hit < i
        k3 = nxt[i, j]
        k4 = np.where(k3 < n, nxt[np.minimum(k3, n - 1), j], n)
        k1 = prv[i, j]
        k0 = np.where(k1 >= 0, prv[np.maximum(k1, 0), j], -1)
        k3 = np.where(k3 < n, k3, i)
        k4 = np.where(k4 < n, k4, k3)
        k1 = np.where(k1 >= 0, k1, i)
        k0 = np.where(k0 >= 0, k0, k1)
        return lines[np.column_stack([k0, k1, i, k3, k4])]

    def knots(self, i: np.ndarray | None = None, j: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Local knot vectors (n, 5) in u and v by ray casting (seed 002 §1.1)."""
        i = self.i if i is None else i
        j = self.j if j is None else j
        ku = self._knots(self._hits(self.vert), self.U, i, j)
        kv = self._knots(self._hits(self.horiz.T), self.V, j, i)
        return ku, kv


def local_knots(mesh: TMesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Nodes (n, 2) and their local knot vectors (n, 5) in u and in v (seed 002 eq. 3)."""
    topo = _Topology(mesh.faces)
    ku, kv = topo.knots()
    return topo.nodes(), ku, kv


@dataclass(frozen=True)
class TJunctions:
    """T-junctions of a mesh: position, missing direction (0:+u 1:-u 2:+v 3:-v), extension.

    ``extension`` rows ``[fixed, lo, hi]``: horizontal extensions (missing ±u) lie at
    v = fixed for u in [lo, hi]; vertical ones (missing ±v) at u = fixed, v in [lo, hi].
    """

    nodes: np.ndarray
    missing: np.ndarray
    extension: np.ndarray

    @property
    def horizontal(self) -> np.ndarray:
        return self.missing <= 1


def t_junctions(mesh: TMesh) -> TJunctions:
    """The T-junctions and their extensions (seed 002 §1.2; Li & Scott 2014).

    A T-junction missing its +u edge extends over [u_i1, u_i4] (two knot intervals on the
    missing side, one on the other); missing -u: [u_i0, u_i3]; likewise in v.
    """
    topo = _Topology(mesh.faces)
    has = topo.has_edges()
    nu, nv = len(topo.U), len(topo.V)
    inner = (topo.i > 0) & (topo.i < nu - 1) & (topo.j > 0) & (topo.j < nv - 1)
    tj = inner & (has.sum(axis=1) == 3)
    ku, kv = topo.knots(topo.i[tj], topo.j[tj])
    nodes_t = np.column_stack([topo.U[topo.i[tj]], topo.V[topo.j[tj]]])
    missing = np.argmin(has[tj], axis=1)
    ext = np.empty((len(nodes_t), 3))
    hor = missing <= 1
    ext[:, 0] = np.where(hor, nodes_t[:, 1], nodes_t[:, 0])
    lo_h = np.where(missing == 0, ku[:, 1], ku[:, 0])
    hi_h = np.where(missing == 0, ku[:, 4], ku[:, 3])
    lo_v = np.where(missing == 2, kv[:, 1], kv[:, 0])
    hi_v = np.where(missing == 2, kv[:, 4], kv[:, 3])
    ext[:, 1] = np.where(hor, lo_h, lo_v)
    ext[:, 2] = np.where(hor, hi_h, hi_v)
    return TJunctions(nodes_t, missing, ext)


def crossings(tj: TJunctions) -> np.ndarray:
    """(k, 2) index pairs (horizontal T-junction, vertical T-junction) whose extensions
    intersect (closed segments). An empty result means the mesh is analysis-suitable."""
    h = np.flatnonzero(tj.horizontal)
    v = np.flatnonzero(~tj.horizontal)
    if len(h) == 0 or len(v) == 0:
        return np.zeros((0, 2), int)
    H, V = tj.extension[h], tj.extension[v]
    hit = ((H[:, None, 1] <= V[None, :, 0]) & (V[None, :, 0] <= H[:, None, 2])
           & (V[None, :, 1] <= H[:, None, 0]) & (H[:, None, 0] <= V[None, :, 2]))
    i, j = np.nonzero(hit)
    return np.column_stack([h[i], v[j]])


def is_analysis_suitable(mesh: TMesh) -> bool:
    """No horizontal T-junction extension intersects a vertical one (seed 002 §1.2)."""
    return len(crossings(t_junctions(mesh))) == 0


# ----------------------------------------------------------------------------- editing
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


def mirror_seam(faces: np.ndarray) -> np.ndarray:
    """Closed-seam blades: give the faces along u = 1 every horizontal line (v = const)
    that the faces along u = 0 have, and vice versa, so the two ends of the T-mesh see the
    same v knots. Without this the seam constraint (:func:`seam_reduction`) would leave
    only the v splines common to both ends near the seam, and refining one end alone
    could not lower the error there. Faces ``[u0,u1,v0,v1]`` over [-mu,1+mu]²."""
    while True:
        f = faces
        inner = (f[:, 0] >= 0) & (f[:, 1] <= 1) & (f[:, 2] >= 0) & (f[:, 3] <= 1)
        left = np.flatnonzero(inner & (f[:, 0] == 0))
        right = np.flatnonzero(inner & (f[:, 1] == 1))
        seen: dict[int, float] = {}
        for this, other in ((left, right), (right, left)):
            marks = np.unique(f[other][:, 2:4])
            for k in this:
                inside = marks[(marks > f[k, 2]) & (marks < f[k, 3])]
                if inside.size:
                    seen.setdefault(int(k), float(inside[0]))
        if not seen:
            return faces
        idx = np.array(list(seen))
        faces = _split(faces, idx, np.ones(len(idx), int), np.array([seen[k] for k in idx]))


def _seam_suitable(mesh: TMesh, max_candidates: int) -> tuple[TMesh, int]:
    """AST conversion alternated with :func:`mirror_seam` until both hold."""
    steps = 0
    for _ in range(50):
        mirrored = mirror_seam(mesh.faces)
        if len(mirrored) == len(mesh.faces) and steps:
            return mesh, steps
        mesh, s = make_analysis_suitable(TMesh(mirrored, mesh.mu), max_candidates)
        steps += s
        if len(mirror_seam(mesh.faces)) == len(mesh.faces):
            return mesh, steps
    raise BladeReconError("closing the T-mesh seam did not settle; use --seam open")


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


# ----------------------------------------------------------------------------- blending functions
def bspline_basis_1d(knots: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Cubic B-spline N[t0..t4](x) by the Cox–de Boor recursion (NURBS Book eq. 2.5),
    0/0 = 0, half-open spans. ``knots`` (5,) or (m, 5) row per x; ``x`` (m,)."""
    t = np.broadcast_to(np.asarray(knots, float), (len(x), 5)) if np.ndim(knots) == 1 else knots
    x = np.asarray(x, float)
    N = [((t[:, k] <= x) & (x < t[:, k + 1])).astype(float) for k in range(4)]
    for p in range(1, 4):
        nxt = []
        for k in range(4 - p):
            d1 = t[:, k + p] - t[:, k]
            d2 = t[:, k + p + 1] - t[:, k + 1]
            a = np.divide(x - t[:, k], d1, out=np.zeros_like(x), where=d1 > 0)
            b = np.divide(t[:, k + p + 1] - x, d2, out=np.zeros_like(x), where=d2 > 0)
            nxt.append(a * N[k] + b * N[k + 1])
        N = nxt
    return N[0]


class _PointIndex:
    """Points sorted by u for fast support queries (rectangles in parameter space)."""

    def __init__(self, uv: np.ndarray) -> None:
        self.order = np.argsort(uv[:, 0], kind="stable")
        self.u = uv[self.order, 0]
        self.v = uv[self.order, 1]

    def in_box(self, u0: float, u1: float, v0: float, v1: float) -> np.ndarray:
        a = np.searchsorted(self.u, u0, side="left")
        b = np.searchsorted(self.u, u1, side="right")
        vv = self.v[a:b]
        return self.order[a:b][(vv >= v0) & (vv <= v1)]


def _column(index: _PointIndex, uv: np.ndarray, ku: np.ndarray, kv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    rows = index.in_box(ku[0], ku[4], kv[0], kv[4])
    vals = bspline_basis_1d(ku, uv[rows, 0]) * bspline_basis_1d(kv, uv[rows, 1])
    nz = vals != 0
    return rows[nz], vals[nz]


def basis_matrix(uv: np.ndarray, ku: np.ndarray, kv: np.ndarray, index: _PointIndex | None = None,
                 cache: dict | None = None, nodes: np.ndarray | None = None) -> sp.csc_matrix:
    """Sparse (m, n) matrix A_ji = B_i(u_j, v_j) (seed 002 eq. 2, eq. 7).

    One vectorised evaluation per node over the points in its support. With ``cache``
    (keyed by node position and knots) columns of unchanged blending functions are reused,
    so a refinement step only evaluates the new and changed ones.
    """
    if index is None:
        index = _PointIndex(uv)
    rows, cols, vals = [], [], []
    for i in range(len(ku)):
        key = None
        if cache is not None:
            key = (tuple(nodes[i]), tuple(ku[i]), tuple(kv[i]))
            hit = cache.get(key)
        if cache is None or hit is None:
            hit = _column(index, uv, ku[i], kv[i])
            if cache is not None:
                cache[key] = hit
        r, v = hit
        rows.append(r)
        vals.append(v)
        cols.append(np.full(len(r), i))
    A = sp.csc_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(len(uv), len(ku)))
    return A


# ----------------------------------------------------------------------------- features
def gaussian_curvature(uv: np.ndarray, xyz: np.ndarray, k: int = 16) -> np.ndarray:
    """|K| estimate at each point from a local quadratic fit x(u,v) over its k nearest
    parameter neighbours: K = (LN - M²)/(EG - F²) of the fitted patch.

    Seed 002 §2.2.1 takes principal curvatures from the triangle mesh (Rusinkiewicz 2004);
    this is a different, standard estimator with the same purpose (ranking points).
    """
    m = len(uv)
    k = min(k, m)
    tree = cKDTree(uv)
    _, nb = tree.query(uv, k=k)
    d = uv[nb] - uv[:, None, :]                            # (m, k, 2)
    h = np.maximum(np.abs(d).max(axis=(1, 2)), 1e-12)[:, None]
    du, dv = d[..., 0] / h, d[..., 1] / h
    D = np.stack([np.ones_like(du), du, dv, 0.5 * du * du, du * dv, 0.5 * dv * dv], axis=-1)
    X = xyz[nb] - xyz[:, None, :]
    G = np.einsum("mki,mkj->mij", D, D) + 1e-9 * np.eye(6)
    R = np.einsum("mki,mkc->mic", D, X)
    C = np.linalg.solve(G, R)                              # (m, 6, 3)
    Su, Sv = C[:, 1] / h, C[:, 2] / h
    Suu, Suv, Svv = C[:, 3] / h ** 2, C[:, 4] / h ** 2, C[:, 5] / h ** 2
    n = np.cross(Su, Sv)
    nn = np.linalg.norm(n, axis=1)
    n = n / np.maximum(nn, 1e-300)[:, None]
    E, F, Gm = (Su * Su).sum(1), (Su * Sv).sum(1), (Sv * Sv).sum(1)
    L, M, N = (Suu * n).sum(1), (Suv * n).sum(1), (Svv * n).sum(1)
    den = E * Gm - F * F
    K = np.where(den > 1e-300, (L * N - M * M) / np.where(den > 1e-300, den, 1.0), 0.0)
    return np.abs(K)


def feature_mask(uv: np.ndarray, xyz: np.ndarray, fraction: float = 0.10) -> np.ndarray:
    """The ``fraction`` (seed 002: 10 %) of points with the largest |Gaussian curvature|."""
    K = gaussian_curvature(uv, xyz)
    n = int(round(fraction * len(K)))
    mask = np.zeros(len(K), bool)
    if n > 0:
        mask[np.argsort(-K, kind="stable")[:n]] = True
    return mask


# ----------------------------------------------------------------------------- point location
class _FaceLocator:
    """Face of the reduced domain holding each parameter point (points in [0,1]²)."""

    def __init__(self, mesh: TMesh) -> None:
        rf = mesh.reduced_faces()
        f = mesh.faces[rf]
        self.U = np.unique(f[:, :2])
        self.V = np.unique(f[:, 2:])
        table = np.full((len(self.U) - 1, len(self.V) - 1), -1, int)
        iu0 = np.searchsorted(self.U, f[:, 0])
        iu1 = np.searchsorted(self.U, f[:, 1])
        iv0 = np.searchsorted(self.V, f[:, 2])
        iv1 = np.searchsorted(self.V, f[:, 3])
        for k in range(len(f)):
            table[iu0[k]:iu1[k], iv0[k]:iv1[k]] = rf[k]
        self.table = table

    def __call__(self, uv: np.ndarray) -> np.ndarray:
        iu = np.clip(np.searchsorted(self.U, uv[:, 0], side="right") - 1, 0, len(self.U) - 2)
        iv = np.clip(np.searchsorted(self.V, uv[:, 1], side="right") - 1, 0, len(self.V) - 2)
        return self.table[iu, iv]


# ----------------------------------------------------------------------------- initial mesh
def initial_mesh(uv: np.ndarray, features: np.ndarray, n_data: int, n_feature: int, mu: float = 0.05,
                 min_size: float = 1.0 / 1024, lengths: tuple[float, float] = (1.0, 1.0),
                 order: str = "longer-side") -> TMesh:
    """Seed 002 §2.2.2–2.2.3: split [0,1]² cells across their longer side at the midpoint
    while a cell holds > ``n_data`` points or > ``n_feature`` feature points (cells are not
    split below ``min_size``), then add the strip of width ``mu``."""
    faces = np.array([[0.0, 1.0, 0.0, 1.0]])
    while True:
        mesh = TMesh(add_strip(faces, mu), mu)
        loc = _FaceLocator(mesh)(uv)
        nd = np.bincount(loc, minlength=len(mesh.faces))
        nf = np.bincount(loc[features], minlength=len(mesh.faces))
        inner_idx = np.arange(len(faces))  # inner faces come first in add_strip
        f = faces
        big = np.maximum(f[:, 1] - f[:, 0], f[:, 3] - f[:, 2]) > min_size
        split = inner_idx[((nd[inner_idx] > n_data) | (nf[inner_idx] > n_feature)) & big]
        if len(split) == 0:
            return TMesh(add_strip(faces, mu), mu)
        new = split_longer_side(faces, split, uv, loc, lengths, order=order)
        if len(new) == len(faces):      # no cell can be cut with data on both halves
            return TMesh(add_strip(faces, mu), mu)
        faces = new


def tensor_mesh(u_lines: np.ndarray, v_lines: np.ndarray, mu: float = 0.05) -> TMesh:
    """A tensor-product mesh (no T-junctions) with the given lines in [0,1], plus the strip."""
    u = np.concatenate([[-mu], np.asarray(u_lines, float), [1 + mu]])
    v = np.concatenate([[-mu], np.asarray(v_lines, float), [1 + mu]])
    U0, V0 = np.meshgrid(u[:-1], v[:-1], indexing="ij")
    U1, V1 = np.meshgrid(u[1:], v[1:], indexing="ij")
    return TMesh(np.column_stack([U0.ravel(), U1.ravel(), V0.ravel(), V1.ravel()]), mu)


# ----------------------------------------------------------------------------- parameters
def normalise_parameters(uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Map parameters affinely onto [0,1]² (per axis). Returns (uv01, origin, scale)."""
    uv = np.asarray(uv, float)
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    span = hi - lo
    if np.any(span <= 0):
        axis = "u" if span[0] <= 0 else "v"
        raise BladeReconError(f"degenerate parameterisation: every point has the same {axis}; "
                              "the points do not span a surface")
    return np.clip((uv - lo) / span, 0.0, 1.0), lo, span


def duplicate_parameters(uv: np.ndarray, values: np.ndarray, tol: float = 1e-9) -> dict:
    """Points sharing one (u, v): how many, and how many with different values (> tol)
    — those no surface can fit; the fit then approximates their mean."""
    _, inverse, counts = np.unique(uv, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    dup = counts[inverse] > 1
    n_dup = int(dup.sum())
    conflicting = 0
    if n_dup:
        idx = np.flatnonzero(dup)
        groups = inverse[idx]
        vals = values[idx]
        mean = np.zeros((counts.size, values.shape[1]))
        np.add.at(mean, groups, vals)
        mean /= counts[:, None]
        spread = np.linalg.norm(vals - mean[groups], axis=1)
        conflicting = int(np.unique(groups[spread > tol]).size)
    return {"points_sharing_parameters": n_dup, "conflicting_groups": conflicting}


def parameter_lengths(uv: np.ndarray, xyz: np.ndarray, bands: int = 16, steps: int = 64) -> tuple[float, float]:
    """Model length (mm) of the unit step in u and in v: in each of ``bands`` bands of the
    other parameter, the points are averaged in ``steps`` bins of this one and the length
    of the polyline of the means is divided by its parameter span; the median over bands.
    For a z-map over (x, y) this is about the x and y extents."""
    out = []
    for col in (0, 1):
        band = np.minimum((uv[:, 1 - col] * bands).astype(int), bands - 1)
        step = np.minimum((uv[:, col] * steps).astype(int), steps - 1)
        key = band * steps + step
        count = np.bincount(key, minlength=bands * steps)
        mean_p = np.stack([np.bincount(key, xyz[:, c], bands * steps) for c in range(3)], axis=1)
        mean_t = np.bincount(key, uv[:, col], bands * steps)
        ok = count > 0
        mean_p[ok] /= count[ok, None]
        mean_t[ok] /= count[ok]
        lengths = []
        for b in range(bands):
            sl = slice(b * steps, (b + 1) * steps)
            sel = ok[sl]
            if sel.sum() < 2:
                continue
            p, t = mean_p[sl][sel], mean_t[sl][sel]
            if np.ptp(t) > 0:
                lengths.append(np.linalg.norm(np.diff(p, axis=0), axis=1).sum() / np.ptp(t))
        out.append(float(np.median(lengths)) if lengths else 1.0)
    return out[0], out[1]


# ----------------------------------------------------------------------------- fitting
@dataclass(frozen=True)
class FitLimits:
    """When the refinement gives up (seed 002 §2.5 loops until max error <= eps)."""

    max_iterations: int = 40
    max_control_points: int = 6000
    min_cell: float = 1.0 / 2048       # cells are not split below this parameter size


@dataclass(frozen=True, eq=False)
class TSplineFit:
    """An AS T-spline S(u,v) = Σ P_i B_i(u,v) over [0,1]² and how the fit went."""

    mesh: TMesh
    nodes: np.ndarray
    knots_u: np.ndarray
    knots_v: np.ndarray
    poles: np.ndarray                   # (n, d)
    max_error: float
    mean_error: float
    refinements: int
    converged: bool
    stop_reason: str
    history: list = field(default_factory=list)
    seconds: float = 0.0
    ast_steps: int = 0
    duplicates: dict = field(default_factory=dict)
    seam: str = "open"                  # open / closed / closed-c1 in u (see fit_tspline)

    @property
    def n_control_points(self) -> int:
        return len(self.nodes)


def _least_squares(A: sp.csc_matrix, rhs: np.ndarray, guess: np.ndarray, ridge: float | None = None) -> np.ndarray:
    """min ||A P - rhs||² (seed 002 eq. 7 / eq. 10) by sparse normal equations.

    A ridge of ``ridge`` × mean diagonal pulls poles towards ``guess`` only where the data
    leave them undetermined (empty supports), so a singular system cannot occur.
    """
    N = (A.T @ A).tocsc()
    diag = N.diagonal()
    lam = (_RIDGE if ridge is None else ridge) * max(float(diag.mean()) if diag.size else 1.0, 1e-300)
    N = N + lam * sp.identity(N.shape[0], format="csc")
    b = A.T @ rhs + lam * guess
    lu = spla.splu(N)
    return lu.solve(np.ascontiguousarray(b))


def seam_rows(ku: np.ndarray, kv: np.ndarray, c1: bool = True) -> np.ndarray:
    """Dense rows C (k, n) with C P = S(0,v_k) − S(1,v_k) (and, with ``c1``, the same for
    ∂S/∂u) for the blending functions ``ku``, ``kv``. The v_k are 4 points in each span
    between all v knots in [0,1] plus the knots, so C P = 0 makes the two u-ends equal
    identically: both sides are cubic in v on each span. ∂/∂u at an end is exact: every
    N_u is one cubic on [0, h] (h = the nearest positive u knot), whose Bernstein
    coefficients come from 4 samples; the end derivative is 3(c1 − c0)/h (NURBS Book eq. 1.9)."""
    br = np.unique(kv[(kv >= 0) & (kv <= 1)])
    vk = np.concatenate([br, (br[:-1, None] + np.diff(br)[:, None] * _BERN_T).ravel()])
    n, k = len(ku), len(vk)
    d0 = ku[ku > 1e-12]
    d1 = 1.0 - ku[ku < 1 - 1e-12]
    h0 = min(float(d0.min()) if d0.size else 1.0, 0.5)
    h1 = min(float(d1.min()) if d1.size else 1.0, 0.5)
    # u samples and their weights: value rows use u = 0 and u = 1; derivative rows use the
    # 4 Bernstein samples on [0, h0] and [1 - h1, 1]
    ends = [(np.array([0.0]), np.array([1.0]), np.array([1.0]), np.array([1.0]))]
    if c1:
        ends.append((_BERN_T * h0, 3.0 * (_BERN_INV[1] - _BERN_INV[0]) / h0,
                     1.0 - h1 + _BERN_T * h1, 3.0 * (_BERN_INV[3] - _BERN_INV[2]) / h1))
    near = np.flatnonzero(((ku[:, 0] < h0) & (ku[:, 4] > 0)) | ((ku[:, 0] < 1) & (ku[:, 4] > 1 - h1)))
    r = len(near)
    nv = bspline_basis_1d(np.repeat(kv[near], k, axis=0), np.tile(vk, r)).reshape(r, k)

    def nu_weighted(us, w):
        vals = bspline_basis_1d(np.repeat(ku[near], len(us), axis=0), np.tile(us, r)).reshape(r, len(us))
        return vals @ w                                              # (r,)

    rows = []
    for u0, w0, u1, w1 in ends:
        block = np.zeros((k, n))
        block[:, near] = ((nu_weighted(u0, w0) - nu_weighted(u1, w1))[:, None] * nv).T
        rows.append(block)
    return np.concatenate(rows)


def seam_reduction(ku: np.ndarray, kv: np.ndarray, c1: bool = True) -> sp.csc_matrix:
    """Sparse T (n, n') whose columns span the poles with :func:`seam_rows` C P = 0:
    identity on the poles C does not touch, an orthonormal null-space basis of C (SVD,
    relative threshold 1e-10) on those it does. P = T z closes the seam for every z."""
    C = seam_rows(ku, kv, c1)
    n = len(ku)
    J = np.flatnonzero(np.any(np.abs(C) > 0, axis=0))
    free = np.setdiff1d(np.arange(n), J)
    CJ = C[:, J]
    norm = np.linalg.norm(CJ, axis=1)
    CJ = CJ[norm > 0] / norm[norm > 0, None]
    _, sv, vt = np.linalg.svd(CJ, full_matrices=True)
    rank = int(np.sum(sv > 1e-10 * sv[0])) if sv.size else 0
    NJ = vt[rank:].T                                               # (|J|, |J| - rank)
    rows = np.concatenate([free, np.repeat(J, NJ.shape[1])])
    cols = np.concatenate([np.arange(len(free)), np.tile(len(free) + np.arange(NJ.shape[1]), len(J))])
    vals = np.concatenate([np.ones(len(free)), NJ.ravel()])
    keep = np.abs(vals) > 1e-15
    return sp.csc_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n, len(free) + NJ.shape[1]))


def _least_squares_closed(A: sp.csc_matrix, rhs: np.ndarray, guess: np.ndarray, T: sp.csc_matrix,
                          ridge: float | None = None) -> np.ndarray:
    """:func:`_least_squares` over P = T z (seed 002 eq. 7 with the seam closed): solve for z
    with the ridge pulling T z towards the orthogonal projection of ``guess``; T is
    orthonormal column by column, so Tᵀ guess is that projection's coordinates."""
    z = _least_squares((A @ T).tocsc(), rhs, T.T @ guess, ridge)
    return T @ z


def greville(ku: np.ndarray, kv: np.ndarray) -> np.ndarray:
    """Greville point (mean of the three middle knots) of each blending function, clipped to
    [0,1]²: where a pole sits on its surface, to second order (NURBS Book §9.2)."""
    return np.clip(np.column_stack([ku[:, 1:4].mean(axis=1), kv[:, 1:4].mean(axis=1)]), 0.0, 1.0)


def _nearest_data(uv: np.ndarray, values: np.ndarray):
    tree = cKDTree(uv)
    return lambda q: values[tree.query(q)[1]]


def fit_tspline(uv: np.ndarray, values: np.ndarray, eps: float, n_data: int | None = None,
                n_feature: int | None = None, xyz: np.ndarray | None = None, mu: float = 0.05,
                limits: FitLimits = FitLimits(), local: bool = True,
                max_candidates: int = 40, initial: TMesh | None = None,
                lengths: tuple[float, float] | None = None, prior=None, ridge: float | None = None,
                cut_order: str = "longer-side", seam: str = "open") -> TSplineFit:
    """Adaptive ASTS fitting (seed 002 Fig. 2): initial mesh → AST → least squares →
    [split cells with error > eps → AST → local least squares (eq. 10)]* .

    ``uv`` (m, 2) in [0,1]²; ``values`` (m, d); ``xyz`` (m, 3) the point positions used for
    the curvature features (default: ``values`` when d == 3). ``n_data``/``n_feature``: N_d,
    N_f of §2.2.2 (seed 002 does not state its values; defaults m/16 and m/80: no cell
    holds more than 1/16 of the points or 1/8 of the feature points).
    ``local=False`` re-solves all poles each step.
    ``prior``: a function (k, 2) parameters -> (k, d) values of a smooth reference surface;
    the tiny ridge of the solves pulls poles towards it at their Greville points, which only
    matters where the data leave poles free (between measured sections). Default: the
    nearest data point for the first solve, the current T-spline for refined poles.
    ``ridge``: weight of that pull relative to the mean diagonal of AᵀA (default 1e-10, or
    1e-4 with a ``prior``: then it also damps poles the data fix only weakly, e.g. on cells
    between two close sections).
    ``cut_order``: see :func:`_split_choice` (``longer-side`` or ``switch-side``).
    ``lengths``: model lengths of the u and v directions for the longer-side rule (default:
    estimated from ``xyz`` by :func:`parameter_lengths`).
    ``seam``: ``open`` (default), ``closed`` (S(0,v) = S(1,v) identically) or ``closed-c1``
    (also ∂S/∂u(0,v) = ∂S/∂u(1,v)), for u periodic with period 1 (a blade profile). Not a
    periodic T-mesh: the mesh keeps its mu strips in u, :func:`mirror_seam` gives both
    u-ends the same v lines, and every solve is global over the poles P = T z that
    satisfy the seam equations (:func:`seam_reduction`); eq. 10's local re-solve is not used.
    Stops at max error <= eps, or at a :class:`FitLimits` limit with ``converged=False``
    and the reason and the error reached.
    """
    t0 = time.perf_counter()
    uv = np.asarray(uv, float)
    values = np.asarray(values, float)
    if values.ndim == 1:
        values = values[:, None]
    m = len(uv)
    if m < 16:
        raise BladeReconError(f"a T-spline fit needs at least 16 points, got {m}")
    if not eps > 0:
        raise BladeReconError(f"--tolerance must be a positive distance, got {eps}")
    if cut_order not in CUT_ORDERS:
        raise BladeReconError(f"unknown cut order '{cut_order}': use one of {', '.join(CUT_ORDERS)}")
    if np.any(uv < -1e-12) or np.any(uv > 1 + 1e-12):
        raise BladeReconError("parameters must lie in [0,1]²; normalise them first")
    if seam not in SEAMS:
        raise BladeReconError(f"unknown seam '{seam}': use one of {', '.join(SEAMS)}")
    closed = seam != "open"
    c1 = seam == "closed-c1"
    if closed:
        local = False

    def suitable(mesh_):
        return _seam_suitable(mesh_, max_candidates) if closed else make_analysis_suitable(mesh_, max_candidates)

    def solve(A_, rhs_, guess_, ku_, kv_):
        if closed:
            return _least_squares_closed(A_, rhs_, guess_, seam_reduction(ku_, kv_, c1), ridge)
        return _least_squares(A_, rhs_, guess_, ridge)
    dups = duplicate_parameters(uv, values)
    if n_data is None:
        n_data = max(16, m // 16)
    if n_feature is None:
        n_feature = max(4, m // 80)
    if initial is None:
        if xyz is None:
            xyz = values if values.shape[1] == 3 else np.column_stack([uv, values[:, 0]])
        feat = feature_mask(uv, np.asarray(xyz, float))
    if lengths is None:
        lengths = parameter_lengths(uv, np.asarray(xyz, float)) if xyz is not None else (1.0, 1.0)
    if initial is None:
        mesh = initial_mesh(uv, feat, n_data, n_feature, mu, lengths=lengths, order=cut_order)
    else:
        mesh = initial
    mesh, ast_steps = suitable(mesh)
    index = _PointIndex(uv)
    cache: dict = {}
    nodes, ku, kv = local_knots(mesh)
    A = basis_matrix(uv, ku, kv, index, cache, nodes)
    if ridge is None:
        ridge = _RIDGE if prior is None else 1e-4
    nearest = _nearest_data(uv, values)
    poles = solve(A, values, (prior or nearest)(greville(ku, kv)), ku, kv)
    err = np.linalg.norm(A @ poles - values, axis=1)
    history = [{"control_points": len(nodes), "max": float(err.max()), "mean": float(err.mean()),
                "changed": len(nodes)}]
    refinements = 0
    reason = "max error <= tolerance"
    converged = bool(err.max() <= eps)
    while not converged:
        if refinements >= limits.max_iterations:
            reason = f"iteration limit ({limits.max_iterations}) reached"
            break
        loc = _FaceLocator(mesh)(uv)
        bad = np.unique(loc[err > eps])
        f = mesh.faces[bad]
        bad = bad[np.maximum(f[:, 1] - f[:, 0], f[:, 3] - f[:, 2]) > limits.min_cell]
        if len(bad) == 0:
            reason = f"cells holding points with error > tolerance are at the smallest size ({limits.min_cell:g})"
            break
        split_faces = split_longer_side(mesh.faces, bad, uv, loc, lengths, order=cut_order)
        if len(split_faces) == len(mesh.faces):
            # fall back to cuts that keep one data line per half (e.g. between two sections)
            split_faces = split_longer_side(mesh.faces, bad, uv, loc, lengths, min_lines=1, order=cut_order)
        if len(split_faces) == len(mesh.faces):
            reason = "no cell holding points with error > tolerance can be cut with data on both halves"
            break
        new_mesh, steps = suitable(TMesh(split_faces, mu))
        new_nodes, new_ku, new_kv = local_knots(new_mesh)
        if len(new_nodes) > limits.max_control_points:
            reason = f"control point limit ({limits.max_control_points}) would be exceeded ({len(new_nodes)})"
            break
        ast_steps += steps
        refinements += 1
        # unchanged blending function: same node and same local knot vectors
        old = {(tuple(p), tuple(a), tuple(b)): i for i, (p, a, b) in enumerate(zip(nodes, ku, kv))}
        keep_old = np.array([old.get((tuple(p), tuple(a), tuple(b)), -1)
                             for p, a, b in zip(new_nodes, new_ku, new_kv)])
        A = basis_matrix(uv, new_ku, new_kv, index, cache, new_nodes)
        changed = keep_old < 0
        new_poles = np.empty((len(new_nodes), values.shape[1]))
        new_poles[~changed] = poles[keep_old[~changed]]
        g = greville(new_ku[changed], new_kv[changed])
        guess = prior(g) if prior else basis_matrix(g, ku, kv) @ poles
        if local:
            # seed 002 eq. 10: P_r = (A_srᵀA_sr)⁻¹ A_srᵀ (V_s − A_s(n−r) P_(n−r))
            Ar = A[:, np.flatnonzero(changed)]
            rows = np.unique(Ar.indices)
            Ar = Ar[rows]
            Ak = A[rows][:, np.flatnonzero(~changed)]
            rhs = values[rows] - Ak @ new_poles[~changed]
            new_poles[changed] = _least_squares(Ar.tocsc(), rhs, guess, ridge)
        else:
            g = greville(new_ku, new_kv)
            new_poles = solve(A, values, prior(g) if prior else basis_matrix(g, ku, kv) @ poles, new_ku, new_kv)
        mesh, nodes, ku, kv, poles = new_mesh, new_nodes, new_ku, new_kv, new_poles
        alive = set(zip(map(tuple, nodes), map(tuple, ku), map(tuple, kv)))
        for key in [k for k in cache if k not in alive]:
            del cache[key]
        err = np.linalg.norm(A @ poles - values, axis=1)
        history.append({"control_points": len(nodes), "max": float(err.max()), "mean": float(err.mean()),
                        "changed": int(changed.sum())})
        converged = bool(err.max() <= eps)
    if not converged and reason == "max error <= tolerance":
        reason = "not converged"
    return TSplineFit(mesh, nodes, ku, kv, poles, float(err.max()), float(err.mean()), refinements,
                      converged, reason if converged else f"stopped: {reason}; max error {err.max():.4g}",
                      history, time.perf_counter() - t0, ast_steps, dups, seam)


def evaluate(fit: TSplineFit, uv: np.ndarray) -> np.ndarray:
    """S(u, v) = Σ P_i B_i(u, v) (seed 002 eq. 5) at parameters (k, 2) in [0,1]²."""
    uv = np.atleast_2d(np.asarray(uv, float))
    return basis_matrix(uv, fit.knots_u, fit.knots_v) @ fit.poles


def partition_of_unity(fit_or_mesh, uv: np.ndarray) -> np.ndarray:
    """Σ_i B_i(u, v) at the parameters (1 on the reduced domain of an AS T-mesh)."""
    mesh = fit_or_mesh.mesh if isinstance(fit_or_mesh, TSplineFit) else fit_or_mesh
    _, ku, kv = local_knots(mesh)
    return np.asarray(basis_matrix(np.atleast_2d(uv), ku, kv).sum(axis=1)).ravel()


# ----------------------------------------------------------------------------- tensor comparison
def tensor_least_squares(uv: np.ndarray, values: np.ndarray, nu: int, nv: int, knots: str = "uniform"
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares bicubic tensor-product B-spline (NURBS with unit weights) with nu x nv
    poles on [0,1]², clamped; interior knots ``uniform`` or ``averaged`` (NURBS Book eq.
    9.69 on the distinct parameter values of each direction; uniform where there are
    fewer distinct values than poles). Returns (poles (nu*nv, d),
    per-point error). The peer of seed 002 §3 (their NURBS fits use uniform knots)."""
    from bladerecon.core.geometry.bspline import approximation_knots, collocation_matrix

    values = np.asarray(values, float).reshape(len(uv), -1)
    mats = []
    for col, n in ((0, nu), (1, nv)):
        distinct = np.unique(uv[:, col])
        if knots == "averaged" and n <= len(distinct):   # else: uniform in that direction
            U = approximation_knots(distinct, 3, n)
            inner = U[4:-4]
        else:
            inner = np.linspace(0.0, 1.0, n - 2)[1:-1]
        kn = np.concatenate([[0.0], inner, [1.0]])
        mult = np.concatenate([[4], np.ones(len(inner), int), [4]])
        mats.append(collocation_matrix(kn, mult, 3, False, n, uv[:, col]).tocsr())
    Nu, Nv = mats
    m = len(uv)
    cu, du_ = Nu.indices.reshape(m, -1), Nu.data.reshape(m, -1)
    cv, dv_ = Nv.indices.reshape(m, -1), Nv.data.reshape(m, -1)
    cols = (cu[:, :, None] * nv + cv[:, None, :]).reshape(m, -1)
    vals = (du_[:, :, None] * dv_[:, None, :]).reshape(m, -1)
    A = sp.csc_matrix((vals.ravel(), (np.repeat(np.arange(m), cols.shape[1]), cols.ravel())), shape=(m, nu * nv))
    P = _least_squares(A, values, np.tile(values.mean(axis=0), (nu * nv, 1)))
    return P, np.linalg.norm(A @ P - values, axis=1)


# ----------------------------------------------------------------------------- Bézier extraction
@dataclass(frozen=True)
class BezierPatch:
    """One bicubic Bézier element: parameter box [u0,u1]×[v0,v1] and 4x4 control points."""

    box: tuple[float, float, float, float]
    poles: np.ndarray                  # (4, 4, d), index [i along u, j along v]
    face: int                          # the T-mesh face it lies in


_BERN_T = np.array([0.125, 0.375, 0.625, 0.875])


def _bernstein(t: np.ndarray) -> np.ndarray:
    s = 1.0 - t
    return np.stack([s ** 3, 3 * t * s * s, 3 * t * t * s, t ** 3], axis=-1)


_BERN_INV = np.linalg.inv(_bernstein(_BERN_T))


def bezier_elements(fit: TSplineFit) -> list[tuple[int, float, float, float, float]]:
    """Bézier elements of the reduced domain: each T-mesh face, cut by every knot line of a
    blending function whose support covers part of the face (so every blending function is
    a single bicubic polynomial on every element)."""
    out = []
    ku, kv = fit.knots_u, fit.knots_v
    seam_v = np.empty(0)
    if fit.seam != "open":
        # closed seam: the elements along u = 0 and u = 1 are cut at the same v values so
        # their edges coincide and the sewn shell closes around the profile
        first = bezier_elements(TSplineFit(**{**fit.__dict__, "seam": "open"}))
        seam_v = np.unique([[e[3], e[4]] for e in first if e[1] == 0 or e[2] == 1])
    for k in fit.mesh.reduced_faces():
        a, b, c, d = fit.mesh.faces[k]
        act = (ku[:, 0] < b) & (ku[:, 4] > a) & (kv[:, 0] < d) & (kv[:, 4] > c)
        us = np.unique(np.concatenate([[a, b], ku[act].ravel()]))
        vs = np.unique(np.concatenate([[c, d], kv[act].ravel()] + ([seam_v] if a == 0 or b == 1 else [])))
        us = us[(us >= a) & (us <= b)]
        vs = vs[(vs >= c) & (vs <= d)]
        for i in range(len(us) - 1):
            for j in range(len(vs) - 1):
                out.append((int(k), us[i], us[i + 1], vs[j], vs[j + 1]))
    return out


def bezier_patches(fit: TSplineFit) -> list[BezierPatch]:
    """Bézier extraction: on element [a,b]×[c,d] each active B_i = N_u(u) N_v(v) is a
    product of cubics; their Bernstein coefficients (from 4 interior samples, exact up to
    rounding) give the element's control points Σ_i P_i c_u,i ⊗ c_v,i."""
    ku, kv, P = fit.knots_u, fit.knots_v, fit.poles
    patches = []
    for k, a, b, c, d in bezier_elements(fit):
        act = np.flatnonzero((ku[:, 0] < b) & (ku[:, 4] > a) & (kv[:, 0] < d) & (kv[:, 4] > c))
        su = a + (b - a) * _BERN_T
        sv = c + (d - c) * _BERN_T
        r = len(act)
        nu = bspline_basis_1d(np.repeat(ku[act], 4, axis=0), np.tile(su, r)).reshape(r, 4)
        nv = bspline_basis_1d(np.repeat(kv[act], 4, axis=0), np.tile(sv, r)).reshape(r, 4)
        cu = nu @ _BERN_INV.T                                        # Bernstein coefficients
        cv = nv @ _BERN_INV.T
        poles = np.einsum("ri,rj,rd->ijd", cu, cv, P[act])
        patches.append(BezierPatch((a, b, c, d), poles, k))
    return patches


def zmap_patches(patches: list[BezierPatch], origin: np.ndarray, scale: np.ndarray) -> list[BezierPatch]:
    """3D control points of z-map patches: x, y are affine in (u, v) (x = origin + scale u),
    so their Bernstein coefficients are the box's thirds; z is the fitted value."""
    out = []
    third = np.arange(4) / 3.0
    for p in patches:
        a, b, c, d = p.box
        x = origin[0] + scale[0] * (a + (b - a) * third)
        y = origin[1] + scale[1] * (c + (d - c) * third)
        X, Y = np.meshgrid(x, y, indexing="ij")
        out.append(BezierPatch(p.box, np.stack([X, Y, p.poles[..., 0]], axis=-1), p.face))
    return out


def evaluate_patches(patches: list[BezierPatch], uv: np.ndarray) -> np.ndarray:
    """Evaluate the Bézier patches (de Casteljau via Bernstein sums) at parameters in [0,1]²."""
    uv = np.atleast_2d(np.asarray(uv, float))
    boxes = np.array([p.box for p in patches])
    out = np.full((len(uv), patches[0].poles.shape[2]), np.nan)
    for n, p in enumerate(patches):
        a, b, c, d = p.box
        inside = (uv[:, 0] >= a) & (uv[:, 0] <= b) & (uv[:, 1] >= c) & (uv[:, 1] <= d) & np.isnan(out[:, 0])
        if inside.any():
            bu = _bernstein((uv[inside, 0] - a) / (b - a))
            bv = _bernstein((uv[inside, 1] - c) / (d - c))
            out[inside] = np.einsum("mi,mj,ijd->md", bu, bv, p.poles)
    del boxes
    return out
