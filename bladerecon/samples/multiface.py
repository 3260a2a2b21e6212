# SPDX-License-Identifier: LGPL-2.1-or-later
"""A multi-face nominal blade as a design tool writes it: the geometry (numpy only) from which
:mod:`bladerecon.fc.nominal_faces` builds the solid, and points to measure against it.

The sample blade (:class:`~bladerecon.samples.blade.SampleBlade`) is interpolated as in
:func:`~bladerecon.samples.blade.nominal_surface`, but over span fractions a little beyond the
hub and the tip (``h_range``), so that the flow path can cut it: the airfoil is **one**
periodic-in-u, clamped-in-v B-spline surface, split into four faces that are parameter-range
restrictions of it (LE strip, pressure side, TE strip, suction side; ``splits`` are the u
values of the joints, the seam u = 0 at the start of the LE strip). The flow path is a
rotor's annulus about the machine axis (+x, through ``axis_point``): the hub is a surface of
revolution of a non-rational cubic B-spline meridian (axial x, radius r), the casing (tip) a
cone. The solid is the extended airfoil solid intersected with the annulus, so the airfoil
faces end on the hub and tip in trimming curves that are not iso-parameter lines, and the
caps are the pieces of the hub and tip surfaces inside the blade's outline (faces trimmed
by a closed pcurve loop). Units: mm.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface
from bladerecon.samples.blade import SampleBlade, _length_table, t_at_length_fraction

__all__ = ["MultifaceSpec", "multiface_spec", "hub_radius", "tip_radius", "multiface_points"]

FACE_NAMES = ("LE", "pressure", "TE", "suction")


@dataclass(frozen=True)
class MultifaceSpec:
    """The geometry of the multi-face nominal (mm)."""

    airfoil: BSplineSurface            # periodic u (around), clamped v (span, beyond hub and tip)
    splits: tuple[float, ...]          # u of the joints LE|pressure, pressure|TE, TE|suction (LE starts at u = 0)
    axis_point: np.ndarray             # a point of the machine axis
    axis_dir: np.ndarray               # unit direction of the machine axis (+x)
    hub_meridian: BSplineCurve         # 2D (x along the axis, r radius), non-rational cubic
    tip_line: tuple[tuple[float, float], tuple[float, float]]   # (x, r) at both ends: a cone
    x_range: tuple[float, float]       # axial extent of the annulus

    def radius_and_axial(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r, x) of points (m, 3) about the machine axis."""
        q = np.asarray(points, float) - self.axis_point
        x = q @ self.axis_dir
        return np.linalg.norm(q - x[:, None] * self.axis_dir, axis=1), x


def _grid(blade: SampleBlade, heights: np.ndarray, frac: np.ndarray, weight: float) -> np.ndarray:
    return np.stack([blade.point(h, t_at_length_fraction(blade, h, frac, weight)) for h in heights])


def multiface_spec(blade: SampleBlade | None = None, n_span: int = 21, n_profile: int = 120,
                   h_range: tuple[float, float] = (-0.08, 1.08), hub_radius0: float = 250.0,
                   curvature_weight: float = 1.5) -> MultifaceSpec:
    """The multi-face nominal of ``blade`` (default :class:`SampleBlade`): see the module doc.

    ``n_profile`` rows around at equal fractions of curvature-weighted arc length, starting
    at the suction|LE joint of mid-span; ``n_span`` sections over ``h_range``; the machine
    axis is +x through (0, 0, -hub_radius0), so the blade's z is about r - hub_radius0.
    """
    from bladerecon.core.surface.skinning import closed_grid_parameters, interpolate_grid

    blade = blade or SampleBlade()
    _, table = _length_table(blade, 0.5, curvature_weight)
    totals = np.array([tab[1][-1] for tab in table])
    joints = np.concatenate([[0.0], np.cumsum(totals)]) / totals.sum()   # LE low|P|TE|S|LE up
    start = joints[4]                                # suction|LE joint: the seam
    frac = np.mod(start + np.arange(n_profile) / n_profile, 1.0)
    heights = np.linspace(h_range[0], h_range[1], n_span)
    grid = _grid(blade, heights, frac, curvature_weight)
    surface = interpolate_grid(grid, "chord")
    # u of the rows, then of the joints by linear interpolation between rows
    u_rows = closed_grid_parameters(grid)
    rel = np.mod(joints[[1, 2, 3]] - start, 1.0) * n_profile          # fractional row index
    splits = tuple(float(np.interp(r, np.arange(n_profile + 1), np.append(u_rows, 1.0))) for r in rel)

    axis_point = np.array([0.0, 0.0, -hub_radius0])
    axis_dir = np.array([1.0, 0.0, 0.0])
    z0, span = blade.hub_z, blade.span
    # hub: r(x) = R0 + z0 + 1.5 + 0.03 x + 2 (x/40)^2, a cubic B-spline through 7 points
    x_range = (-60.0, 60.0)
    xs = np.linspace(*x_range, 7)
    rs = hub_radius0 + z0 + 1.5 + 0.03 * xs + 2.0 * (xs / 40.0) ** 2
    hub = _interpolate_2d(np.column_stack([xs, rs]))
    tip = ((x_range[0], hub_radius0 + z0 + span - 2.0 - 0.06 * 60.0),
           (x_range[1], hub_radius0 + z0 + span - 2.0 + 0.06 * 60.0))
    return MultifaceSpec(surface, splits, axis_point, axis_dir, hub, tip, x_range)


