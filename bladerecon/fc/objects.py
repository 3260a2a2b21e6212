# SPDX-License-Identifier: LGPL-2.1-or-later
"""Parametric document objects of the workbench: proxies and ``make_*`` factories (mm, degrees).

MeasuredPoints -> BladeSections (LE/TE marked) and BladeSurface (native B-spline face) ->
DeviationAnalysis (against a nominal shape). Each proxy only adapts: the work is done by
``bladerecon.core`` (sections, reconstruction) and ``bladerecon.fc.deviation``.

Rules kept here (they make saved files survive):

* every result lives in document properties (``PropertyVectorList``, ``PropertyFloatList``,
  ``Shape``), never in pickled proxy state: the proxy's state is only ``{"Type", "Version"}``
  (``dumps``/``loads`` and the older ``__getstate__``/``__setstate__``);
* the module path ``bladerecon.fc.objects`` and the class names are permanent: FCStd files
  name them;
* a file opened without the workbench still shows the Part shapes and keeps every property;
* a failed recompute leaves the previous result in place, writes the one-line reason to
  ``Status`` and the report view, and raises so FreeCAD marks the object as failed.

View providers are attached only when ``FreeCAD.GuiUp`` (``bladerecon.gui.view_providers``).
"""
from __future__ import annotations

import os
import traceback
from dataclasses import dataclass
from typing import Any

import numpy as np

from bladerecon.core.errors import BladeReconError

from bladerecon.fc.convert import compound
from bladerecon.fc.freecad_env import import_freecad

__all__ = ["MeasuredPoints", "BladeSections", "BladeSurface", "DeviationAnalysis",
           "make_measured_points", "make_blade_sections", "make_blade_surface", "make_deviation_analysis",
           "point_set", "core_surface", "surface_grid", "section_parameters", "SectionParameters",
           "export_step", "register_view_provider", "VIEW_PROVIDERS", "register_failure_hook", "FAILURE_HOOKS",
           "is_type", "ALIGN_MODES", "METHODS", "DeviationJob", "DeviationMeasurement", "deviation_job",
           "measure_job", "store_measurement"]

FreeCAD, Part = import_freecad()

ALIGN_MODES = ["none", "rigid", "translate", "rotate-z"]
METHODS = ["auto", "interpolate", "approximate"]
#: deviation colour map on the surface: samples per knot span around, and along the span
MAP_SAMPLES_PER_SPAN = 1
MAP_SAMPLES_SPAN = 21
_VERSION = 1


def _vectors(points: np.ndarray) -> list:
    return [FreeCAD.Vector(*p) for p in np.asarray(points, float).reshape(-1, 3).tolist()]


def _array(vectors) -> np.ndarray:
    return np.array([(v.x, v.y, v.z) for v in vectors], dtype=float).reshape(-1, 3)


def is_type(obj: Any, type_name: str) -> bool:
    """True if ``obj`` is a BladeRecon object of ``type_name`` (e.g. ``"BladeSurface"``)."""
    proxy = getattr(obj, "Proxy", None)
    return getattr(proxy, "Type", None) == type_name


class _Feature:
    """Proxy base: properties declared once in ``PROPERTIES``, state-free pickling, failure marking.

    ``PROPERTIES``: (type, name, group, tooltip, editor mode) with editor mode 0 editable,
    1 read-only (a result), 2 hidden (bulk data).
    """

    TYPE = ""
    PROPERTIES: tuple = ()

    def __init__(self, obj: Any) -> None:
        self.Type = self.TYPE
        obj.Proxy = self
        self._add_properties(obj)

    def _add_properties(self, obj: Any) -> None:
        for kind, name, group, tip, mode in self.PROPERTIES + (
                ("App::PropertyString", "Status", "Base", "ok, or why the last recompute failed", 1),):
            if name not in obj.PropertiesList:
                obj.addProperty(kind, name, group, tip)
            obj.setEditorMode(name, mode)

    def onDocumentRestored(self, obj: Any) -> None:  # noqa: N802
        self._add_properties(obj)   # properties added in later versions appear in old files

    def dumps(self) -> dict:
        return {"Type": self.TYPE, "Version": _VERSION}

    def loads(self, state: Any) -> None:
        self.Type = state.get("Type", self.TYPE) if isinstance(state, dict) else self.TYPE

    __getstate__ = dumps       # FreeCAD 0.20 pickles through these
    __setstate__ = loads

    def execute(self, obj: Any) -> None:
        try:
            warning = self.compute(obj)
        except BladeReconError as err:
            message = str(err)
        except Exception as err:
            if "abort" in f"{type(err).__name__} {err}".lower():     # Esc on FreeCAD's progress bar
                message = "cancelled; the previous result is kept: recompute to run it again"
            else:  # a bug: one line for the user, the traceback in the log only
                FreeCAD.Console.PrintLog(traceback.format_exc())
                message = f"internal error: {type(err).__name__}: {err}"
        else:
            # a result that does not do what was asked (a tolerance not met) is said, never "ok"
            obj.Status = warning or "ok"
            if warning:
                FreeCAD.Console.PrintWarning(f"BladeRecon: {_prefixed(obj, warning)}\n")
            return
        # Keep the previous result, say why in one line, and raise: raising is the only way a
        # Python feature gets marked as failed. FreeCAD then reports the exception again (with
        # a traceback, and "Recompute failed!"): the hooks the GUI registers keep those out of
        # the report view and status bar, so the user reads this one line.
        obj.Status = f"failed: {message}"
        FreeCAD.Console.PrintError(f"BladeRecon: {_prefixed(obj, message)}\n")
        for hook in FAILURE_HOOKS:
            hook(obj, message)
        raise BladeReconError(message) from None

    def compute(self, obj: Any) -> str | None:
        """Recompute ``obj``; return None, or a one-line warning that becomes its ``Status``."""
        raise NotImplementedError


