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
    bb = shape.BoundBox
    centre = np.array([bb.Center.x, bb.Center.y, bb.Center.z])
    out = []
    for k, (o, n) in enumerate(zip(np.asarray(origins, float), np.asarray(normals, float))):
        n = n / np.linalg.norm(n)
        inward = 1.0 if (centre - o) @ n >= 0 else -1.0
        best = None
        # a section measured at the very end of the blade lies in the plane of the nominal's
        # boundary: step inside by up to 0.1 mm until the cut is one closed wire
        for shift in NUDGES:
            wires = shape.slice(FreeCAD.Vector(*n), float(n @ o + inward * shift))
            closed = [w for w in wires if w.isClosed()]
            if closed:
                best = min(closed, key=lambda w: np.linalg.norm(
                    np.array([w.BoundBox.Center.x, w.BoundBox.Center.y, w.BoundBox.Center.z]) - o))
                break
        if best is None:
            raise BladeReconError(f"{path}: the plane of section {k} (through {np.round(o, 3).tolist()} mm, "
                                  f"normal {np.round(n, 4).tolist()}) gives no closed section of the nominal "
                                  "(missed, or only touches a cap); choose a height inside the blade")
        pts = _wire_points(best, step)
        e1 = np.cross(n, np.eye(3)[np.argmin(np.abs(n))])
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(n, e1)
        q = np.column_stack([(pts - o) @ e1, (pts - o) @ e2])
        area = 0.5 * np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1])
        if area < 0:
            pts = pts[::-1]
        out.append(pts)
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
    bb = shape.BoundBox
    centre = np.array([bb.Center.x, bb.Center.y, bb.Center.z])
    out = []
    for o, n in zip(np.asarray(origins, float), np.asarray(normals, float)):
        n = n / np.linalg.norm(n)
        inward = 1.0 if (centre - o) @ n >= 0 else -1.0
        pts = None
        # a section measured at the very end of the blade lies in the plane of the nominal's
        # end: step inside by up to 0.1 mm, as the OCC path below does
        for shift in NUDGES:
            try:
                pts = cut_surface(surf, o + inward * shift * n, n, step)
                break
            except BladeReconError:
                continue
        if pts is None:
            return None
        e1 = np.cross(n, np.eye(3)[np.argmin(np.abs(n))])
        e2 = np.cross(n, e1)
        q = np.column_stack([(pts - o) @ e1, (pts - o) @ e2])
        if 0.5 * np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1]) < 0:
            pts = pts[::-1]
        out.append(pts)
    return out


def cut_at_heights(path: str, heights: np.ndarray, axis: np.ndarray = np.array([0.0, 0.0, 1.0]),
                   step: float = 0.1) -> list[np.ndarray]:
    """Sections of the nominal in the planes ``axis·x = h`` for each height h (mm)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    shape = read_shape(path)
    bb = shape.BoundBox
    centre = np.array([bb.Center.x, bb.Center.y, bb.Center.z])
    origins = np.array([centre + (h - centre @ a) * a for h in np.asarray(heights, float)])
    return cut_sections(path, origins, np.tile(a, (len(origins), 1)), step, shape=shape)
