# SPDX-License-Identifier: LGPL-2.1-or-later
"""Point-to-shape distances computed by OpenCASCADE: the independent referee of tests and benchmarks.

Nothing here uses the core's evaluator or projector: the distance of each point is the
minimum over the shape's faces found by ``BRepExtrema_DistShapeShape``
(``Part.Vertex(p).distToShape``), which also handles feet on edges and vertices.

Speed, ms per point (FreeCAD 0.20.2 / OCCT 7.6.3, one core of a busy 2-core machine;
:func:`distance_method_timings`; a u-periodic cubic blade face, 200 points within 2 mm of
it, some beyond the hub and tip). On an idle machine every figure is about half.

====================================================  =============  ==============
call                                                   40 x 6 poles   150 x 25 poles
====================================================  =============  ==============
``Part.Vertex(p).distToShape(face)``                   2.9            21
``face.distToShape(Part.Vertex(p))``                   3.0            21
``face.Surface.parameter(p)`` + ``value``              2.4            18
``face.Surface.projectPoint(p, "LowerDistance")``      2.2            19
``distToShape`` on the face cut into 12 x 6-span
patches (what :func:`occ_distances` does)              2.1            5.3
``Part.Shape.makeParallelProjection``                  not a point distance: OCC refuses
                                                       a vertex ("neither wire nor edge")
====================================================  =============  ==============

Every OpenCASCADE projection rebuilds its search grid on each call, and the grid grows
with the number of knot spans; so a large B-spline face without trimming is cut (exactly,
by knot insertion: ``BSplineSurface.segment``) into patches of about 12 x 6 spans, and
``distToShape``'s bounding-box pruning then searches only the few nearby patches. The
surface-projection calls are only 10-25 % faster than ``distToShape`` on the same face,
but find no foot on a face boundary and ignore trimming, so they are not used.
"""
from __future__ import annotations

import time
from typing import Any, Callable

import numpy as np

from bladerecon.core.errors import BladeReconError

from bladerecon.fc.freecad_env import import_freecad

__all__ = ["occ_distances", "occ_target_faces", "distance_method_timings"]

FreeCAD, Part = import_freecad()

PATCH_SPANS = (12, 6)  # knot spans per patch in u and v when a face is cut for speed


def _shape_outward_signs(shape: Any, faces: list[Any]) -> np.ndarray:
    """+1/-1 per face: -1 where the face lies on a closed shell or solid oriented inward."""
    signs = np.ones(len(faces))
    closed = list(shape.Solids)
    in_solids = [f for s in closed for f in s.Faces]
    for shell in shape.Shells:
        # a closed shell's own volume is signed by its orientation (Part.Solid would re-orient it)
        if shell.isClosed() and not any(shell.Faces[0].isSame(f) for f in in_solids):
            closed.append(shell)
    for body in closed:
        if body.Volume < 0:
            for i, face in enumerate(faces):
                if any(face.isSame(f) for f in body.Faces):
                    signs[i] = -1.0
    return signs


def _has_natural_bounds(face: Any) -> bool:
    """True for an untrimmed B-spline face: its whole surface, nothing cut away."""
    surface = face.Surface
    if not isinstance(surface, Part.BSplineSurface) or len(face.Wires) != 1:
        return False
    if not np.allclose(face.ParameterRange, surface.bounds(), rtol=0, atol=1e-9):
        return False
    # a trimming wire that touches all four sides still cuts area away
    whole = Part.Face(surface).Area
    return abs(face.Area - whole) <= 1e-9 * whole


def _patches(face: Any, spans: tuple[int, int]) -> list[Any]:
    """The face cut along knot lines into faces of at most about ``spans`` knot spans each."""
    surface = face.Surface
    cuts = []
    for knots, n in ((surface.getUKnots(), spans[0]), (surface.getVKnots(), spans[1])):
        count = max(1, int(np.ceil((len(knots) - 1) / n)))
        cuts.append([knots[i] for i in np.unique(np.linspace(0, len(knots) - 1, count + 1).round().astype(int))])
    patches = []
    for u0, u1 in zip(cuts[0][:-1], cuts[0][1:]):
        for v0, v1 in zip(cuts[1][:-1], cuts[1][1:]):
            piece = surface.copy()
            piece.segment(u0, u1, v0, v1)
            patch = Part.Face(piece)
            if face.Orientation == "Reversed":
                patch.reverse()
            patches.append(patch)
    return patches


