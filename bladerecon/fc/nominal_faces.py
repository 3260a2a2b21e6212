# SPDX-License-Identifier: LGPL-2.1-or-later
"""A CAD nominal's faces as core data (surface models, trimming loops, boundary edges), and the
multi-face test nominal of :mod:`bladerecon.samples.multiface` built as a FreeCAD solid.

:func:`core_faces` reads every face of a ``Part.Shape`` into what
:func:`bladerecon.core.geometry.faces.measure_faces` measures against:

* the surface as a core model (:mod:`bladerecon.core.geometry.analytic`): non-rational
  B-splines as they are; planes, cylinders, cones, spheres, tori by their frames; surfaces of
  revolution and linear extrusion by their basis curves; offset surfaces by their basis; any
  other surface through ``toBSpline()`` if that is non-rational and keeps the parameters.
  Each model is checked against OpenCASCADE on points of the face (the foot and its (u, v));
  a face that fails, or cannot be converted, is measured by OpenCASCADE per point;
* the trimming loops: every pcurve sampled to a polyline in (u, v) within ``PCURVE_TOL`` mm
  on the surface (a seam's second pcurve is its first moved by the period);
* the boundary edges (seams too: an apex may be reached by no other edge), each once for
  the faces that meet there: lines and
  circles in closed form, other curves as non-rational B-splines (converted, or the edge's
  polyline within ``PCURVE_TOL`` as a degree-1 B-spline), with the outward normals of its
  faces sampled along it.
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.analytic import (
    BSplineModel,
    ConeModel,
    CylinderModel,
    ExtrusionModel,
    OffsetModel,
    PlaneModel,
    RevolutionModel,
    SphereModel,
    TorusModel,
)
from bladerecon.core.geometry.edges import ArcEdge, SegmentEdge, SplineEdge
from bladerecon.core.geometry.faces import Edge, Face
from bladerecon.core.geometry.spline import BSplineCurve
from bladerecon.core.geometry.trimming import UVRegion

from bladerecon.fc.freecad_env import import_freecad

__all__ = ["core_faces", "surface_model", "solid_inside", "build_multiface_nominal", "write_multiface_nominal",
           "PCURVE_TOL"]

FreeCAD, Part = import_freecad()

PCURVE_TOL = 2e-7          # mm on the surface: trimming polygons and polyline edges
_EDGE_SAMPLES = 256        # normals sampled along an edge
_CHECK = 5                 # a model is checked on _CHECK x _CHECK points of its face


def _vec(p) -> np.ndarray:
    return np.array([p.x, p.y, p.z], float)


def _unit(a: np.ndarray) -> np.ndarray:
    return a / np.linalg.norm(a)


# --------------------------------------------------------------------------- surfaces
def _analytic_model(surf: Any) -> Any:
    name = type(surf).__name__
    val = lambda u, v: _vec(surf.value(u, v))  # noqa: E731
    if name == "Plane":
        o = val(0.0, 0.0)
        x, y = val(1.0, 0.0) - o, val(0.0, 1.0) - o
        return PlaneModel(o, x, y, _unit(np.cross(x, y)))
    if name == "Cylinder":
        R = float(surf.Radius)
        o = 0.5 * (val(0.0, 0.0) + val(np.pi, 0.0))
        return CylinderModel(o, (val(0.0, 0.0) - o) / R, (val(np.pi / 2, 0.0) - o) / R,
                             val(0.0, 1.0) - val(0.0, 0.0), R)
    if name == "Cone":
        R, a = float(surf.Radius), float(surf.SemiAngle)
        o = 0.5 * (val(0.0, 0.0) + val(np.pi, 0.0))
        v = 1.0 if abs(R + np.sin(a)) >= abs(R - np.sin(a)) else -1.0
        c = 0.5 * (val(0.0, v) + val(np.pi, v))
        r = R + v * np.sin(a)
        z = (c - o) / (v * np.cos(a))
        return ConeModel(o, (val(0.0, v) - c) / r, (val(np.pi / 2, v) - c) / r, z, R, a)
    if name == "Sphere":
        R = float(surf.Radius)
        o = _vec(surf.Center)
        return SphereModel(o, (val(0.0, 0.0) - o) / R, (val(np.pi / 2, 0.0) - o) / R, (val(0.0, np.pi / 2) - o) / R, R)
    if name == "Toroid":
        R, r = float(surf.MajorRadius), float(surf.MinorRadius)
        o = 0.5 * (val(0.0, 0.0) + val(np.pi, 0.0))
        x = (val(0.0, 0.0) - o) / (R + r)
        return TorusModel(o, x, (val(np.pi / 2, 0.0) - o) / (R + r), (val(0.0, np.pi / 2) - o - R * x) / r, R, r)
    return None


def _curve_poles(curve: Any, v0: float, v1: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, bool] | None:
    """(poles (n, 3), knots, mults, degree, periodic) of a basis curve with its own parameter,
    or None (rational, or another kind). A line becomes a degree-1 B-spline over [v0, v1]."""
    name = type(curve).__name__
    if name in ("Line", "LineSegment"):
        ends = np.array([_vec(curve.value(v0)), _vec(curve.value(v1))])
        return ends, np.array([v0, v1]), np.array([2, 2]), 1, False
    if name == "TrimmedCurve" and hasattr(curve, "BasisCurve"):
        return _curve_poles(curve.BasisCurve, v0, v1)
    if name == "BezierCurve":
        curve = curve.toBSpline()
        name = "BSplineCurve"
    if name == "BSplineCurve" and not curve.isRational():
        return (np.array([_vec(p) for p in curve.getPoles()]), np.array(curve.getKnots(), float),
                np.array(curve.getMultiplicities(), int), int(curve.Degree), bool(curve.isPeriodic()))
    return None


def _revolution_model(surf: Any, face: Any) -> Any:
    L, D = _vec(surf.Location), _unit(_vec(surf.Direction))
    u0, u1, v0, v1 = face.ParameterRange
    pad = max(v1 - v0, 1.0)
    got = _curve_poles(surf.BasisCurve, v0 - pad, v1 + pad)
    if got is None:
        return None
    poles, knots, mults, degree, periodic = got
    q = poles - L
    radial = q - np.outer(q @ D, D)
    e0 = radial[np.argmax(np.linalg.norm(radial, axis=1))]
    if np.linalg.norm(e0) == 0.0:
        return None
    e0 = _unit(e0)
    e1 = np.cross(D, e0)
    if np.abs(q @ e1).max() > 1e-9 * max(1.0, float(np.abs(q).max())):
        return None                         # the basis curve does not lie in a plane through the axis
    meridian = BSplineCurve(np.column_stack([q @ e0, q @ D]), knots, mults, degree, periodic)
    period = float(knots[-1] - knots[0]) if periodic else None
    return RevolutionModel(L, D, e0, meridian, period)


def _extrusion_model(surf: Any, face: Any) -> Any:
    D = _unit(_vec(surf.Direction))
    u0, u1, v0, v1 = face.ParameterRange
    pad = max(u1 - u0, 1.0)
    got = _curve_poles(surf.BasisCurve, u0 - pad, u1 + pad)
    if got is None:
        return None
    poles, knots, mults, degree, periodic = got
    e1 = _unit(np.cross(D, [1.0, 0.0, 0.0]) if abs(D[0]) < 0.9 else np.cross(D, [0.0, 1.0, 0.0]))
    e2 = np.cross(D, e1)
    origin = poles[0]
    q = poles - origin
    curve = BSplineCurve(np.column_stack([q @ e1, q @ e2, q @ D]), knots, mults, degree, periodic)
    return ExtrusionModel(origin, e1, e2, D, curve, float(knots[-1] - knots[0]) if periodic else None)


def surface_model(surf: Any, face: Any) -> tuple[Any, str]:
    """(core model or None, method name) for a face's surface."""
    from bladerecon.fc.convert import from_part_surface

    name = type(surf).__name__
    if name == "BSplineSurface":
        if surf.isURational() or surf.isVRational():
            return None, "occ (rational B-spline)"
        return BSplineModel(from_part_surface(surf)), "core-bspline"
    if name == "RectangularTrimmedSurface" and hasattr(surf, "BasisSurface"):
        return surface_model(surf.BasisSurface, face)
    model = _analytic_model(surf)
    if model is not None:
        return model, f"core-{model.kind}"
    if name == "SurfaceOfRevolution":
        model = _revolution_model(surf, face)
        if model is not None:
            return model, "core-revolution"
    elif name == "SurfaceOfExtrusion":
        model = _extrusion_model(surf, face)
        if model is not None:
            return model, "core-extrusion"
    elif name == "OffsetSurface":
        basis, method = surface_model(surf.BasisSurface, face)
        if basis is not None:
            return OffsetModel(basis, float(surf.OffsetValue)), f"core-offset({method[5:]})"
    try:                                   # anything else: its B-spline form, if exact and non-rational
        bs = surf.toBSpline()
    except Exception:                      # noqa: BLE001 - OCC refuses some surfaces
        return None, f"occ ({name})"
    if bs.isURational() or bs.isVRational():
        return None, f"occ ({name}: rational as a B-spline)"
    return BSplineModel(from_part_surface(bs)), f"core-bspline(toBSpline of {name})"