def _prefixed(obj: Any, message: str) -> str:
    return message if message.startswith(obj.Label) else f"{obj.Label}: {message}"


#: Called as ``hook(obj, message)`` when a recompute fails, just before the exception that marks
#: ``obj`` as failed is raised. The GUI registers one (:mod:`bladerecon.gui.view_providers`) that
#: keeps FreeCAD's own report of that exception (a traceback) out of the report view: this
#: module never imports the GUI.
FAILURE_HOOKS: list = []


def register_failure_hook(hook: Any) -> None:
    if hook not in FAILURE_HOOKS:
        FAILURE_HOOKS.append(hook)


class _Progress:
    """FreeCAD's progress bar (status bar in the GUI; Esc cancels between steps), or nothing."""

    def __init__(self, text: str, steps: int) -> None:
        self.bar = None
        maker = getattr(FreeCAD.Base, "ProgressIndicator", None)
        if maker is not None and FreeCAD.GuiUp:
            self.bar = maker()
            self.bar.start(text, steps)

    def step(self) -> None:
        if self.bar is not None:
            self.bar.next(True)     # True: the user may abort here (raises FreeCAD's abort)

    def __enter__(self) -> "_Progress":
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.bar is not None:
            self.bar.stop()


# --------------------------------------------------------------------------- measured points
class MeasuredPoints(_Feature):
    """Measured blade points (mm) with their section labels; the shape is one vertex per point."""

    TYPE = "MeasuredPoints"
    PROPERTIES = (
        ("App::PropertyVectorList", "Points", "Points", "measured points (mm), file order", 2),
        ("App::PropertyIntegerList", "SectionIndex", "Points", "0-based section of each point", 2),
        ("App::PropertyIntegerList", "LineNumbers", "Points", "1-based file line of each point", 2),
        ("App::PropertyStringList", "SectionNames", "Points", "section names, hub to tip as in the file", 1),
        ("App::PropertyString", "SourceFile", "Points", "file the points were read from", 1),
        ("App::PropertyString", "Format", "Points", "csv, xyz-blocks or section-table", 1),
        ("App::PropertyString", "Units", "Points", "length unit of the points", 1),
        ("App::PropertyInteger", "PointCount", "Points", "number of points", 1),
        ("App::PropertyInteger", "SectionCount", "Points", "number of sections", 1),
        ("App::PropertyFloat", "ProbeRadius", "Compensation",
         "touch-probe ball radius (mm): the points are ball centres; each is moved this far toward the material, "
         "along its section curve's normal (0: none)", 0),
        ("App::PropertyFloat", "Coating", "Compensation",
         "coating thickness (mm) over the part: each point is moved this far toward the material (0: none)", 0),
    )

    def compute(self, obj: Any) -> None:
        n = len(obj.Points)
        if len(obj.SectionIndex) != n:
            raise BladeReconError(f"{obj.Label}: {n} points but {len(obj.SectionIndex)} section labels: "
                                  "import the file again")
        obj.PointCount, obj.SectionCount = n, len(obj.SectionNames)
        # the shape shows the points every later step uses: compensated when asked
        pts = point_set(obj).points if n and _offset(obj) else obj.Points
        obj.Shape = compound([Part.Vertex(*map(float, v)) for v in pts]) if n else Part.Shape()


def _offset(obj: Any) -> tuple[float, float]:
    """(probe radius, coating) of a MeasuredPoints in mm, or () when neither is set."""
    r, t = float(getattr(obj, "ProbeRadius", 0.0) or 0.0), float(getattr(obj, "Coating", 0.0) or 0.0)
    return (r, t) if r or t else ()


def make_measured_points(doc: Any, path: str, name: str = "MeasuredPoints") -> Any:
    """Read ``path`` (any format of :func:`bladerecon.core.io.readers.read_points`) into a MeasuredPoints.

    Raises :class:`BladeReconError` for a bad file before anything is added to ``doc``.
    """
    from bladerecon.core.io.readers import read_points

    ps = read_points(path)
    obj = doc.addObject("Part::FeaturePython", name)
    MeasuredPoints(obj)
    obj.Label = f"Measured points ({os.path.basename(path)})"
    obj.Points = _vectors(ps.points)
    obj.SectionIndex = [int(i) for i in ps.section]
    obj.LineNumbers = [int(i) for i in ps.line]
    obj.SectionNames = [str(s) for s in ps.section_names]
    obj.SourceFile = os.path.abspath(path)
    obj.Format = ps.format
    obj.Units = "mm"
    _attach_view(obj, "MeasuredPoints")
    return obj


