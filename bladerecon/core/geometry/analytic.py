# SPDX-License-Identifier: LGPL-2.1-or-later
"""Closest points on the surfaces of CAD faces that are not B-splines, in closed form or by
reduction to a curve: planes, cylinders, cones, spheres, tori, surfaces of revolution and of
linear extrusion, offset surfaces; and the B-spline surface itself, behind the same interface.

Every model projects many points at once (numpy, no loop over points) and returns a
:class:`~bladerecon.core.geometry.projection.Projection` (``project``; ``project_all`` gives
every local foot that can be a face's nearest point: both nappes of a cone): the foot's (u, v) in the
parameterisation OpenCASCADE uses for that surface (so that a face's trimming loops, given
as pcurves in those parameters, apply to it), the foot, the distance, the distance signed
along the normal ``S_u x S_v``, and that unit normal.

Parameterisations (``e(u) = cos u X + sin u Y``; X, Y, Z orthonormal, either handedness):

* plane ``O + u X + v Y``; cylinder ``O + R e(u) + v Z``;
* cone ``O + (R + v sin a) e(u) + v cos a Z``; sphere ``O + R cos v e(u) + R sin v Z``;
* torus ``O + (R + r cos v) e(u) + r sin v Z``;
* revolution ``L + z(v) D + r(v) (cos u E0 + sin u D x E0)``: the meridian (r(v), z(v)) is the
  basis curve written in its own half-plane, a 2D B-spline with the basis curve's knots
  (the basis curve must lie in a plane through the axis); the foot lies in the point's own
  meridian half-plane, so a point is projected onto the 2D meridian curve
  (:func:`~bladerecon.core.geometry.projection.project_points_to_curve`);
* linear extrusion ``C(u) + v D``: the curve seen along D is a 2D B-spline; the 2D foot
  gives u, and v follows;
* offset ``S(u, v) + d N(u, v)``: the basis surface's foot, moved by d along its normal
  (valid while |d| is less than the radii of curvature on that side, as for OCC's own).

A point on an axis (or at a sphere's centre) has every angle as a foot: u = 0 is taken.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bladerecon.core.geometry.bspline import curve_derivatives
from bladerecon.core.geometry.projection import Projection, project_points_to_curve, project_points_to_surface
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

__all__ = ["PlaneModel", "CylinderModel", "ConeModel", "SphereModel", "TorusModel", "RevolutionModel",
           "ExtrusionModel", "OffsetModel", "BSplineModel", "TWO_PI"]

TWO_PI = 2.0 * np.pi


def _unit(a: np.ndarray) -> np.ndarray:
    a = np.asarray(a, float)
    return a / np.linalg.norm(a)


def _finish(u, v, foot, P, Su, Sv) -> Projection:
    """Projection from feet and first derivatives: normal Su x Sv (the offset where it vanishes)."""
    off = P - foot
    dist = np.sqrt(np.einsum("ij,ij->i", off, off))
    n = np.cross(Su, Sv)
    n_len = np.linalg.norm(n, axis=1)
    scale = np.sqrt(np.maximum(np.einsum("ij,ij->i", Su, Su) * np.einsum("ij,ij->i", Sv, Sv), 1e-300))
    degenerate = n_len <= 1e-14 * scale
    n = np.where(degenerate[:, None], off / np.maximum(dist, 1e-300)[:, None],
                 n / np.where(degenerate, 1.0, n_len)[:, None])
    signed = np.where(np.einsum("ij,ij->i", off, n) < 0, -dist, dist)
    return Projection(u=u, v=v, foot=foot, distance=dist, signed=signed, normal=n,
                      converged=np.ones(len(u), dtype=bool))


def _key(*parts) -> tuple:
    return tuple(np.round(np.asarray(p, float).ravel(), 12).tobytes() if isinstance(p, (np.ndarray, list, tuple))
                 else p for p in parts)


@dataclass(frozen=True)
class _Frame:
    origin: np.ndarray
    x: np.ndarray
    y: np.ndarray
    z: np.ndarray

    def local(self, P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q = np.asarray(P, float) - self.origin
        return q @ self.x, q @ self.y, q @ self.z

    def e(self, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c, s = np.cos(u)[:, None], np.sin(u)[:, None]
        return c * self.x + s * self.y, -s * self.x + c * self.y


@dataclass(frozen=True)
class PlaneModel(_Frame):
    kind = "plane"
    u_period = None
    v_period = None

    @property
    def key(self):
        return _key("plane", self.origin, self.x, self.y)

    def project(self, P: np.ndarray) -> Projection:
        P = np.asarray(P, float)
        u, v, _ = self.local(P)
        foot = self.origin + u[:, None] * self.x + v[:, None] * self.y
        m = len(P)
        return _finish(u, v, foot, P, np.broadcast_to(self.x, (m, 3)), np.broadcast_to(self.y, (m, 3)))


@dataclass(frozen=True)
class CylinderModel(_Frame):
    radius: float = 1.0
    kind = "cylinder"
    u_period = TWO_PI
    v_period = None

    @property
    def key(self):
        return _key("cylinder", self.origin, self.x, self.y, self.z, self.radius)

    def project(self, P: np.ndarray) -> Projection:
        P = np.asarray(P, float)
        a, b, c = self.local(P)
        u = np.mod(np.arctan2(b, a), TWO_PI)
        e, de = self.e(u)
        foot = self.origin + self.radius * e + c[:, None] * self.z
        return _finish(u, c, foot, P, self.radius * de, np.broadcast_to(self.z, (len(P), 3)))


@dataclass(frozen=True)
class ConeModel(_Frame):
    radius: float = 1.0
    semi_angle: float = 0.0
    kind = "cone"
    u_period = TWO_PI
    v_period = None

    @property
    def key(self):
        return _key("cone", self.origin, self.x, self.y, self.z, self.radius, self.semi_angle)

    def project_all(self, P: np.ndarray) -> list[Projection]:
        """The feet on both nappes: the meridian line (R + v s, v c) in the point's own
        half-plane, and in the opposite one (its part beyond the apex, R + v s < 0), each
        held at the apex. Both count: a face on one nappe is nearest a point at its own
        nappe's foot even where the other nappe's is nearer."""
        P = np.asarray(P, float)
        a, b, h = self.local(P)
        rho, phi = np.hypot(a, b), np.arctan2(b, a)
        s, c, R = np.sin(self.semi_angle), np.cos(self.semi_angle), self.radius
        out = []
        for side in (1.0, -1.0) if s != 0.0 else (1.0,):
            v = (side * rho - R) * s + h * c
            if s != 0.0:
                apex = -R / s
                v = np.maximum(v, apex) if (side > 0) == (s > 0) else np.minimum(v, apex)
            u = np.mod(phi + (0.0 if side > 0 else np.pi), TWO_PI)
            e, de = self.e(u)
            r = R + v * s
            foot = self.origin + r[:, None] * e + (v * c)[:, None] * self.z
            out.append(_finish(u, v, foot, P, r[:, None] * de, s * e + c * self.z))
        return out

    def project(self, P: np.ndarray) -> Projection:
        return _nearest(self.project_all(P))


def _nearest(candidates: list[Projection]) -> Projection:
    """Per point, the candidate foot with the least distance."""
    best = candidates[0]
    for other in candidates[1:]:
        w = other.distance < best.distance
        best = Projection(*(np.where(w.reshape((-1,) + (1,) * (np.ndim(x) - 1)), y, x)
                            for x, y in zip((best.u, best.v, best.foot, best.distance, best.signed, best.normal,
                                             best.converged),
                                            (other.u, other.v, other.foot, other.distance, other.signed, other.normal,
                                             other.converged))))
    return best


@dataclass(frozen=True)
class SphereModel(_Frame):
    radius: float = 1.0
    kind = "sphere"
    u_period = TWO_PI
    v_period = None

    @property
    def key(self):
        return _key("sphere", self.origin, self.x, self.y, self.z, self.radius)

    def project(self, P: np.ndarray) -> Projection:
        P = np.asarray(P, float)
        a, b, c = self.local(P)
        rho = np.hypot(a, b)
        u = np.mod(np.arctan2(b, a), TWO_PI)
        v = np.arctan2(c, rho)
        e, de = self.e(u)
        R = self.radius
        cv, sv = np.cos(v)[:, None], np.sin(v)[:, None]
        foot = self.origin + R * cv * e + R * sv * self.z
        return _finish(u, v, foot, P, R * cv * de, -R * sv * e + R * cv * self.z)


@dataclass(frozen=True)
class TorusModel(_Frame):
    major: float = 1.0
    minor: float = 0.1
    kind = "torus"
    u_period = TWO_PI
    v_period = TWO_PI

    @property
    def key(self):
        return _key("torus", self.origin, self.x, self.y, self.z, self.major, self.minor)

    def project(self, P: np.ndarray) -> Projection:
        P = np.asarray(P, float)
        a, b, c = self.local(P)
        rho = np.hypot(a, b)
        u = np.mod(np.arctan2(b, a), TWO_PI)
        v = np.mod(np.arctan2(c, rho - self.major), TWO_PI)
        e, de = self.e(u)
        R, r = self.major, self.minor
        cv, sv = np.cos(v)[:, None], np.sin(v)[:, None]
        foot = self.origin + (R + r * cv) * e + r * sv * self.z
        return _finish(u, v, foot, P, (R + r * cv) * de, -r * sv * e + r * cv * self.z)


@dataclass(frozen=True)
class RevolutionModel:
    """Surface of revolution: axis point ``location``, unit ``direction`` D, ``e0`` the unit
    radial direction of the basis curve's half-plane, ``meridian`` (r, z) a 2D B-spline."""

    location: np.ndarray
    direction: np.ndarray
    e0: np.ndarray
    meridian: BSplineCurve
    v_period: float | None = None
    kind = "revolution"
    u_period = TWO_PI
    _crosses_axis: bool = field(default=False)

    @property
    def key(self):
        m = self.meridian
        return _key("revolution", self.location, self.direction, self.e0, m.poles, m.knots, m.mults, m.degree)

    def project_all(self, P: np.ndarray) -> list[Projection]:
        """The foot in the point's own meridian half-plane, and where the meridian crosses
        the axis (r < 0 somewhere) the one in the opposite half-plane too."""
        P = np.asarray(P, float)
        D, e0 = self.direction, self.e0
        e1 = np.cross(D, e0)
        q = P - self.location
        h, a, b = q @ D, q @ e0, q @ e1
        rho = np.hypot(a, b)
        phi = np.arctan2(b, a)
        sides = (1.0, -1.0) if (self._crosses_axis or float(np.min(self.meridian.poles[:, 0])) < 0.0) else (1.0,)
        out = []
        for side in sides:
            t = project_points_to_curve(self.meridian, np.column_stack([side * rho, h])).t
            u = np.mod(phi + (0.0 if side > 0 else np.pi), TWO_PI)
            d = curve_derivatives(self.meridian, t, 1)             # (m, 2, 2): value, first derivative
            r, z, dr, dz = d[:, 0, 0], d[:, 0, 1], d[:, 1, 0], d[:, 1, 1]
            c, s = np.cos(u)[:, None], np.sin(u)[:, None]
            e, de = c * e0 + s * e1, -s * e0 + c * e1
            foot = self.location + z[:, None] * D + r[:, None] * e
            out.append(_finish(u, t, foot, P, r[:, None] * de, dr[:, None] * e + dz[:, None] * D))
        return out

    def project(self, P: np.ndarray) -> Projection:
        return _nearest(self.project_all(P))