def _check_model(model: Any, face: Any, size: float) -> bool:
    """The model's feet of points on the face are those points, at their own (u, v)."""
    u0, u1, v0, v1 = face.ParameterRange
    uu, vv = np.meshgrid(np.linspace(u0, u1, _CHECK + 2)[1:-1], np.linspace(v0, v1, _CHECK + 2)[1:-1])
    uv = np.column_stack([uu.ravel(), vv.ravel()])
    pts = np.array([_vec(face.Surface.value(u, v)) for u, v in uv])
    normals = np.array([_vec(face.Surface.normal(u, v)) for u, v in uv])
    off, tol = 1e-5 * max(size, 1.0), 1e-7 * max(size, 1.0)
    # points a little off the surface along its normal must come back to the same foot
    try:
        pr = model.project(pts + off * normals)
    except Exception:                      # noqa: BLE001 - a model that cannot project is no model
        return False
    if np.abs(pr.distance - off).max() > tol or np.linalg.norm(pr.foot - pts, axis=1).max() > tol:
        return False
    for got, want, period in ((pr.u, uv[:, 0], model.u_period), (pr.v, uv[:, 1], model.v_period)):
        diff = got - want
        if period:
            diff = (diff + period / 2) % period - period / 2
        if np.abs(diff).max() > 1e-6 * max(1.0, abs(want).max()):
            return False
    return bool(np.all(np.einsum("ij,ij->i", pr.normal, normals) > 0.5))


