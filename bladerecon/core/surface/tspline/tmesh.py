# SPDX-License-Identifier: LGPL-2.1-or-later
"""The T-mesh (seed 002 §2.2.3): its faces, its topology on the fine grid of its lines, the
local knot vectors by ray casting (§1.1) and the T-junctions with their extensions (§1.2).

* :class:`TMesh` — a T-mesh over the reduced domain [0,1]² extended by ``mu`` on every side
  (seed 002 §2.2.3, Fig. 4), stored as its faces (axis-aligned rectangles that tile
  [-mu, 1+mu]²). Nodes are the face corners; edges are the face sides.
* Local knot vectors by ray casting (§1.1, Sederberg et al. 2003): from node (u_i2, v_i2)
  the first two edges hit in +u give u_i3, u_i4, and so on; where a ray leaves the mesh the
  last knot is repeated (so the outer boundary carries triple knots and the blending
  functions sum to one on the reduced domain [0,1]²).
* T-junction extensions (Li–Scott: two knot intervals on the side of the missing edge, one
  on the other); the mesh is analysis-suitable when no two of them cross.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "TMesh", "TJunctions", "local_knots", "t_junctions", "crossings", "is_analysis_suitable", "_Topology",
    "_edge_presence", "_ray_knots",
]

_INF = np.inf


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