@dataclass(frozen=True)
class ExtrusionModel:
    """Surface of linear extrusion ``C(u) + v D``: ``curve`` is C written in the frame
    (``origin``; e1, e2, D): a 3D B-spline whose first two coordinates are the curve seen along D."""

    origin: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    direction: np.ndarray
    curve: BSplineCurve
    u_period: float | None = None
    kind = "extrusion"
    v_period = None

    @property
    def key(self):
        c = self.curve
        return _key("extrusion", self.origin, self.e1, self.e2, self.direction, c.poles, c.knots, c.mults, c.degree)

    def _plane_curve(self) -> BSplineCurve:
        c = self.curve
        return BSplineCurve(np.ascontiguousarray(c.poles[:, :2]), c.knots, c.mults, c.degree, c.periodic)

    def project(self, P: np.ndarray) -> Projection:
        P = np.asarray(P, float)
        q = P - self.origin
        x, y, w = q @ self.e1, q @ self.e2, q @ self.direction
        plane = self.__dict__.get("_plane")
        if plane is None:
            plane = self._plane_curve()
            object.__setattr__(self, "_plane", plane)
        pr = project_points_to_curve(plane, np.column_stack([x, y]))
        d = curve_derivatives(self.curve, pr.t, 1)
        c3, dc3 = d[:, 0], d[:, 1]
        v = w - c3[:, 2]
        frame = np.stack([self.e1, self.e2, self.direction])
        foot = self.origin + c3 @ frame + v[:, None] * self.direction
        return _finish(pr.t, v, foot, P, dc3 @ frame, np.broadcast_to(self.direction, (len(P), 3)))