def point_set(obj: Any):
    """The :class:`~bladerecon.core.io.readers.PointSet` held by a MeasuredPoints object."""
    from bladerecon.core.io.readers import PointSet

    if not is_type(obj, "MeasuredPoints"):
        raise BladeReconError(f"{getattr(obj, 'Label', obj)} is not a MeasuredPoints object: select imported points")
    n = len(obj.Points)
    lines = np.array(obj.LineNumbers, dtype=int) if len(obj.LineNumbers) == n else np.arange(1, n + 1)
    ps = PointSet(points=_array(obj.Points), section=np.array(obj.SectionIndex, dtype=int), line=lines,
                  section_names=tuple(obj.SectionNames), source=obj.SourceFile or obj.Label,
                  format=obj.Format or "csv")
    offset = _offset(obj)
    if not offset:
        return ps
    # ProbeRadius / Coating: every point moved toward the material along its section curve's normal
    from bladerecon.core.surface.compensation import compensate_points

    return PointSet(points=compensate_points(ps, *offset), section=ps.section, line=ps.line, section_names=ps.section_names,
                    source=ps.source, format=ps.format)


def _linked_points(obj: Any, link: str = "Points"):
    target = getattr(obj, link)
    if target is None:
        raise BladeReconError(f"{obj.Label}: no measured points linked: set its '{link}' property")
    return point_set(target)


# --------------------------------------------------------------------------- sections
@dataclass(frozen=True)
class SectionParameters:
    """Per-section results shown by BladeSections (mm, degrees): curves, LE/TE, and the
    parameters of :mod:`bladerecon.core.sections.parameters` (issue 3). NaN where a value
    could not be measured (an edge with too few points for a radius: see ``warnings``)."""

    names: tuple[str, ...]
    curves: tuple               # core BSplineCurve per section
    leading_edge: np.ndarray    # (k, 3)
    trailing_edge: np.ndarray   # (k, 3)
    chord: np.ndarray           # (k,) |TE - LE|
    reordered: np.ndarray       # (k,) bool: points re-ordered along the profile
    span_axis: np.ndarray
    stagger_deg: np.ndarray
    max_thickness: np.ndarray
    max_thickness_pos: np.ndarray   # mm from the LE along the chord
    le_radius: np.ndarray
    te_radius: np.ndarray
    inlet_angle_deg: np.ndarray
    outlet_angle_deg: np.ndarray
    warnings: tuple[str, ...]
    le_rule: str = "first_point"    # how the LE was chosen (core.sections.parameters.LE_RULES)
    le_shape: tuple[str, ...] = ()  # per section: circle, ellipse a × b, flat width, irregular (edge_shape_text)
    te_shape: tuple[str, ...] = ()


def edge_shape_text(fit: dict | None) -> str:
    """An edge's shape in words with its figures (mm, degrees): what LEShape/TEShape list."""
    if not fit:
        return "not measured"
    kind = fit.get("shape", "circle")
    if kind == "ellipse":
        e = fit["ellipse"]
        return f"ellipse {e['a_mm']:.4f} × {e['b_mm']:.4f} mm (tip radius {e['tip_radius_mm']:.4f} mm)"
    if kind == "flat":
        f = fit["flat"]
        width = "width unknown" if f["width_mm"] is None else f"{f['width_mm']:.4f} mm wide"
        return f"flat {width}, normal {f['normal_to_chord_deg']:.2f}° from the chord"
    return kind


def flow_of(obj: Any) -> np.ndarray | None:
    """The object's ``FlowDirection`` as a unit vector, or None when it is (0,0,0) (not known)."""
    v = np.array(tuple(getattr(obj, "FlowDirection", (0.0, 0.0, 0.0))), float)
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-12 else None


def section_parameters(section_set, flow: np.ndarray | None = None) -> SectionParameters:
    """Section curves, LE/TE and parameters of every section of a
    :class:`~bladerecon.core.sections.ordering.SectionSet`.

    Curves are fitted as :func:`bladerecon.core.reconstruct.reconstruct` does (interpolating
    or smoothing, chosen from spacing against noise); segmentation and parameters by
    :func:`bladerecon.core.sections.parameters.segment_sections` / ``measure_section`` (LE/TE
    from the curvature peaks, the LE chained from the first section's measured start). An
    edge too sparse for a radius gives NaN and a warning, not a failure. ``flow`` (the
    direction the fluid travels): every LE is its section's upstream end; without it the LE
    is guessed by one rule for the whole blade, and the guess is among the warnings.
    """
    from bladerecon.core.reconstruct import _fit_sections
    from bladerecon.core.surface.section_curves import choose_method
    from bladerecon.core.sections.parameters import measure_section, segment_blade

    pts = [s.points for s in section_set.sections]
    curves = _fit_sections(pts, choose_method(pts), None)
    blade = segment_blade(pts, section_set.span_axis, not section_set.sections[0].reordered, flow=flow,
                          canonical=True)
    measured = [measure_section(seg, strict_radius=False) for seg in blade.sections]

    def column(name: str) -> np.ndarray:
        return np.array([np.nan if getattr(m, name) is None else float(getattr(m, name)) for m in measured])

    return SectionParameters(
        tuple(s.name for s in section_set.sections), tuple(sc.curve for sc in curves),
        np.array([m.le for m in measured]), np.array([m.te for m in measured]), column("chord"),
        np.array([s.reordered for s in section_set.sections]), section_set.span_axis,
        column("stagger_deg"), column("max_thickness"), column("max_thickness_pos"), column("le_radius"),
        column("te_radius"), column("inlet_angle_deg"), column("outlet_angle_deg"),
        ((blade.warning,) if blade.warning else ())
        + tuple(f"{s.name}: {w}" for s, m in zip(section_set.sections, measured) for w in m.warnings),
        blade.le_rule, tuple(edge_shape_text(m.le_fit) for m in measured),
        tuple(edge_shape_text(m.te_fit) for m in measured))