# --------------------------------------------------------------------------- trimming loops
def _uv_scale(face: Any) -> float:
    """Largest |S_u|, |S_v| over the face (mm per parameter unit), from finite differences."""
    u0, u1, v0, v1 = face.ParameterRange
    s = face.Surface
    h_u, h_v = 1e-6 * max(u1 - u0, 1e-9), 1e-6 * max(v1 - v0, 1e-9)
    best = 1e-12
    for u in np.linspace(u0, u1, 5):
        for v in np.linspace(v0, v1, 5):
            p = _vec(s.value(u, v))
            best = max(best, np.linalg.norm(_vec(s.value(u + h_u, v)) - p) / h_u,
                       np.linalg.norm(_vec(s.value(u, v + h_v)) - p) / h_v)
    return best


def _pcurve_polyline(face: Any, edge: Any, deflection: float) -> np.ndarray | None:
    got = face.curveOnSurface(edge)
    if not got:
        return None
    c2, first, last = got
    try:
        pts = c2.discretize(Deflection=deflection, First=first, Last=last)
    except Exception:                      # noqa: BLE001 - fall back to a fixed count
        pts = c2.discretize(Number=2000, First=first, Last=last)
    if len(pts) < 2:
        pts = [c2.value(first), c2.value(last)]
    return np.array([(p.x, p.y) for p in pts], float)


