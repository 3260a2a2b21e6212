# SPDX-License-Identifier: LGPL-2.1-or-later
"""The multi-face test nominal of :mod:`bladerecon.samples.multiface` built as a FreeCAD solid:
four restricted B-spline airfoil faces trimmed by a hub of revolution and a conical casing.
"""
from __future__ import annotations

import os
from typing import Any

import numpy as np

from bladerecon.core.errors import BladeReconError

from bladerecon.fc.freecad_env import import_freecad

__all__ = ["build_multiface_nominal", "write_multiface_nominal"]

FreeCAD, Part = import_freecad()


def _unit(a: np.ndarray) -> np.ndarray:
    return a / np.linalg.norm(a)


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
