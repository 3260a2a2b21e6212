# SPDX-License-Identifier: LGPL-2.1-or-later
"""Shape error against a nominal blade (STEP/IGES/BREP/FCStd): signed distances in mm.

Stage "analysis" of the pipeline (seed 000 §2.4 shape error; seed 001 §2 minimum distance).
A nominal that is one non-rational B-spline face goes through the core's vectorised
projection (:mod:`bladerecon.core.geometry.projection`); any other shape face by face
(:class:`bladerecon.fc.deviation.Nominal`: trimmed B-spline and analytic faces through the
core, OpenCASCADE only for a face no core model covers); ``method`` then names the way of
every face (``0:core-bspline+1:core-cone+...``). Sign: + where the point is outside the
nominal (material in excess), − inside.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.bspline import evaluate_surface
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.orientation import outward_sign
from bladerecon.core.geometry.projection import project_points_to_surface
from bladerecon.core.geometry.spline import BSplineSurface

__all__ = ["Deviation", "deviation_to_nominal", "surface_samples", "outward_sign"]


@dataclass(frozen=True)
class Deviation:
    signed: np.ndarray   # (m,) mm, + outside the nominal
    method: str          # "core-projection", or per face "index:way" joined by "+"


def surface_samples(surface: BSplineSurface, n_u: int = 400, n_v: int = 41) -> tuple[np.ndarray, np.ndarray]:
    """A grid of points on the surface for surface-to-nominal comparison: ((m, 2) uv, (m, 3) xyz).

    u samples follow the knots (8 per span) so round edges, where knots are dense, are
    sampled as densely as the surface can change there; v is sampled evenly.
    """
    k = np.asarray(surface.u_knots, float)
    per = max(2, int(np.ceil(n_u / (k.size - 1))))
    f = np.arange(per) / per
    u = (k[:-1, None] + np.diff(k)[:, None] * f[None, :]).ravel()
    v0, v1 = surface.v_domain
    v = np.linspace(v0, v1, n_v)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    uv = np.column_stack([uu.ravel(), vv.ravel()])
    return uv, evaluate_surface(surface, uv[:, 0], uv[:, 1])


def _single_bspline_face(shape):
    faces = shape.Faces
    if len(faces) != 1:
        return None
    face = faces[0]
    surf = face.Surface
    if type(surf).__name__ != "BSplineSurface" or surf.isURational() or surf.isVRational():
        return None
    # the face must use the whole surface (untrimmed): compare parameter ranges
    u0, u1, v0, v1 = face.ParameterRange
    U0, U1, V0, V1 = surf.bounds()
    span = max(U1 - U0, V1 - V0)
    if max(abs(u0 - U0), abs(u1 - U1), abs(v0 - V0), abs(v1 - V1)) > 1e-9 * max(span, 1.0):
        return None
    return face


def deviation_to_nominal(points: np.ndarray, nominal) -> Deviation:
    """Signed distance (mm) of each point to the nominal (a path or a Part.Shape)."""
    from bladerecon.fc.convert import from_part_surface
    from bladerecon.fc.export import read_shape

    shape = read_shape(nominal) if isinstance(nominal, (str, bytes)) or hasattr(nominal, "__fspath__") else nominal
    pts = np.asarray(points, dtype=float)
    face = _single_bspline_face(shape)
    if face is not None:
        surf = from_part_surface(face.Surface)
        proj = project_points_to_surface(surf, pts)
        if surf.u_periodic:   # a closed blade surface: outward is decided by the geometry
            sign = outward_sign(surf)
        else:                 # an open face: the face's own orientation says which side is out
            sign = -1.0 if face.Orientation == "Reversed" else 1.0
        return Deviation(sign * proj.signed, "core-projection")
    if not shape.Faces:
        raise BladeReconError("the nominal has no faces: export the blade surface or solid to STEP")
    from bladerecon.fc.deviation import Nominal

    nominal = Nominal(shape)
    dev = nominal.measure(pts)
    return Deviation(np.asarray(dev.signed, float), "+".join(nominal.methods))
