# SPDX-License-Identifier: LGPL-2.1-or-later
"""Stream-surface sections measured in the conformal m′–θ plane (issue 24 §6, issue 25 §3).

A section whose points are not planar but lie on a surface of revolution about the machine
axis (a stream surface: cone, cylinder, the curved hub-to-shroud surfaces of a mixed-flow
rotor) is measured where blade design tools draw it, in the plane of the meridional
coordinates m′ and θ:

* **meridional coordinates**: every point's axial coordinate ``a`` (along the axis from
  ``axis_point``) and radius ``r`` from the axis, and its angle θ about the axis
  (right-handed, from the axis-normal direction nearest +x; relative to the section's mean
  angle θ₀, so a section never crosses the ±π cut);
* **is it a stream-surface section?** (:func:`stream_surface`): the points' (a, r) must lie
  on one smooth meridional curve: a cubic least-squares spline ``w(u)`` across the principal
  direction ``u`` of the (a, r) points, whose largest perpendicular residual stays within
  ``5 σ + 1e-5 × size`` (σ: the points' noise, from their second differences along the loop;
  size: the section's extent; the spline's spans, evenly spaced, one per 60 points up to 6, are
  doubled while the curve misses half that and there are 12 points a span). A planar section
  (within :data:`NONPLANAR_LIMIT`, or the noise) is not one: a plane normal to the axis is a
  degenerate surface of revolution (its meridional curve a radial line) and is measured in its
  plane as before;
* **m′ = ∫ dm / r**: ``dm`` the meridional arc length along that curve (Gauss-Legendre
  quadrature of ``√(1 + w′²) / r(u)`` on a 256-interval table, exact to round-off for the
  spline), zero at the middle of the section's meridional extent, where ``r = r_ref``;
  m′ increases with the axial coordinate (with r on a surface normal to the axis);
* the map is **conformal** (angle-preserving): ``x = r_ref m′``, ``y = r_ref θ`` are mm at
  ``r_ref``, and a length dℓ in that plane is ``r / r_ref dℓ`` on the surface.

:class:`RevolutionSurface` maps 3D points to (m′, θ, offset) (offset: the signed distance
from the surface in the meridional plane, so the map round-trips exactly) and back.
:func:`measure_meridional` measures a segmented section there with the planar code of
:mod:`bladerecon.core.sections.parameters` (angles true; lengths scaled back to mm by the
local radius). numpy/scipy only. Units mm, angles in degrees at the interface.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import BSpline, make_lsq_spline

from bladerecon.core.errors import BladeReconError
from bladerecon.core.sections.chord_lines import chord_normal_crossings
from bladerecon.core.sections.segmentation import NONPLANAR_LIMIT, segment_section

__all__ = ["RevolutionSurface", "StreamSurfaceFit", "stream_surface", "cylindrical", "measure_meridional",
           "FRAME", "noise_estimate"]

#: the JSON's name of the frame
FRAME = "m'-theta"
_GL_X, _GL_W = np.polynomial.legendre.leggauss(10)
_TABLE = 256                 # intervals of the m′(u) table
_MARGIN = 0.05               # the curve is fitted and tabulated 5 % past the points' extent


def _unit(v, what: str) -> np.ndarray:
    v = np.asarray(v, float).reshape(-1)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) < 1e-12:
        raise BladeReconError(f"{what} {v.tolist()}: give three numbers X,Y,Z, not all zero")
    return v / np.linalg.norm(v)


def _axis_frame(axis) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit axis and the right-handed pair (e1, e2) normal to it: e1 the direction of +x
    normal to the axis (+y when the axis is near x), e2 = axis × e1."""
    a = _unit(axis, "axis")
    ref = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = ref - (ref @ a) * a
    e1 /= np.linalg.norm(e1)
    return a, e1, np.cross(a, e1)


