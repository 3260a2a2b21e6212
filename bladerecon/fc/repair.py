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
from bladerecon.fc.freecad_env import import_freecad

__all__ = ["blade_surface", "target_shape", "tip_missing_shape"]

FreeCAD, Part = import_freecad()


def blade_surface(path: str) -> tuple[BSplineSurface, float, Any]:
    """The nominal's blade surface (the B-spline face of largest extent), the sign that
    turns its normal out of the material, and the :class:`Nominal` read from ``path``."""
    from bladerecon.fc.deviation import load_nominal

    nominal = load_nominal(path)
    if not nominal.core:
        raise BladeReconError(f"{path}: the nominal holds no untrimmed B-spline face: repair needs the "
                              "blade surface as one B-spline face (u around the section, v along the span)")

    def extent(item) -> float:
        poles = np.asarray(item[1].poles).reshape(-1, 3)
        return float(np.linalg.norm(poles.max(axis=0) - poles.min(axis=0)))

    _, surface, sign = max(nominal.core, key=extent)
    if not surface.u_periodic:
        raise BladeReconError(f"{path}: the nominal's blade face is not closed around the section "
                              "(not periodic in u): repair needs the whole blade surface in one face")
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