def occ_target_faces(shape: Any, subdivide: bool = True) -> tuple[list[Any], np.ndarray]:
    """Faces to measure against, and the outward sign of each (see :func:`occ_distances`).

    With ``subdivide``, each untrimmed B-spline face with more than 12 x 6 knot spans is
    replaced by its patches (same geometry, same orientation).
    """
    faces = list(shape.Faces)
    if not faces:
        raise BladeReconError("cannot measure distances: the shape has no faces")
    signs = _shape_outward_signs(shape, faces)
    targets, target_signs = [], []
    for face, sign in zip(faces, signs):
        pieces = [face]
        if subdivide and _has_natural_bounds(face):
            s = face.Surface
            if s.NbUKnots - 1 > PATCH_SPANS[0] or s.NbVKnots - 1 > PATCH_SPANS[1]:
                pieces = _patches(face, PATCH_SPANS)
        targets += pieces
        target_signs += [sign] * len(pieces)
    return targets, np.array(target_signs)


def _normal_at_foot(compound: Any, faces: list[Any], info: tuple, foot: Any) -> tuple[Any, int]:
    """Oriented normal (face orientation respected) at the foot of one solution, and its face's index."""
    kind, index, params = info[3], info[4], info[5]
    if kind == "Face":
        return faces[index].normalAt(*params), index
    # foot on an edge or vertex: sum the normals of the faces meeting there
    sub = compound.Edges[index] if kind == "Edge" else compound.Vertexes[index]
    normal, owner = FreeCAD.Vector(), -1
    for face in compound.ancestorsOfType(sub, Part.Face):
        u, v = face.Surface.parameter(foot)
        normal += face.normalAt(u, v)
        owner = next(i for i, f in enumerate(faces) if f.isSame(face))
    return normal, owner


def occ_distances(points: np.ndarray, shape: Any, signed: bool = False, subdivide: bool = True) -> np.ndarray:
    """Distance (mm) from each point (N, 3) to the nearest face of ``shape``, shape (N,).

    A solid counts by its boundary: a point inside is at the distance to the nearest face,
    not 0. ``signed``: positive on the side the face normal points to at the foot point,
    face orientation respected; for a closed shell or solid the normals are taken outward,
    so points outside the body are positive. Feet on an edge or vertex use the sum of the
    normals of the faces meeting there. ``subdivide``: see :func:`occ_target_faces`.
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 3)
    faces, signs = occ_target_faces(shape, subdivide)
    compound = Part.Compound(faces)
    out = np.empty(len(pts))
    for k, p in enumerate(pts):
        point = FreeCAD.Vector(*p)
        dist, pairs, infos = Part.Vertex(point).distToShape(compound)
        out[k] = dist
        if signed and dist > 0.0:
            foot = pairs[0][1]
            normal, owner = _normal_at_foot(compound, faces, infos[0], foot)
            if owner >= 0 and (point - foot).dot(normal) * signs[owner] < 0:
                out[k] = -dist
    return out


def distance_method_timings(points: np.ndarray, face: Any) -> dict[str, float]:
    """Milliseconds per point of each OCC call that can measure point-to-face distance.

    For reports and benchmarks; each entry is timed on the same points.
    """
    vectors = [FreeCAD.Vector(*p) for p in np.asarray(points, dtype=float).reshape(-1, 3)]
    surface = face.Surface
    patched = Part.Compound(occ_target_faces(face)[0])

    def parameter_value(v: Any) -> float:
        u, w = surface.parameter(v)
        return (surface.value(u, w) - v).Length

    methods: dict[str, Callable[[Any], Any]] = {
        "Vertex.distToShape(face)": lambda v: Part.Vertex(v).distToShape(face)[0],
        "Face.distToShape(Vertex)": lambda v: face.distToShape(Part.Vertex(v))[0],
        "Surface.parameter + value": parameter_value,
        "Surface.projectPoint LowerDistance": lambda v: surface.projectPoint(v, "LowerDistance"),
        "Vertex.distToShape(patches)": lambda v: Part.Vertex(v).distToShape(patched)[0],
    }
    timings = {}
    for name, call in methods.items():
        start = time.perf_counter()
        for v in vectors:
            call(v)
        timings[name] = (time.perf_counter() - start) * 1e3 / max(len(vectors), 1)
    return timings