def _region(face: Any, model: Any) -> UVRegion | None:
    """The face's trimming loops as a :class:`UVRegion`, or None for the whole surface."""
    if _whole_surface(face):
        return None
    deflection = PCURVE_TOL / _uv_scale(face)
    loops = []
    u0, u1, v0, v1 = face.ParameterRange
    for wire in face.Wires:
        for edge in wire.Edges:
            line = _pcurve_polyline(face, edge, deflection)
            if line is None:
                raise BladeReconError("a face edge has no pcurve")
            loops.append(line)
            if edge.isSeam(face):           # its other pcurve: one period across
                for k, (period, lo, hi) in enumerate(((model.u_period, u0, u1), (model.v_period, v0, v1))):
                    if period and np.ptp(line[:, k]) < 1e-9 * period:
                        other = line.copy()
                        other[:, k] += -period if line[:, k].mean() > 0.5 * (lo + hi) else period
                        loops.append(other)
                        break
    return UVRegion.from_loops(loops, model.u_period, model.v_period)


def _whole_surface(face: Any) -> bool:
    """True for a face on the whole of a bounded surface (a B-spline with nothing cut away)."""
    surface = face.Surface
    if type(surface).__name__ != "BSplineSurface" or len(face.Wires) != 1:
        return False
    if not np.allclose(face.ParameterRange, surface.bounds(), rtol=0, atol=1e-9):
        return False
    whole = Part.Face(surface).Area
    return abs(face.Area - whole) <= 1e-9 * whole


# --------------------------------------------------------------------------- edges
def _edge_model(edge: Any) -> Any:
    from bladerecon.fc.convert import from_part_curve

    c, t0, t1 = edge.Curve, float(edge.FirstParameter), float(edge.LastParameter)
    name = type(c).__name__
    if name in ("Line", "LineSegment"):
        return SegmentEdge(_vec(edge.valueAt(t0)), _vec(edge.valueAt(t1)), t0, t1)
    if name == "Circle":
        centre, R = _vec(c.Center), float(c.Radius)
        x = (_vec(c.value(0.0)) - centre) / R
        y = (_vec(c.value(np.pi / 2)) - centre) / R
        return ArcEdge(centre, x, y, R, t0, t1)
    if name in ("BSplineCurve", "BezierCurve"):
        b = c.toBSpline() if name == "BezierCurve" else c.copy()
        if not b.isRational():
            if b.isPeriodic() and (t1 - t0) < b.LastParameter - b.FirstParameter - 1e-12:
                b.segment(t0, t1)
            elif not b.isPeriodic() and (t0 > b.FirstParameter + 1e-12 or t1 < b.LastParameter - 1e-12):
                b.segment(t0, t1)
            return SplineEdge(from_part_curve(b))
    # anything else: the edge's polyline within PCURVE_TOL, a degree-1 B-spline in its own parameter
    pts = edge.discretize(Deflection=PCURVE_TOL)
    params = np.array([edge.Curve.parameter(p) for p in pts], float)
    params = np.maximum.accumulate(np.clip(params, t0, t1))
    keep = np.concatenate([[True], np.diff(params) > 1e-15])
    poles = np.array([_vec(p) for p in pts])[keep]
    knots = params[keep]
    if len(knots) < 2:
        return SegmentEdge(_vec(edge.valueAt(t0)), _vec(edge.valueAt(t1)), t0, t1)
    mults = np.ones(len(knots), int)
    mults[[0, -1]] = 2
    return SplineEdge(BSplineCurve(poles, knots, mults, 1, False))


def _edge_normals(model: Any, faces: list[Any], cores: list[Face], signs: list[float]) -> tuple[np.ndarray, np.ndarray]:
    """t samples along the edge and the outward unit normals of its faces there: from the
    face's core model where it has one (the samples projected onto it), else from OCC."""
    t, pts = model.sample(_EDGE_SAMPLES)
    normals = np.zeros((len(faces), len(t), 3))
    for k, (face, core, sign) in enumerate(zip(faces, cores, signs)):
        if core.model is not None:
            normals[k] = core.sign * core.model.project(pts).normal
            continue
        few = np.unique(np.linspace(0, len(t) - 1, 33).round().astype(int))   # OCC: ~3 ms a point
        got = np.zeros((few.size, 3))
        for i, p in enumerate(pts[few]):
            try:
                u, w = face.Surface.parameter(FreeCAD.Vector(*p))
                n = _vec(face.normalAt(u, w))
            except Exception:                  # noqa: BLE001 - a singular point: no normal
                n = np.zeros(3)
            got[i] = sign * n / max(np.linalg.norm(n), 1e-300)
        normals[k] = np.stack([np.interp(t, t[few], got[:, c]) for c in range(3)], axis=1)
    return t, normals


