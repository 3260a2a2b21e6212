# SPDX-License-Identifier: LGPL-2.1-or-later
"""FreeCAD side of ``repair`` (issue 18): the nominal's blade surface, the target and the
missing-material shapes as Part solids/faces (mm).

The numbers come from :func:`bladerecon.core.repair.repair_target`; this module only reads
the nominal and turns B-spline data into shapes for STEP.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.bspline import evaluate_surface
from bladerecon.core.geometry.spline import BSplineSurface
from bladerecon.fc import objects as _objects
from bladerecon.fc.freecad_env import import_freecad

__all__ = ["blade_surface", "target_shape", "tip_missing_shape", "region_missing_shapes", "missing_shape",
           "RepairAnalysis", "RepairPiece", "repair_pieces", "make_repair_analysis",
           "export_target_step"]

FreeCAD, Part = import_freecad()


def blade_surface(path: str) -> tuple[BSplineSurface, float, Any]:
    """The nominal's blade surface (the B-spline face of largest extent), the sign that
    turns its normal out of the material, and the :class:`Nominal` read from ``path``."""
    from bladerecon.fc.deviation import load_nominal

    nominal = load_nominal(path)
    surface, sign = _blade_face(nominal, path)
    return surface, float(sign), nominal


def target_shape(surface: BSplineSurface) -> tuple[Any, str]:
    """A closed solid (planar caps at hub and tip) when the ends are planar, else the face;
    and which of the two ("solid" or "face")."""
    from bladerecon.fc.convert import make_face
    from bladerecon.fc.export import make_solid

    try:
        return make_solid(surface), "solid"
    except BladeReconError:
        return make_face(surface), "face"


def tip_missing_shape(target: BSplineSurface, v_cut: float, n_u: int = 600, n_v: int = 9) -> Any:
    """The material to add at the tip: the target between ``v_cut`` and its tip end,
    capped (a solid). Rebuilt by interpolating the target on a grid (the core's skinning)."""
    from bladerecon.core.surface.skinning import interpolate_grid
    from bladerecon.fc.export import make_solid

    u = np.linspace(*target.u_domain, n_u, endpoint=False)
    v = np.linspace(v_cut, target.v_domain[1], n_v)
    grid = np.stack([evaluate_surface(target, u, np.full_like(u, vv)) for vv in v])
    return make_solid(interpolate_grid(grid, "chord"))


def _bilinear_face(grid: np.ndarray) -> Any:
    """A face through the (rows, columns, 3) grid (mm): a B-spline of degree 1 x 1 whose
    poles are the grid's points (it passes through every one, flat between them)."""
    rows, cols = grid.shape[:2]
    surface = Part.BSplineSurface()
    mults = lambda n: [2] + [1] * (n - 2) + [2]          # noqa: E731  clamped, degree 1
    surface.buildFromPolesMultsKnots(
        [[FreeCAD.Vector(*map(float, p)) for p in row] for row in grid],
        mults(rows), mults(cols), [float(k) for k in range(rows)], [float(k) for k in range(cols)],
        False, False, 1, 1)
    return Part.Face(surface)


def region_missing_shapes(result) -> list:
    """The material to add in each shallow damaged region as a closed solid (mm, measured
    frame): the target over the region, the damaged floor under it
    (:func:`bladerecon.core.repair.missing.missing_region_grids`, sampled 4x finer than the
    damage cells, so the faces are flat between samples 0.1-0.3 mm apart) and four side faces
    between their boundaries. A region that runs all round the section gives no solid."""
    from bladerecon.core.repair.missing import missing_region_grids

    solids = []
    for reg in missing_region_grids(result):
        if reg.closed:
            continue
        top, floor = reg.top, reg.floor
        sides = [np.stack([top[0], floor[0]]), np.stack([top[-1], floor[-1]]),
                 np.stack([top[:, 0], floor[:, 0]]), np.stack([top[:, -1], floor[:, -1]])]
        faces = [_bilinear_face(top), _bilinear_face(floor)] + [_bilinear_face(s) for s in sides]
        shell = Part.Shell(faces)
        shell.sewShape()
        try:
            solid = Part.Solid(Part.Shell(shell.Faces) if shell.ShapeType != "Shell" else shell)
        except Part.OCCError as err:
            raise BladeReconError(f"cannot make the missing material of the {reg.kind} region a solid: "
                                  f"OpenCASCADE refused its faces ({err})") from None
        if solid.Volume < 0:
            solid.reverse()
        if not (solid.isValid() and solid.isClosed()):
            raise BladeReconError(f"the missing material of the {reg.kind} region is not a valid closed solid")
        solids.append(solid)
    return solids


def missing_shape(result) -> Any:
    """All the material to add as one compound of solids (the tip's, each shallow region's),
    or None where nothing is missing."""
    pieces = []
    if any(r["kind"] == "tip" for r in result.regions):
        g = result.depth_map
        v_cut = float(np.interp(g["cut_mm"], *g["z_to_v"]))      # the cut may lie above the rows
        pieces.append(tip_missing_shape(result.adapted, v_cut))
    pieces += region_missing_shapes(result)
    from bladerecon.fc.convert import compound       # not Part.makeCompound: it kills FreeCAD 1.0 headless

    return compound(pieces) if pieces else None


# --------------------------------------------------------------------------- document object

class RepairAnalysis(_objects._Feature):
    """Repair target of a damaged blade (issue 18), as ``python3 -m bladerecon repair``.

    Inputs: the MeasuredPoints of the damaged blade and the nominal (any object with a shape
    holding the blade's B-spline face). Results: the statistics, one JSON line per region,
    each point's missing depth (mm, for colouring the measured blade), and the shapes:
    ``TargetShape`` (the repair target, a solid when its ends are planar),
    ``MissingShape`` (the missing material, a solid per region: the tip, each shallow region)
    and ``Shape`` (all of them).
    The class path ``bladerecon.fc.repair.RepairAnalysis`` is permanent (saved files name it).
    """

    TYPE = "RepairAnalysis"
    PROPERTIES = (
        ("App::PropertyLink", "Measured", "Input", "MeasuredPoints of the damaged blade", 0),
        ("App::PropertyLink", "Nominal", "Input", "nominal blade: an object whose shape holds the blade face", 0),
        ("App::PropertyFloat", "Tolerance", "Input", "a point deeper than this under the target is damaged (mm)", 0),
        ("App::PropertyFloat", "CutHeight", "Input", "rebuild everything above this span height (mm); 0: none", 0),
        ("App::PropertyFloat", "Blend", "Input", "blend band width (mm); 0: from the damage size", 0),
        ("App::PropertyFloat", "VolumeMm3", "Repair", "missing material (mm³)", 1),
        ("App::PropertyFloat", "TwistDegAtTip", "Repair", "service twist at the tip, relative to the hub (degrees)", 1),
        ("App::PropertyFloat", "MaxBendMm", "Repair", "largest in-plane bend relative to the hub (mm)", 1),
        ("App::PropertyInteger", "RegionCount", "Repair", "damaged regions (tip included)", 1),
        ("App::PropertyFloat", "TargetMaxMm", "Repair", "target vs undamaged points: largest distance (mm)", 1),
        ("App::PropertyFloat", "NaiveMaxMm", "Repair", "naive target (nominal, best-fitted) vs target over the damage (mm)", 1),
        ("App::PropertyFloat", "CurvatureJump", "Repair", "largest curvature jump across the blend band (1/mm)", 1),
        ("App::PropertyStringList", "Regions", "Repair", "one JSON object per region (kind, area, depth, volume)", 1),
        ("App::PropertyFloatList", "PointDepth", "Data", "missing depth per measured point (mm, > 0 under the target)", 2),
        ("App::PropertyString", "Summary", "Data", "the --json summary", 2),
        ("Part::PropertyPartShape", "TargetShape", "Data", "the repair target", 2),
        ("Part::PropertyPartShape", "MissingShape", "Data", "the missing material: a solid per region", 2),
    )

    def _add_properties(self, obj: Any) -> None:
        fresh = "Tolerance" not in obj.PropertiesList
        super()._add_properties(obj)
        if fresh:
            obj.Tolerance = 0.03

    def compute(self, obj: Any) -> None:
        import json

        from bladerecon.core.repair import repair_target
        from bladerecon.fc.deviation import Nominal

        if obj.Measured is None or obj.Nominal is None:
            raise BladeReconError(f"{obj.Label}: link the measured points and the nominal first")
        ps = _objects.point_set(obj.Measured)
        shape = getattr(obj.Nominal, "Shape", None)
        if shape is None or shape.isNull():
            raise BladeReconError(f"{obj.Label}: the nominal {obj.Nominal.Label} has no shape")
        surface, sign = _blade_face(Nominal(shape, obj.Nominal.Label), obj.Nominal.Label)
        section = ps.section if ps.n_sections > 1 else None
        res = repair_target(np.asarray(ps.points, float), surface, sign, tolerance=obj.Tolerance,
                            cut_height=obj.CutHeight or None, blend=obj.Blend or None, section=section)
        target, _ = target_shape(res.target)
        pieces = [target]
        missing = missing_shape(res)
        if missing is not None:
            pieces += missing.Solids
        d = res.deformation
        obj.VolumeMm3, obj.TwistDegAtTip, obj.MaxBendMm = res.volume_mm3, d["twist_deg_at_tip"], d["max_bend_mm"]
        obj.RegionCount = len(res.regions)
        obj.TargetMaxMm = res.target_vs_measured["max"]
        obj.NaiveMaxMm = res.naive_vs_target["max"]
        obj.CurvatureJump = res.blend["max_curvature_jump"]
        obj.Regions = [json.dumps(r) for r in res.regions]
        obj.PointDepth = [float(x) for x in res.depth_map["point_depth"]]
        obj.Summary = json.dumps(res.summary())
        obj.TargetShape = target
        obj.MissingShape = missing if missing is not None else Part.Shape()
        obj.Shape = _objects.compound(pieces)
        return res.depth_map["tip"].get("warning")      # sections without a cut: an upper bound


def _blade_face(nominal, name: str) -> tuple[BSplineSurface, float]:
    if not nominal.core:
        raise BladeReconError(f"{name}: the nominal holds no untrimmed B-spline face: repair needs the "
                              "blade surface as one B-spline face (u around the section, v along the span)")

    def extent(item) -> float:
        poles = np.asarray(item[1].poles).reshape(-1, 3)
        return float(np.linalg.norm(poles.max(axis=0) - poles.min(axis=0)))

    _, surface, sign = max(nominal.core, key=extent)
    if not surface.u_periodic:
        raise BladeReconError(f"{name}: the nominal's blade face is not closed around the section "
                              "(not periodic in u): repair needs the whole blade surface in one face")
    return surface, float(sign)


class RepairPiece(_objects._Feature):
    """One shape of a RepairAnalysis as an object of its own, shown as its child in the tree:
    ``Piece`` "target" (the repair target) or "missing" (the material to add, a solid per
    region), copied from the analysis at each recompute, so each can be shown, coloured and
    exported on its own (File > Export). The class path ``bladerecon.fc.repair.RepairPiece``
    is permanent (saved files name it)."""

    TYPE = "RepairPiece"
    PROPERTIES = (
        ("App::PropertyLink", "Analysis", "Input", "the RepairAnalysis whose shape this is", 1),
        ("App::PropertyString", "Piece", "Input", "target or missing", 1),
    )

    def compute(self, obj: Any) -> None:
        analysis = obj.Analysis
        if analysis is None:
            raise BladeReconError(f"{obj.Label}: no repair analysis linked")
        shape = analysis.TargetShape if obj.Piece == "target" else analysis.MissingShape
        obj.Shape = shape.copy()


def repair_pieces(analysis: Any) -> list:
    """The RepairPiece objects of ``analysis`` (its children in the tree)."""
    return [o for o in analysis.InList
            if getattr(getattr(o, "Proxy", None), "Type", "") == "RepairPiece" and o.Analysis == analysis]


def make_repair_analysis(doc: Any, measured: Any, nominal: Any, tolerance: float = 0.03,
                         name: str = "RepairAnalysis") -> Any:
    """A RepairAnalysis of ``measured`` (MeasuredPoints) against ``nominal`` (object with a shape),
    with its target and missing material as child objects (:class:`RepairPiece`)."""
    obj = doc.addObject("Part::FeaturePython", name)
    RepairAnalysis(obj)
    obj.Label = "Repair analysis"
    obj.Measured, obj.Nominal = measured, nominal
    obj.Tolerance = float(tolerance)
    _objects._attach_view(obj, "RepairAnalysis")
    for piece, label in (("target", "Repair target"), ("missing", "Missing material")):
        child = doc.addObject("Part::FeaturePython", f"{name}_{piece}")
        RepairPiece(child)
        child.Label = label
        child.Analysis, child.Piece = obj, piece
        _objects._attach_view(child, "RepairPiece")
        if FreeCAD.GuiUp and child.ViewObject is not None:
            child.ViewObject.Visibility = False        # the analysis draws both with the points
    return obj


def export_target_step(obj: Any, path: str) -> None:
    """Write a RepairAnalysis's target to STEP (mm), atomically."""
    from bladerecon.fc.export import write_step

    shape = getattr(obj, "TargetShape", None)
    if shape is None or shape.isNull():
        raise BladeReconError(f"{getattr(obj, 'Label', obj)}: no target to export: recompute it first")
    write_step(shape, path)
