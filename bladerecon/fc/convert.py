# SPDX-License-Identifier: LGPL-2.1-or-later
"""Copy the core's B-spline dataclasses to and from ``Part.BSplineCurve``/``Part.BSplineSurface``.

Both sides use OpenCASCADE's convention (distinct knots + multiplicities, periodic poles not
repeated), so the conversion is a one-to-one copy of poles, knots, multiplicities, degrees
and periodic flags. Units: millimetres on both sides.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

from bladerecon.fc.freecad_env import import_freecad

__all__ = ["to_part_surface", "to_part_curve", "from_part_surface", "from_part_curve", "make_face", "compound"]

FreeCAD, Part = import_freecad()


def compound(shapes: list) -> Any:
    """A ``Part.Compound`` of ``shapes`` (an empty list gives an empty compound).

    Not ``Part.makeCompound``: in FreeCAD 1.0 run headless (``import FreeCAD`` in a plain
    Python) it crashes the process with a segfault, which FreeCAD's own handler turns into a
    silent exit status 1. The ``Part.Compound`` constructor builds the same shape on 0.20 and 1.x.
    """
    return Part.Compound(list(shapes))


def _vector(p: np.ndarray) -> Any:
    return FreeCAD.Vector(float(p[0]), float(p[1]), float(p[2]))


def _floats(values: np.ndarray) -> list[float]:
    return [float(x) for x in np.asarray(values, dtype=float)]


def _ints(values: np.ndarray) -> list[int]:
    return [int(x) for x in np.asarray(values)]


def to_part_surface(s: BSplineSurface) -> Any:
    """``Part.BSplineSurface`` with the same poles, knots, multiplicities, degrees and periodic flags."""
    poles = np.asarray(s.poles, dtype=float)
    rows = [[_vector(p) for p in row] for row in poles]
    surface = Part.BSplineSurface()
    surface.buildFromPolesMultsKnots(
        rows,
        _ints(s.u_mults), _ints(s.v_mults),
        _floats(s.u_knots), _floats(s.v_knots),
        bool(s.u_periodic), bool(s.v_periodic),
        int(s.u_degree), int(s.v_degree),
    )
    return surface


def to_part_curve(c: BSplineCurve) -> Any:
    """``Part.BSplineCurve`` with the same poles, knots, multiplicities, degree and periodic flag.

    2D poles are placed in the z = 0 plane.
    """
    poles = np.asarray(c.poles, dtype=float)
    if poles.shape[1] == 2:
        poles = np.column_stack([poles, np.zeros(len(poles))])
    curve = Part.BSplineCurve()
    curve.buildFromPolesMultsKnots(
        [_vector(p) for p in poles], _ints(c.mults), _floats(c.knots), bool(c.periodic), int(c.degree)
    )
    return curve


def _geometry_of(shape_or_geometry: Any, kind: str) -> Any:
    """Accept a Part geometry, or a Face / Edge whose geometry is wanted."""
    attr = "Surface" if kind == "surface" else "Curve"
    return getattr(shape_or_geometry, attr, shape_or_geometry) if hasattr(shape_or_geometry, "ShapeType") else shape_or_geometry


def from_part_surface(part_surface: Any) -> BSplineSurface:
    """Core :class:`BSplineSurface` from a non-rational ``Part.BSplineSurface`` (or a Face on one).

    Raises :class:`BladeReconError` for a rational surface or one that is not a B-spline.
    """
    surface = _geometry_of(part_surface, "surface")
    if not isinstance(surface, Part.BSplineSurface):
        raise BladeReconError(
            f"expected a B-spline surface, got {type(surface).__name__}: convert it with toBSpline() first"
        )
    if surface.isURational() or surface.isVRational():
        raise BladeReconError("the surface is rational (weights differ): BladeRecon handles non-rational B-splines only")
    poles = np.array([[(p.x, p.y, p.z) for p in row] for row in surface.getPoles()], dtype=float)
    return BSplineSurface(
        poles=poles,
        u_knots=np.array(surface.getUKnots(), dtype=float),
        u_mults=np.array(surface.getUMultiplicities(), dtype=int),
        v_knots=np.array(surface.getVKnots(), dtype=float),
        v_mults=np.array(surface.getVMultiplicities(), dtype=int),
        u_degree=int(surface.UDegree),
        v_degree=int(surface.VDegree),
        u_periodic=bool(surface.isUPeriodic()),
        v_periodic=bool(surface.isVPeriodic()),
    )


def from_part_curve(part_curve: Any) -> BSplineCurve:
    """Core :class:`BSplineCurve` from a non-rational ``Part.BSplineCurve`` (or an Edge on one)."""
    curve = _geometry_of(part_curve, "curve")
    if not isinstance(curve, Part.BSplineCurve):
        raise BladeReconError(
            f"expected a B-spline curve, got {type(curve).__name__}: convert it with toBSpline() first"
        )
    if curve.isRational():
        raise BladeReconError("the curve is rational (weights differ): BladeRecon handles non-rational B-splines only")
    return BSplineCurve(
        poles=np.array([(p.x, p.y, p.z) for p in curve.getPoles()], dtype=float),
        knots=np.array(curve.getKnots(), dtype=float),
        mults=np.array(curve.getMultiplicities(), dtype=int),
        degree=int(curve.Degree),
        periodic=bool(curve.isPeriodic()),
    )


def make_face(s: BSplineSurface) -> Any:
    """``Part.Face`` on the whole parameter domain of the surface."""
    return Part.Face(to_part_surface(s))
