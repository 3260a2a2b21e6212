# SPDX-License-Identifier: LGPL-2.1-or-later
"""Is a nominal blade-like? (issue 23 §6) A blade is two large sheets facing opposite ways (the
pressure and the suction side) a thickness apart that is small against the blade's size; a box,
a cylinder or a sphere given as the nominal by mistake has its opposite walls a large part of
its size apart.

Works on a triangulation (vertices, triangles) of the nominal's faces: the sheets are the
triangles whose normals point along (and against) the direction most of the area faces (the
largest eigenvector of the area-weighted normal tensor); the wall distance is the median, over
the area of one sheet, of the distance to the nearest triangle centre of the other.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["wall_ratio", "BLADE_WALL_RATIO"]

#: a nominal whose opposite walls lie more than this share of its size apart is not blade-like
#: (measured on 33 x 33 grids a face: the sample blade 0.03, its multi-face solid 0.03, a
#: 1500 x 16-pole blade face 0.003; a 60 x 30 x 100 mm box 0.25, a cylinder 0.25, a sphere 0.37)
BLADE_WALL_RATIO = 0.10


def wall_ratio(vertices: np.ndarray, triangles: np.ndarray) -> float:
    """Median distance between the two opposite-facing sheets over the bounding-box diagonal;
    nan when the triangulation has no two opposite sheets at all."""
    V = np.asarray(vertices, float)
    T = np.asarray(triangles, int)
    if len(T) == 0:
        return float("nan")
    A, B, C = V[T[:, 0]], V[T[:, 1]], V[T[:, 2]]
    n = np.cross(B - A, C - A)                       # |n| = 2 x area
    area = np.linalg.norm(n, axis=1)
    ok = area > 0
    if not ok.any():
        return float("nan")
    n, area, centre = n[ok], area[ok], ((A + B + C) / 3.0)[ok]
    unit = n / area[:, None]
    d = np.linalg.eigh(unit.T @ (unit * area[:, None]))[1][:, -1]
    facing = unit @ d
    front, back = facing > 0.5, facing < -0.5
    if not front.any() or not back.any():
        return float("nan")
    dist, _ = cKDTree(centre[back]).query(centre[front])
    order = np.argsort(dist)
    w = np.cumsum(area[front][order])
    median = float(dist[order][np.searchsorted(w, 0.5 * w[-1])])
    size = float(np.linalg.norm(np.ptp(V, axis=0)))
    return median / size if size > 0 else float("nan")