def _interpolate_2d(points: np.ndarray) -> BSplineCurve:
    """Clamped cubic B-spline through points (n, 2), chord-length parameters, averaged knots."""
    from bladerecon.core.geometry.bspline import averaged_knots, chord_parameters, collocation_matrix
    from bladerecon.core.geometry.fitting import knots_from_full

    t = chord_parameters(points)
    U = averaged_knots(t, 3)
    knots, mults = knots_from_full(U)
    A = collocation_matrix(knots, mults, 3, False, len(points), t)
    A = A.toarray() if hasattr(A, "toarray") else np.asarray(A)
    poles = np.linalg.solve(A, points)
    return BSplineCurve(poles, knots, mults, 3, False)


def hub_radius(spec: MultifaceSpec, x: np.ndarray) -> np.ndarray:
    """Hub radius at axial positions x (by sampling the meridian densely)."""
    from bladerecon.core.geometry.bspline import evaluate_curve

    c = spec.hub_meridian
    xy = evaluate_curve(c, np.linspace(*c.domain, 4001))
    return np.interp(x, xy[:, 0], xy[:, 1])


def tip_radius(spec: MultifaceSpec, x: np.ndarray) -> np.ndarray:
    (x0, r0), (x1, r1) = spec.tip_line
    return r0 + (r1 - r0) * (np.asarray(x, float) - x0) / (x1 - x0)


def multiface_points(spec: MultifaceSpec, m: int, seed: int = 0, spread: float = 0.3) -> np.ndarray:
    """m points (mm) about the multi-face nominal, for measuring it.

    Half are spread over the airfoil (uniform in u, v over the surface, so some lie beyond
    the hub and the tip), pushed off along the normal by N(0, ``spread``); a quarter sit
    round the LE and TE (u near the edge strips, offsets from 0.6 mm in to 1.5 mm out, so
    that feet land on both flanks, the edge strip and the face joints); a quarter lie near
    the hub and tip caps (blends of two section points: mostly inside the outline, some
    beyond it or off the concave pressure side, at radii from 2 mm inside to 2 mm outside
    the cap). Far points on purpose: the hardest case for the projection, not a scan's.
    """
    from bladerecon.core.geometry.bspline import surface_derivatives

    rng = np.random.default_rng(seed)
    s = spec.airfoil
    (v0, v1) = s.v_domain
    n_a, n_e = m // 2, m // 4
    n_c = m - n_a - n_e

    def on_surface(u, v, offset):
        d = surface_derivatives(s, u, v, 1)
        n = np.cross(d[:, 1, 0], d[:, 0, 1])
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        return d[:, 0, 0] + n * offset[:, None]

    a = on_surface(rng.random(n_a), v0 + (v1 - v0) * rng.random(n_a), spread * rng.standard_normal(n_a))
    le_w = spec.splits[0]
    te_a, te_b = spec.splits[1], spec.splits[2]
    pick = rng.random(n_e) < 0.5
    u_e = np.where(pick, np.mod(rng.uniform(-1.5 * le_w, 1.5 * le_w, n_e), 1.0),
                   rng.uniform(te_a - 0.5 * (te_b - te_a), te_b + 0.5 * (te_b - te_a), n_e))
    e = on_surface(u_e, v0 + (v1 - v0) * rng.random(n_e), rng.uniform(-0.6, 1.5, n_e))
    # caps: a blend of two section points at the hub or the tip height, moved radially
    tip = rng.random(n_c) < 0.5
    h_frac = np.where(tip, 0.93, 0.07)
    v = v0 + (v1 - v0) * h_frac
    p1 = on_surface(rng.random(n_c), v, np.zeros(n_c))
    p2 = on_surface(rng.random(n_c), v, np.zeros(n_c))
    lam = rng.uniform(-0.05, 1.05, n_c)[:, None]
    c = p1 + lam * (p2 - p1)
    r, x = spec.radius_and_axial(c)
    target = np.where(tip, tip_radius(spec, x), hub_radius(spec, x)) + rng.uniform(-2.0, 2.0, n_c)
    q = c - spec.axis_point - x[:, None] * spec.axis_dir
    c = spec.axis_point + x[:, None] * spec.axis_dir + q * (target / r)[:, None]
    pts = np.concatenate([a, e, c])
    return pts[rng.permutation(m)]
