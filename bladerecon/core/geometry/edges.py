# SPDX-License-Identifier: LGPL-2.1-or-later
"""Closest points on the boundary edges of CAD faces: line segments and circular arcs in
closed form, any other edge as a non-rational B-spline curve through the core's projection.

Each model keeps its edge's own parameter (OpenCASCADE's: a line's arc length, a circle's
angle, a B-spline's knots), so a foot's parameter finds the edge's samples (the normals of
the faces that meet there). ``project`` returns (t, foot, distance, at_end): at_end marks a
foot at one of the edge's ends (a vertex), where the faces that meet are more than two.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.projection import project_points_to_curve
from bladerecon.core.geometry.spline import BSplineCurve

__all__ = ["SegmentEdge", "ArcEdge", "SplineEdge"]


def _result(t, foot, P, t0, t1):
    dist = np.linalg.norm(P - foot, axis=1)
    span = abs(t1 - t0)
    at_end = (np.abs(t - t0) <= 1e-9 * span) | (np.abs(t - t1) <= 1e-9 * span)
    return t, foot, dist, at_end


@dataclass(frozen=True)
class SegmentEdge:
    """Straight edge from ``p0`` (parameter t0) to ``p1`` (t1)."""

    p0: np.ndarray
    p1: np.ndarray
    t0: float
    t1: float

    def project(self, P: np.ndarray):
        P = np.asarray(P, float)
        d = self.p1 - self.p0
        s = np.clip((P - self.p0) @ d / max(float(d @ d), 1e-300), 0.0, 1.0)
        return _result(self.t0 + s * (self.t1 - self.t0), self.p0 + s[:, None] * d, P, self.t0, self.t1)

    def sample(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        s = np.linspace(0.0, 1.0, n)
        return self.t0 + s * (self.t1 - self.t0), self.p0 + s[:, None] * (self.p1 - self.p0)


@dataclass(frozen=True)
class ArcEdge:
    """Circular arc ``centre + R (cos t X + sin t Y)`` for t in [t0, t1] (t1 - t0 <= 2 pi)."""

    centre: np.ndarray
    x: np.ndarray
    y: np.ndarray
    radius: float
    t0: float
    t1: float

    def point(self, t: np.ndarray) -> np.ndarray:
        return self.centre + self.radius * (np.cos(t)[:, None] * self.x + np.sin(t)[:, None] * self.y)

    def project(self, P: np.ndarray):
        P = np.asarray(P, float)
        q = P - self.centre
        phi = np.arctan2(q @ self.y, q @ self.x)
        t = self.t0 + np.mod(phi - self.t0, 2 * np.pi)              # in [t0, t0 + 2 pi)
        inside = t <= self.t1
        ends = np.array([self.t0, self.t1])
        pe = self.point(ends)
        d_end = np.linalg.norm(P[:, None, :] - pe[None], axis=2)
        t = np.where(inside, t, ends[np.argmin(d_end, axis=1)])
        return _result(t, self.point(t), P, self.t0, self.t1)

    def sample(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        t = np.linspace(self.t0, self.t1, n)
        return t, self.point(t)


@dataclass(frozen=True)
class SplineEdge:
    """An edge that is (or was converted to) a non-rational B-spline curve over [t0, t1]."""

    curve: BSplineCurve

    @property
    def t0(self) -> float:
        return float(self.curve.knots[0])

    @property
    def t1(self) -> float:
        return float(self.curve.knots[-1])

    def project(self, P: np.ndarray):
        P = np.asarray(P, float)
        pr = project_points_to_curve(self.curve, P)
        return pr.t, pr.foot, pr.distance, _result(pr.t, pr.foot, P, self.t0, self.t1)[3]

    def sample(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        from bladerecon.core.geometry.bspline import evaluate_curve

        t = np.linspace(self.t0, self.t1, n)
        return t, evaluate_curve(self.curve, t)