@dataclass(frozen=True)
class OffsetModel:
    """Offset surface ``S + d N`` of another model."""

    basis: object
    offset: float
    kind = "offset"

    @property
    def u_period(self):
        return self.basis.u_period

    @property
    def v_period(self):
        return self.basis.v_period

    @property
    def key(self):
        return ("offset", self.basis.key, float(self.offset))

    def project(self, P: np.ndarray) -> Projection:
        """The basis's foot moved along its normal. Where the basis foot is held on the
        basis's own boundary (the offset from it is not along the normal), the offset
        surface's nearest point is elsewhere on its boundary: (u, v) is NaN there, so no
        face takes that foot and the face's edges decide."""
        P = np.asarray(P, float)
        pr = self.basis.project(P)
        foot = pr.foot + self.offset * pr.normal
        signed = pr.signed - self.offset
        off = P - pr.foot
        across = np.linalg.norm(off - np.einsum("ij,ij->i", off, pr.normal)[:, None] * pr.normal, axis=1)
        held = across > 1e-7 * np.maximum(pr.distance, 1.0)
        u, v = np.where(held, np.nan, pr.u), np.where(held, np.nan, pr.v)
        # there, only a lower bound of the distance is known: no offset point is nearer
        # than the basis less the offset
        dist = np.where(held, np.maximum(pr.distance - abs(self.offset), 0.0), np.abs(signed))
        return Projection(u=u, v=v, foot=foot, distance=dist, signed=signed,
                          normal=pr.normal, converged=pr.converged)


@dataclass(frozen=True)
class BSplineModel:
    """A non-rational B-spline surface: the core's exact projection."""

    surface: BSplineSurface
    kind = "bspline"

    @property
    def u_period(self):
        s = self.surface
        return float(s.u_knots[-1] - s.u_knots[0]) if s.u_periodic else None

    @property
    def v_period(self):
        s = self.surface
        return float(s.v_knots[-1] - s.v_knots[0]) if s.v_periodic else None

    @property
    def key(self):
        s = self.surface
        return _key("bspline", s.poles, s.u_knots, s.u_mults, s.v_knots, s.v_mults, s.u_degree, s.v_degree,
                    s.u_periodic, s.v_periodic)

    def project(self, P: np.ndarray) -> Projection:
        return project_points_to_surface(self.surface, P)
