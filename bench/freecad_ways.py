# SPDX-License-Identifier: LGPL-2.1-or-later
"""FreeCAD's own ways to put a surface through blade sections, done as a careful user would.

Every way gets each section as an (n, 3) array (mm) in the same order (counter-clockwise
about the span axis) and its leading-edge point; the section is rolled so that it starts
at its point nearest the leading edge, so every seam lies at the LE and no way is
penalised for a seam it could not place.

* :func:`loft_periodic` — ``Part.BSplineCurve.interpolate(PeriodicFlag=True)`` per
  section, then ``Part.makeLoft(wires, solid=False, ruled=False)`` (FreeCAD 0.20:
  ``makeLoft(list, solid, ruled, closed, maxDegree=5)``).
* :func:`loft_closed` — the same loft, but each section interpolated non-periodic with its
  first point appended (a closed curve with a C0 seam at the LE).
* :func:`grid_interpolate` — each section interpolated periodic, then
  ``curve.discretize(Number=N+1)`` (N points at equal arc length from the LE, the closing
  point appended so the grid closes), and ``Part.BSplineSurface().interpolate(grid)``.

Each returns the shape and a short description of its poles.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from bladerecon.fc.freecad_env import import_freecad

__all__ = ["start_at_leading_edge", "loft_periodic", "loft_closed", "grid_interpolate", "poles_text"]

FreeCAD, Part = import_freecad()

GRID_POINTS = 200  # points per section in the interpolated grid (before the closing point)


def start_at_leading_edge(section: np.ndarray, le: np.ndarray) -> np.ndarray:
    """The section's points rolled to start at the point nearest ``le`` (order kept)."""
    return np.roll(section, -int(np.argmin(np.linalg.norm(section - le, axis=1))), axis=0)


def _vectors(points: np.ndarray) -> list[Any]:
    return [FreeCAD.Vector(*map(float, p)) for p in points]


def _section_curve(points: np.ndarray, periodic: bool) -> Any:
    curve = Part.BSplineCurve()
    vectors = _vectors(points)
    if periodic:
        curve.interpolate(Points=vectors, PeriodicFlag=True)
    else:
        curve.interpolate(Points=vectors + vectors[:1])
    return curve


def loft_periodic(sections: list[np.ndarray]) -> Any:
    """Loft (not ruled, not solid) through periodic interpolating section curves."""
    wires = [Part.Wire(_section_curve(s, True).toShape()) for s in sections]
    return Part.makeLoft(wires, False, False)


def loft_closed(sections: list[np.ndarray]) -> Any:
    """Loft (not ruled, not solid) through closed non-periodic interpolating section curves."""
    wires = [Part.Wire(_section_curve(s, False).toShape()) for s in sections]
    return Part.makeLoft(wires, False, False)


def grid_interpolate(sections: list[np.ndarray], n: int = GRID_POINTS) -> Any:
    """Face of ``Part.BSplineSurface().interpolate`` through the sections resampled at equal arc length."""
    grid = [_section_curve(s, True).discretize(Number=n + 1) for s in sections]
    surface = Part.BSplineSurface()
    surface.interpolate(grid)
    return Part.Face(surface)


def poles_text(shape: Any, around_is_u: bool = True) -> str:
    """Poles as 'around x span' (summed over faces when the shape has several)."""
    counts = []
    for face in shape.Faces:
        s = face.Surface
        nu, nv = int(s.NbUPoles), int(s.NbVPoles)
        counts.append((nu, nv) if around_is_u else (nv, nu))
    if len(counts) == 1:
        return f"{counts[0][0]}×{counts[0][1]}"
    spans = {c[1] for c in counts}
    span = spans.pop() if len(spans) == 1 else "?"
    return f"{sum(c[0] for c in counts)}×{span} ({len(counts)} faces)"
