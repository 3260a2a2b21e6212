# SPDX-License-Identifier: LGPL-2.1-or-later
"""Inside or outside a closed triangulated surface (the nominal solid tessellated once): ray
parity, vectorised over points, with the triangles binned on a grid across each ray direction.

A point is inside a closed surface iff a ray from it crosses the surface an odd number of
times. Each of three fixed, skew ray directions gets its own grid: the triangles are
projected on the plane across the direction and listed in every grid cell their projected
box overlaps, so a point meets only the triangles of its own cell. A ray that grazes an
edge or a vertex of the tessellation (or passes through a crack of an unsewn one) may
count wrong; the three directions vote, so one such ray does not decide.

The answer is the tessellation's: points nearer the surface than its deflection may fall on
the wrong side of it. Callers use it where that does not matter (a sign decided between
feet that tie, points farther off than the deflection).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MeshInside"]

_DIRECTIONS = np.array([[0.5773, 0.6012, 0.5527], [-0.7071, 0.3090, 0.6360], [0.2120, -0.8815, 0.4218]])
_PAIRS = 4_000_000          # (point, triangle) pairs tested at once


@dataclass(frozen=True)
class _RayGrid:
    d: np.ndarray             # unit ray direction
    a: np.ndarray             # unit vectors across it
    b: np.ndarray
    lo: np.ndarray            # grid origin (2,) in (a, b)
    cell: float
    shape: tuple[int, int]
    start: np.ndarray         # (n_cells + 1,) CSR offsets into tri
    tri: np.ndarray           # triangle index per entry


class MeshInside:
    """Ray-parity inside test against a closed triangle mesh (vertices (n, 3) mm, triangles (t, 3))."""

    def __init__(self, vertices: np.ndarray, triangles: np.ndarray):
        V = np.asarray(vertices, float)
        T = np.asarray(triangles, dtype=np.int64)
        if len(T) == 0:
            raise ValueError("MeshInside: no triangles")
        self.A, self.B, self.C = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
        self.normal = np.cross(self.B - self.A, self.C - self.A)
        self.lo, self.hi = V.min(axis=0), V.max(axis=0)
        self.grids = [self._grid(_unit(d)) for d in _DIRECTIONS]

    def _grid(self, d: np.ndarray) -> _RayGrid:
        a = _unit(np.cross(d, [0.0, 0.0, 1.0]) if abs(d[2]) < 0.9 else np.cross(d, [1.0, 0.0, 0.0]))
        b = np.cross(d, a)
        P2 = np.stack([np.stack([X @ a, X @ b], axis=1) for X in (self.A, self.B, self.C)])   # (3, t, 2)
        tmin, tmax = P2.min(axis=0), P2.max(axis=0)
        lo, hi = tmin.min(axis=0), tmax.max(axis=0)
        n_t = len(self.A)
        extent = np.maximum(hi - lo, 1e-12)
        g = max(1, int(np.sqrt(n_t / 2.0)))
        cell = float(max(extent) / g)
        shape = (int(extent[0] / cell) + 1, int(extent[1] / cell) + 1)
        i0 = ((tmin - lo) / cell).astype(np.int64)
        i1 = ((tmax - lo) / cell).astype(np.int64)
        ni, nj = i1[:, 0] - i0[:, 0] + 1, i1[:, 1] - i0[:, 1] + 1
        count = ni * nj
        tri = np.repeat(np.arange(n_t), count)
        local = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count)
        ci = np.repeat(i0[:, 0], count) + local // np.repeat(nj, count)
        cj = np.repeat(i0[:, 1], count) + local % np.repeat(nj, count)
        cid = ci * shape[1] + cj
        order = np.argsort(cid, kind="stable")
        start = np.searchsorted(cid[order], np.arange(shape[0] * shape[1] + 1))
        return _RayGrid(d, a, b, lo, cell, shape, start, tri[order])

    def _parity(self, g: _RayGrid, P: np.ndarray) -> np.ndarray:
        m = len(P)
        p2 = np.stack([P @ g.a, P @ g.b], axis=1)
        ij = np.floor((p2 - g.lo) / g.cell).astype(np.int64)
        ok = (ij[:, 0] >= 0) & (ij[:, 0] < g.shape[0]) & (ij[:, 1] >= 0) & (ij[:, 1] < g.shape[1])
        crossings = np.zeros(m, dtype=np.int64)
        idx = np.flatnonzero(ok)
        cid = ij[idx, 0] * g.shape[1] + ij[idx, 1]
        counts = g.start[cid + 1] - g.start[cid]
        # blocks of points whose pairs fit in memory
        csum = np.cumsum(counts)
        s = 0
        while s < idx.size:
            base = csum[s - 1] if s else 0
            e = max(s + 1, int(np.searchsorted(csum, base + _PAIRS, side="right")))
            rows, c, cnt = idx[s:e], cid[s:e], counts[s:e]
            pt = np.repeat(np.arange(rows.size), cnt)
            off = np.arange(cnt.sum()) - np.repeat(np.cumsum(cnt) - cnt, cnt)
            tri = g.tri[np.repeat(g.start[c], cnt) + off]
            hits = self._hits(P[rows][pt], tri, g)
            crossings[rows] += np.bincount(pt, weights=hits, minlength=rows.size).astype(np.int64)
            s = e
        return (crossings & 1) == 1

    def _hits(self, p: np.ndarray, tri: np.ndarray, g: _RayGrid) -> np.ndarray:
        """1.0 where the ray p + s d (s > 0) crosses triangle tri (Moller-Trumbore)."""
        A, B, C = self.A[tri], self.B[tri], self.C[tri]
        e1, e2 = B - A, C - A
        h = np.cross(g.d, e2)
        det = np.einsum("ij,ij->i", e1, h)
        with np.errstate(divide="ignore", invalid="ignore"):
            f = 1.0 / det
            s = p - A
            u = f * np.einsum("ij,ij->i", s, h)
            q = np.cross(s, e1)
            v = f * (q @ g.d)
            t = f * np.einsum("ij,ij->i", e2, q)
        hit = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        return hit.astype(float)

    def contains(self, points: np.ndarray) -> np.ndarray:
        """True where a point is inside (majority of the three ray directions)."""
        P = np.asarray(points, float).reshape(-1, 3)
        out = np.zeros(len(P), dtype=bool)
        box = np.all((P >= self.lo) & (P <= self.hi), axis=1)
        idx = np.flatnonzero(box)
        if idx.size:
            votes = sum(self._parity(g, P[idx]).astype(int) for g in self.grids)
            out[idx] = votes >= 2
        return out


def _unit(a) -> np.ndarray:
    a = np.asarray(a, float)
    return a / np.linalg.norm(a)