def cylindrical(points, axis=(0.0, 0.0, 1.0), axis_point=(0.0, 0.0, 0.0)):
    """(a, r, θ) of points (n, 3) about the axis through ``axis_point``: a along the axis, r
    from it (mm), θ (rad, in (−π, π]) right-handed about it from e1 (+x normal to the axis)."""
    a, e1, e2 = _axis_frame(axis)
    d = np.asarray(points, float) - np.asarray(axis_point, float)
    x, y = d @ e1, d @ e2
    return d @ a, np.hypot(x, y), np.arctan2(y, x)


def noise_estimate(points) -> float:
    """σ (mm) of the points' noise from their second differences along the loop, the part
    normal to the chord of each triple: median / (1.177 √6) (a Rayleigh median; the curve's own
    bending ``κ h²`` adds to it, so it errs high: a looser, never tighter, tolerance)."""
    P = np.asarray(points, float)
    prev, nxt = np.roll(P, 1, axis=0), np.roll(P, -1, axis=0)
    d2 = prev - 2 * P + nxt
    t = nxt - prev
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-300)
    perp = d2 - (d2 * t).sum(axis=1, keepdims=True) * t
    return float(np.median(np.linalg.norm(perp, axis=1)) / (1.1774 * np.sqrt(6.0)))