class BladeSections(_Feature):
    """Ordered closed sections of the linked points, LE/TE marked; shape: curves + edge vertices."""

    TYPE = "BladeSections"
    PROPERTIES = (
        ("App::PropertyLink", "Points", "Input", "MeasuredPoints to segment", 0),
        ("App::PropertyVector", "FlowDirection", "Input",
         "direction the fluid travels: each LE is its section's upstream end; (0,0,0): not known, the LE is guessed", 0),
        ("App::PropertyString", "LERule", "Sections",
         "how the LE was chosen: flow (FlowDirection), first_point or blunter_edge (guesses)", 1),
        ("App::PropertyStringList", "SectionNames", "Sections", "names, hub to tip", 1),
        ("App::PropertyVectorList", "LeadingEdges", "Sections", "LE point of each section (mm)", 1),
        ("App::PropertyVectorList", "TrailingEdges", "Sections", "TE point of each section (mm)", 1),
        ("App::PropertyFloatList", "ChordLengths", "Sections", "|TE - LE| per section (mm)", 1),
        ("App::PropertyIntegerList", "Reordered", "Sections", "1 where the points were re-ordered along the profile", 1),
        ("App::PropertyVector", "SpanAxis", "Sections", "unit span direction, first section to last", 1),
        ("App::PropertyFloatList", "StaggerDeg", "Parameters", "angle of LE->TE from +x in the section plane (deg)", 1),
        ("App::PropertyFloatList", "MaxThickness", "Parameters", "largest inscribed-circle diameter (mm)", 1),
        ("App::PropertyFloatList", "MaxThicknessPos", "Parameters", "its position from the LE along the chord (mm)", 1),
        ("App::PropertyFloatList", "LERadius", "Parameters", "circle fit to the LE region (mm; nan: too few points)", 1),
        ("App::PropertyFloatList", "TERadius", "Parameters", "circle fit to the TE region (mm; nan: too few points)", 1),
        ("App::PropertyFloatList", "InletAngle", "Parameters", "camber-line angle at the LE (deg)", 1),
        ("App::PropertyFloatList", "OutletAngle", "Parameters", "camber-line angle at the TE (deg)", 1),
        ("App::PropertyStringList", "LEShape", "Parameters",
         "LE shape per section: circle, ellipse (semi-axes), flat (width, direction) or irregular", 1),
        ("App::PropertyStringList", "TEShape", "Parameters",
         "TE shape per section: circle, ellipse (semi-axes), flat (width, direction) or irregular", 1),
        ("App::PropertyStringList", "Warnings", "Parameters", "values that could not be measured, and why", 1),
    )

    def compute(self, obj: Any) -> None:
        from bladerecon.core.sections.ordering import build_sections

        from bladerecon.fc.convert import to_part_curve

        params = section_parameters(build_sections(_linked_points(obj)), flow_of(obj))
        edges = [Part.Edge(to_part_curve(c)) for c in params.curves]
        marks = [Part.Vertex(FreeCAD.Vector(*p)) for p in np.vstack([params.leading_edge, params.trailing_edge])]
        obj.Shape = compound(edges + marks)
        obj.SectionNames = list(params.names)
        obj.LeadingEdges = _vectors(params.leading_edge)
        obj.TrailingEdges = _vectors(params.trailing_edge)
        obj.ChordLengths = [float(c) for c in params.chord]
        obj.Reordered = [int(r) for r in params.reordered]
        obj.SpanAxis = FreeCAD.Vector(*params.span_axis)
        for prop, values in (("StaggerDeg", params.stagger_deg), ("MaxThickness", params.max_thickness),
                             ("MaxThicknessPos", params.max_thickness_pos), ("LERadius", params.le_radius),
                             ("TERadius", params.te_radius), ("InletAngle", params.inlet_angle_deg),
                             ("OutletAngle", params.outlet_angle_deg)):
            setattr(obj, prop, [float(v) for v in values])
        obj.Warnings = list(params.warnings)
        obj.LERule = params.le_rule
        obj.LEShape, obj.TEShape = list(params.le_shape), list(params.te_shape)


def make_blade_sections(doc: Any, points_obj: Any, name: str = "BladeSections") -> Any:
    obj = doc.addObject("Part::FeaturePython", name)
    BladeSections(obj)
    obj.Label = "Blade sections"
    obj.Points = points_obj
    _attach_view(obj, "BladeSections")
    return obj


