# SPDX-License-Identifier: LGPL-2.1-or-later
"""Parametric document objects of the workbench: proxies and ``make_*`` factories (mm, degrees).

MeasuredPoints -> BladeSections (LE/TE marked) and BladeSurface (native B-spline face) ->
DeviationAnalysis (against a nominal shape). Each proxy only adapts: the work is done by
``bladerecon.core`` (sections, reconstruction) and ``bladerecon.fc.deviation``. A whole-blade
cloud (a MeasuredPoints with ``Cloud``) takes the command line's path,
:mod:`bladerecon.core.sections.whole_cloud`: sections cut automatically, the surface fitted to
every node, what was chosen and why in ``Slicing``.

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

__all__ = ["MeasuredPoints", "BladeSections", "BladeSurface", "DeviationAnalysis", "is_cloud", "CLOUD_INPUTS",
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
    """Measured blade points (mm) with their section labels, or a whole-blade cloud (``Cloud``:
    no labels; BladeSurface and BladeSections cut its sections automatically); the shape is one
    vertex per point."""

    TYPE = "MeasuredPoints"
    PROPERTIES = (
        ("App::PropertyVectorList", "Points", "Points", "measured points (mm), file order", 2),
        ("App::PropertyIntegerList", "SectionIndex", "Points", "0-based section of each point (a cloud: all 0)", 2),
        ("App::PropertyIntegerList", "LineNumbers", "Points", "1-based file line of each point", 2),
        ("App::PropertyStringList", "SectionNames", "Points", "section names, hub to tip as in the file", 1),
        ("App::PropertyString", "SourceFile", "Points", "file the points were read from", 1),
        ("App::PropertyString", "Format", "Points", "csv, xyz-blocks or section-table", 1),
        ("App::PropertyString", "Units", "Points", "length unit of the points", 1),
        ("App::PropertyInteger", "PointCount", "Points", "number of points", 1),
        ("App::PropertyInteger", "SectionCount", "Points", "number of sections (a cloud: 0, cut automatically)", 1),
        ("App::PropertyBool", "Cloud", "Points",
         "a whole-blade cloud with no section labels: BladeSurface and BladeSections cut its sections automatically "
         "(their Cloud properties)", 1),
        ("App::PropertyFloat", "CloudScale", "Points",
         "a cloud's unit factor: the file's coordinates times this are the points in mm (1000 for a file in metres, "
         "25.4 in inches; as --cloud-scale)", 0),
        ("App::PropertyFloat", "ScaleApplied", "Points", "the CloudScale the Points are multiplied by", 2),
        ("App::PropertyFloat", "ProbeRadius", "Compensation",
         "touch-probe ball radius (mm): the points are ball centres; each is moved this far toward the material, "
         "along its section curve's normal (a cloud: its cut sections and nodes; 0: none)", 0),
        ("App::PropertyFloat", "Coating", "Compensation",
         "coating thickness (mm) over the part: each point is moved this far toward the material (0: none)", 0),
    )

    def _add_properties(self, obj: Any) -> None:
        fresh = "CloudScale" not in obj.PropertiesList
        super()._add_properties(obj)
        if fresh:                   # files saved before clouds: measured sections, as read
            obj.CloudScale = obj.ScaleApplied = 1.0
        obj.setEditorMode("CloudScale", 0 if obj.Cloud else 2)     # sections are read as they are

    def compute(self, obj: Any) -> None:
        n = len(obj.Points)
        if len(obj.SectionIndex) != n:
            raise BladeReconError(f"{obj.Label}: {n} points but {len(obj.SectionIndex)} section labels: "
                                  "import the file again")
        if obj.Cloud:
            _apply_cloud_scale(obj)
        obj.PointCount, obj.SectionCount = n, 0 if obj.Cloud else len(obj.SectionNames)
        # the shape shows the points every later step uses: compensated when asked
        pts = point_set(obj).points if n and _offset(obj) else obj.Points
        obj.Shape = compound([Part.Vertex(*map(float, v)) for v in pts]) if n else Part.Shape()


def _apply_cloud_scale(obj: Any) -> None:
    """A cloud's Points multiplied anew when its CloudScale changed (they are held in mm)."""
    scale, applied = float(obj.CloudScale), float(obj.ScaleApplied or 1.0)
    if not (np.isfinite(scale) and scale > 0.0):
        raise BladeReconError(f"{obj.Label}: CloudScale {scale:g}: give a positive factor (1000 for a file in metres, "
                              "25.4 in inches, 1 in mm)")
    if scale == applied:
        return
    from bladerecon.core.io.outputs import check_coordinates

    P = _array(obj.Points) * (scale / applied)
    try:
        check_coordinates(P, obj.LineNumbers if len(obj.LineNumbers) == len(P) else None, obj.SourceFile or obj.Label)
    except BladeReconError as err:
        raise BladeReconError(f"{err} (coordinates multiplied by CloudScale {scale:g})") from None
    obj.Points = _vectors(P)
    obj.ScaleApplied = scale


