# SPDX-License-Identifier: LGPL-2.1-or-later
"""View providers of the BladeRecon objects: coloured points, LE/TE marks, zebra, curvature and
deviation maps drawn with coin (pivy) on a tessellation of the B-spline face.

Each analysis is an extra display mode whose geometry (vertices, exact normals) is built
once when the shape changes; switching mode, stripe count or colour range only rewrites
the per-vertex ``SoMaterial`` colours, so nothing is recomputed in the document.
Units in legends: µm (deviation, as the HTML report), 1/mm and 1/mm^2 (curvature).
A selected object in a colour-map mode shows as an outline, never repainted (the map stays true).

The proxies keep no state worth saving (``dumps`` returns None); their module path is
permanent because FCStd files name it.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import FreeCADGui
from pivy import coin

from bladerecon.fc import objects

from bladerecon.gui import colormap, paths

__all__ = ["ViewProviderMeasuredPoints", "ViewProviderBladeSections", "ViewProviderBladeSurface",
           "ViewProviderDeviationAnalysis", "ColourLegend", "ColouredMesh", "SURFACE_MODES", "PLAIN_MODE",
           "show_again", "draw_surface_deviation"]

#: display samples per knot span around the section, and along the span, of the analysis mesh
MESH_PER_SPAN = 4
MESH_SPAN = 41


def _add_view_property(vobj: Any, kind: str, name: str, group: str, tip: str, default: Any) -> None:
    if name not in vobj.PropertiesList:
        vobj.addProperty(kind, name, group, tip)
        setattr(vobj, name, default)


class _ViewProvider:
    """Base: icon, no pickled state, ``updateData``/``onChanged`` safe before ``attach`` has run."""

    ICON = "BladeRecon"

    def __init__(self, vobj: Any) -> None:
        vobj.Proxy = self

    def getIcon(self) -> str:  # noqa: N802
        return paths.icon(self.ICON)

    def dumps(self) -> None:
        return None

    def loads(self, state: Any) -> None:
        return None

    __getstate__ = dumps
    __setstate__ = loads

    def setDisplayMode(self, mode: str) -> str:  # noqa: N802
        return mode


# --------------------------------------------------------------------------- coin building blocks
class ColouredMesh:
    """A quad mesh (nu x nv grid, u-major) with per-vertex normals and colours, two-sided lit."""

    def __init__(self, lit: bool = True) -> None:
        self.node = coin.SoSeparator()
        hints = coin.SoShapeHints()
        # a known ordering with an unknown shape type is what turns on coin's two-sided lighting
        # (the inside of the open blade, seen over the tip, is lit too) and keeps back faces
        hints.vertexOrdering = coin.SoShapeHints.COUNTERCLOCKWISE
        hints.shapeType = coin.SoShapeHints.UNKNOWN_SHAPE_TYPE
        self.light = coin.SoLightModel()
        self.light.model = coin.SoLightModel.PHONG if lit else coin.SoLightModel.BASE_COLOR
        nb = coin.SoNormalBinding()
        nb.value = coin.SoNormalBinding.PER_VERTEX
        mb = coin.SoMaterialBinding()
        mb.value = coin.SoMaterialBinding.PER_VERTEX
        self.normals, self.material = coin.SoNormal(), coin.SoMaterial()
        self.coords, self.mesh = coin.SoCoordinate3(), coin.SoQuadMesh()
        for n in (hints, self.light, nb, self.normals, mb, self.material, self.coords, self.mesh):
            self.node.addChild(n)
        self.count = 0

    def set_geometry(self, grid: np.ndarray, normals: np.ndarray) -> None:
        nu, nv = grid.shape[:2]
        self.count = nu * nv
        self.coords.point.setNum(0)
        self.normals.vector.setNum(0)
        if not self.count:
            self.mesh.verticesPerRow = self.mesh.verticesPerColumn = 0
            return
        self.coords.point.setValues(0, self.count, grid.reshape(-1, 3).tolist())
        self.normals.vector.setValues(0, self.count, normals.reshape(-1, 3).tolist())
        self.mesh.verticesPerRow = nv
        self.mesh.verticesPerColumn = nu

    def set_colours(self, rgb: np.ndarray) -> None:
        self.material.diffuseColor.setNum(0)
        self.material.diffuseColor.setValues(0, len(rgb), np.asarray(rgb, float).tolist())

    def colours(self) -> np.ndarray:
        return np.array([tuple(c.getValue()) for c in self.material.diffuseColor])


class ColouredPoints:
    """Points with one colour each (unlit, so the colour reads as the value)."""

    def __init__(self, size: float = 3.0) -> None:
        self.node = coin.SoSeparator()
        self.style = coin.SoDrawStyle()
        self.style.pointSize = size
        light = coin.SoLightModel()
        light.model = coin.SoLightModel.BASE_COLOR
        mb = coin.SoMaterialBinding()
        mb.value = coin.SoMaterialBinding.PER_VERTEX
        self.material, self.coords, self.points = coin.SoMaterial(), coin.SoCoordinate3(), coin.SoPointSet()
        for n in (self.style, light, mb, self.material, self.coords, self.points):
            self.node.addChild(n)

    def set(self, points: np.ndarray, rgb: np.ndarray) -> None:
        n = len(points)
        self.coords.point.setNum(0)
        self.material.diffuseColor.setNum(0)
        if n:
            self.coords.point.setValues(0, n, np.asarray(points, float).tolist())
            self.material.diffuseColor.setValues(0, n, np.asarray(rgb, float).tolist())
        self.points.numPoints = n


class ColourLegend:
    """A colour bar drawn on top of the scene at the right of the view, with labelled ticks.

    Its own orthographic camera (viewport coordinates -1..1) inside an ``SoAnnotation``: it
    stays put while the model turns and is drawn over it. Not pickable.
    """

    ROWS = 41
    X0, X1, Y0, Y1 = 0.56, 0.61, -0.6, 0.6

    def __init__(self) -> None:
        self.node = coin.SoAnnotation()
        pick = coin.SoPickStyle()
        pick.style = coin.SoPickStyle.UNPICKABLE
        cam = coin.SoOrthographicCamera()
        cam.viewportMapping = coin.SoCamera.LEAVE_ALONE
        cam.position = (0.0, 0.0, 5.0)
        cam.height = 2.0
        cam.nearDistance, cam.farDistance = 1.0, 10.0
        light = coin.SoLightModel()
        light.model = coin.SoLightModel.BASE_COLOR
        self.content = coin.SoSeparator()
        for n in (pick, cam, light, self.content):
            self.node.addChild(n)

    def _y(self, t: float) -> float:
        return self.Y0 + (t + 1.0) * 0.5 * (self.Y1 - self.Y0)

    def update(self, colours_of, ticks: list[tuple[float, str]], title: str,
               band: tuple[float, str] | None = None) -> None:
        """Redraw: ``colours_of(t)`` -> RGB for bar positions t in [-1, 1]; ``ticks`` (t, label);
        ``band``: (t, text) of a symmetric ±band marked across the bar (t >= 1: beyond the bar)."""
        self.content.removeAllChildren()
        t = np.linspace(-1.0, 1.0, self.ROWS)
        rgb = colours_of(t)
        bar = ColouredMesh(lit=False)
        y = self._y(t)
        grid = np.stack([np.column_stack([np.full_like(y, x), y, np.zeros_like(y)]) for x in (self.X0, self.X1)], axis=1)
        bar.set_geometry(grid, np.broadcast_to([0.0, 0.0, 1.0], grid.shape))
        bar.set_colours(np.repeat(rgb, 2, axis=0))
        self.content.addChild(bar.node)
        ink = coin.SoBaseColor()
        ink.rgb = (0.0, 0.0, 0.0)
        self.content.addChild(ink)
        font = coin.SoFont()
        font.size = 13.0
        self.content.addChild(font)
        lines = [((self.X0, self.Y0), (self.X1, self.Y0)), ((self.X1, self.Y0), (self.X1, self.Y1)),
                 ((self.X1, self.Y1), (self.X0, self.Y1)), ((self.X0, self.Y1), (self.X0, self.Y0))]
        for pos, _ in ticks:
            lines.append(((self.X1, self._y(pos)), (self.X1 + 0.012, self._y(pos))))
        if band is not None and band[0] < 1.0:
            for s in (-1, 1):   # the tolerance band: thick marks across the bar
                lines.append(((self.X0 - 0.015, self._y(s * band[0])), (self.X1 + 0.015, self._y(s * band[0]))))
        self.content.addChild(_line_set(lines, width=2.0))
        for pos, label in ticks:
            self.content.addChild(_text(label, (self.X1 + 0.02, self._y(pos) - 0.012)))
        self.content.addChild(_text(title, (self.X0 - 0.04, self.Y1 + 0.05 + 0.045 * title.count("\n"))))
        if band is not None:
            self.content.addChild(_text(band[1], (self.X0 - 0.04, self.Y0 - 0.08)))


def _line_set(segments: list, width: float = 1.0) -> Any:
    sep = coin.SoSeparator()
    style = coin.SoDrawStyle()
    style.lineWidth = width
    coords = coin.SoCoordinate3()
    pts = [(x, y, 0.01) for seg in segments for (x, y) in seg]
    coords.point.setValues(0, len(pts), pts)
    lines = coin.SoLineSet()
    lines.numVertices.setValues(0, len(segments), [2] * len(segments))
    for n in (style, coords, lines):
        sep.addChild(n)
    return sep


def _text(label: str, at: tuple[float, float], z: float = 0.02) -> Any:
    sep = coin.SoSeparator()
    move = coin.SoTranslation()
    move.translation = (at[0], at[1], z)
    text = coin.SoText2()
    lines = label.split("\n")
    text.string.setValues(0, len(lines), lines)
    sep.addChild(move)
    sep.addChild(text)
    return sep


# --------------------------------------------------------------------------- measured points
class ViewProviderMeasuredPoints(_ViewProvider):
    """Points coloured by section (display mode ``Sections``); the Part modes stay available."""

    ICON = "BladeRecon_ImportPoints"

    def attach(self, vobj: Any) -> None:
        self.Object = vobj.Object
        self.points = ColouredPoints(vobj.PointSize if hasattr(vobj, "PointSize") else 3.0)
        self.labels = coin.SoSeparator()
        mode = coin.SoSeparator()
        mode.addChild(self.points.node)
        mode.addChild(self.labels)
        vobj.addDisplayMode(mode, "Sections")
        self._update(vobj.Object)

    def getDisplayModes(self, vobj: Any) -> list[str]:  # noqa: N802
        return ["Sections"]

    def getDefaultDisplayMode(self) -> str:  # noqa: N802
        return "Sections"

    def updateData(self, obj: Any, prop: str) -> None:  # noqa: N802
        if prop in ("Points", "SectionIndex") and hasattr(self, "points"):
            self._update(obj)

    def onChanged(self, vobj: Any, prop: str) -> None:  # noqa: N802
        if prop == "PointSize" and hasattr(self, "points"):
            self.points.style.pointSize = vobj.PointSize

    def _update(self, obj: Any) -> None:
        n = len(obj.Points)
        if n == 0 or len(obj.SectionIndex) != n:
            self.points.set(np.zeros((0, 3)), np.zeros((0, 3)))
            return
        section = np.array(obj.SectionIndex, dtype=int)
        palette = colormap.section_colours(int(section.max()) + 1)
        pts = np.array([(v.x, v.y, v.z) for v in obj.Points])
        self.points.set(pts, palette[section])
        # each section's name in its colour, just beyond the section's far end (an edge)
        self.labels.removeAllChildren()
        font = coin.SoFont()
        font.size = 15.0
        self.labels.addChild(font)
        for k, name in enumerate(obj.SectionNames):
            rows = np.flatnonzero(section == k)
            if not rows.size:
                continue
            colour = coin.SoBaseColor()
            colour.rgb = tuple(palette[k])
            self.labels.addChild(colour)
            q = pts[rows]
            centre = q.mean(axis=0)
            far = q[np.argmax(np.linalg.norm(q - centre, axis=1))]
            p = far + 0.08 * (far - centre)
            self.labels.addChild(_text(f"section {name}", (p[0], p[1]), p[2]))


# --------------------------------------------------------------------------- sections
class ViewProviderBladeSections(_ViewProvider):
    """Section curves (Part display) with the LE (red) and TE (blue) marked and labelled."""

    ICON = "BladeRecon_Sections"

    def attach(self, vobj: Any) -> None:
        self.Object = vobj.Object
        self.marks = coin.SoSeparator()
        # the marks sit beside the Part display modes, so they follow Visibility through a switch
        self.switch = coin.SoSwitch()
        self.switch.addChild(self.marks)
        self.switch.whichChild = 0 if vobj.Visibility else -1
        vobj.RootNode.addChild(self.switch)
        self._update(vobj.Object)

    def updateData(self, obj: Any, prop: str) -> None:  # noqa: N802
        if prop in ("LeadingEdges", "TrailingEdges") and hasattr(self, "marks"):
            self._update(obj)

    def onChanged(self, vobj: Any, prop: str) -> None:  # noqa: N802
        if prop == "Visibility" and hasattr(self, "switch"):
            self.switch.whichChild = 0 if vobj.Visibility else -1

    def _update(self, obj: Any) -> None:
        self.marks.removeAllChildren()
        light = coin.SoLightModel()
        light.model = coin.SoLightModel.BASE_COLOR
        self.marks.addChild(light)
        font = coin.SoFont()
        font.size = 12.0
        self.marks.addChild(font)
        for prop, rgb, label in (("LeadingEdges", (0.85, 0.05, 0.05), "LE"), ("TrailingEdges", (0.05, 0.2, 0.85), "TE")):
            pts = [(v.x, v.y, v.z) for v in getattr(obj, prop)]
            if not pts:
                continue
            sep = coin.SoSeparator()
            colour = coin.SoBaseColor()
            colour.rgb = rgb
            coords = coin.SoCoordinate3()
            coords.point.setValues(0, len(pts), pts)
            markers = coin.SoMarkerSet()
            markers.markerIndex = coin.SoMarkerSet.CIRCLE_FILLED_9_9
            markers.numPoints = len(pts)
            for n in (colour, coords, markers):
                sep.addChild(n)
            for p in (pts[0], pts[-1]):
                sep.addChild(_text(f" {label}", p[:2], p[2]))
            self.marks.addChild(sep)


# --------------------------------------------------------------------------- selection, hidden objects
#: display modes that colour an object by a value: a selection must not repaint them
MAPPED_MODES = ("Zebra", "Curvature", "Deviation", "Points")
#: the surface's analysis modes (one at a time: the surface is drawn once, by its view provider)
SURFACE_MODES = ("Zebra", "Curvature", "Deviation")
#: the Part mode a surface goes back to when it leaves its analysis modes
PLAIN_MODE = "Flat Lines"


def _selection_outline(vobj: Any, mapped: bool) -> None:
    """A selected object in a colour-map mode shows as a box outline, not repainted in the
    selection colour (which would make the map and its legend lie); other modes as FreeCAD does.

    FreeCAD's selection root paints a whole selected object (style Full) unless its style is
    Box (the BoundBox of the SelectionStyle property of Part objects)."""
    root = getattr(vobj, "RootNode", None)
    field = root.getField("selectionStyle") if root is not None else None
    if field is None:
        return
    user_box = getattr(vobj, "SelectionStyle", "Shape") == "BoundBox"
    field.set("Box" if mapped or user_box else "Full")


def _restoring(vobj: Any) -> bool:
    doc = getattr(getattr(vobj, "Object", None), "Document", None)
    return bool(getattr(doc, "Restoring", False))


def _busy(obj: Any) -> bool:
    """The document of ``obj`` is being recomputed or read."""
    doc = obj.Document
    return bool(getattr(doc, "Recomputing", False) or getattr(doc, "Restoring", False))


def show_again(vobj: Any, prop: str) -> None:
    """Show the objects named in the view property ``prop`` (hidden by a mode) and forget them."""
    names = list(getattr(vobj, prop, []) or [])
    if not names:
        return
    doc = vobj.Object.Document
    for name in names:
        other = doc.getObject(name)
        if other is not None and other.ViewObject is not None:
            other.ViewObject.Visibility = True
    setattr(vobj, prop, [])


def _hidden_list(vobj: Any, name: str, tip: str) -> None:
    if name not in vobj.PropertiesList:
        vobj.addProperty("App::PropertyStringList", name, "Analysis", tip)
    vobj.setEditorMode(name, 2)


# --------------------------------------------------------------------------- surface
class ViewProviderBladeSurface(_ViewProvider):
    """The B-spline face (Part display) plus the analysis display modes ``Zebra``, ``Curvature``
    and ``Deviation``: one surface display at a time, each analysis mode with its own legend.

    Zebra: per-vertex black/white from the exact unit normals reflected about the current
    view direction (:func:`bladerecon.gui.colormap.zebra_colours`); the stripes follow the
    camera while the mode is on. Curvature: Gaussian (1/mm^2) or mean (1/mm), outward normal.
    Deviation: the signed deviation of the surface from the nominal, from the DeviationAnalysis
    named by ``DeviationMap`` (µm, as the HTML report).

    ``HiddenByMode``: objects an analysis mode hid (the points and section curves under the
    map); they are shown again when the surface leaves its analysis modes, whichever way
    (command, undo, deleting the analysis).
    """

    ICON = "BladeRecon_Reconstruct"

    def __init__(self, vobj: Any) -> None:
        super().__init__(vobj)
        self._add_properties(vobj)

    def _add_properties(self, vobj: Any) -> None:
        _add_view_property(vobj, "App::PropertyInteger", "ZebraStripes", "Analysis",
                           "white bands per turn of the reflected light", 12)
        if "ZebraDirection" not in vobj.PropertiesList:
            vobj.addProperty("App::PropertyEnumeration", "ZebraDirection", "Analysis", "axis the light bands run along")
            vobj.ZebraDirection = list(colormap.STRIPE_AXES)
        if "CurvatureKind" not in vobj.PropertiesList:
            vobj.addProperty("App::PropertyEnumeration", "CurvatureKind", "Analysis", "Gaussian (1/mm^2) or mean (1/mm)")
            vobj.CurvatureKind = ["Mean", "Gaussian"]
        _add_view_property(vobj, "App::PropertyString", "DeviationMap", "Analysis",
                           "name of the DeviationAnalysis the Deviation display mode shows", "")
        _hidden_list(vobj, "HiddenByMode", "objects hidden while an analysis mode is on (shown again after)")

    def attach(self, vobj: Any) -> None:
        self._add_properties(vobj)
        self.Object = vobj.Object
        self.zebra = ColouredMesh(lit=False)
        self.curvature = ColouredMesh(lit=True)
        # one geometry, two colourings: the curvature mesh shares the zebra mesh's nodes
        for i in (3, 6, 7):   # normals, coords, quad mesh
            self.curvature.node.replaceChild(i, self.zebra.node.getChild(i))
        self.curvature.normals, self.curvature.coords, self.curvature.mesh = \
            self.zebra.normals, self.zebra.coords, self.zebra.mesh
        self.legend = ColourLegend()
        curvature_mode = coin.SoSeparator()
        curvature_mode.addChild(self.curvature.node)
        curvature_mode.addChild(self.legend.node)
        self.deviation = ColouredMesh(lit=True)
        self.deviation_legend = ColourLegend()
        deviation_mode = coin.SoSeparator()
        deviation_mode.addChild(self.deviation.node)
        deviation_mode.addChild(self.deviation_legend.node)
        vobj.addDisplayMode(self.zebra.node, "Zebra")
        vobj.addDisplayMode(curvature_mode, "Curvature")
        vobj.addDisplayMode(deviation_mode, "Deviation")
        self.geometry = None      # (normals (m, 3), Curvature) of the current shape, built lazily
        self.sensor = None

    def getDisplayModes(self, vobj: Any) -> list[str]:  # noqa: N802
        return list(SURFACE_MODES)

    def getDefaultDisplayMode(self) -> str:  # noqa: N802
        return PLAIN_MODE

    def updateData(self, obj: Any, prop: str) -> None:  # noqa: N802
        if prop == "Shape" and hasattr(self, "zebra"):
            self.geometry = None
            self._refresh(obj.ViewObject)

    def onChanged(self, vobj: Any, prop: str) -> None:  # noqa: N802
        if not hasattr(self, "zebra"):
            return
        if prop in ("DisplayMode", "ZebraStripes", "ZebraDirection", "CurvatureKind", "DeviationMap"):
            self._refresh(vobj)
        if prop in ("DisplayMode", "SelectionStyle"):
            _selection_outline(vobj, vobj.DisplayMode in SURFACE_MODES)
        if prop == "DisplayMode" and vobj.DisplayMode not in SURFACE_MODES and not _restoring(vobj):
            show_again(vobj, "HiddenByMode")

    def onDelete(self, vobj: Any, subelements: Any) -> bool:  # noqa: N802
        show_again(vobj, "HiddenByMode")     # the points and curves under a map show again
        return True

    def deviation_analysis(self) -> Any:
        """The DeviationAnalysis shown by the Deviation mode (``DeviationMap``, else the newest on this surface)."""
        obj = self.Object
        vobj = obj.ViewObject
        named = obj.Document.getObject(vobj.DeviationMap) if vobj.DeviationMap else None
        if named is not None and objects.is_type(named, "DeviationAnalysis"):
            return named
        mine = [o for o in obj.Document.Objects if objects.is_type(o, "DeviationAnalysis") and o.Surface == obj]
        return mine[-1] if mine else None

    def refresh_deviation(self) -> None:
        """Redraw the Deviation mode from its analysis (its results or its colour range changed)."""
        if hasattr(self, "deviation") and self.Object.ViewObject.DisplayMode == "Deviation":
            self._refresh(self.Object.ViewObject)

    def _build_geometry(self, obj: Any) -> bool:
        from bladerecon.core.geometry.bspline import surface_derivatives
        from bladerecon.core.analysis.surface_analysis import curvature_from_derivatives
        from bladerecon.fc.compare import outward_sign

        try:
            surface = objects.core_surface(obj)
        except Exception:
            return False
        u, v, grid = objects.surface_grid(surface, MESH_PER_SPAN, MESH_SPAN)
        uu, vv = np.meshgrid(u, v, indexing="ij")
        d = surface_derivatives(surface, uu.ravel(), vv.ravel(), 2)
        sign = outward_sign(surface) if surface.u_periodic else 1.0
        curv = curvature_from_derivatives(d[:, 1, 0], d[:, 0, 1], d[:, 2, 0], d[:, 1, 1], d[:, 0, 2], sign)
        self.zebra.set_geometry(grid, curv.normal)
        self.geometry = (curv.normal, curv)
        return True

    def _refresh(self, vobj: Any) -> None:
        mode = vobj.DisplayMode
        if mode not in ("Zebra", "Curvature"):
            self._follow_camera(False)
        if mode == "Deviation":
            analysis = self.deviation_analysis()
            if analysis is not None:
                draw_surface_deviation(analysis, self.deviation, self.deviation_legend)
            return
        if mode not in ("Zebra", "Curvature"):
            return
        if self.geometry is None and not self._build_geometry(vobj.Object):
            return
        normals, curv = self.geometry
        if mode == "Zebra":
            self.zebra.set_colours(colormap.zebra_colours(normals, _view_direction(), vobj.ZebraStripes,
                                                          vobj.ZebraDirection))
            self._follow_camera(True)
        else:
            self._follow_camera(False)
            gaussian = vobj.CurvatureKind == "Gaussian"
            values = curv.gaussian if gaussian else curv.mean
            rgb, knee, limit = colormap.curvature_colours(values)
            self.curvature.set_colours(rgb)
            ticks = [(colormap.symlog_position(c, knee, limit), f"{c:+.3g}") for c in (-limit, -4 * knee, 4 * knee, limit)]
            self.legend.update(colormap.diverging, ticks + [(0.0, "0")],
                               f"{vobj.CurvatureKind.lower()} curvature, {'1/mm^2' if gaussian else '1/mm'}",
                               band=(2.0, "log scale above median/4"))

    def _follow_camera(self, on: bool) -> None:
        """Recolour the zebra when the camera turns (reflection lines move with the eye)."""
        if not on:
            if self.sensor is not None:
                self.sensor.detach()
                self.sensor = None
            return
        if self.sensor is not None:
            return
        view = _active_view()
        camera = view.getCameraNode() if view is not None and hasattr(view, "getCameraNode") else None
        if camera is None:
            return
        self.sensor = coin.SoFieldSensor(lambda *_: self._recolour_zebra(), None)
        self.sensor.attach(camera.orientation)

    def _recolour_zebra(self) -> None:
        vobj = self.Object.ViewObject
        if self.geometry is not None and vobj.DisplayMode == "Zebra":
            self.zebra.set_colours(colormap.zebra_colours(self.geometry[0], _view_direction(), vobj.ZebraStripes,
                                                          vobj.ZebraDirection))


def _active_view() -> Any:
    gdoc = FreeCADGui.ActiveDocument
    view = getattr(gdoc, "ActiveView", None) if gdoc is not None else None
    return view if view is not None and hasattr(view, "getViewDirection") else None


def _view_direction() -> np.ndarray:
    view = _active_view()
    if view is None:
        return np.array([0.0, 0.0, -1.0])
    d = view.getViewDirection()
    return np.array([d.x, d.y, d.z])


# --------------------------------------------------------------------------- deviation
def _colour_limit(analysis: Any, values: np.ndarray) -> float:
    vobj = analysis.ViewObject
    chosen = getattr(vobj, "ColourRange", 0.0) if vobj is not None else 0.0
    return chosen if chosen > 0 else colormap.deviation_limit(values, analysis.Tolerance)


def _deviation_legend(legend: ColourLegend, what: str, limit: float, tolerance: float) -> None:
    """The deviation legend in µm, as the HTML report (values in mm in, labels in µm out)."""
    ticks = [(v / limit, label) for v, label in colormap.legend_ticks(limit, tolerance, unit="µm")]
    note = f"tolerance ±{tolerance * 1000:.1f} µm" + ("" if tolerance < limit else " (beyond the bar)")
    legend.update(lambda t: colormap.deviation_colours(t * limit, limit), ticks,
                  f"{what} - nominal, µm\n+ outside, - inside", band=(tolerance / limit, note))


def draw_surface_deviation(analysis: Any, mesh: ColouredMesh, legend: ColourLegend) -> bool:
    """Fill ``mesh`` and ``legend`` with the surface deviation map of ``analysis``; False if it has none."""
    size = list(analysis.SurfaceGridSize)
    sdev = np.array(analysis.SurfaceDeviations, float)
    if not (len(size) == 2 and len(sdev) == size[0] * size[1] == len(analysis.SurfaceGrid) and len(sdev)):
        mesh.set_geometry(np.zeros((0, 0, 3)), np.zeros((0, 0, 3)))
        legend.content.removeAllChildren()
        return False
    grid = np.array([(p.x, p.y, p.z) for p in analysis.SurfaceGrid]).reshape(size[0], size[1], 3)
    mesh.set_geometry(grid, colormap.grid_normals(grid))
    lim = _colour_limit(analysis, sdev)
    mesh.set_colours(colormap.deviation_colours(sdev, lim))
    _deviation_legend(legend, "surface", lim, analysis.Tolerance)
    return True


class ViewProviderDeviationAnalysis(_ViewProvider):
    """Deviation colour map of the points (display mode ``Points``, with its legend).

    The map on the surface is a display mode of the surface itself (``Deviation``, see
    :class:`ViewProviderBladeSurface`), so the surface is drawn once; this object's mode
    ``Surface`` draws nothing and says the map belongs on the surface (what the map
    commands toggle). Blue inside the nominal, red outside, darker beyond the colour range;
    the legend (µm) marks the ±tolerance band. ``ColourRange`` 0 takes min(2 x tolerance,
    largest |deviation|).

    ``HiddenByMap``: the points hidden under the points map (shown again when it goes);
    ``HiddenByCompare``: the nominal Compare hid (shown again when this object is deleted).

    Display mode ``Verdict`` (with an inspection Plan): the measured points of every section in
    green where the section passes, red where it fails (``SectionVerdicts``, issue 19).
    """

    ICON = "BladeRecon_DeviationMap"

    def __init__(self, vobj: Any) -> None:
        super().__init__(vobj)
        self._add_properties(vobj)

    def _add_properties(self, vobj: Any) -> None:
        _add_view_property(vobj, "App::PropertyFloat", "ColourRange", "Colour map",
                           "deviation at the ends of the colour bar (mm); 0 = automatic", 0.0)
        _add_view_property(vobj, "App::PropertyFloat", "PointSize", "Colour map", "point size (pixels)", 4.0)
        _hidden_list(vobj, "HiddenByMap", "objects hidden under the points map (shown again after)")
        _hidden_list(vobj, "HiddenByCompare", "objects Compare hid (shown again when this is deleted)")

    def attach(self, vobj: Any) -> None:
        self._add_properties(vobj)
        self.Object = vobj.Object
        self.points = ColouredPoints(vobj.PointSize)
        self.legend = ColourLegend()
        sep = coin.SoSeparator()
        sep.addChild(self.points.node)
        sep.addChild(self.legend.node)
        vobj.addDisplayMode(sep, "Points")
        vobj.addDisplayMode(coin.SoSeparator(), "Surface")
        self.verdict_points = ColouredPoints(vobj.PointSize)
        vobj.addDisplayMode(self.verdict_points.node, "Verdict")
        self._update(vobj.Object)
        if _restoring(vobj):          # once the document (and its view properties) is read
            self._later(self._bring_back_the_map, 0)

    @staticmethod
    def _later(call: Any, ms: int) -> None:
        from PySide import QtCore

        QtCore.QTimer.singleShot(ms, call)

    def _bring_back_the_map(self, tries: int = 0) -> None:
        """A document saved before the surface map became a display mode of the surface (before
        5b77c3f) has this object visible in its mode ``Surface``, which the map drew then and
        draws nothing now: show the map where it lives now, the surface in its ``Deviation``
        mode (the view properties only; nothing is recomputed)."""
        try:
            obj = self.Object
            doc, vobj = obj.Document, obj.ViewObject
        except Exception:         # deleted meanwhile
            return
        if getattr(doc, "Restoring", False):
            if tries < 600:
                self._later(lambda: self._bring_back_the_map(tries + 1), 50)
            return
        surface = getattr(obj, "Surface", None)
        svo = getattr(surface, "ViewObject", None)
        if vobj is None or vobj.DisplayMode != "Surface" or not vobj.Visibility or svo is None \
                or not hasattr(svo, "DeviationMap") or not len(obj.SurfaceDeviations):
            return
        if svo.Visibility and svo.DisplayMode in ("Zebra", "Curvature"):
            return                # the surface shows another analysis: the map stays one command away
        svo.DeviationMap = obj.Name
        svo.DisplayMode = "Deviation"
        svo.Visibility = True
        vobj.Visibility = False
        import FreeCAD

        FreeCAD.Console.PrintLog(f"BladeRecon: {obj.Label}: its surface map (saved by an older version) is "
                                 f"now shown on {surface.Label}\n")

    def getDisplayModes(self, vobj: Any) -> list[str]:  # noqa: N802
        return ["Surface", "Points", "Verdict"]

    def getDefaultDisplayMode(self) -> str:  # noqa: N802
        return "Surface"

    def claimChildren(self) -> list:  # noqa: N802
        return []

    def updateData(self, obj: Any, prop: str) -> None:  # noqa: N802
        if prop in ("Deviations", "AlignedPoints", "SurfaceDeviations", "SurfaceGrid", "SurfaceGridSize", "Tolerance",
                    "SectionVerdicts") and hasattr(self, "points"):
            if _busy(obj):        # a recompute or a file sets them one by one: draw once, after
                if not getattr(self, "pending", False):
                    self.pending = True
                    self._later(self._flush, 0)
                return
            self._update(obj)

    def _flush(self) -> None:
        try:
            obj = self.Object
            busy = _busy(obj)
        except Exception:         # deleted meanwhile
            self.pending = False
            return
        if busy:
            self._later(self._flush, 20)
            return
        self.pending = False
        self._update(obj)

    def onChanged(self, vobj: Any, prop: str) -> None:  # noqa: N802
        if not hasattr(self, "points"):
            return
        if prop == "ColourRange":
            self._update(vobj.Object)
        elif prop == "PointSize":
            self.points.style.pointSize = vobj.PointSize
            if hasattr(self, "verdict_points"):
                self.verdict_points.style.pointSize = vobj.PointSize
        elif prop in ("DisplayMode", "Visibility"):
            on_points = vobj.DisplayMode == "Points" and vobj.Visibility
            was_on, self.on_points = getattr(self, "on_points", False), on_points
            _selection_outline(vobj, vobj.DisplayMode == "Points")
            if was_on and not on_points and not _restoring(vobj):   # the points map went: give back
                show_again(vobj, "HiddenByMap")

    def surface_showing_me(self) -> Any:
        surface = getattr(self.Object, "Surface", None)
        svo = getattr(surface, "ViewObject", None)
        proxy = getattr(svo, "Proxy", None)
        if svo is None or svo.DisplayMode != "Deviation" or not hasattr(proxy, "deviation_analysis"):
            return None
        return surface if proxy.deviation_analysis() == self.Object else None

    def onDelete(self, vobj: Any, subelements: Any) -> bool:  # noqa: N802
        """Deleting the analysis gives back what it hid: the surface leaves its map, the points
        and the nominal show again."""
        surface = self.surface_showing_me()
        if surface is not None:
            surface.ViewObject.DisplayMode = PLAIN_MODE
            surface.ViewObject.Visibility = True
        show_again(vobj, "HiddenByMap")
        show_again(vobj, "HiddenByCompare")
        return True

    def limit(self, values: np.ndarray) -> float:
        return _colour_limit(self.Object, values)

    def _update(self, obj: Any) -> None:
        dev = np.array(obj.Deviations, float)
        if len(dev) and len(obj.AlignedPoints) == len(dev):
            lim = self.limit(dev)
            P = np.array([(p.x, p.y, p.z) for p in obj.AlignedPoints])
            self.points.set(P, colormap.deviation_colours(dev, lim))
            _deviation_legend(self.legend, "points", lim, obj.Tolerance)
            verdicts = list(getattr(obj, "SectionVerdicts", []))
            if hasattr(self, "verdict_points"):   # drawn only with a plan: a large scan costs the GUI thread
                if verdicts:
                    self.verdict_points.set(P, colormap.verdict_colours(_point_sections(obj), verdicts))
                else:
                    self.verdict_points.set(P[:0], P[:0])
        surface = self.surface_showing_me()
        if surface is not None:
            surface.ViewObject.Proxy.refresh_deviation()


def _point_sections(obj: Any) -> np.ndarray:
    """Section index of every measured point of a DeviationAnalysis (-1 when unknown)."""
    measured = getattr(obj, "Measured", None)
    index = np.array(getattr(measured, "SectionIndex", []) or [], dtype=int)
    return index if len(index) == len(obj.Deviations) else np.full(len(obj.Deviations), -1)


# --------------------------------------------------------------------------- failed recomputes
class _QuietFailure:
    """After a BladeRecon object has said in one line why its recompute failed, keep FreeCAD's own
    report of the exception that marks it failed (a Python traceback, "Recompute failed!") out
    of the report view and the status bar, until the recompute is over."""

    OBSERVERS = ("ReportOutput", "StatusBar", "NotificationArea")

    def __init__(self) -> None:
        self.muted: list[str] = []
        self.since = 0.0
        self.line = ""

    def __call__(self, obj: Any, message: str) -> None:
        import time

        import FreeCAD

        if not FreeCAD.GuiUp:
            return
        # the status bar says it too (again once the recompute is over: FreeCAD 1.0 clears it)
        self.line = f"BladeRecon: {message if message.startswith(obj.Label) else f'{obj.Label}: {message}'}"
        FreeCADGui.getMainWindow().statusBar().showMessage(self.line)
        if self.muted:
            return
        for name in self.OBSERVERS:
            try:
                if FreeCAD.Console.GetStatus(name, "Err"):
                    FreeCAD.Console.SetStatus(name, "Err", False)
                    self.muted.append(name)
            except Exception:
                continue
        self.since = time.time()
        self._later(0)

    @staticmethod
    def _timer() -> Any:
        from PySide import QtCore

        return QtCore.QTimer

    def _later(self, ms: int) -> None:
        self._timer().singleShot(ms, self._check)

    def _check(self) -> None:
        import time

        import FreeCAD

        busy = any(getattr(d, "Recomputing", False) for d in FreeCAD.listDocuments().values())
        if busy and time.time() - self.since < 120:
            self._later(50)
            return
        for name in self.muted:
            FreeCAD.Console.SetStatus(name, "Err", True)
        self.muted = []
        if self.line:
            FreeCADGui.getMainWindow().statusBar().showMessage(self.line)
            self.line = ""


objects.register_failure_hook(_QuietFailure())

for _kind in ("MeasuredPoints", "BladeSections", "BladeSurface", "DeviationAnalysis"):
    objects.register_view_provider(_kind, globals()[f"ViewProvider{_kind}"])