# --------------------------------------------------------------------------- surface
class BladeSurface(_Feature):
    """One periodic x clamped cubic B-spline face through the linked points (core.reconstruct)."""

    TYPE = "BladeSurface"
    PROPERTIES = (
        ("App::PropertyLink", "Points", "Input", "MeasuredPoints to reconstruct", 0),
        ("App::PropertyVector", "FlowDirection", "Input",
         "direction the fluid travels: the surface's seam starts at the upstream edge; (0,0,0): not known", 0),
        ("App::PropertyEnumeration", "Method", "Reconstruction",
         "auto: interpolate or smooth, chosen from point spacing against noise", 0),
        ("App::PropertyFloat", "Tolerance", "Reconstruction",
         "with Method approximate: largest distance of a measured point (mm); 0 = from the noise", 0),
        ("App::PropertyString", "MethodUsed", "Result", "method the reconstruction used", 1),
        ("App::PropertyString", "MethodReason", "Result", "why that method", 1),
        ("App::PropertyInteger", "UPoles", "Result", "poles around the section", 1),
        ("App::PropertyInteger", "VPoles", "Result", "poles along the span", 1),
        ("App::PropertyInteger", "UDegree", "Result", "degree around", 1),
        ("App::PropertyInteger", "VDegree", "Result", "degree along the span", 1),
        ("App::PropertyFloat", "NoiseEstimate", "Result", "estimated measurement noise (mm)", 1),
        ("App::PropertyFloat", "RefitError", "Result", "compatible curves vs section curves, max (mm)", 1),
        ("App::PropertyFloat", "FitMax", "Result", "largest distance measured point - surface (mm)", 1),
        ("App::PropertyFloat", "FitRms", "Result", "RMS distance measured point - surface (mm)", 1),
    )

    def _add_properties(self, obj: Any) -> None:
        fresh = "Method" not in obj.PropertiesList
        super()._add_properties(obj)
        if fresh:
            obj.Method = METHODS
            obj.Method = "auto"

    def compute(self, obj: Any) -> str | None:
        from bladerecon.core.geometry.projection import project_points_to_surface
        from bladerecon.core.reconstruct import reconstruct, start_upstream
        from bladerecon.core.sections.ordering import build_sections

        from bladerecon.fc.convert import make_face

        if obj.Tolerance < 0:
            raise BladeReconError(f"{obj.Label}: Tolerance {obj.Tolerance} mm: give 0 (automatic) or a positive distance")
        tolerance = obj.Tolerance if obj.Method == "approximate" and obj.Tolerance > 0 else None
        with _Progress(f"{obj.Label}: reconstructing", 3) as progress:
            sections = build_sections(_linked_points(obj))
            pts = [s.points for s in sections.sections]
            measured_start = not sections.sections[0].reordered
            flow = flow_of(obj)
            if flow is not None:
                pts, measured_start = start_upstream(pts, flow), True
            progress.step()
            rec = reconstruct(pts, sections.span_axis, method=obj.Method, tolerance=tolerance,
                              first_point_is_measured=measured_start)
            progress.step()
            proj = project_points_to_surface(rec.surface, np.concatenate(pts), rec.point_u, rec.point_v)
            progress.step()
        obj.Shape = make_face(rec.surface)
        s = rec.surface
        obj.MethodUsed, obj.MethodReason = rec.choice.method, rec.choice.reason
        obj.UPoles, obj.VPoles = int(s.shape[0]), int(s.shape[1])
        obj.UDegree, obj.VDegree = int(s.u_degree), int(s.v_degree)
        obj.NoiseEstimate, obj.RefitError = float(rec.choice.noise_mm), float(rec.refit_error)
        obj.FitMax = float(proj.distance.max())
        obj.FitRms = float(np.sqrt(np.mean(proj.distance ** 2)))
        if tolerance is not None and obj.FitMax > tolerance:
            return (f"tolerance not met: the largest distance of a measured point is {obj.FitMax * 1000:.1f} µm, "
                    f"over the {tolerance * 1000:.1f} µm asked ({obj.UPoles} x {obj.VPoles} poles)")
        return None


def make_blade_surface(doc: Any, points_obj: Any, method: str = "auto", tolerance: float = 0.0,
                       name: str = "BladeSurface") -> Any:
    obj = doc.addObject("Part::FeaturePython", name)
    BladeSurface(obj)
    obj.Label = "Blade surface"
    obj.Points = points_obj
    obj.Method = method
    obj.Tolerance = float(tolerance)
    _attach_view(obj, "BladeSurface")
    return obj


def core_surface(obj: Any):
    """The core :class:`~bladerecon.core.geometry.spline.BSplineSurface` of a BladeSurface (or any one-face shape)."""
    from bladerecon.fc.convert import from_part_surface

    shape = getattr(obj, "Shape", None)
    if shape is None or shape.isNull() or len(shape.Faces) != 1:
        raise BladeReconError(f"{getattr(obj, 'Label', obj)}: no surface yet: recompute it first")
    return from_part_surface(shape.Faces[0].Surface)


