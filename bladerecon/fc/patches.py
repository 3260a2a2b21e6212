# SPDX-License-Identifier: LGPL-2.1-or-later
"""The local bicubic surface (seed 004 eqs. 9-11) as a sewn shell of Bézier patch faces.

Each cell of the C1 double-knot B-spline (:func:`bladerecon.core.surface.local_bicubic.bezier_patches`)
becomes one ``Part.BezierSurface`` face; the faces are sewn into one shell so that STEP
readers see shared edges, not a heap of loose patches. Units: mm.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.surface.local_bicubic import bezier_patches
from bladerecon.core.geometry.spline import BSplineSurface

from bladerecon.fc.freecad_env import import_freecad

__all__ = ["make_patch_shell", "SEW_TOLERANCE"]

FreeCAD, Part = import_freecad()

SEW_TOLERANCE = 1e-6    # mm: neighbouring patches share their boundary control points exactly


def _bezier_face(net: np.ndarray) -> Any:
    s = Part.BezierSurface()
    s.increase(3, 3)
    for i in range(4):
        for j in range(4):
            s.setPole(i + 1, j + 1, FreeCAD.Vector(*map(float, net[i, j])))
    return s.toShape()


def make_patch_shell(surface: BSplineSurface, tolerance: float = SEW_TOLERANCE) -> Any:
    """One shell of bicubic Bézier faces, sewn (``Shape.sewShape``) within ``tolerance`` mm."""
    nets = bezier_patches(surface)
    faces = [_bezier_face(nets[i, j]) for i in range(nets.shape[0]) for j in range(nets.shape[1])]
    shell = Part.Shell(faces)
    shell.sewShape(tolerance)
    shells = shell.Shells if shell.ShapeType != "Shell" else [shell]
    if len(shells) != 1:
        raise BladeReconError(f"sewing the {len(faces)} Bézier patches gave {len(shells)} shells, not one")
    return shells[0]
