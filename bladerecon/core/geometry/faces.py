# SPDX-License-Identifier: LGPL-2.1-or-later
"""Closest point on a shape made of trimmed faces (a CAD nominal), vectorised over points:
each face's surface projected once, the foot kept where it lies in the face, else the boundary.

For every face the point is projected onto the face's whole surface (a B-spline by the core's
projection, the other kinds by :mod:`bladerecon.core.geometry.analytic`, which may give more
than one local foot: both nappes of a cone); faces that share one surface (parameter-range
restrictions of one B-spline, say) share that projection. A foot counts for a face if its
(u, v) lies inside the face's trimming loops
(:class:`~bladerecon.core.geometry.trimming.UVRegion`). Where it does not, and the surface's
distance (a lower bound of the face's) is below the best found so far, the face's closest
point is on its boundary: the point is projected onto the face's boundary edges
(:mod:`bladerecon.core.geometry.edges`), each edge once for all the faces that meet there.
Faces whose box is farther than a point's best distance are not tried for it.

Signs (+ outside): a foot inside a face takes the face's outward normal. A foot on an edge
takes the sum of the outward normals of the faces meeting there (the edge's pseudo-normal,
which is exact for a closed surface, Baerentzen & Aanaes 2005). Where that is not enough -
the foot is a vertex, or the nearest feet with + and - signs are within ``tie_tol`` of each
other (both flanks of a thin edge) - and a solid is known, the solid decides: ``inside``
(e.g. :class:`~bladerecon.core.geometry.inside.MeshInside` on a tessellation made once).

A face that no model covers can still take part through an ``external`` measurer (the
caller's, e.g. OpenCASCADE per point), which handles its own boundary.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from bladerecon.core.geometry.trimming import UVRegion

__all__ = ["Face", "Edge", "FaceFeet", "measure_faces"]


@dataclass
class Face:
    """One face: its surface ``model`` (or an ``external`` measurer), trimming ``region``
    (None: the whole surface), outward ``sign`` relative to the model's normal, boundary
    ``edges`` (indices into the edge list: every edge with a curve, seams too), box (2, 3)
    and the way it is measured."""

    model: Any
    region: UVRegion | None
    sign: float
    edges: tuple[int, ...]
    box: np.ndarray
    method: str
    external: Any = None


@dataclass
class Edge:
    """A boundary edge: curve ``model`` (``project`` -> t, foot, distance, at_end), box (2, 3),
    and the outward unit normals of the faces that meet there, sampled along it: ``t`` (k,)
    increasing, ``normals`` (faces, k, 3)."""

    model: Any
    box: np.ndarray
    t: np.ndarray
    normals: np.ndarray
    faces: tuple[int, ...] = field(default=())


@dataclass(frozen=True)
class FaceFeet:
    """Per point: signed distance (+ outside), foot, outward unit normal at the foot, face
    index (for an edge foot the first face that meets there), (u, v) on that face (NaN on an
    edge), ``on_edge`` and ``decided_by_solid`` (the sign came from the inside test)."""

    signed: np.ndarray
    foot: np.ndarray
    normal: np.ndarray
    face: np.ndarray
    u: np.ndarray
    v: np.ndarray
    on_edge: np.ndarray
    decided_by_solid: np.ndarray
    seconds: dict


def _box_gap(P: np.ndarray, box: np.ndarray) -> np.ndarray:
    return np.linalg.norm(np.maximum(0.0, np.maximum(box[0] - P, P - box[1])), axis=1)


class _Best:
    """The running best foot of every point, and the nearest distance of each sign."""

    def __init__(self, m: int):
        self.dist = np.full(m, np.inf)
        self.signed = np.zeros(m)
        self.foot = np.zeros((m, 3))
        self.normal = np.zeros((m, 3))
        self.face = np.full(m, -1, dtype=np.int64)
        self.u = np.full(m, np.nan)
        self.v = np.full(m, np.nan)
        self.on_edge = np.zeros(m, dtype=bool)
        self.vertex = np.zeros(m, dtype=bool)
        self.pos = np.full(m, np.inf)
        self.neg = np.full(m, np.inf)

    def take_all(self, face_of: np.ndarray, signs: np.ndarray, c) -> None:
        """The first candidates, for every point (nothing to compare with yet): the feet of
        projection ``c`` where they lie in a face (``face_of`` >= 0)."""
        hit = face_of >= 0
        sign = np.where(hit, signs[np.maximum(face_of, 0)], 0.0)
        self.dist = np.where(hit, c.distance, np.inf)
        self.signed = sign * c.signed
        self.foot = np.array(c.foot, dtype=float, copy=True)
        self.normal = sign[:, None] * c.normal
        self.face = np.where(hit, face_of, -1)
        self.u = np.where(hit, c.u, np.nan)
        self.v = np.where(hit, c.v, np.nan)
        positive = self.signed >= 0
        self.pos = np.where(hit & positive, self.dist, np.inf)
        self.neg = np.where(hit & ~positive, self.dist, np.inf)

    def offer(self, idx, dist, signed, foot, normal, face, u=None, v=None, edge=False, vertex=None):
        """Candidates for points ``idx``: kept where closer than the best so far."""
        positive = signed >= 0
        p, n = idx[positive], idx[~positive]
        self.pos[p] = np.minimum(self.pos[p], dist[positive])
        self.neg[n] = np.minimum(self.neg[n], dist[~positive])
        win = dist < self.dist[idx]
        w = idx[win]
        self.dist[w], self.signed[w], self.foot[w], self.normal[w] = dist[win], signed[win], foot[win], normal[win]
        self.face[w] = face if np.isscalar(face) else face[win]
        self.u[w] = np.nan if u is None else u[win]
        self.v[w] = np.nan if v is None else v[win]
        self.on_edge[w] = edge
        self.vertex[w] = False if vertex is None else vertex[win]


def measure_faces(P: np.ndarray, faces: list[Face], edges: list[Edge],
                  inside: Callable[[np.ndarray], np.ndarray] | None = None,
                  tie_tol: float = 1e-6, inside_tol: float = 0.0,
                  clock: Callable[[], float] | None = None) -> FaceFeet:
    """Closest foot on the faces for each point (m, 3) mm; see the module doc.

    ``inside`` (points -> bool) signs the points whose feet tie or sit on a vertex, if they
    are farther than ``inside_tol`` (the inside test's own uncertainty: a tessellation's
    deflection) from the faces; nearer ones keep the sign of their foot's normals.
    """
    import time

    clock = clock or time.perf_counter
    P = np.asarray(P, float).reshape(-1, 3)
    m = len(P)
    best = _Best(m)
    seconds = {"surfaces": 0.0, "in_face": 0.0, "edges": 0.0, "external": 0.0, "solid": 0.0}
    # faces grouped by surface, the largest boxes first (they give small best distances early)
    groups: dict[Any, list[int]] = {}
    for k, f in enumerate(faces):
        if f.model is not None:
            groups.setdefault(f.model.key, []).append(k)
    def size(k: int) -> float:
        return float(np.prod(faces[k].box[1] - faces[k].box[0] + 1e-9))

    order = sorted((sorted(ks, key=size, reverse=True) for ks in groups.values()),
                   key=lambda ks: -sum(size(k) for k in ks))
    seen: list[tuple[int, np.ndarray, np.ndarray]] = []   # (face, points whose foot is not in it, surface distance)
    seen_any = False                                     # the first group takes every point
    for ks in order:
        box = np.stack([np.min([faces[k].box[0] for k in ks], axis=0), np.max([faces[k].box[1] for k in ks], axis=0)])
        first = not seen_any
        idx = np.arange(m) if first else np.flatnonzero(_box_gap(P, box) < best.dist)
        seen_any = True
        if idx.size == 0:
            continue
        t0 = clock()
        model = faces[ks[0]].model
        cands = model.project_all(P[idx]) if hasattr(model, "project_all") else [model.project(P[idx])]
        lower = np.min([c.distance for c in cands], axis=0)           # the surface's distance
        t1 = clock()
        seconds["surfaces"] += t1 - t0
        first_seen = len(seen)
        if len(cands) == 1:
            # one foot per point: the faces of one surface do not overlap, so a foot inside
            # one face is tested against no other
            c = cands[0]
            open_ = np.arange(idx.size)
            face_of = np.full(idx.size, -1, dtype=np.int64)
            for k in ks:
                f = faces[k]
                inside_f = np.ones(open_.size, dtype=bool) if f.region is None else f.region.contains(c.u[open_],
                                                                                                        c.v[open_])
                face_of[open_[inside_f]] = k
                open_ = open_[~inside_f]
                if f.edges and open_.size:
                    seen.append((k, idx[open_], lower[open_]))
            if first:                                  # every point, nothing to beat: whole arrays
                best.take_all(face_of, np.array([f.sign for f in faces]), c)
            else:
                j = np.flatnonzero(face_of >= 0)
                sign = np.array([f.sign for f in faces])[face_of[j]]
                best.offer(idx[j], c.distance[j], sign * c.signed[j], c.foot[j], sign[:, None] * c.normal[j],
                           face_of[j], c.u[j], c.v[j])
        else:
            for k in ks:
                f = faces[k]
                nearest_in = np.zeros(idx.size, dtype=bool)
                for c in cands:
                    inside_f = np.ones(idx.size, dtype=bool) if f.region is None else f.region.contains(c.u, c.v)
                    j = np.flatnonzero(inside_f)
                    best.offer(idx[j], c.distance[j], f.sign * c.signed[j], c.foot[j], f.sign * c.normal[j], k,
                               c.u[j], c.v[j])
                    nearest_in |= inside_f & (c.distance <= lower)
                if f.edges and not nearest_in.all():
                    out = ~nearest_in
                    seen.append((k, idx[out], lower[out]))
        # a face's boundary matters only where its surface comes nearer than the best so far
        for n in range(first_seen, len(seen)):
            k, i, low = seen[n]
            keep = low < best.dist[i]
            seen[n] = (k, i[keep], low[keep])
        seconds["in_face"] += clock() - t1
    # faces measured outside the core: their boundary is theirs
    t0 = clock()
    for k, f in enumerate(faces):
        if f.model is None and f.external is not None:
            idx = np.flatnonzero(_box_gap(P, f.box) < best.dist)
            if idx.size:
                dist, signed, foot, normal = f.external(P[idx], best.dist[idx])
                best.offer(idx, dist, signed, foot, normal, k)
    seconds["external"] = clock() - t0
    # boundary edges, for the points whose foot fell outside a face that could still be nearer
    t0 = clock()
    need: dict[int, list[np.ndarray]] = {}
    for k, idx, lower in seen:
        for e in faces[k].edges:
            need.setdefault(e, []).append((idx, lower))
    for e, parts in sorted(need.items()):
        edge = edges[e]
        idx = np.unique(np.concatenate([i[lower < best.dist[i]] for i, lower in parts]))
        if idx.size == 0:
            continue
        idx = idx[_box_gap(P[idx], edge.box) < best.dist[idx]]
        if idx.size == 0:
            continue
        t, foot, dist, at_end = edge.model.project(P[idx])
        keep = np.flatnonzero(dist <= best.dist[idx] + tie_tol)          # a tie of signs counts too
        if keep.size == 0:
            continue
        idx, t, foot, dist, at_end = idx[keep], t[keep], foot[keep], dist[keep], at_end[keep]
        pseudo = np.zeros((idx.size, 3))
        for nk in edge.normals:
            pseudo += np.stack([np.interp(t, edge.t, nk[:, c]) for c in range(3)], axis=1)
        off = P[idx] - foot
        sign = np.where(np.einsum("ij,ij->i", off, pseudo) < 0, -1.0, 1.0)
        length = np.linalg.norm(pseudo, axis=1, keepdims=True)
        normal = pseudo / np.maximum(length, 1e-300)
        best.offer(idx, dist, sign * dist, foot, normal, edge.faces[0] if edge.faces else -1,
                   edge=True, vertex=at_end)
    seconds["edges"] = clock() - t0
    # signs the normals cannot settle: the solid decides
    t0 = clock()
    decided = np.zeros(m, dtype=bool)
    if inside is not None:
        tie = np.abs(best.pos - best.neg) <= tie_tol
        ask = np.flatnonzero((tie | best.vertex) & np.isfinite(best.dist) & (best.dist > inside_tol))
        if ask.size:
            inner = inside(P[ask])
            best.signed[ask] = np.where(inner, -best.dist[ask], best.dist[ask])
            decided[ask] = True
    seconds["solid"] = clock() - t0
    return FaceFeet(best.signed, best.foot, best.normal, best.face, best.u, best.v, best.on_edge, decided, seconds)