def surface_grid(surface, per_span: int, n_v: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A (nu, nv) grid on ``surface`` for display: (u, v, points (nu, nv, 3) mm).

    u follows the knots (``per_span`` samples per span, so the round edges, where the knots
    are dense, are sampled densely); for a periodic u the first column is repeated at the
    end so that a quad mesh closes.
    """
    from bladerecon.core.geometry.bspline import evaluate_surface

    k = np.asarray(surface.u_knots, float)
    f = np.arange(per_span) / per_span
    u = (k[:-1, None] + np.diff(k)[:, None] * f[None, :]).ravel()
    u = np.append(u, k[-1])
    v = np.linspace(*surface.v_domain, n_v)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    pts = evaluate_surface(surface, uu.ravel(), vv.ravel()).reshape(len(u), len(v), 3)
    return u, v, pts


# --------------------------------------------------------------------------- deviation
class DeviationAnalysis(_Feature):
    """Signed deviation (mm, + outside) of the measured points, and of the surface, from a nominal.

    A recompute measures in the foreground (:func:`deviation_job`, :func:`measure_job`,
    :func:`store_measurement`), unless ``precomputed`` holds ``(key, DeviationMeasurement or
    exception)`` for the same inputs: the GUI measures off its thread and hands the result
    over this way, so that storing it stays in the recompute (and its undo transaction).

    The statistics are those of ``python3 -m bladerecon deviation --json`` (same functions:
    :func:`bladerecon.fc.deviation.measure_deviation`).
    """

    TYPE = "DeviationAnalysis"
    PROPERTIES = (
        ("App::PropertyLink", "Measured", "Input", "MeasuredPoints compared with the nominal", 0),
        ("App::PropertyLink", "Nominal", "Input", "nominal blade: any object with a shape", 0),
        ("App::PropertyLink", "Surface", "Input", "optional BladeSurface to colour by its deviation", 0),
        ("App::PropertyEnumeration", "Alignment", "Input", "best fit before comparing", 0),
        ("App::PropertyBool", "RobustFit", "Input",
         "robust best fit (Tukey biweight): a worn or damaged zone does not pull the alignment", 0),
        ("App::PropertyFloat", "Tolerance", "Input", "profile tolerance ±mm", 0),
        ("App::PropertyFile", "Plan", "Input", "inspection plan (TOML, docs/verdicts.md): pass/fail per section, "
                                               "zone and parameter; its [fit] replaces Alignment", 0),
        ("App::PropertyVector", "FlowDirection", "Input",
         "direction the fluid travels: the Plan's LE zone and parameters at every section's upstream end; "
         "(0,0,0) = not known (the segmentation's rule decides)", 0),
        ("App::PropertyString", "Verdict", "Verdict", "pass or fail against the Plan (empty without a plan)", 1),
        ("App::PropertyStringList", "SectionVerdicts", "Verdict", "per section: pass, or fail and what failed", 1),
        ("App::PropertyFloat", "MaxNormalised", "Verdict",
         "largest |deviation| / zone half-width after the plan's fit (<= 1: inside every zone)", 1),
        ("App::PropertyInteger", "PointCount", "Statistics", "points compared", 1),
        ("App::PropertyFloat", "Max", "Statistics", "largest signed deviation (mm)", 1),
        ("App::PropertyFloat", "Min", "Statistics", "smallest signed deviation (mm)", 1),
        ("App::PropertyFloat", "Mean", "Statistics", "mean signed deviation (mm)", 1),
        ("App::PropertyFloat", "Std", "Statistics", "standard deviation (mm)", 1),
        ("App::PropertyFloat", "Rms", "Statistics", "RMS deviation (mm)", 1),
        ("App::PropertyFloat", "MaxAbs", "Statistics", "largest |deviation| (mm)", 1),
        ("App::PropertyFloat", "MeanAbs", "Statistics", "mean |deviation| (mm)", 1),
        ("App::PropertyFloat", "WithinTolerancePct", "Statistics", "% of points within ±Tolerance", 1),
        ("App::PropertyString", "MeasureMethod", "Statistics", "core-projection and/or occ", 1),
        ("App::PropertyMatrix", "AlignmentMatrix", "Statistics", "rigid transform applied to the measured data", 1),
        ("App::PropertyFloat", "RotationDeg", "Statistics", "rotation of the alignment (degrees)", 1),
        ("App::PropertyVector", "TranslationMm", "Statistics", "translation of the alignment (mm)", 1),
        ("App::PropertyInteger", "PointsWeightedOut", "Statistics",
         "robust fit: points whose residual weighed nothing (worn, damaged, outliers)", 1),
        ("App::PropertyFloatList", "Deviations", "Data", "signed deviation per measured point (mm)", 2),
        ("App::PropertyVectorList", "AlignedPoints", "Data", "measured points after alignment (mm)", 2),
        ("App::PropertyFloatList", "SurfaceDeviations", "Data", "signed deviation per surface grid vertex (mm)", 2),
        ("App::PropertyVectorList", "SurfaceGrid", "Data", "surface grid after alignment (mm), u-major", 2),
        ("App::PropertyIntegerList", "SurfaceGridSize", "Data", "grid size (nu, nv)", 2),
    )

    def _add_properties(self, obj: Any) -> None:
        fresh = "Alignment" not in obj.PropertiesList
        super()._add_properties(obj)
        if fresh:
            obj.Alignment = ALIGN_MODES
            obj.Alignment = "none"
            obj.Tolerance = 0.03

    def compute(self, obj: Any) -> None:
        inputs = (obj.Measured, obj.Nominal, obj.Surface, obj.Alignment, obj.Tolerance, bool(obj.RobustFit))
        plan = getattr(obj, "Plan", "") or ""
        flow = flow_of(obj) if plan else None          # the flow matters to the plan's zones only
        ready, self.precomputed = getattr(self, "precomputed", None), None
        if ready is not None and ready[0] == deviation_key(*inputs, plan=plan, flow=flow):   # measured off the GUI thread
            outcome = ready[1]
            if isinstance(outcome, BaseException):
                raise outcome
        else:
            job = deviation_job(*inputs, obj.Label, plan=plan, flow=flow)
            with _Progress(f"{obj.Label}: measuring against {job.nominal_label}", 3) as progress:
                outcome = measure_job(job, progress.step)
        store_measurement(obj, outcome)

    @staticmethod
    def stats(obj: Any) -> dict:
        """The statistics as in ``deviation --json`` (mm)."""
        return {"points": obj.PointCount, "max": obj.Max, "min": obj.Min, "mean": obj.Mean, "std": obj.Std,
                "rms": obj.Rms, "max_abs": obj.MaxAbs, "mean_abs": obj.MeanAbs,
                "within_tolerance_pct": obj.WithinTolerancePct, "tolerance": obj.Tolerance}


@dataclass
class DeviationJob:
    """What a DeviationAnalysis measures, copied out of the document: :func:`measure_job` reads
    nothing else, so it can run in a worker thread while the document stays editable.
    ``key`` names the inputs (a result measured for one key is stored only for the same)."""

    points: np.ndarray
    source: str
    shape: Any
    nominal_label: str
    surface: Any
    alignment: str
    tolerance: float
    robust: bool
    key: tuple
    plan: str = ""                  # inspection plan file (issue 19), "" for none
    pointset: Any = None            # the measured PointSet (sections) when there is a plan
    flow: Any = None                # direction the fluid travels, for the plan's zones (issue 24)


@dataclass
class DeviationMeasurement:
    """The result of :func:`measure_job`, written into the object by :func:`store_measurement`."""

    result: Any
    grid: np.ndarray
    grid_deviation: Any
    grid_size: list
    matrix: np.ndarray
    verdicts: dict | None = None    # inspect_blade's JSON when the job had a plan


def deviation_job(measured: Any, nominal: Any, surface: Any, alignment: str, tolerance: float, robust: bool,
                  label: str = "Deviation analysis", copy_shape: bool = False, plan: str = "",
                  flow: np.ndarray | None = None) -> DeviationJob:
    """The :class:`DeviationJob` of these inputs (document objects), checked: one-line errors.
    ``copy_shape``: the job holds a copy of the nominal's shape (to measure in a worker thread
    while the document may change)."""
    if measured is None:
        raise BladeReconError(f"{label}: no measured points linked: set its 'Measured' property")
    ps = point_set(measured)
    if nominal is None:
        raise BladeReconError(f"{label}: no nominal linked: set its 'Nominal' property")
    shape = getattr(nominal, "Shape", None)
    if shape is None or shape.isNull():
        raise BladeReconError(f"{label}: the nominal {nominal.Label} has no shape")
    if not tolerance > 0:
        raise BladeReconError(f"{label}: Tolerance {tolerance}: give a positive tolerance in mm")
    core = core_surface(surface) if surface is not None else None
    points = np.ascontiguousarray(ps.points, float)
    if plan:
        from bladerecon.core.inspection.plan import read_inspection_plan

        read_inspection_plan(plan)                      # a bad plan: its one-line error now, not in the worker
    return DeviationJob(points, ps.source, shape.copy() if copy_shape else shape, nominal.Label, core, alignment,
                        float(tolerance), bool(robust), deviation_key(measured, nominal, surface, alignment, tolerance,
                                                                      robust, plan=plan, flow=flow),
                        plan, ps if plan else None, flow)


def deviation_key(measured: Any, nominal: Any, surface: Any, alignment: str, tolerance: float, robust: bool,
                  plan: str = "", flow: np.ndarray | None = None) -> tuple:
    """What names the inputs of a measurement without reading them: the objects, their shapes
    (a MeasuredPoints gets a new shape whenever its points change: a recompute makes it), the
    options."""

    def shape_of(o: Any) -> Any:
        shape = getattr(o, "Shape", None)
        return None if o is None else (o.Name, None if shape is None or shape.isNull() else shape.hashCode())

    key = (shape_of(measured), getattr(measured, "PointCount", None), shape_of(nominal), shape_of(surface),
           alignment, float(tolerance), bool(robust))
    if flow is not None:
        key += (tuple(float(c) for c in flow),)
    return key + ((plan, _mtime(plan)),) if plan else key


def _mtime(path: str) -> float | None:
    import os

    try:
        return os.path.getmtime(path)
    except OSError:
        return None


def measure_job(job: DeviationJob, step: Any = None) -> DeviationMeasurement:
    """Measure ``job`` (no document access: safe off the GUI thread). ``step()``, if given, is
    called after each of 3 steps (FreeCAD's progress bar; it may raise to cancel)."""
    from bladerecon.core.analysis.alignment import apply_transform

    from bladerecon.fc.deviation import Nominal, measure_deviation

    step = step or (lambda: None)
    nominal = Nominal(job.shape, job.nominal_label)
    step()
    grid, grid_dev, size = np.zeros((0, 3)), [], []
    if job.surface is not None:
        g = surface_grid(job.surface, MAP_SAMPLES_PER_SPAN, MAP_SAMPLES_SPAN)[2]
        grid, size = g.reshape(-1, 3), list(g.shape[:2])
    verdicts = None
    if job.plan:
        from bladerecon.core.inspection.plan import read_inspection_plan
        from bladerecon.fc.inspection import inspect_measured

        inspection = inspect_measured(job.pointset, nominal, read_inspection_plan(job.plan), tolerance=job.tolerance,
                                      robust=job.robust, nominal_name=job.nominal_label, flow=job.flow)
        res, verdicts = inspection.result, inspection.verdicts
        step()
        if len(grid):
            if res.alignment is not None:
                grid = apply_transform(grid, res.alignment.matrix)
            grid_dev = nominal.measure(grid).signed
    elif job.alignment == "none":
        # one projection for points and surface grid: its set-up is most of the cost
        res, grid_dev = _measure_together(job.points, grid, nominal, job.tolerance, job.source)
        step()
    else:
        res = measure_deviation(job.points, nominal, job.alignment, job.tolerance, source=job.source,
                                robust=job.robust)
        step()
        if len(grid):
            grid = apply_transform(grid, res.alignment.matrix)
            grid_dev = nominal.measure(grid).signed
    matrix = res.alignment.matrix if res.alignment is not None else np.eye(4)
    step()
    return DeviationMeasurement(res, grid, grid_dev, size, matrix, verdicts)


def store_measurement(obj: Any, m: DeviationMeasurement) -> None:
    """Write a :class:`DeviationMeasurement` into the DeviationAnalysis ``obj`` (GUI thread)."""
    res, matrix, grid = m.result, m.matrix, m.grid
    s = res.stats
    obj.PointCount = s["points"]
    obj.Max, obj.Min, obj.Mean, obj.Std = s["max"], s["min"], s["mean"], s["std"]
    obj.Rms, obj.MaxAbs, obj.MeanAbs = s["rms"], s["max_abs"], s["mean_abs"]
    obj.WithinTolerancePct = s["within_tolerance_pct"]
    obj.MeasureMethod = "+".join(res.deviation.methods)
    obj.AlignmentMatrix = FreeCAD.Matrix(*np.asarray(matrix, float).ravel().tolist())
    obj.RotationDeg = float(res.alignment.rotation_deg) if res.alignment is not None else 0.0
    obj.TranslationMm = FreeCAD.Vector(*(matrix[:3, 3]))
    obj.PointsWeightedOut = res.alignment.points_weighted_out if res.alignment is not None else 0
    obj.Deviations = [float(x) for x in res.deviation.signed]
    obj.AlignedPoints = _vectors(res.points)
    obj.SurfaceDeviations = [float(x) for x in m.grid_deviation]
    obj.SurfaceGrid = _vectors(grid) if len(grid) else []
    obj.SurfaceGridSize = [int(x) for x in m.grid_size]
    if "Verdict" in obj.PropertiesList:
        _store_verdicts(obj, m.verdicts)


def _store_verdicts(obj: Any, verdicts: dict | None) -> None:
    """Verdict, SectionVerdicts ('label: pass' or 'label: fail: what failed'), MaxNormalised."""
    if verdicts is None:
        obj.Verdict, obj.SectionVerdicts, obj.MaxNormalised = "", [], 0.0
        return
    lines = []
    for s in verdicts["sections"]:
        zones = s["form"] if s.get("form") else s["profile"]
        failed = [f"{k} {v['min'] * 1000:+.1f}/{v['max'] * 1000:+.1f} µm (±{v['tol'] * 1000:g})"
                  for k, v in zones.items() if k != "motion" and not v["pass"]]
        failed += [k if v["difference"] is None else f"{k} {v['difference']:+.4f}"
                   for k, v in s["parameters"].items() if not v["pass"]]
        lines.append(f"{s['label']}: {s['verdict']}" + (": " + ", ".join(failed) if failed else ""))
    obj.Verdict = verdicts["verdict"]
    obj.SectionVerdicts = lines
    obj.MaxNormalised = float(verdicts["fit"].get("max_normalised") or 0.0)


def _measure_together(points: np.ndarray, extra: np.ndarray, nominal, tolerance: float, source: str):
    """:func:`~bladerecon.fc.deviation.measure_deviation` without alignment for ``points``, plus the
    signed deviations of ``extra`` points from the same projection call (each point's foot is
    found independently, so the points' results are those of measuring them alone)."""
    from dataclasses import fields

    from bladerecon.fc.deviation import DeviationResult, PointDeviation, check_units, deviation_summary

    P = np.asarray(points, float)
    check_units(P, nominal, source)
    dev = nominal.measure(np.vstack([P, extra]) if len(extra) else P)
    m = len(P)
    mine = PointDeviation(**{f.name: (getattr(dev, f.name) if f.name == "methods" or getattr(dev, f.name) is None
                                      else getattr(dev, f.name)[:m]) for f in fields(PointDeviation)})
    res = DeviationResult(P, mine, None, deviation_summary(mine.signed, tolerance), {})
    return res, dev.signed[m:]


def make_deviation_analysis(doc: Any, measured: Any, nominal: Any, surface: Any = None, alignment: str = "none",
                            tolerance: float = 0.03, name: str = "DeviationAnalysis", robust: bool = False,
                            plan: str = "") -> Any:
    obj = doc.addObject("App::FeaturePython", name)
    DeviationAnalysis(obj)
    obj.Label = "Deviation analysis"
    obj.Measured, obj.Nominal, obj.Surface = measured, nominal, surface
    obj.Alignment = alignment
    obj.RobustFit = bool(robust)
    obj.Tolerance = float(tolerance)
    obj.Plan = plan
    _attach_view(obj, "DeviationAnalysis")
    return obj


# --------------------------------------------------------------------------- view providers
#: View-provider classes by object kind ("MeasuredPoints", ...). The GUI layer fills it when it is
#: loaded (:mod:`bladerecon.gui.view_providers` registers its classes on import), so this module
#: never imports the GUI: headless there is nothing to attach.
VIEW_PROVIDERS: dict[str, Any] = {}


def register_view_provider(kind: str, cls: Any) -> None:
    """Make ``cls(obj.ViewObject)`` the view provider the factories attach to objects of ``kind``."""
    VIEW_PROVIDERS[kind] = cls


def _attach_view(obj: Any, kind: str) -> None:
    """Attach the registered view provider of ``kind`` when the GUI is up."""
    cls = VIEW_PROVIDERS.get(kind)
    if FreeCAD.GuiUp and cls is not None:
        cls(obj.ViewObject)


# --------------------------------------------------------------------------- outputs
def export_step(obj: Any, path: str) -> None:
    """Write the shape of ``obj`` (a BladeSurface's face) to a STEP file in mm, atomically."""
    from bladerecon.fc.export import write_step

    shape = getattr(obj, "Shape", None)
    if shape is None or shape.isNull():
        raise BladeReconError(f"{getattr(obj, 'Label', obj)}: nothing to export: recompute it first")
    write_step(shape, path)