def is_cloud(obj: Any) -> bool:
    """True for a MeasuredPoints holding a whole-blade cloud (no section labels)."""
    return is_type(obj, "MeasuredPoints") and bool(getattr(obj, "Cloud", False))


def _offset(obj: Any) -> tuple[float, float]:
    """(probe radius, coating) of a MeasuredPoints in mm, or () when neither is set."""
    r, t = float(getattr(obj, "ProbeRadius", 0.0) or 0.0), float(getattr(obj, "Coating", 0.0) or 0.0)
    return (r, t) if r or t else ()


def make_measured_points(doc: Any, path: str, name: str = "MeasuredPoints", cloud_scale: float = 1.0) -> Any:
    """Read ``path`` (any format of :func:`bladerecon.core.io.readers.read_points`) into a MeasuredPoints.

    A file with no section structure (one block of points, no labels) is a whole-blade cloud
    (``Cloud``; its sections are cut automatically), read as ``reconstruct CLOUD`` reads it, its
    coordinates times ``cloud_scale`` (1000 for a file in metres); a cloud under
    :data:`~bladerecon.core.sections.whole_cloud.MIN_CLOUD_POINTS` points is refused as there.
    Raises :class:`BladeReconError` for a bad file before anything is added to ``doc``.
    """
    from bladerecon.core.io.readers import read_points

    ps = read_points(path, require_sections=False)
    cloud = not ps.structured
    if cloud:
        from bladerecon.core.sections.whole_cloud import check_cloud_size, read_cloud_mm

        if not (np.isfinite(cloud_scale) and cloud_scale > 0.0):
            raise BladeReconError(f"cloud scale {cloud_scale:g}: give a positive factor (1000 for a file in metres)")
        P, lines = read_cloud_mm(path, cloud_scale, scale_name="the cloud scale")
        check_cloud_size(path, len(P))
        section, names = np.zeros(len(P), dtype=int), []
    elif cloud_scale != 1.0:
        raise BladeReconError(f"cloud scale {cloud_scale:g} applies to an unordered cloud; {path} holds "
                              f"{len(ps.section_names)} sections, read as they are (mm)")
    else:
        P, lines, section, names = ps.points, ps.line, ps.section, ps.section_names
    obj = doc.addObject("Part::FeaturePython", name)
    MeasuredPoints(obj)
    obj.Label = f"Measured points ({os.path.basename(path)})"
    obj.Points = _vectors(P)
    obj.SectionIndex = [int(i) for i in section]
    obj.LineNumbers = [int(i) for i in lines]
    obj.SectionNames = [str(s) for s in names]
    obj.SourceFile = os.path.abspath(path)
    obj.Format = ps.format
    obj.Units = "mm"
    obj.Cloud = cloud
    obj.CloudScale = obj.ScaleApplied = float(cloud_scale)
    obj.setEditorMode("CloudScale", 0 if cloud else 2)
    _attach_view(obj, "MeasuredPoints")
    return obj


def point_set(obj: Any):
    """The :class:`~bladerecon.core.io.readers.PointSet` held by a MeasuredPoints object."""
    from bladerecon.core.io.readers import PointSet

    if not is_type(obj, "MeasuredPoints"):
        raise BladeReconError(f"{getattr(obj, 'Label', obj)} is not a MeasuredPoints object: select imported points")
    n = len(obj.Points)
    lines = np.array(obj.LineNumbers, dtype=int) if len(obj.LineNumbers) == n else np.arange(1, n + 1)
    if is_cloud(obj):       # one block with no labels, as read_points gives a cloud; compensated where it is cut
        return PointSet(points=_array(obj.Points), section=np.zeros(n, dtype=int), line=lines, section_names=("1",),
                        source=obj.SourceFile or obj.Label, format=obj.Format or "csv", structured=False)
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