class RevolutionSurface:
    """A surface of revolution: a meridional curve ``C(u) = c + u d + w(u) n`` in the (a, r)
    plane (``w`` a cubic spline) turned about the axis. m′ is zero at ``u_ref``."""

    def __init__(self, axis, axis_point, centre, d, spline: BSpline, lo: float, hi: float, theta0: float,
                 u_ref: float | None = None):
        self.axis, self.e1, self.e2 = _axis_frame(axis)
        self.axis_point = np.asarray(axis_point, float).reshape(3)
        self.centre, self.d = np.asarray(centre, float), np.asarray(d, float)
        self.n = np.array([-self.d[1], self.d[0]])
        self.spline, self.dspline, self.d2spline = spline, spline.derivative(1), spline.derivative(2)
        self.lo, self.hi, self.theta0 = float(lo), float(hi), float(theta0)
        self._nodes = np.linspace(self.lo, self.hi, _TABLE + 1)
        steps = self._integral(self._nodes[:-1], self._nodes[1:])
        self._cum = np.concatenate([[0.0], np.cumsum(steps)])
        self.u_ref = 0.5 * (self.lo + self.hi) if u_ref is None else float(u_ref)
        self._m0 = 0.0
        self._m0 = float(self.m_prime_of_u(np.array([self.u_ref]))[0])
        self.r_ref = float(self.curve(np.array([self.u_ref]))[0][0, 1])

    # -------------------------------------------------------------- the meridional curve
    def curve(self, u):
        """C(u), C′(u), C″(u) in (a, r) mm, each (k, 2)."""
        u = np.asarray(u, float)
        w, w1, w2 = self.spline(u), self.dspline(u), self.d2spline(u)
        c = self.centre + u[:, None] * self.d + w[:, None] * self.n
        return c, self.d + w1[:, None] * self.n, w2[:, None] * self.n

    def _speed_over_r(self, u):
        c, c1, _ = self.curve(u)
        return np.linalg.norm(c1, axis=-1) / c[..., 1]

    def _integral(self, u0, u1):
        """∫ from u0 to u1 of √(1 + w′²) / r du (10-point Gauss-Legendre; arrays)."""
        u0, u1 = np.asarray(u0, float), np.asarray(u1, float)
        half, mid = 0.5 * (u1 - u0), 0.5 * (u1 + u0)
        x = mid[:, None] + half[:, None] * _GL_X[None, :]
        c, c1, _ = self.curve(x.ravel())
        g = (np.linalg.norm(c1, axis=1) / c[:, 1]).reshape(x.shape)
        return half * (g @ _GL_W)

    def m_prime_of_u(self, u) -> np.ndarray:
        """m′ (dimensionless) at curve parameters u: the table's value at the interval start
        plus the quadrature of the rest (no interpolation: exact for the spline)."""
        u = np.asarray(u, float)
        k = np.clip(np.searchsorted(self._nodes, u, side="right") - 1, 0, _TABLE - 1)
        return self._cum[k] + self._integral(self._nodes[k], u) - self._m0

    def u_of_m_prime(self, mp) -> np.ndarray:
        """Inverse of :meth:`m_prime_of_u` (Newton from the table's linear interpolation)."""
        mp = np.asarray(mp, float) + self._m0
        u = np.interp(mp, self._cum, self._nodes)
        # past the table's ends: a straight continuation with the end slope
        span = (self._nodes[-1] - self._nodes[0]) / (self._cum[-1] - self._cum[0])
        u = np.where(mp < self._cum[0], self._nodes[0] + (mp - self._cum[0]) * span, u)
        u = np.where(mp > self._cum[-1], self._nodes[-1] + (mp - self._cum[-1]) * span, u)
        for _ in range(50):
            f = self.m_prime_of_u(u) + self._m0 - mp
            step = f / self._speed_over_r(u)
            u = u - step
            if np.all(np.abs(step) <= 1e-15 * max(1.0, abs(self.hi - self.lo))):
                break
        return u

    def radius_at(self, mp) -> np.ndarray:
        """Radius (mm) of the surface at m′."""
        return self.curve(self.u_of_m_prime(mp))[0][:, 1]

    # -------------------------------------------------------------- the maps
    def foot(self, M) -> tuple[np.ndarray, np.ndarray]:
        """Foot points on the meridional curve of (a, r) points (k, 2): their u and the signed
        distance along the curve's normal (+ to the left of C′, i.e. +n)."""
        M = np.asarray(M, float)
        u = (M - self.centre) @ self.d
        for _ in range(30):
            c, c1, c2 = self.curve(u)
            diff = c - M
            g = (diff * c1).sum(axis=1)
            gp = (c1 * c1).sum(axis=1) + (diff * c2).sum(axis=1)
            step = g / np.where(np.abs(gp) > 1e-300, gp, 1e-300)
            u = u - step
            if np.all(np.abs(step) <= 1e-14 * max(1.0, abs(self.hi - self.lo))):
                break
        c, c1, _ = self.curve(u)
        nrm = np.column_stack([-c1[:, 1], c1[:, 0]]) / np.linalg.norm(c1, axis=1, keepdims=True)
        return u, ((M - c) * nrm).sum(axis=1)

    def to_mtheta(self, points) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """3D points (k, 3) -> (m′, θ − θ₀ in (−π, π] rad, offset from the surface mm)."""
        a, r, th = cylindrical(points, self.axis, self.axis_point)
        u, off = self.foot(np.column_stack([a, r]))
        return self.m_prime_of_u(u), np.angle(np.exp(1j * (th - self.theta0))), off

    def to_space(self, mp, theta, offset=None) -> np.ndarray:
        """(m′, θ − θ₀ rad[, offset mm]) -> 3D points (k, 3) mm on (or offset from) the surface."""
        mp, theta = np.atleast_1d(np.asarray(mp, float)), np.atleast_1d(np.asarray(theta, float))
        u = self.u_of_m_prime(mp)
        c, c1, _ = self.curve(u)
        if offset is not None:
            nrm = np.column_stack([-c1[:, 1], c1[:, 0]]) / np.linalg.norm(c1, axis=1, keepdims=True)
            c = c + np.asarray(offset, float).reshape(-1)[:, None] * nrm
        th = theta + self.theta0
        radial = np.outer(np.cos(th), self.e1) + np.outer(np.sin(th), self.e2)
        return self.axis_point + np.outer(c[:, 0], self.axis) + c[:, 1:2] * radial

    def to_conformal(self, points) -> np.ndarray:
        """3D points -> (x, y) = (r_ref m′, r_ref θ) mm at r_ref."""
        mp, th, _ = self.to_mtheta(points)
        return self.r_ref * np.column_stack([mp, th])

    def from_conformal(self, xy) -> np.ndarray:
        """(x, y) mm at r_ref -> 3D points on the surface."""
        xy = np.atleast_2d(np.asarray(xy, float))
        return self.to_space(xy[:, 0] / self.r_ref, xy[:, 1] / self.r_ref)

    def scale_at(self, x) -> np.ndarray:
        """Length on the surface per length in the conformal plane at conformal x: r / r_ref."""
        return self.radius_at(np.asarray(x, float) / self.r_ref) / self.r_ref

    def as_dict(self) -> dict:
        return {"axis": self.axis.tolist(), "axis_point": self.axis_point.tolist(), "r_ref_mm": self.r_ref,
                "theta0_deg": float(np.degrees(self.theta0)),
                "m_prime_origin_a_r_mm": self.curve(np.array([self.u_ref]))[0][0].tolist()}


