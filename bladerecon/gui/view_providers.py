# SPDX-License-Identifier: LGPL-2.1-or-later
"""View providers of the BladeRecon objects: coloured points, LE/TE marks, zebra, curvature and
deviation maps drawn with coin (pivy) on a tessellation of the B-spline face.

Each analysis is an extra display mode whose geometry (vertices, exact normals) is built
once when the shape changes; switching mode, stripe count or colour range only rewrites
the per-vertex ``SoMaterial`` colours, so nothing is recomputed in the document.
Units in legends: mm (deviation), 1/mm and 1/mm^2 (curvature).

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
           "ViewProviderDeviationAnalysis", "ColourLegend", "ColouredMesh"]

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


# --------------------------------------------------------------------------- surface
class ViewProviderBladeSurface(_ViewProvider):
    """The B-spline face (Part display) plus ``Zebra`` and ``Curvature`` display modes.

    Zebra: per-vertex black/white from the exact unit normals reflected about the current
    view direction (:func:`bladerecon.gui.colormap.zebra_colours`); the stripes follow the
    camera while the mode is on. Curvature: Gaussian (1/mm^2) or mean (1/mm), outward normal.
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
        vobj.addDisplayMode(self.zebra.node, "Zebra")
        vobj.addDisplayMode(curvature_mode, "Curvature")
        self.geometry = None      # (normals (m, 3), Curvature) of the current shape, built lazily
        self.sensor = None

    def getDisplayModes(self, vobj: Any) -> list[str]:  # noqa: N802
        return ["Zebra", "Curvature"]

    def getDefaultDisplayMode(self) -> str:  # noqa: N802
        return "Flat Lines"

    def updateData(self, obj: Any, prop: str) -> None:  # noqa: N802
        if prop == "Shape" and hasattr(self, "zebra"):
            self.geometry = None
            self._refresh(obj.ViewObject)

    def onChanged(self, vobj: Any, prop: str) -> None:  # noqa: N802
        if prop in ("DisplayMode", "ZebraStripes", "ZebraDirection", "CurvatureKind") and hasattr(self, "zebra"):
            self._refresh(vobj)

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
class ViewProviderDeviationAnalysis(_ViewProvider):
    """Deviation colour map on the surface (mode ``Surface``) or the points (``Points``), with legend.

    Blue inside the nominal, red outside, darker beyond the colour range; the legend marks
    the ±tolerance band. ``ColourRange`` 0 takes min(2 x tolerance, largest |deviation|).
    """

    ICON = "BladeRecon_DeviationMap"

    def __init__(self, vobj: Any) -> None:
        super().__init__(vobj)
        self._add_properties(vobj)

    def _add_properties(self, vobj: Any) -> None:
        _add_view_property(vobj, "App::PropertyFloat", "ColourRange", "Colour map",
                           "deviation at the ends of the colour bar (mm); 0 = automatic", 0.0)
        _add_view_property(vobj, "App::PropertyFloat", "PointSize", "Colour map", "point size (pixels)", 4.0)

    def attach(self, vobj: Any) -> None:
        self._add_properties(vobj)
        self.Object = vobj.Object
        self.surface = ColouredMesh(lit=True)
        self.points = ColouredPoints(vobj.PointSize)
        self.legends = {"Surface": ColourLegend(), "Points": ColourLegend()}
        for mode, node in (("Surface", self.surface.node), ("Points", self.points.node)):
            sep = coin.SoSeparator()
            sep.addChild(node)
            sep.addChild(self.legends[mode].node)
            vobj.addDisplayMode(sep, mode)
        self._update(vobj.Object)

    def getDisplayModes(self, vobj: Any) -> list[str]:  # noqa: N802
        return ["Surface", "Points"]

    def getDefaultDisplayMode(self) -> str:  # noqa: N802
        return "Surface"

    def claimChildren(self) -> list:  # noqa: N802
        return []

    def updateData(self, obj: Any, prop: str) -> None:  # noqa: N802
        if prop in ("Deviations", "AlignedPoints", "SurfaceDeviations", "SurfaceGrid", "SurfaceGridSize", "Tolerance") \
                and hasattr(self, "surface"):
            self._update(obj)

    def onChanged(self, vobj: Any, prop: str) -> None:  # noqa: N802
        if not hasattr(self, "surface"):
            return
        if prop == "ColourRange":
            self._update(vobj.Object)
        elif prop == "PointSize":
            self.points.style.pointSize = vobj.PointSize

    def limit(self, values: np.ndarray) -> float:
        vobj = self.Object.ViewObject
        chosen = getattr(vobj, "ColourRange", 0.0)
        return chosen if chosen > 0 else colormap.deviation_limit(values, self.Object.Tolerance)

    def _update(self, obj: Any) -> None:
        tol = obj.Tolerance
        dev = np.array(obj.Deviations, float)
        if len(dev) and len(obj.AlignedPoints) == len(dev):
            lim = self.limit(dev)
            self.points.set(np.array([(p.x, p.y, p.z) for p in obj.AlignedPoints]), colormap.deviation_colours(dev, lim))
            self._legend("Points", lim, tol)
        size = list(obj.SurfaceGridSize)
        sdev = np.array(obj.SurfaceDeviations, float)
        if len(size) == 2 and len(sdev) == size[0] * size[1] == len(obj.SurfaceGrid):
            grid = np.array([(p.x, p.y, p.z) for p in obj.SurfaceGrid]).reshape(size[0], size[1], 3)
            self.surface.set_geometry(grid, colormap.grid_normals(grid))
            lim = self.limit(sdev)
            self.surface.set_colours(colormap.deviation_colours(sdev, lim))
            self._legend("Surface", lim, tol)

    def _legend(self, mode: str, limit: float, tolerance: float) -> None:
        what = "surface" if mode == "Surface" else "points"
        ticks = [(v / limit, label) for v, label in colormap.legend_ticks(limit, tolerance)]
        note = f"tolerance ±{tolerance:.4f} mm" + ("" if tolerance < limit else " (beyond the bar)")
        self.legends[mode].update(lambda t: colormap.deviation_colours(t * limit, limit), ticks,
                                  f"{what} - nominal, mm\n+ outside, - inside", band=(tolerance / limit, note))


for _kind in ("MeasuredPoints", "BladeSections", "BladeSurface", "DeviationAnalysis"):
    objects.register_view_provider(_kind, globals()[f"ViewProvider{_kind}"])