def section_parameters(section_set, flow: np.ndarray | None = None,
                       first_point_is_measured: bool | None = None) -> SectionParameters:
    """Section curves, LE/TE and parameters of every section of a
    :class:`~bladerecon.core.sections.ordering.SectionSet`.

    Curves are fitted as :func:`bladerecon.core.reconstruct.reconstruct` does (interpolating
    or smoothing, chosen from spacing against noise); segmentation and parameters by
    :func:`bladerecon.core.sections.parameters.segment_sections` / ``measure_section`` (LE/TE
    from the curvature peaks, the LE chained from the first section's measured start). An
    edge too sparse for a radius gives NaN and a warning, not a failure. ``flow`` (the
    direction the fluid travels): every LE is its section's upstream end; without it the LE
    is guessed by one rule for the whole blade, and the guess is among the warnings.
    ``first_point_is_measured``: whether each section's first point is where the measurement
    started (default: unless its points were re-ordered; sections cut from a cloud: False).
    """
    from bladerecon.core.reconstruct import _fit_sections
    from bladerecon.core.surface.section_curves import choose_method
    from bladerecon.core.sections.parameters import measure_section, segment_blade

    pts = [s.points for s in section_set.sections]
    curves = _fit_sections(pts, choose_method(pts), None)
    if first_point_is_measured is None:
        first_point_is_measured = not section_set.sections[0].reordered
    blade = segment_blade(pts, section_set.span_axis, first_point_is_measured, flow=flow, canonical=True)
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


# --------------------------------------------------------------------------- whole-blade clouds
#: the choices for cutting a cloud (BladeSurface, BladeSections), as the command line's options
CLOUD_INPUTS = (
    ("App::PropertyEnumeration", "CloudBladeKind", "Cloud",
     "a whole-blade cloud: axial (planes across the span), radial (stream surfaces between hub and shroud) or "
     "auto (radial when planes cut it into open curves); as --blade-kind", 0),
    ("App::PropertyEnumeration", "CloudSpanAxis", "Cloud",
     "a cloud's span direction hub -> tip; auto: found from the cloud (as --span-axis)", 0),
    ("App::PropertyString", "CloudSpanRange", "Cloud",
     "a cloud's airfoil span to cut, A:B in mm along the span axis (radial: span fractions 0..1); empty: found "
     "from the cloud, leaving out the hub fillet and the tip cap (as --span-range)", 0),
    ("App::PropertyInteger", "CloudSections", "Cloud",
     "number of sections cut from a cloud; 0: from its density, 6 to 21 (as --sections)", 0),
    ("App::PropertyEnumeration", "CloudRotorAxis", "Cloud",
     "with a radial blade: the rotor axis through the origin (as --rotor-axis)", 0),
    ("App::PropertyStringList", "Slicing", "Cloud",
     "what was chosen for the cloud and why: span axis, span, kind, sections, slab width, method, fit to the "
     "cloud (empty for measured sections)", 1),
    ("App::PropertyString", "SlicingJson", "Cloud", "the same as JSON: reconstruct --json's 'slicing' (and "
     "'cloud_fit')", 2),
)
#: the workbench's names of the choices, in messages
CLOUD_NAMES = {"sections": "CloudSections", "span_axis": "CloudSpanAxis", "span_range": "CloudSpanRange",
               "rotor_axis": "CloudRotorAxis", "blade_kind": "CloudBladeKind", "cloud_scale": "CloudScale"}
_CLOUD_ENUMS = {"CloudBladeKind": (["auto", "axial", "radial"], "auto"),
                "CloudSpanAxis": (["auto", "x", "y", "z", "-x", "-y", "-z"], "auto"),
                "CloudRotorAxis": (["x", "y", "z"], "z")}


def _init_cloud_inputs(obj: Any, missing: list) -> None:
    for name, (values, default) in _CLOUD_ENUMS.items():
        if name in missing:
            setattr(obj, name, values)
            setattr(obj, name, default)


