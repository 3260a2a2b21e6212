# SPDX-License-Identifier: LGPL-2.1-or-later
"""T-spline → CAD: Bézier patches as ``Part.BezierSurface`` faces sewn into one shell, STEP.

The core's Bézier extraction (:func:`bladerecon.core.surface.tspline.bezier_patches`) gives one
bicubic patch per Bézier element of the reduced domain; each becomes a face with the
parameter box mapped onto the Bézier surface's [0,1]². Neighbouring patches meet exactly
(the T-spline is C² across simple knot lines), so sewing at 1e-6 mm joins them into one
shell; T-junctions are handled by the sewing's edge cutting. Units: mm.
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.surface.tspline import BezierPatch

from bladerecon.fc.freecad_env import import_freecad

__all__ = ["patch_surface", "patch_faces", "sew_patches", "occ_evaluate", "shell_gaps", "write_tspline_step",
           "make_tspline_feature", "add_tspline_feature", "seam_check", "free_edges"]

FreeCAD, Part = import_freecad()

SEW_TOL = 1e-6  # mm


def patch_surface(patch: BezierPatch) -> Any:
    """``Part.BezierSurface`` of degree 3x3 with the patch's 4x4 control points (mm)."""
    poles = np.asarray(patch.poles, float)
    if poles.shape != (4, 4, 3):
        raise BladeReconError(f"a Bézier patch needs 4x4 3D control points, got {poles.shape}")
    s = Part.BezierSurface()
    s.increase(3, 3)
    for i in range(4):
        for j in range(4):
            s.setPole(i + 1, j + 1, FreeCAD.Vector(*map(float, poles[i, j])))
    return s


def patch_faces(patches: list[BezierPatch]) -> list[Any]:
    return [patch_surface(p).toShape() for p in patches]


def sew_patches(faces: list[Any], tol: float = SEW_TOL) -> Any:
    """One shell from the patch faces, sewn at ``tol`` mm (BRepBuilderAPI_Sewing)."""
    shell = Part.makeShell(faces)
    shell.sewShape(tol)
    shells = shell.Shells
    if len(shells) != 1:
        raise BladeReconError(f"sewing the {len(faces)} T-spline patches gave {len(shells)} shells, not one")
    return shells[0]


def occ_evaluate(patches: list[BezierPatch], surfaces: list[Any], uv: np.ndarray) -> np.ndarray:
    """Evaluate the exported surfaces with OpenCASCADE at T-spline parameters (k, 2)."""
    uv = np.atleast_2d(np.asarray(uv, float))
    boxes = np.array([p.box for p in patches])
    out = np.full((len(uv), 3), np.nan)
    for n, (u, v) in enumerate(uv):
        k = np.flatnonzero((boxes[:, 0] <= u) & (u <= boxes[:, 1]) & (boxes[:, 2] <= v) & (v <= boxes[:, 3]))[0]
        a, b, c, d = boxes[k]
        p = surfaces[k].value((u - a) / (b - a), (v - c) / (d - c))
        out[n] = (p.x, p.y, p.z)
    return out


def shell_gaps(patches: list[BezierPatch], surfaces: list[Any], samples: int = 9) -> float:
    """Largest distance (mm) between neighbouring patches along their common boundaries,
    both sides evaluated by OpenCASCADE at the same T-spline parameter: every interior patch
    side is sampled and compared with the patch across it."""
    boxes = np.array([p.box for p in patches])
    worst = 0.0
    t = np.linspace(0.0, 1.0, samples)
    for k, (a, b, c, d) in enumerate(boxes):
        sides = []
        if b < 1:
            sides.append((np.full(samples, b), c + (d - c) * t, 0))
        if d < 1:
            sides.append((a + (b - a) * t, np.full(samples, d), 1))
        for us, vs, axis in sides:
            for u, v in zip(us, vs):
                if axis == 0:
                    nb = np.flatnonzero((boxes[:, 0] == u) & (boxes[:, 2] <= v) & (v <= boxes[:, 3]))
                else:
                    nb = np.flatnonzero((boxes[:, 2] == v) & (boxes[:, 0] <= u) & (u <= boxes[:, 1]))
                mine = surfaces[k].value((u - a) / (b - a), (v - c) / (d - c))
                for j in nb:
                    a2, b2, c2, d2 = boxes[j]
                    other = surfaces[j].value((u - a2) / (b2 - a2), (v - c2) / (d2 - c2))
                    worst = max(worst, (mine - other).Length)
    return worst


def write_tspline_step(patches: list[BezierPatch], path: str | os.PathLike, tol: float = SEW_TOL,
                       seam: bool = False) -> dict:
    """Sew the patches into one shell and write it to STEP (mm, atomic). Returns counts;
    with ``seam`` (a blade, u around the profile) also :func:`seam_check` of the shell."""
    from bladerecon.fc.export import write_step

    faces = patch_faces(patches)
    shell = sew_patches(faces, tol)
    write_step(shell, path)
    info = {"faces": len(shell.Faces), "free_edges": _free_edge_count(shell)}
    if seam:
        info.update(seam_check(patches, [f.Surface for f in faces], shell))
    return info


def free_edges(shell: Any) -> list[Any]:
    """Edges of ``shell`` used by only one face."""
    count: dict = {}
    for f in shell.Faces:
        for e in f.Edges:
            count.setdefault(e.hashCode(), [e, 0])[1] += 1
    return [e for e, n in count.values() if n == 1]


