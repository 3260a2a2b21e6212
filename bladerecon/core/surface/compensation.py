# SPDX-License-Identifier: LGPL-2.1-or-later
"""Probe-radius and coating compensation of measured sections (issue 16, item 5).

A touch probe reports the centre of its ball, which lies the ball's radius R off the surface
along the surface normal; an optical scan of a coated part sees the coating's outer surface, a
thickness T off the metal. In a section plane the measured path is then the offset curve of the
profile at distance ``R + T``, and an offset curve has the same normals as the curve it offsets.
So each point is moved back by ``R + T`` against the outward normal of the measured path at it:

1. the section's points (ordered, counter-clockwise about the span axis: :class:`SectionSet`)
   are fitted by the reconstruction's own closed section curve, chosen as it chooses
   (:func:`~bladerecon.core.surface.section_curves.choose_method`: interpolation for sparse
   plans, a noise-consistent smoothing spline for dense noisy sections), so that noise does not
   become normal noise;
2. the outward normal at each point's foot on that curve is ``tangent x plane normal`` in the
   section's best-fit plane;
3. the point moves by ``-(R + T) * normal``.

Exact for noise-free points on the offset path up to the curve fit's tangent error ``δ``: the
compensated point is off by ``(R + T)(1 - cos δ)`` across the profile (and ``(R + T) sin δ``
along it, which does not change the shape). A point where the measured path is curved more
tightly than ``1 / (R + T)`` cannot be an offset path at that distance (the ball would not fit):
that is refused, naming the section and line (with a margin, :data:`TIGHT_MARGIN`, for the fit's
curvature overshoot where an edge circle meets a flank).
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.bspline import curve_derivatives
from bladerecon.core.sections.ordering import Section, SectionSet

__all__ = ["compensate_points", "compensate_sections", "outward_normals"]

# the fitted curve overshoots the curvature where an edge circle meets a flank (a curvature jump):
# a path is refused only when it turns tighter than this share of the offset
TIGHT_MARGIN = 0.8


def outward_normals(sections: SectionSet) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Per section: the unit outward normal (n, 3) at every point, in the section's plane, and
    the curvature (1/mm, > 0 convex) of the fitted section curve there."""
    from bladerecon.core.reconstruct import _fit_sections
    from bladerecon.core.surface.section_curves import choose_method

    pts = [np.asarray(s.points, float) for s in sections.sections]
    curves = _fit_sections(pts, choose_method(pts), None)
    a = np.asarray(sections.span_axis, float)
    normals, curvature = [], []
    for s, p, sc in zip(sections.sections, pts, curves):
        c = p - p.mean(axis=0)
        plane = np.linalg.svd(c, full_matrices=False)[2][-1]
        plane = plane if plane @ a >= 0 else -plane
        off = float(np.abs(c @ plane).max())
        if off > max(0.01, 0.005 * float(np.ptp(c, axis=0).max())):
            raise BladeReconError(
                f"{sections.source}: section '{s.name}' is not planar (points up to {off:.3f} mm off its plane): "
                "probe-radius and coating compensation work on sections in planes")
        d = curve_derivatives(sc.curve, np.asarray(sc.t_points, float), 2)
        d1, d2 = d[:, 1], d[:, 2]
        t = d1 - np.outer(d1 @ plane, plane)
        n = np.cross(t, plane)
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        # signed curvature in the plane: > 0 where the loop turns counter-clockwise (convex)
        k = (np.cross(d1, d2) @ plane) / np.maximum(np.linalg.norm(t, axis=1) ** 3, 1e-300)
        normals.append(n)
        curvature.append(k)
    return normals, curvature


def compensate_sections(sections: SectionSet, probe_radius: float = 0.0, coating: float = 0.0) -> SectionSet:
    """The sections with every point moved ``probe_radius + coating`` (mm) toward the material
    (see the module text); same order, lines and names."""
    offset = float(probe_radius) + float(coating)
    if not np.isfinite(offset) or probe_radius < 0 or coating < 0:
        raise BladeReconError("--probe-radius and --coating must be zero or positive distances in mm")
    if offset == 0.0:
        return sections
    normals, curvature = outward_normals(sections)
    out = []
    for s, n, k in zip(sections.sections, normals, curvature):
        tight = np.flatnonzero(k * offset >= 1.0 / TIGHT_MARGIN)
        if tight.size:
            i = int(tight[np.argmax(k[tight])])
            raise BladeReconError(
                f"{sections.source}: section '{s.name}', line {int(s.lines[i])}: the measured path turns with a "
                f"radius of {1.0 / k[i]:.3f} mm, smaller than the {offset:g} mm to take off (probe radius + "
                "coating): a ball that size cannot have made it; check --probe-radius and --coating")
        moved = np.asarray(s.points, float) - offset * n
        out.append(Section(index=s.index, name=s.name, points=moved, lines=np.array(s.lines), reordered=s.reordered))
    return SectionSet(sections=tuple(out), span_axis=np.array(sections.span_axis), source=sections.source)


def compensate_points(pointset, probe_radius: float = 0.0, coating: float = 0.0) -> np.ndarray:
    """The points of a sectioned :class:`~bladerecon.core.io.readers.PointSet`, in its own order,
    moved as :func:`compensate_sections` moves them (matched back by their line numbers)."""
    from bladerecon.core.sections.ordering import build_sections

    lines = np.asarray(pointset.line)
    order = np.argsort(lines, kind="stable")
    out = np.array(pointset.points, float)
    for s in compensate_sections(build_sections(pointset), probe_radius, coating).sections:
        out[order[np.searchsorted(lines[order], np.asarray(s.lines))]] = s.points
    return out