def _in_workbench_words(message: str) -> str:
    """A message of the cut naming the command line's options, with the properties' names."""
    for option, prop in (("--span-range", "CloudSpanRange"), ("--span-axis", "CloudSpanAxis"),
                         ("--sections", "CloudSections"), ("--blade-kind", "CloudBladeKind"),
                         ("--rotor-axis", "CloudRotorAxis")):
        message = message.replace(option, prop)
    return message


def _cloud_choices(obj: Any) -> dict:
    """The cloud choices of a BladeSurface/BladeSections that differ from 'found from the cloud'."""
    given = {"CloudBladeKind": obj.CloudBladeKind != "auto", "CloudSpanAxis": obj.CloudSpanAxis != "auto",
             "CloudSpanRange": bool(obj.CloudSpanRange.strip()), "CloudSections": obj.CloudSections != 0}
    return {k: v for k, v in given.items() if v}


def _cut_linked_cloud(obj: Any, method: str | None):
    """The sections cut from the cloud linked to ``obj`` as ``reconstruct CLOUD`` cuts them
    (:func:`bladerecon.core.sections.whole_cloud.cut_cloud`, its options from the Cloud
    properties); ``method`` 'auto' also chooses the fitting method there."""
    from bladerecon.core.sections.whole_cloud import check_cloud_size, cloud_options, cut_cloud

    ps = _linked_points(obj)
    target = obj.Points
    try:
        axis, rng, rotor = cloud_options(obj.CloudSections or None,
                                         None if obj.CloudSpanAxis == "auto" else obj.CloudSpanAxis,
                                         obj.CloudSpanRange.strip() or None, obj.CloudRotorAxis, CLOUD_NAMES)
        check_cloud_size(ps.source, len(ps.points))
        return cut_cloud(np.asarray(ps.points), np.asarray(ps.line), ps.source, obj.CloudBladeKind, rng,
                         obj.CloudSections or None, axis, rotor, method, scale=float(target.CloudScale))
    except BladeReconError as err:
        raise BladeReconError(_in_workbench_words(str(err))) from None


def _sections_of(obj: Any):
    """The ordered sections of the measured sections linked to ``obj``; the Cloud choices are
    refused there in one line, as the command line refuses its cloud options on such a file."""
    target = obj.Points
    given = _cloud_choices(obj)
    if given and target is not None and is_type(target, "MeasuredPoints"):
        name = next(iter(given))
        raise BladeReconError(f"{name} applies to a whole-blade cloud; {target.Label} holds "
                              f"{target.SectionCount} measured sections: set it back to "
                              f"{'0' if name == 'CloudSections' else 'empty' if name == 'CloudSpanRange' else 'auto'}")
    from bladerecon.core.sections.ordering import build_sections

    return build_sections(_linked_points(obj))


def _store_slicing(obj: Any, info: dict | None, cloud_fit: dict | None = None, method_note: str = "") -> None:
    import json

    from bladerecon.core.sections.whole_cloud import slicing_lines

    if info is None:
        obj.Slicing, obj.SlicingJson = [], ""
        return
    lines = slicing_lines(info, cloud_fit)
    if method_note:
        lines.insert(len(lines) - 1 - (cloud_fit is not None), method_note)
    obj.Slicing = lines
    obj.SlicingJson = json.dumps({"slicing": info, "cloud_fit": cloud_fit})


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
    ) + CLOUD_INPUTS

    def _add_properties(self, obj: Any) -> None:
        missing = [p[1] for p in self.PROPERTIES if p[1] not in obj.PropertiesList]
        super()._add_properties(obj)
        _init_cloud_inputs(obj, missing)

    def compute(self, obj: Any) -> None:
        from bladerecon.fc.convert import to_part_curve

        if is_cloud(obj.Points):
            # sections cut as ``sections CLOUD`` cuts them, moved by the probe compensation there
            # too; their first points are where the cut began, not where a measurement started
            with _Progress(f"{obj.Label}: cutting the cloud into sections", 2) as progress:
                cut = _cut_linked_cloud(obj, None)
                progress.step()
                sections = cut.sections
                offset = _offset(obj.Points)
                if offset:
                    from bladerecon.core.surface.compensation import compensate_sections

                    sections = compensate_sections(sections, *offset)
                params = section_parameters(sections, flow_of(obj), first_point_is_measured=False)
                progress.step()
            _store_slicing(obj, cut.info)
        else:
            params = section_parameters(_sections_of(obj), flow_of(obj))
            _store_slicing(obj, None)
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