def seam_check(patches: list[BezierPatch], surfaces: list[Any], shell: Any, samples: int = 401) -> dict:
    """The blade seam as OpenCASCADE sees it (mm):

    * ``seam_gap_occ``: largest distance between the exported surfaces at u = 0 and at
      u = 1 (same v, ``samples`` values), each evaluated by OCC on its own patch;
    * ``free_edges_off_hub_tip``: free edges of the sewn shell whose midpoint and ends are
      farther than 1e-6 mm from the hub (v = 0) and tip (v = 1) boundary curves, which are
      built as OCC edges from the patches' v-isolines. 0 means the shell is closed around
      the profile and open only at hub and tip;
    * ``seam_du_jump_rel_occ`` / ``seam_tangent_angle_deg_occ``: largest jump of ∂S/∂u across
      the seam relative to its size, and largest angle between the u tangents, from OCC's
      patch derivatives (0 for a C1 seam; the angle is the G1 measure).
    """
    v = np.linspace(0.0, 1.0, samples)
    a = occ_evaluate(patches, surfaces, np.column_stack([np.zeros_like(v), v]))
    b = occ_evaluate(patches, surfaces, np.column_stack([np.ones_like(v), v]))
    ends = []
    for p, srf in zip(patches, surfaces):
        if p.box[2] == 0:
            ends.append(srf.vIso(0.0).toShape())
        if p.box[3] == 1:
            ends.append(srf.vIso(1.0).toShape())
    boxes = np.array([p.box for p in patches])

    def d_du(u):
        # ∂S/∂u in T-spline parameters from OCC's own derivative of the patch (getDN)
        out = np.empty((len(v), 3))
        for n, vv in enumerate(v):
            k = np.flatnonzero((boxes[:, 0] <= u) & (u <= boxes[:, 1]) & (boxes[:, 2] <= vv) & (vv <= boxes[:, 3]))[0]
            a0, b0, c0, d0 = boxes[k]
            d = surfaces[k].getDN((u - a0) / (b0 - a0), (vv - c0) / (d0 - c0), 1, 0)
            out[n] = (d.x / (b0 - a0), d.y / (b0 - a0), d.z / (b0 - a0))
        return out
    du0, du1 = d_du(0.0), d_du(1.0)
    cosang = np.sum(du0 * du1, axis=1) / (np.linalg.norm(du0, axis=1) * np.linalg.norm(du1, axis=1))
    # a point is within 1e-6 mm of the hub/tip curves only inside one of their bounding boxes
    # grown by 1e-6: OCC measures the distance to those few curves, not to the whole compound
    # (one distToShape against ~70 curves took 14 ms; 441 of them were half a T-spline export)
    boxes_ht = []
    for e in ends:
        bb = e.BoundBox
        bb.enlarge(1e-6)
        boxes_ht.append(bb)

    def near_hub_tip(point) -> bool:
        near = [e for e, bb in zip(ends, boxes_ht) if bb.isInside(point)]
        return any(e.distToShape(Part.Vertex(point))[0] <= 1e-6 for e in near)

    off = 0
    free = free_edges(shell)
    for e in free:
        for t in (e.FirstParameter, 0.5 * (e.FirstParameter + e.LastParameter), e.LastParameter):
            if not near_hub_tip(e.valueAt(t)):
                off += 1
                break
    return {"seam_gap_occ": float(np.linalg.norm(a - b, axis=1).max()), "free_edges": len(free),
            "free_edges_off_hub_tip": off,
            "seam_du_jump_rel_occ": float((np.linalg.norm(du0 - du1, axis=1) / np.linalg.norm(du0, axis=1)).max()),
            "seam_tangent_angle_deg_occ": float(np.degrees(np.arccos(np.clip(cosang, -1, 1))).max())}


def _free_edge_count(shell: Any) -> int:
    """Edges used by only one face (the open boundary of the surface)."""
    count: dict = {}
    for f in shell.Faces:
        for e in f.Edges:
            key = e.hashCode()
            count[key] = count.get(key, 0) + 1
    return sum(1 for v in count.values() if v == 1)


def make_tspline_feature(doc: Any, path: str, tolerance: float, zmap: bool = False) -> Any:
    """Fit an ASTS to the points in ``path`` (seed 002) and add the sewn patch shell to
    ``doc`` as a ``Part::Feature`` named ``TSplineSurface``; the fit summary goes in its
    Label2 (description) and the report view. Tolerance in mm."""
    from bladerecon.core.surface.tspline_job import fit_point_file

    _, patches, summary = fit_point_file(path, tolerance, zmap=zmap,
                                         say=lambda m: FreeCAD.Console.PrintMessage(f"BladeRecon: {m}\n"))
    obj = add_tspline_feature(doc, path, sew_patches(patch_faces(patches)), summary)
    doc.recompute()
    return obj


def add_tspline_feature(doc: Any, path: str, shell: Any, summary: dict) -> Any:
    """The ``TSplineSurface`` Part::Feature holding ``shell``, labelled with the fit summary
    of :func:`~bladerecon.core.surface.tspline_job.fit_point_file` (control points, errors, mm)."""
    obj = doc.addObject("Part::Feature", "TSplineSurface")
    obj.Shape = shell
    obj.Label = f"T-spline ({summary['control_points']} control points)"
    state = "" if summary["converged"] else f"; {summary['stop_reason']}"
    obj.Label2 = (f"{os.path.basename(path)}: {summary['control_points']} control points, "
                  f"{summary['refinements']} refinements, max {summary['max']:.4g} mm, "
                  f"mean {summary['mean']:.4g} mm, {len(shell.Faces)} Bézier faces{state}")
    return obj