@dataclass(frozen=True)
class StreamSurfaceFit:
    """Whether a section lies on a surface of revolution, with the evidence (mm)."""

    surface: RevolutionSurface | None      # None: not a stream-surface section
    reason: str                            # why not ("" when it is one)
    flatness: float                        # largest distance of a point from its best-fit plane
    rms: float                             # meridional-curve residuals (perpendicular, in (a, r))
    max_residual: float
    tolerance: float
    noise: float
    spans: int

    def as_dict(self) -> dict:
        return {"rms_mm": self.rms, "max_mm": self.max_residual, "tolerance_mm": self.tolerance,
                "noise_mm": self.noise, "flatness_mm": self.flatness, "spline_spans": self.spans}


def _fit_curve(u: np.ndarray, w: np.ndarray, lo: float, hi: float, spans: int) -> BSpline:
    """Cubic least-squares spline w(u) on [lo, hi], interior knots evenly spaced over the points'
    extent (a meridian bends where it will, not where the points cluster: at the edges), at
    quantiles of u when a span would hold too few points for that."""
    order = np.argsort(u, kind="stable")
    us, ws = u[order], w[order]
    even = np.linspace(us[0], us[-1], spans + 1)[1:-1]
    for q in (even, np.quantile(us, np.arange(1, spans) / spans)):
        t = np.concatenate([[lo] * 4, q, [hi] * 4])
        try:
            return make_lsq_spline(us, ws, t, k=3)
        except (ValueError, np.linalg.LinAlgError):
            continue
    raise BladeReconError(f"stream_surface: no meridional curve of {spans} spans fits the points")