def make_blade_sections(doc: Any, points_obj: Any, name: str = "BladeSections", blade_kind: str = "auto",
                        span_axis: str = "auto", span_range: str = "", sections: int = 0, rotor_axis: str = "z") -> Any:
    """A BladeSections on ``points_obj``; ``blade_kind`` .. ``rotor_axis`` as :func:`make_blade_surface`'s."""
    choices = _cloud_choice_values(blade_kind, span_axis, span_range, sections, rotor_axis)
    obj = doc.addObject("Part::FeaturePython", name)
    BladeSections(obj)
    obj.Label = "Blade sections"
    obj.Points = points_obj
    for prop, value in choices.items():
        setattr(obj, prop, value)
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
        ("App::PropertyFloat", "FitMax", "Result",
         "largest distance measured point - surface (mm); a cloud: its nodes between the end sections", 1),
        ("App::PropertyFloat", "FitRms", "Result",
         "RMS distance measured point - surface (mm); a cloud: its nodes between the end sections", 1),
    ) + CLOUD_INPUTS

    def _add_properties(self, obj: Any) -> None:
        missing = [p[1] for p in self.PROPERTIES if p[1] not in obj.PropertiesList]
        super()._add_properties(obj)
        if "Method" in missing:
            obj.Method = METHODS
            obj.Method = "auto"
        _init_cloud_inputs(obj, missing)

    def compute(self, obj: Any) -> str | None:
        from bladerecon.core.geometry.projection import project_points_to_surface
        from bladerecon.core.reconstruct import reconstruct, start_upstream

        if obj.Tolerance < 0:
            raise BladeReconError(f"{obj.Label}: Tolerance {obj.Tolerance} mm: give 0 (automatic) or a positive distance")
        tolerance = obj.Tolerance if obj.Method == "approximate" and obj.Tolerance > 0 else None
        if is_cloud(obj.Points):
            return self._compute_cloud(obj, tolerance)
        with _Progress(f"{obj.Label}: reconstructing", 3) as progress:
            sections = _sections_of(obj)
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
        _store_slicing(obj, None)
        return self._store(obj, rec, rec.choice.reason, proj.distance, tolerance)

    def _compute_cloud(self, obj: Any, tolerance: float | None) -> str | None:
        """A whole-blade cloud by the path of ``reconstruct CLOUD`` (issue 25): sections cut and
        the method chosen on the cloud (Method auto), the surface through the sections fitted to
        every node, and judged by the nodes (FitMax, FitRms), not the section points."""
        from bladerecon.core.geometry.projection import project_points_to_surface
        from bladerecon.core.reconstruct import start_upstream
        from bladerecon.core.sections.whole_cloud import cloud_surface

        with _Progress(f"{obj.Label}: cutting the cloud and reconstructing", 3) as progress:
            cut = _cut_linked_cloud(obj, obj.Method)
            progress.step()
            sections = cut.sections
            offset = _offset(obj.Points)
            if offset:                  # as reconstruct --probe-radius/--coating: the sections, then the nodes
                from bladerecon.core.surface.compensation import compensate_sections

                sections = compensate_sections(sections, *offset)
            pts = [s.points for s in sections.sections]
            measured_start = not sections.sections[0].reordered
            flow = flow_of(obj)
            if flow is not None:
                pts, measured_start = start_upstream(pts, flow), True
            rec, cloud_fit, cloud_dist = cloud_surface(cut, pts, sections.span_axis, tolerance, measured_start,
                                                       offset=float(sum(offset)))
            progress.step()
            if cloud_dist is None:      # the sections' surface kept (too few nodes): judged by the section points
                cloud_dist = project_points_to_surface(rec.surface, np.concatenate(pts), rec.point_u,
                                                       rec.point_v).distance
            progress.step()
        note = "" if "method_reason" in cut.info else f"method: {cut.method} (the Method property)"
        _store_slicing(obj, cut.info, cloud_fit, note)
        return self._store(obj, rec, cut.info.get("method_reason", rec.choice.reason), cloud_dist, tolerance,
                           "cloud node" if cloud_fit and cloud_fit.get("fitted") else "section point")

    @staticmethod
    def _store(obj: Any, rec, reason: str, distance: np.ndarray, tolerance: float | None,
               judged: str = "measured point") -> str | None:
        from bladerecon.fc.convert import make_face

        obj.Shape = make_face(rec.surface)
        s = rec.surface
        obj.MethodUsed, obj.MethodReason = rec.choice.method, reason
        obj.UPoles, obj.VPoles = int(s.shape[0]), int(s.shape[1])
        obj.UDegree, obj.VDegree = int(s.u_degree), int(s.v_degree)
        obj.NoiseEstimate, obj.RefitError = float(rec.choice.noise_mm), float(rec.refit_error)
        obj.FitMax = float(distance.max())
        obj.FitRms = float(np.sqrt(np.mean(distance ** 2)))
        if tolerance is not None and obj.FitMax > tolerance:
            return (f"tolerance not met: the largest distance of a {judged} is {obj.FitMax * 1000:.1f} µm, "
                    f"over the {tolerance * 1000:.1f} µm asked ({obj.UPoles} x {obj.VPoles} poles)")
        return None