def _box(shape: Any, pad: float) -> np.ndarray:
    b = shape.BoundBox
    return np.array([[b.XMin - pad, b.YMin - pad, b.ZMin - pad], [b.XMax + pad, b.YMax + pad, b.ZMax + pad]])


def core_faces(shape: Any, outward: np.ndarray, size: float) -> tuple[list[Face], list[Edge]]:
    """Every face of ``shape`` as a :class:`Face` (``outward``: +1/-1 per face, the side of
    the face's own normal that is outside) and the boundary edges as :class:`Edge`."""
    faces_occ = list(shape.Faces)
    faces: list[Face] = []
    edge_index: dict[int, int] = {}
    edge_shapes: list[Any] = []
    edge_faces: list[list[int]] = []
    models: dict[Any, Any] = {}            # one model per distinct surface: projected once
    for k, (face, osign) in enumerate(zip(faces_occ, outward)):
        face_sign = -1.0 if face.Orientation == "Reversed" else 1.0
        pad = max(float(face.Tolerance), 1e-7) + 1e-9 * size
        model, method = surface_model(face.Surface, face)
        region = None
        if model is not None:
            model = models.setdefault(model.key, model)
        if model is not None and not _check_model(model, face, size):
            model, method = None, f"occ ({method}: failed the check)"
        if model is not None:
            try:
                region = _region(face, model)
            except (BladeReconError, ValueError):
                model, method = None, "occ (trimming loops unreadable)"
        ids = []
        if model is not None:
            for edge in face.Edges:
                if edge.Degenerated:             # no curve; a seam stays: its ends may be vertices
                    continue                     # (a cone's apex) that no other edge reaches
                key = edge.hashCode()
                if key not in edge_index:
                    edge_index[key] = len(edge_shapes)
                    edge_shapes.append(edge)
                    edge_faces.append([])
                if k not in edge_faces[edge_index[key]]:
                    edge_faces[edge_index[key]].append(k)
                ids.append(edge_index[key])
        faces.append(Face(model, region, face_sign * float(osign), tuple(dict.fromkeys(ids)), _box(face, pad), method))
    # every edge: its model, and the normals of all its faces (the faces measured by OCC too)
    all_faces_of = {}
    for k, face in enumerate(faces_occ):
        for edge in face.Edges:
            all_faces_of.setdefault(edge.hashCode(), []).append(k)
    edges: list[Edge] = []
    for e, edge in enumerate(edge_shapes):
        model = _edge_model(edge)
        adj = list(dict.fromkeys(all_faces_of.get(edge.hashCode(), edge_faces[e])))
        t, normals = _edge_normals(model, [faces_occ[k] for k in adj], [faces[k] for k in adj],
                                   [float(outward[k]) for k in adj])
        pad = max(float(edge.Tolerance), 1e-7) + 1e-9 * size
        edges.append(Edge(model, _box(edge, pad), t, normals, tuple(adj)))
    return faces, edges


