# SPDX-License-Identifier: LGPL-2.1-or-later
"""OpenCASCADE's point-to-shape distance, pruned by bounding boxes so large shapes stay fast.

The distance of each point is still OCC's own ``Part.Vertex(p).distToShape(...)`` on the
same geometry ``bladerecon.fc.occ_measure.occ_distances`` measures against. What changes
is how many faces each call sees: ``occ_distances`` hands OCC the compound of every patch
(about 12 x 6 knot spans each, from ``occ_target_faces``), and OCC then bounds every
patch again on every call, so one point costs ~0.25 ms per patch (575 ms a point on a
FreeCAD loft of six 2000-point sections, 1003 patches). Here each patch is also cut in
``PIECES`` along its longer direction (exactly, by knot insertion: ``segment``): on a
blade that is the span, and a patch that runs the whole twisted span has a box that
holds dozens of its neighbours. Each
piece's box is computed once from its poles (a B-spline lies in the convex hull of its
poles, so the box holds the whole piece), and for each point:

OCC measures the distance to the pieces one at a time, nearest box first, keeping the
least distance ``d``, until the next box is at least ``d`` away. A piece not measured
has its box, so all of it, at least ``d`` away and cannot hold a nearer foot: the result
is the minimum over all the faces, as ``occ_distances`` gives it (see
:func:`agreement`, which the benchmark runs on every row). The points are shared among
forked worker processes, one per usable CPU. Units: mm.
"""
from __future__ import annotations

import multiprocessing
import os
from typing import Any

import numpy as np

from bladerecon.fc.freecad_env import import_freecad
from bladerecon.fc.occ_measure import occ_distances, occ_target_faces

__all__ = ["pruned_occ_distances", "agreement"]

FreeCAD, Part = import_freecad()

PIECES = 8  # pieces each untrimmed B-spline patch is cut into along its longer direction


def _natural_bspline(face: Any) -> bool:
    s = face.Surface
    return (isinstance(s, Part.BSplineSurface) and len(face.Wires) == 1
            and bool(np.allclose(face.ParameterRange, s.bounds(), rtol=0, atol=1e-9)))


def _isoline_length(surface: Any, fixed: float, lo: float, hi: float, along_u: bool) -> float:
    ts = np.linspace(lo, hi, 9)
    pts = np.array([tuple(surface.value(t, fixed) if along_u else surface.value(fixed, t)) for t in ts])
    return float(np.linalg.norm(np.diff(pts, axis=0), axis=1).sum())


def _pieces(face: Any) -> list[Any]:
    """The face cut exactly (``segment``) into ``PIECES`` along its longer parameter direction."""
    if not _natural_bspline(face):
        return [face]
    u0, u1, v0, v1 = face.ParameterRange
    s = face.Surface
    along_u = (_isoline_length(s, 0.5 * (v0 + v1), u0, u1, True)
               > _isoline_length(s, 0.5 * (u0 + u1), v0, v1, False))
    cuts = np.linspace(u0, u1, PIECES + 1) if along_u else np.linspace(v0, v1, PIECES + 1)
    pieces = []
    for a, b in zip(cuts[:-1], cuts[1:]):
        piece_surface = s.copy()
        if along_u:
            piece_surface.segment(float(a), float(b), v0, v1)
        else:
            piece_surface.segment(u0, u1, float(a), float(b))
        piece = Part.Face(piece_surface)
        if face.Orientation == "Reversed":
            piece.reverse()
        pieces.append(piece)
    return pieces


def _box(face: Any) -> tuple[np.ndarray, np.ndarray]:
    surface = face.Surface
    if isinstance(surface, Part.BSplineSurface):
        poles = np.array([[(p.x, p.y, p.z) for p in row] for row in surface.getPoles()]).reshape(-1, 3)
        return poles.min(axis=0), poles.max(axis=0)
    bb = face.BoundBox  # other surfaces: OCC's own (enclosing) box, widened by its gap
    gap = max(face.Tolerance, 1e-7)
    return (np.array([bb.XMin, bb.YMin, bb.ZMin]) - gap, np.array([bb.XMax, bb.YMax, bb.ZMax]) + gap)


_TARGETS: tuple[list[Any], np.ndarray, np.ndarray] | None = None  # read by forked workers


def _measure(points: np.ndarray) -> np.ndarray:
    faces, lo, hi = _TARGETS
    out = np.empty(len(points))
    for k, p in enumerate(points):
        box_gap = np.linalg.norm(np.maximum(0.0, np.maximum(lo - p, p - hi)), axis=1)
        order = np.argsort(box_gap, kind="stable")
        vertex = Part.Vertex(FreeCAD.Vector(*p))
        d = np.inf
        for i in order:
            if box_gap[i] >= d:
                break
            d = min(d, vertex.distToShape(faces[i])[0])
        out[k] = d
    return out


def pruned_occ_distances(points: np.ndarray, shape: Any, processes: int | None = None) -> np.ndarray:
    """Unsigned distance (mm) from each point (N, 3) to the nearest face of ``shape``, (N,).

    ``processes``: forked worker processes sharing the points (default: the usable CPUs;
    1, or a platform without ``fork``, measures in this process).
    """
    global _TARGETS
    faces = [piece for face in occ_target_faces(shape)[0] for piece in _pieces(face)]
    boxes = [_box(f) for f in faces]
    _TARGETS = (faces, np.array([b[0] for b in boxes]), np.array([b[1] for b in boxes]))
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    if processes is None:
        processes = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    processes = min(processes, max(1, len(pts) // 200))
    try:
        if processes > 1 and "fork" in multiprocessing.get_all_start_methods():
            chunks = np.array_split(pts, 4 * processes)
            with multiprocessing.get_context("fork").Pool(processes) as pool:
                return np.concatenate(pool.map(_measure, chunks))
        return _measure(pts)
    finally:
        _TARGETS = None


def agreement(points: np.ndarray, shape: Any, pruned: np.ndarray) -> float:
    """Largest |pruned - occ_distances| (mm) over ``points``: the check that pruning lost nothing."""
    return float(np.max(np.abs(occ_distances(points, shape) - pruned)))