def make_blade_surface(doc: Any, points_obj: Any, method: str = "auto", tolerance: float = 0.0,
                       name: str = "BladeSurface", blade_kind: str = "auto", span_axis: str = "auto",
                       span_range: str = "", sections: int = 0, rotor_axis: str = "z") -> Any:
    """A BladeSurface on ``points_obj``; ``blade_kind`` .. ``rotor_axis``: the choices for a
    whole-blade cloud (its Cloud properties; the defaults find everything from the cloud)."""
    choices = _cloud_choice_values(blade_kind, span_axis, span_range, sections, rotor_axis)
    obj = doc.addObject("Part::FeaturePython", name)
    BladeSurface(obj)
    obj.Label = "Blade surface"
    obj.Points = points_obj
    obj.Method = method
    obj.Tolerance = float(tolerance)
    for prop, value in choices.items():
        setattr(obj, prop, value)
    _attach_view(obj, "BladeSurface")
    return obj


def _cloud_choice_values(blade_kind: str, span_axis: str, span_range: str, sections: int, rotor_axis: str) -> dict:
    """The Cloud properties' values, checked (one line for a value the property cannot take)."""
    out = {}
    for prop, value in (("CloudBladeKind", blade_kind), ("CloudSpanAxis", span_axis), ("CloudRotorAxis", rotor_axis)):
        values = _CLOUD_ENUMS[prop][0]
        if value not in values:
            raise BladeReconError(f"{prop} '{str(value)[:20]}': give one of {', '.join(values)}")
        out[prop] = value
    out["CloudSpanRange"] = str(span_range or "")
    out["CloudSections"] = int(sections or 0)
    return out


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
    offset: float = 0.0             # a cloud's probe radius + coating (mm): moved along the nominal's normals


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
    # a cloud is compensated as ``deviation CLOUD --probe-radius`` does: along the nominal's normals
    offset = float(sum(_offset(measured))) if is_cloud(measured) else 0.0
    if offset and plan:
        raise BladeReconError(f"{label}: ProbeRadius and Coating of a cloud are not applied with a Plan yet (as "
                              "deviation --plan): set them to 0, or compare the reconstructed surface's sections")
    if plan:
        from bladerecon.core.inspection.plan import read_inspection_plan

        read_inspection_plan(plan)                      # a bad plan: its one-line error now, not in the worker
    return DeviationJob(points, ps.source, shape.copy() if copy_shape else shape, nominal.Label, core, alignment,
                        float(tolerance), bool(robust), deviation_key(measured, nominal, surface, alignment, tolerance,
                                                                      robust, plan=plan, flow=flow),
                        plan, ps if plan else None, flow, offset)


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
    if is_cloud(measured) and _offset(measured):     # a cloud's shape shows its points uncompensated
        key += (_offset(measured),)
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
    elif job.alignment == "none" and not job.offset:
        # one projection for points and surface grid: its set-up is most of the cost
        res, grid_dev = _measure_together(job.points, grid, nominal, job.tolerance, job.source)
        step()
    else:
        res = measure_deviation(job.points, nominal, job.alignment, job.tolerance, source=job.source,
                                robust=job.robust, offset=job.offset)
        step()
        if len(grid):
            if res.alignment is not None:
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