# --------------------------------------------------------------------------- the multi-face test nominal
def build_multiface_nominal(spec: Any) -> Any:
    """The multi-face nominal ``spec`` (a :class:`bladerecon.samples.multiface.MultifaceSpec`,
    plain arrays) as a ``Part.Solid``: four airfoil faces (restrictions of one B-spline
    surface) trimmed by the hub (a surface of revolution of a B-spline meridian) and the
    casing (a cone), and the two caps on those surfaces trimmed by the blade's outline."""
    from bladerecon.fc.convert import to_part_surface

    V = FreeCAD.Vector
    surf = to_part_surface(spec.airfoil)
    us = [spec.airfoil.u_domain[0], *spec.splits, spec.airfoil.u_domain[1]]
    v0, v1 = spec.airfoil.v_domain
    strips = [surf.toShape(us[i], us[i + 1], v0, v1) for i in range(4)]
    ends = []
    for v in (v0, v1):
        iso = []
        for f in strips:
            for e in f.Edges:
                a, b = f.Surface.parameter(e.valueAt(e.FirstParameter)), f.Surface.parameter(e.valueAt(e.LastParameter))
                if abs(a[1] - v) < 1e-9 and abs(b[1] - v) < 1e-9:
                    iso.append(e)
        ends.append(Part.Face(Part.Wire(Part.__sortEdges__(iso))))
    shell = Part.Shell(strips + ends)
    shell.sewShape()
    airfoil = Part.Solid(Part.Shell(shell.Faces))
    airfoil.fix(1e-7, 1e-7, 1e-7)
    if airfoil.Volume < 0:
        airfoil.reverse()
    # the annulus: the meridian region between hub and casing revolved about the axis; the
    # profile lies in the half-plane opposite the blade, so the surfaces' seams are far from it
    A, D = spec.axis_point, spec.axis_dir
    towards = spec.airfoil.poles.reshape(-1, 3).mean(axis=0) - A
    away = -_unit(towards - (towards @ D) * D)
    to3 = lambda x, r: V(*(A + x * D + r * away))  # noqa: E731
    c = spec.hub_meridian
    hub = Part.BSplineCurve()
    hub.buildFromPolesMultsKnots([to3(x, r) for x, r in c.poles], [int(m) for m in c.mults],
                                 [float(k) for k in c.knots], False, int(c.degree))
    hub_edge = hub.toShape()
    (xa, ra), (xb, rb) = spec.tip_line
    h0, h1 = hub_edge.valueAt(hub_edge.FirstParameter), hub_edge.valueAt(hub_edge.LastParameter)
    profile = Part.Face(Part.Wire([hub_edge, Part.LineSegment(h1, to3(xb, rb)).toShape(),
                                   Part.LineSegment(to3(xb, rb), to3(xa, ra)).toShape(),
                                   Part.LineSegment(to3(xa, ra), h0).toShape()]))
    annulus = profile.revolve(V(*A), V(*D), 360)
    common = airfoil.common(annulus)
    if len(common.Solids) != 1:
        raise BladeReconError(f"the multi-face nominal: the boolean gave {len(common.Solids)} solids, not 1")
    solid = common.Solids[0]
    if solid.Volume < 0:
        solid.reverse()
    if not (solid.isValid() and solid.isClosed() and len(solid.Faces) == 6):
        raise BladeReconError("the multi-face nominal is not a valid closed solid of 6 faces")
    return solid


def write_multiface_nominal(folder: str | os.PathLike, spec: Any) -> dict[str, str]:
    """Write the multi-face nominal as STEP, IGES and BREP into ``folder``: {kind: path}."""
    from bladerecon.fc.export import write_step

    solid = build_multiface_nominal(spec)
    folder = os.fspath(folder)
    out = {"step": os.path.join(folder, "multiface.step"), "iges": os.path.join(folder, "multiface.igs"),
           "brep": os.path.join(folder, "multiface.brep")}
    write_step(solid, out["step"])
    solid.exportIges(out["iges"])
    solid.exportBrep(out["brep"])
    return out


# --------------------------------------------------------------------------- inside the solid
def solid_inside(shape: Any, deflection: float):
    """``inside(points) -> bool`` against ``shape`` (a solid or closed shell): ray parity
    (:class:`~bladerecon.core.geometry.inside.MeshInside`) on one tessellation of linear
    deflection ``deflection`` mm (MeshPart's, else OCC's own), or None without a shape."""
    from bladerecon.core.geometry.inside import MeshInside

    if shape is None:
        return None
    try:
        import MeshPart

        mesh = MeshPart.meshFromShape(Shape=shape, LinearDeflection=deflection, AngularDeflection=0.5,
                                      Relative=False)
        points, facets = mesh.Topology
    except Exception:                      # noqa: BLE001 - no MeshPart: OCC's own tessellation
        points, facets = shape.tessellate(deflection)
    V = np.array([(p.x, p.y, p.z) for p in points], float)
    T = np.array(facets, dtype=np.int64).reshape(-1, 3)
    if len(T) == 0:
        return None
    return MeshInside(V, T).contains
