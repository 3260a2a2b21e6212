# SPDX-License-Identifier: LGPL-2.1-or-later
"""Cut a nominal blade (STEP/IGES/BREP/FCStd) by planes with Part: dense nominal sections.

``Part.Shape.slice(normal, d)`` returns the wires of the section ``n·x = d``; the wire
nearest the plane's reference point is the blade section. It is discretised at a fixed
step along its length (OCC ``discretize(Distance=...)``). Units mm.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.errors import BladeReconError

from bladerecon.fc.export import read_shape
from bladerecon.fc.freecad_env import import_freecad

__all__ = ["cut_sections", "cut_at_heights", "NUDGES"]

#: shifts (mm) tried towards the blade when a plane lies on the nominal's end
NUDGES = (0.0, 0.002, 0.01, 0.05, 0.1)


def _wire_points(wire, step: float) -> np.ndarray:
    pts = np.array([[v.x, v.y, v.z] for v in wire.discretize(Distance=step)], float)
    if len(pts) > 1 and np.linalg.norm(pts[0] - pts[-1]) < 1e-7:
        pts = pts[:-1]
    return pts


def _nudged_origins(o: np.ndarray, n: np.ndarray, centre: np.ndarray):
    """The plane's origin, then moved along the unit normal ``n`` towards the blade's centre by
    each of :data:`NUDGES`: a section measured at the very end of the blade lies in the plane
    of the nominal's end, and a cut there is tried again up to 0.1 mm inside."""
    inward = 1.0 if (centre - o) @ n >= 0 else -1.0
    for shift in NUDGES:
        yield o + inward * shift * n


def _counter_clockwise(pts: np.ndarray, o: np.ndarray, n: np.ndarray) -> np.ndarray:
    """The loop turned counter-clockwise about the plane normal ``n`` (signed area in the plane)."""
    e1 = np.cross(n, np.eye(3)[np.argmin(np.abs(n))])
    e2 = np.cross(n, e1)
    q = np.column_stack([(pts - o) @ e1, (pts - o) @ e2])
    area = 0.5 * np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1])
    return pts[::-1] if area < 0 else pts


def _centre(shape) -> np.ndarray:
    bb = shape.BoundBox
    return np.array([bb.Center.x, bb.Center.y, bb.Center.z])


def cut_sections(path: str, origins: np.ndarray, normals: np.ndarray, step: float = 0.1,
                 shape=None) -> list[np.ndarray]:
    """Dense points (n_k, 3) of the nominal cut by the planes (origin_k, normal_k), mm.

    Each loop is turned counter-clockwise about its plane normal. ``step``: spacing of the
    points along the section (mm). Raises :class:`BladeReconError` if a plane misses the
    blade or gives an open section.
    """
    FreeCAD, Part = import_freecad()
    if shape is None:
        shape = read_shape(path)
    fast = _cut_single_face(shape, origins, normals, step)
    if fast is not None:
        return fast
    centre = _centre(shape)
    out = []
    for k, (o, n) in enumerate(zip(np.asarray(origins, float), np.asarray(normals, float))):
        n = n / np.linalg.norm(n)
        best = None
        for o2 in _nudged_origins(o, n, centre):       # until the cut is one closed wire
            wires = shape.slice(FreeCAD.Vector(*n), float(n @ o2))
            closed = [w for w in wires if w.isClosed()]
            if closed:
                best = min(closed, key=lambda w: np.linalg.norm(
                    np.array([w.BoundBox.Center.x, w.BoundBox.Center.y, w.BoundBox.Center.z]) - o))
                break
        if best is None:
            raise BladeReconError(f"{path}: the plane of section {k} (through {np.round(o, 3).tolist()} mm, "
                                  f"normal {np.round(n, 4).tolist()}) gives no closed section of the nominal "
                                  "(missed, or only touches a cap); choose a height inside the blade")
        out.append(_counter_clockwise(_wire_points(best, step), o, n))
    return out


def _cut_single_face(shape, origins, normals, step):
    """One whole u-periodic B-spline face (a BladeRecon or CAD blade surface): cut it in the
    core (:func:`bladerecon.core.sections.plan.cut_surface`, ~100x faster than ``Shape.slice``).
    None when the shape is anything else, or a plane does not cross it all round."""
    from bladerecon.core.sections.plan import cut_surface

    from bladerecon.fc.compare import _single_bspline_face
    from bladerecon.fc.convert import from_part_surface

    face = _single_bspline_face(shape)
    if face is None:
        return None
    surf = from_part_surface(face.Surface)
    if not surf.u_periodic:
        return None
    centre = _centre(shape)
    out = []
    for o, n in zip(np.asarray(origins, float), np.asarray(normals, float)):
        n = n / np.linalg.norm(n)
        pts = None
        for o2 in _nudged_origins(o, n, centre):       # as the OCC path: up to 0.1 mm inside
            try:
                pts = cut_surface(surf, o2, n, step)
                break
            except BladeReconError:
                continue
        if pts is None:
            return None
        out.append(_counter_clockwise(pts, o, n))
    return out


def cut_at_heights(path: str, heights: np.ndarray, axis: np.ndarray = np.array([0.0, 0.0, 1.0]),
                   step: float = 0.1) -> list[np.ndarray]:
    """Sections of the nominal in the planes ``axis·x = h`` for each height h (mm)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    shape = read_shape(path)
    centre = _centre(shape)
    origins = np.array([centre + (h - centre @ a) * a for h in np.asarray(heights, float)])
    return cut_sections(path, origins, np.tile(a, (len(origins), 1)), step, shape=shape)