def stream_surface(points, axis=(0.0, 0.0, 1.0), axis_point=(0.0, 0.0, 0.0),
                   plane_limit: float | None = None) -> StreamSurfaceFit:
    """Decide whether a section (n, 3) mm lies on a surface of revolution about the axis, and
    fit it (module docstring). ``plane_limit`` (mm, default the segmentation's
    ``NONPLANAR_LIMIT``): a section within it (or within the tolerance) of its best-fit plane is
    planar, not a stream-surface section. Every figure comes from the points sorted by their
    coordinates, so it does not depend on the loop's order."""
    P = np.asarray(points, float)
    if P.ndim != 2 or P.shape[1] != 3 or len(P) < 8:
        raise BladeReconError("stream_surface: give a section of at least 8 points (n, 3)")
    limit = NONPLANAR_LIMIT if plane_limit is None else float(plane_limit)
    noise = noise_estimate(P)                      # per point: the same set whichever the order
    S = P[np.lexsort((P[:, 2], P[:, 1], P[:, 0]))]
    c3 = S.mean(axis=0)
    sv = np.linalg.svd(S - c3, full_matrices=False)
    size = float(np.ptp(S, axis=0).max())
    flat = float(np.abs((S - c3) @ sv[2][-1]).max())
    tol = 5.0 * noise + 1e-5 * size
    a, r, th = cylindrical(S, axis, axis_point)
    if r.min() < 1e-9 * size:
        return StreamSurfaceFit(None, "the section crosses the axis", flat, np.nan, np.nan, tol, noise, 0)
    if flat <= max(limit, tol):
        return StreamSurfaceFit(None, "planar", flat, 0.0, 0.0, tol, noise, 0)
    M = np.column_stack([a, r])
    cm = M.mean(axis=0)
    d = np.linalg.svd(M - cm, full_matrices=False)[2][0]
    if d[0] < -1e-9 or (abs(d[0]) <= 1e-9 and d[1] < 0):      # m′ grows with a (with r when radial)
        d = -d
    n = np.array([-d[1], d[0]])
    u, w = (M - cm) @ d, (M - cm) @ n
    ext = float(u.max() - u.min())
    lo, hi = float(u.min() - _MARGIN * ext), float(u.max() + _MARGIN * ext)
    theta0 = float(np.arctan2(np.sin(th).mean(), np.cos(th).mean()))
    # spans: one per 60 points up to 6, doubled while the curve misses half the tolerance and every
    # span keeps 12 points on average (a strongly bent meridian: a mixed-flow rotor's axial-to-radial turn)
    spans = int(np.clip(len(S) // 60, 1, 6))
    while True:
        spl = _fit_curve(u, w, lo, hi, spans)
        surf = RevolutionSurface(axis, axis_point, cm, d, spl, lo, hi, theta0)
        uf, off = surf.foot(M)          # residuals perpendicular to the curve, from the foot points
        mx = float(np.abs(off).max())
        if mx <= 0.5 * tol or 2 * spans > len(S) // 12:
            break
        spans *= 2
    # m′ zero at the middle of the points' meridional extent
    surf = RevolutionSurface(axis, axis_point, cm, d, spl, lo, hi, theta0, 0.5 * (float(uf.min()) + float(uf.max())))
    rms = float(np.sqrt(np.mean(off ** 2)))
    if mx > tol:
        return StreamSurfaceFit(None, f"its points leave the best surface of revolution about the axis by "
                                      f"{mx:.4f} mm (tolerance {tol:.4f} mm)", flat, rms, mx, tol, noise, spans)
    return StreamSurfaceFit(surf, "", flat, rms, mx, tol, noise, spans)


def _rhumb_length(surf: RevolutionSurface, p0: np.ndarray, p1: np.ndarray) -> float:
    """Length on the surface (mm) of the straight conformal line p0 -> p1 (a line of constant
    angle to the meridians): ∫ r / r_ref dℓ, 10-point Gauss-Legendre."""
    t = 0.5 * (_GL_X + 1.0)
    x = p0[0] + t * (p1[0] - p0[0])
    return float(np.linalg.norm(p1 - p0) * 0.5 * (surf.scale_at(x) @ _GL_W))


def _offset_stations(surf: RevolutionSurface, le2: np.ndarray, u: np.ndarray, chord_c: float, offsets) -> list:
    """For each offset d (mm on the surface): the conformal distances from the LE along the
    chord of the stations d from the LE and d from the TE, the lengths measured on the surface
    along the chord (∫ r/r_ref dℓ, trapezoids on 4001 points); None beyond the chord."""
    s = np.linspace(0.0, chord_c, 4001)
    sc = surf.scale_at(le2[0] + s * u[0])
    L = np.concatenate([[0.0], np.cumsum(0.5 * (sc[1:] + sc[:-1]) * np.diff(s))])
    out = []
    for d in offsets:
        inside = 0.0 <= d <= L[-1]
        out.append((float(np.interp(d, L, s)) if inside else None,
                    float(np.interp(L[-1] - d, L, s)) if inside else None))
    return out


def _conformal_loop(seg_c) -> np.ndarray:
    """The dense closed profile of a section segmented in the conformal plane, as (x, y) there."""
    from bladerecon.core.geometry.bspline import evaluate_curve

    lo, hi = seg_c.curve.domain
    loop = seg_c.table_points(_AREA_SAMPLES)
    if loop is None:
        loop = evaluate_curve(seg_c.curve, lo + (hi - lo) * np.arange(_AREA_SAMPLES) / _AREA_SAMPLES)
    return seg_c.frame.to_space(loop)[:, :2]           # the segmentation's plane frame -> conformal (x, y)


def _surface_area(surf: RevolutionSurface, xy: np.ndarray) -> float:
    """Area on the surface (mm²) of a profile given by its dense loop ``xy`` in the conformal
    plane (:func:`_conformal_loop`): ∬ (r/r_ref)² dA = ∮ F(x) dy, F(x) = ∫ (r/r_ref)² dx
    (trapezoids on 4001 points)."""
    x, y = xy[:, 0], xy[:, 1]
    grid = np.linspace(x.min(), x.max(), 4001)
    s2 = surf.scale_at(grid) ** 2
    F = np.concatenate([[0.0], np.cumsum(0.5 * (s2[1:] + s2[:-1]) * np.diff(grid))])
    xm = 0.5 * (x + np.roll(x, -1))
    return float(abs(np.sum(np.interp(xm, grid, F) * (np.roll(y, -1) - y))))


_AREA_SAMPLES = 8000


def _peak(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Largest y and its x: the vertex of the parabola through the top three samples."""
    k = int(np.argmax(y))
    if 0 < k < len(y) - 1:
        co = np.polyfit(x[k - 1:k + 2] - x[k], y[k - 1:k + 2], 2)
        if co[0] < 0:
            xv = -co[1] / (2 * co[0])
            if abs(xv) <= abs(x[k + 1] - x[k - 1]):
                return float(np.polyval(co, xv)), float(x[k] + xv)
    return float(y[k]), float(x[k])


def measure_meridional(seg, measure, axis=None, axis_point=None, strict_radius: bool = True,
                       fractions: tuple = (), offsets: tuple = ()) -> tuple[dict | None, str | None]:
    """The m′–θ block of one segmented non-planar section, or (None, why not).

    The section's points (rebuilt from the segmentation: its plane points and offsets) are
    mapped to the conformal plane ``(x, y) = (r_ref m′, r_ref θ)`` and measured there by
    ``measure`` (:func:`~bladerecon.core.sections.parameters.measure_section`, passed in: that
    module calls this one), with the LE at the same end as
    the span-normal measurement. Angles are taken as measured (the map is conformal); lengths
    are scaled to mm on the surface with the local radius: ``chord_mm`` the surface length of
    the straight conformal chord (a rhumb line, ∫ r/r_ref dℓ), thicknesses and radii × r/r_ref
    at their circle's centre. ``fractions`` (of the conformal chord): the thickness there in mm on
    the surface, in both conventions (camber-line normal: the inscribed diameter × r/r_ref at its
    centre; chord normal: the surface length of the conformal line ⟂ chord across the profile,
    ∫ r/r_ref dℓ); ``offsets`` (mm on the surface along the chord from the LE and from the TE,
    the rhumb line's own length): the thickness there in both conventions (:func:`_offset_stations`);
    ``camber_height_mm`` likewise at its place; ``area_mm2`` the profile's area on the surface,
    ∬ (r/r_ref)² over the conformal profile (Green's theorem on the dense loop: ∮ F(x) dy with
    F′ = (r/r_ref)²).
    """
    if seg.offsets is None:
        return None, "no out-of-plane offsets kept"
    axis = (0.0, 0.0, 1.0) if axis is None else axis
    axis_point = (0.0, 0.0, 0.0) if axis_point is None else axis_point
    P = seg.frame.to_space(seg.points2d) + seg.offsets[:, None] * seg.frame.normal
    fit = stream_surface(P, axis, axis_point)
    if fit.surface is None:
        return None, (f"section {seg.index}: not on a surface of revolution about the axis "
                      f"{np.round(_unit(axis, 'axis'), 6).tolist()} through {np.asarray(axis_point, float).tolist()}: "
                      f"{fit.reason}; no m'-theta figures (give the machine axis: --axis X,Y,Z, --axis-point X,Y,Z)")
    surf = fit.surface
    # the surface was fitted on the points sorted by their coordinates and the map works point
    # by point: a loop in canonical order (segment_blade's default) gives the same bits whichever
    # point it started at and whichever way it ran
    xy = surf.to_conformal(P)
    Q = np.column_stack([xy, np.zeros(len(xy))])
    hint = surf.to_conformal(seg.lift(seg.le))[0]
    try:
        seg_c = segment_section(Q, seg.index, np.array([0.0, 0.0, 1.0]),
                                le_hint=np.array([hint[0], hint[1], 0.0]))
        pc = measure(seg_c, strict_radius=strict_radius)
    except BladeReconError as err:
        return None, f"section {seg.index}: in the m'-theta plane: {err}"
    le2, te2 = pc.le[:2], pc.te[:2]
    chord_c = float(np.linalg.norm(te2 - le2))
    u = (te2 - le2) / chord_c
    cam = pc.camber[:, :2]
    xc = (cam - le2) @ u
    half_mm = 0.5 * pc.camber_thickness * surf.scale_at(cam[:, 0])
    order = np.argsort(xc)
    r_max, x_max = _peak(xc[order], half_mm[order])
    le3, te3 = surf.from_conformal(le2)[0], surf.from_conformal(te2)[0]

    def radius(rad, centre):
        return None if rad is None or centre is None else float(rad * surf.scale_at(centre[:1])[0])

    xs, hs, cs = xc[order], half_mm[order], cam[order]
    v = np.array([-u[1], u[0]])
    loop = _conformal_loop(seg_c)

    def camber_normal(x):
        return float(2 * np.interp(x, xs, hs)) if x is not None and xs[0] <= x <= xs[-1] else None

    def chord_normal(x):
        if x is None:
            return None
        c = chord_normal_crossings(loop, le2, u, [x])[0]
        if c is None:
            return None
        a, b = le2 + x * u + c[0] * v, le2 + x * u + c[1] * v
        return _rhumb_length(surf, a, b)

    thick_frac = {f"{f:g}": camber_normal(f * chord_c) for f in fractions}
    thick_frac_cn = {f"{f:g}": chord_normal(f * chord_c) for f in fractions}
    thick_at, thick_at_cn = {}, {}
    for off, (x_le, x_te) in zip(offsets, _offset_stations(surf, le2, u, chord_c, offsets)):
        for name, x in (("le", x_le), ("te", x_te)):
            thick_at[f"{name}+{off:g}"], thick_at_cn[f"{name}+{off:g}"] = camber_normal(x), chord_normal(x)
    yc = (cs - le2) @ v
    k_c = int(np.argmax(np.abs(yc)))
    camber_mm = float(abs(yc[k_c]) * surf.scale_at(cs[k_c:k_c + 1, 0])[0])
    turning = (pc.inlet_angle_deg - pc.outlet_angle_deg + 180.0) % 360.0 - 180.0
    block = {"frame": FRAME, **surf.as_dict(),
             "lengths": "mm on the surface: chord_mm along the straight conformal chord (a rhumb line), "
                        "thicknesses and radii x r/r_ref at their circle's centre; *_conformal_mm in the "
                        "conformal plane (x, y) = (r_ref m', r_ref theta)",
             "angles": "degrees in the m'-theta plane (true: the map is conformal), from +m' towards +theta",
             "le": le3.tolist(), "te": te3.tolist(),
             "le_m_theta": [float(le2[0] / surf.r_ref), float(le2[1] / surf.r_ref)],
             "te_m_theta": [float(te2[0] / surf.r_ref), float(te2[1] / surf.r_ref)],
             "chord_mm": _rhumb_length(surf, le2, te2), "chord_3d_mm": float(np.linalg.norm(te3 - le3)),
             "chord_conformal_mm": chord_c, "stagger_deg": pc.stagger_deg,
             "le_metal_angle_deg": pc.inlet_angle_deg, "te_metal_angle_deg": pc.outlet_angle_deg,
             "camber_angle_deg": float(turning),
             "max_thickness_mm": 2.0 * r_max, "max_thickness_pos_frac": float(x_max / chord_c),
             "max_thickness_conformal_mm": pc.max_thickness,
             "le_radius_mm": radius(pc.le_radius, pc.le_center), "te_radius_mm": radius(pc.te_radius, pc.te_center),
             "thickness_at_fraction_mm": thick_frac, "thickness_at_fraction_chord_normal_mm": thick_frac_cn,
             "thickness_at_mm": thick_at, "thickness_at_chord_normal_mm": thick_at_cn,
             "camber_height_mm": camber_mm,
             "camber_height_pos_frac": float(xs[k_c] / chord_c), "area_mm2": _surface_area(surf, loop),
             "fit": fit.as_dict(), "warnings": list(pc.warnings)}
    return block, None
