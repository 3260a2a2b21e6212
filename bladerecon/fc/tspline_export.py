"""T-spline → CAD: Bézier patches as ``Part.BezierSurface`` faces sewn into one shell, STEP.

The core's Bézier extraction (:func:`bladerecon.core.tspline.bezier_patches`) gives one
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
from bladerecon.core.tspline import BezierPatch

from .freecad_env import import_freecad

__all__ = ["patch_surface", "patch_faces", "sew_patches", "occ_evaluate", "shell_gaps", "write_tspline_step",
           "make_tspline_feature"]

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


def write_tspline_step(patches: list[BezierPatch], path: str | os.PathLike, tol: float = SEW_TOL) -> dict:
    """Sew the patches into one shell and write it to STEP (mm, atomic). Returns counts."""
    from .export import write_step

    faces = patch_faces(patches)
    shell = sew_patches(faces, tol)
    write_step(shell, path)
    return {"faces": len(shell.Faces), "free_edges": _free_edge_count(shell)}


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
    from bladerecon.tspline_cli import fit_point_file

    _, patches, summary = fit_point_file(path, tolerance, zmap=zmap,
                                         say=lambda m: FreeCAD.Console.PrintMessage(f"BladeRecon: {m}\n"))
    shell = sew_patches(patch_faces(patches))
    obj = doc.addObject("Part::Feature", "TSplineSurface")
    obj.Shape = shell
    obj.Label = f"T-spline ({summary['control_points']} control points)"
    state = "" if summary["converged"] else f"; {summary['stop_reason']}"
    obj.Label2 = (f"{os.path.basename(path)}: {summary['control_points']} control points, "
                  f"{summary['refinements']} refinements, max {summary['max']:.4g} mm, "
                  f"mean {summary['mean']:.4g} mm, {len(shell.Faces)} Bézier faces{state}")
    doc.recompute()
    return obj
