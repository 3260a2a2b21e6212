# SPDX-License-Identifier: LGPL-2.1-or-later
"""Section parameters of a blade section, as CMM blade packages report them (mm, degrees).

Measured on a :class:`~bladerecon.core.sections.segmentation.Segmentation` (section in its own
best-fit plane; see there for LE/TE, regions and the frame):

* **LE / TE points**: ends of the section along its chord: the points of the two fitted edge
  circles farthest apart along the line of their centres (``le_camber``/``te_camber``: the
  other convention, the camber line extended through the edge circle to the profile).
* **chord**: |TE − LE| in space (for a non-planar stream-surface section this includes the
  rise of the flow path; ``chord_in_plane`` is the projected one); **stagger**: angle of
  LE→TE from e1 (+x projected on the plane) about the plane normal (≈ +z), degrees in
  (−180, 180]. Thickness, radii and angles are measured in the section plane.
* **mean camber line**: centres of the inscribed circles. For each station on the pressure
  side (normal n pointing into the blade) the circle tangent there grows along n until it
  touches the suction half: ``dist(p + r n, suction) = r``, solved by bisection for all
  stations at once (maximal inscribed circles = medial axis between the two sides).
* **max thickness**: the largest inscribed-circle diameter, its position: chordwise
  distance of its centre from the LE (mm) and as a fraction of the chord.
* **LE / TE radius** (issue 24 §3): the circle through the measured points on its arc
  (between the flanks' touching points) and tangent (G1) to both flanks, each flank a polynomial fitted to its points near
  the edge (:func:`_edge_circle`); one arc point and two flanks fix it.
* **thickness at offsets / chord fractions**: inscribed-circle diameter at given chordwise
  positions (camber-line-normal convention) and the width across the line ⟂ chord there
  (chord-normal convention); camber height, area, centroid; stacking across sections
  (:func:`stacking`).
* **which end is the LE**: the upstream end along a given flow direction, else one guess
  for the whole blade (:func:`segment_blade`); every loop is measured from a canonical start
  and direction (:func:`canonical_loop`), so no figure depends on them.
* **inlet / outlet metal angle**: direction of the camber-line tangent (LE→TE sense) at
  its ends, from a quadratic fit of the camber points over 15 % of the chord next to each
  edge, evaluated at the edge-circle centre; degrees from e1 like the stagger.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from bladerecon.core.geometry.bspline import curve_derivatives, evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.sections.chord_lines import chord_normal_crossings
from bladerecon.core.sections.edge_shape import edge_shape
from bladerecon.core.sections.segmentation import LE, PRESSURE, SUCTION, TE, Segmentation

__all__ = ["SectionParameters", "measure_section", "segment_sections", "fit_circle", "kasa_circle", "inscribed_circles", "MIN_EDGE_POINTS",
           "PARAMETER_KEYS", "compare_with_nominal",
           "LE_RULES", "BladeSegmentation", "canonical_loop", "segment_blade", "stacking", "EdgeCircle"]

#: (kept for older callers) points the old region-only radius fit asked for
MIN_EDGE_POINTS = 5
#: chord fractions tried, narrowest first, for the flank windows of the edge G1 condition (a cubic on
#: 35 % of the chord: ~0.1 µm from the analytic flanks, and enough points that 2 µm noise averages out)
FLANK_WINDOWS = (0.35, 0.5)
#: first split, and the arc points judged for roundness: this many radii ahead of the edge circle's
#: centre along the camber tangent (the flanks touch the circle ahead of its centre where the blade
#: thickens, by the sine of the wedge half-angle)
ARC_AHEAD = 0.25
FLANK_DEGREE = 3
#: radians inside a touching point for a point to count as measured on the arc (``arc_points``)
ARC_MARGIN = 0.02
#: an edge whose arc points scatter more than 4 × the flanks' rms + this (mm) is reported as not round
#: (3 µm: a circle on a cambered flank pair, sheared by the camber, scatters 2 µm about its best circle)
NOT_ROUND = 0.003


@dataclass(frozen=True)
class SectionParameters:
    """Measured parameters of one section (global coordinates, mm and degrees)."""

    index: int
    points: int
    le: np.ndarray
    te: np.ndarray
    chord: float
    stagger_deg: float
    max_thickness: float
    max_thickness_pos: float          # mm from the LE along the chord
    max_thickness_pos_frac: float     # fraction of the chord
    le_radius: float | None           # None only with strict_radius=False and too few edge points
    te_radius: float | None
    inlet_angle_deg: float
    outlet_angle_deg: float
    camber: np.ndarray                # (m, 3) centres of the inscribed circles, LE to TE
    camber_thickness: np.ndarray      # (m,) their diameters
    thickness_at: dict = field(default_factory=dict)   # {"le+1.0": t, "te+1.0": t}
    le_fit_points: int = 0
    te_fit_points: int = 0
    le_center: np.ndarray | None = None
    te_center: np.ndarray | None = None
    throat: dict | None = None
    warnings: tuple = ()
    chord_in_plane: float = 0.0       # chord in the section plane (= chord for planar sections)
    le_fit: dict | None = None        # edge-circle fit: arc_points, flank_points (2), rms (mm)
    te_fit: dict | None = None
    gauges: dict = field(default_factory=dict)   # named gauge measurements (see measure_section)

    def as_dict(self) -> dict:
        d = {"index": self.index, "points": self.points, "le": self.le.tolist(), "te": self.te.tolist(),
             "chord": self.chord, "stagger_deg": self.stagger_deg, "max_thickness": self.max_thickness,
             "max_thickness_pos": self.max_thickness_pos, "max_thickness_pos_frac": self.max_thickness_pos_frac,
             "le_radius": self.le_radius, "te_radius": self.te_radius,
             "inlet_angle_deg": self.inlet_angle_deg, "outlet_angle_deg": self.outlet_angle_deg,
             "chord_in_plane": self.chord_in_plane, "thickness_at": self.thickness_at, "le_fit_points": self.le_fit_points,
             "te_fit_points": self.te_fit_points, "le_fit": self.le_fit, "te_fit": self.te_fit,
             **self.gauges, "warnings": list(self.warnings)}
        if self.throat is not None:
            d["throat"] = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.throat.items()}
        return d


def kasa_circle(q: np.ndarray, floor: float = 1e-30) -> tuple[np.ndarray, float]:
    """Algebraic (Kåsa) circle through 2D points q (k, 2): centre and radius (mm), the
    squared radius held at least ``floor`` (mm²)."""
    q = np.asarray(q, float)
    A = np.column_stack([2 * q, np.ones(len(q))])
    sol = np.linalg.lstsq(A, (q ** 2).sum(axis=1), rcond=None)[0]
    c = sol[:2]
    return c, float(np.sqrt(max(sol[2] + c @ c, floor)))


def fit_circle(q: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Least-squares circle through 2D points: Kåsa algebraic fit (:func:`kasa_circle`), then
    Gauss-Newton on the geometric distances. Returns (centre, radius, rms residual), mm."""
    q = np.asarray(q, float)
    c, r = kasa_circle(q)
    for _ in range(30):
        d = q - c
        dist = np.linalg.norm(d, axis=1)
        res = dist - r
        J = np.column_stack([-d / dist[:, None], -np.ones(len(q))])
        step = np.linalg.lstsq(J, -res, rcond=None)[0]
        c, r = c + step[:2], r + step[2]
        if np.abs(step).max() < 1e-13:
            break
    res = np.linalg.norm(q - c, axis=1) - r
    return c, float(r), float(np.sqrt(np.mean(res ** 2)))


def _side_parameters(seg: Segmentation, side: int, n: int) -> np.ndarray:
    """Curve parameters of n stations at equal parameter steps along one side, LE to TE."""
    a, b = seg.side_interval(side)
    lo, hi = seg.curve.domain
    t = a + (b - a) * (np.arange(n) + 0.5) / n
    return lo + np.mod(t - lo, hi - lo)


def inscribed_circles(seg: Segmentation, stations: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Centres (m, 2) and radii (m,) of the maximal inscribed circles, LE to TE (in-plane mm).

    ``stations`` (default: 2 per measured point, 600 to 2000) on the pressure side; the
    suction side sampled 2.5 times as densely: a sparse section's curve holds no detail
    finer than its points, so more stations would only cost time.

    Each circle is tangent to the pressure side at a station and touches the suction half
    (bisection on ``dist(p + r n, suction) − r``, vectorised over the stations).
    """
    if stations is None:
        stations = int(np.clip(2 * len(seg.points2d), 600, 2000))
    s_pts = evaluate_curve(seg.curve, _side_parameters(seg, SUCTION, int(2.5 * stations)))
    # the circle centres lie far from the sampled side: without compacted node boxes scipy finds
    # the same nearest points in about 60 % of the time (measured; issue 24 §7)
    tree = cKDTree(s_pts, compact_nodes=False)
    t = _side_parameters(seg, PRESSURE, stations)
    der = curve_derivatives(seg.curve, t, 1)
    p, d1 = der[:, 0], der[:, 1]
    tan = d1 / np.linalg.norm(d1, axis=1, keepdims=True)
    n = np.column_stack([-tan[:, 1], tan[:, 0]])
    # inward normal: left of the tangent on a counter-clockwise loop
    lo, hi = seg.curve.domain
    loop = evaluate_curve(seg.curve, np.linspace(lo, hi, 2000, endpoint=False))
    area = 0.5 * np.sum(loop[:, 0] * np.roll(loop[:, 1], -1) - np.roll(loop[:, 0], -1) * loop[:, 1])
    if area < 0:
        n = -n
    chord_dir = (seg.te - seg.le) / seg.chord
    x = (p - seg.le) @ chord_dir
    keep = (x > 0.005 * seg.chord) & (x < 0.995 * seg.chord)
    p, n = p[keep], n[keep]
    d0, near = tree.query(p)
    lo_r = np.zeros(len(p))
    hi_r = np.full(len(p), 0.5 * seg.chord)
    r = 0.5 * d0
    act = np.arange(len(p))
    for _ in range(40):      # safeguarded Newton: f(r) = dist(p + r n, S) - r, f' = n·(c - s)/|c - s| - 1
        pa, na, ra = p[act], n[act], r[act]
        c = pa + ra[:, None] * na
        d, i = _nearest(tree, s_pts, c, near[act])
        near[act] = i
        f = d - ra
        lo_r[act] = np.where(f > 0, ra, lo_r[act])
        hi_r[act] = np.where(f > 0, hi_r[act], ra)
        g = ((c - s_pts[i]) * na).sum(axis=1) / np.maximum(d, 1e-300) - 1.0
        step = -f / np.where(g < -1e-12, g, -1e-12)
        r_new = ra + step
        bad = ~((r_new > lo_r[act]) & (r_new < hi_r[act]))
        r_new[bad] = 0.5 * (lo_r[act] + hi_r[act])[bad]
        r[act] = r_new
        act = act[np.abs(r_new - ra) >= 1e-7]      # only the stations still moving
        if not act.size:
            break
    c = p + r[:, None] * n
    d, _ = _nearest(tree, s_pts, c, near)
    # a station whose circle never touches the other side (a loop of the interpolant at a
    # sharp, sparsely measured edge) has no inscribed circle: drop it
    ok = (np.abs(d - r) < 1e-3) & (r < 0.25 * seg.chord) & _inside(c, loop)
    if ok.sum() < 10:
        raise BladeReconError(f"section {seg.index}: no inscribed circles found between the suction and pressure "
                              "sides: check that the section is one closed blade profile")
    c, r = c[ok], r[ok]
    order = np.argsort((c - seg.le) @ chord_dir)
    return c[order], r[order]


def _nearest(tree, pts: np.ndarray, q: np.ndarray, hint: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``tree.query(q)`` (tree over ``pts``), the same answer sooner: no neighbour lies farther
    than each query point's distance to ``pts[hint]`` (its neighbour a step before), so nodes
    beyond the largest of those are never searched (scipy 1.10 takes one bound for all points)."""
    diff = q - pts[hint]
    bound = float(np.sqrt(np.max(np.einsum("ij,ij->i", diff, diff)))) if len(q) else 0.0
    d, i = tree.query(q, distance_upper_bound=bound * (1.0 + 1e-9) + 1e-12)
    lost = i >= tree.n
    if lost.any():           # not expected (the bound holds every neighbour): the full search
        d[lost], i[lost] = tree.query(q[lost])
    return d, i


def _inside(pts: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Points inside a closed polygon (counter-clockwise or not): behind the outward normal of
    the nearest polygon edge. Exact for points farther from the loop than the edge length
    (here the centres of circles that touch it, r ≫ the sampling step)."""
    area = 0.5 * np.sum(loop[:, 0] * np.roll(loop[:, 1], -1) - np.roll(loop[:, 0], -1) * loop[:, 1])
    mid = 0.5 * (loop + np.roll(loop, -1, axis=0))
    e = np.roll(loop, -1, axis=0) - loop
    out = np.column_stack([e[:, 1], -e[:, 0]]) * np.sign(area)    # right of a ccw edge: outward
    _, i = cKDTree(mid, compact_nodes=False).query(pts)
    return ((pts - mid[i]) * out[i]).sum(axis=1) < 0


@dataclass(frozen=True)
class EdgeCircle:
    """An edge circle fitted with all the evidence (in-plane mm): centre, radius, the measured
    points on the arc, the flank points that set the G1 condition, the rms of the arc residuals."""

    centre: np.ndarray
    radius: float
    arc_points: int
    flank_points: tuple[int, int]
    rms: float
    axis: np.ndarray           # the camber line's tangent at the edge, pointing into the blade
    flank_rms: float = float("nan")   # rms of the flank points about their models (mm): the noise level


def _flank_model(x: np.ndarray, y: np.ndarray):
    """Polynomial y(x) of one flank next to the edge (edge-local frame; degree 2, 1 when sparse)
    with what its uncertainty needs: (coefficients, x shift, (VᵀV)⁻¹ of the fit)."""
    if len(x) < 2:
        return None
    deg = FLANK_DEGREE if len(x) >= 6 else (2 if len(x) >= 4 else 1)
    xm = float(x.mean())     # a plain float: the foot-point Newton then runs on plain floats, not numpy scalars
    V = np.vander(x - xm, deg + 1)
    coef = np.linalg.lstsq(V, y, rcond=None)[0]
    # the polynomial and its two derivatives as plain floats a0 + a1 x + ..., made once per model:
    # the foot-point Newton runs thousands of times a section and scalar Horner is fast
    a = [float(v) for v in coef[::-1]]
    a1 = [i * v for i, v in enumerate(a)][1:]
    a2 = [i * v for i, v in enumerate(a1)][1:]
    return coef, xm, np.linalg.pinv(V.T @ V), (a, a1, a2, np.arange(len(coef) - 1, -1, -1))


def _horner(k: list, x: float) -> float:
    out = 0.0
    for v in reversed(k):
        out = out * x + v
    return out


def _foot_data(model) -> tuple[float, list, list]:
    """A flank model as :func:`_foot` takes it: (x shift, the polynomial's coefficients highest
    power first, the leverage vᵀ (VᵀV)⁻¹ v as a polynomial in x, highest power first), v =
    (x^deg, ..., x, 1) as np.vander's columns, so the leverage costs one Horner a foot."""
    _, xm, inv, (a, _, _, _) = model
    rows = inv.tolist() if isinstance(inv, np.ndarray) else inv
    n = len(rows)
    lev = [0.0] * (2 * n - 1)
    for i, row in enumerate(rows):
        for j, v in enumerate(row):
            lev[i + j] += v
    return xm, a[::-1], lev


def _foot(c0: float, cy: float, fd) -> tuple[float, float, float, float]:
    """:func:`_foot_on_flank` on plain floats (``fd`` from :func:`_foot_data`): (distance,
    leverage, foot x, foot y)."""
    xm, ad, lev = fd
    cx = c0 - xm
    x = cx
    for _ in range(8):
        # f, f' and f'' by one Horner pass
        f, d1, d2 = ad[0], 0.0, 0.0
        for co in ad[1:]:
            d2 = d2 * x + d1
            d1 = d1 * x + f
            f = f * x + co
        g = (x - cx) + (f - cy) * d1
        gp = 1 + d1 * d1 + (f - cy) * (2.0 * d2)
        step = g / gp if abs(gp) > 1e-12 else 0.0
        x -= step
        if abs(step) < 1e-13:
            break
    fy = lv = 0.0
    for co in ad:
        fy = fy * x + co
    for co in lev:
        lv = lv * x + co
    fx = x + xm
    return math.hypot(c0 - fx, cy - fy), lv, fx, fy


def _foot_on_flank(c: np.ndarray, model) -> tuple[float, float, np.ndarray]:
    """Distance from c to the curve y = f(x) and the leverage of the fit at the foot point
    (Newton on the foot, from x = c_x): the G1 residual's variance is σ² times the leverage."""
    d, lev, fx, fy = _foot(float(c[0]), float(c[1]), _foot_data(model))
    return d, lev, np.array([fx, fy])


def _solve_spd3(A: list, b: list) -> list | None:
    """x with A x = b for a symmetric positive definite 3 × 3 A (Cholesky on plain floats);
    None when A is not numerically positive definite."""
    (a00, a01, a02), (_, a11, a12), (_, _, a22) = A
    if not a00 > 0:
        return None
    l00 = math.sqrt(a00)
    l10, l20 = a01 / l00, a02 / l00
    d1 = a11 - l10 * l10
    if not d1 > 0:
        return None
    l11 = math.sqrt(d1)
    l21 = (a12 - l20 * l10) / l11
    d2 = a22 - l20 * l20 - l21 * l21
    if not d2 > 0:
        return None
    l22 = math.sqrt(d2)
    y0 = b[0] / l00
    y1 = (b[1] - l10 * y0) / l11
    y2 = (b[2] - l20 * y0 - l21 * y1) / l22
    x2 = y2 / l22
    x1 = (y1 - l21 * x2) / l11
    x0 = (y0 - l10 * x1 - l20 * x2) / l00
    return [x0, x1, x2]


def _fit_edge_circle(pa: np.ndarray, flanks: list, z: np.ndarray, report: bool = False):
    """Levenberg-Marquardt on (cx, cy, r): arc residuals |p − c| − r and the G1 residuals
    (dist(c, flank) − r) / sqrt(leverage); the gradient of a distance to a curve is the unit
    vector from its foot point (the foot moves along the curve, to first order no change).

    The damped normal equations (JᵀJ + λ diag JᵀJ) step = −Jᵀres are 3 × 3: formed and solved on
    plain floats (the arc's rows summed by numpy), so a step costs a few microseconds, not a
    LAPACK call's overhead; 42 edges of a blade take ~2000 steps. With ``report``: (centre and
    radius, whether the iteration ended at the minimum rather than at its step limit)."""
    n = len(pa)
    px, py = np.ascontiguousarray(pa[:, 0]), np.ascontiguousarray(pa[:, 1])
    fl = [_foot_data(m) for m in flanks]
    J = np.empty((3, n))
    J[2] = -1.0

    def residuals(cx: float, cy: float, rz: float):
        """(cost, what :func:`normal` needs) at the circle (cx, cy, rz): a rejected step needs
        no more (most steps near the end are, while the damping grows)."""
        dx, dy = cx - px, cy - py
        dist = np.maximum(np.sqrt(dx * dx + dy * dy), 1e-300)
        res = dist - rz
        cost = float(res @ res)
        feet = []
        for mod in fl:
            d, lev, fx, fy = _foot(cx, cy, mod)
            w = 1.0 / math.sqrt(max(lev, 1e-3))
            rk = w * (d - rz)
            cost += rk * rk
            feet.append((d, w, rk, fx, fy))
        return cost, (cx, cy, dx, dy, dist, res, feet)

    def normal(state):
        """JᵀJ (its 6 entries) and Jᵀres at an accepted circle."""
        cx, cy, dx, dy, dist, res, feet = state
        np.divide(dx, dist, out=J[0])
        np.divide(dy, dist, out=J[1])
        (s00, s01, s02), (_, s11, s12), (_, _, s22) = (J @ J.T).tolist()
        g0, g1, g2 = (J @ res).tolist()
        for d, w, rk, fx, fy in feet:
            dd = max(d, 1e-300)
            j0, j1, j2 = w * ((cx - fx) / dd), w * ((cy - fy) / dd), -w
            s00 += j0 * j0
            s01 += j0 * j1
            s02 += j0 * j2
            s11 += j1 * j1
            s12 += j1 * j2
            s22 += j2 * j2
            g0 += j0 * rk
            g1 += j1 * rk
            g2 += j2 * rk
        return (s00, s01, s02, s11, s12, s22), (g0, g1, g2)

    def system(cx: float, cy: float, rz: float):
        cost, state = residuals(cx, cy, rz)
        return (cost, *normal(state))

    z0, z1, z2 = (float(v) for v in z)
    cost, S, g = system(z0, z1, z2)
    scale = max(abs(z2), 1.0)
    lam = 1e-6
    solved = False
    for _ in range(100):
        # Levenberg-Marquardt (Marquardt's scaling): along a thin edge the flanks' G1 hardly moves
        # with the centre's place along the camber line, so a plain Gauss-Newton step there is
        # huge, and halving it keeps its bad direction; the damping turns it towards the gradient
        s00, s01, s02, s11, s12, s22 = S
        A = [[s00 + lam * max(s00, 1e-12), s01, s02], [s01, s11 + lam * max(s11, 1e-12), s12],
             [s02, s12, s22 + lam * max(s22, 1e-12)]]
        step = _solve_spd3(A, [-g[0], -g[1], -g[2]])
        if step is None:                             # singular: the least-squares step as before
            step = np.linalg.lstsq(np.array(A), -np.array(g), rcond=None)[0].tolist()
        if max(abs(step[0]), abs(step[1]), abs(step[2])) < 1e-12 * scale:       # converged to round-off
            solved = True
            break
        t0, t1, t2 = z0 + step[0], z1 + step[1], z2 + step[2]
        cost_new, state = residuals(t0, t1, t2)
        if cost_new < cost:
            S, g = normal(state)
            z0, z1, z2, cost = t0, t1, t2, cost_new
            lam = max(lam * 0.1, 1e-12)
        else:
            lam *= 10.0
            if lam > 1e12:                           # no descent left: at the minimum
                solved = True
                break
    z = np.array([z0, z1, z2])
    return (z, solved) if report else z


def _touch_angle(c: np.ndarray, model, sgn: int, r: float) -> tuple[float, float]:
    """Where a flank touches the edge circle (centre c, radius r; edge-local frame): the angle of
    the foot point about the centre from the edge's tip direction (−x; towards the flank's side
    > 0) and its x. Without a flank model yet: 0.25 r ahead of the centre (ARC_AHEAD)."""
    if model is None:
        return float(np.arccos(ARC_AHEAD)), float(c[0] - ARC_AHEAD * r)
    foot = _foot_on_flank(c, model)[2]
    return float(sgn * np.arctan2(foot[1] - c[1], c[0] - foot[0])), float(foot[0])


def _edge_circle(seg: Segmentation, region: int, cam: np.ndarray, rad: np.ndarray) -> EdgeCircle | None:
    """The edge circle from all the evidence (issue 24 §3).

    Works in an edge-local frame: origin the edge point, x into the blade along the camber
    tangent, y across; the circle starts with the foremost measured point on its tip. Each
    measured point is evidence for the piece of the profile it lies on: the arc between the
    flanks' touching points (the feet of the G1 condition) or the flank on its side (split by
    the camber line, the inscribed-circle centres ``cam``), that flank's points from its
    touching point to 35 % of the chord (50 % when fewer than 5) fitted by a cubic y(x) (a
    quadratic or a line with fewer than 6). The first passes split by fixed bands (arc 0.25 r
    ahead of the centre, flanks from 0.5 r behind it), robust from a poor start; then by the
    touching points, which keeps the points near them, the ones that place a sparsely measured
    circle along the camber line. Unknowns (centre, radius) by Levenberg-Marquardt on the arc
    residuals ``|p − c| − r`` plus the G1 condition to both flanks, ``dist(c, flank) − r`` over
    the square root of the flank fit's leverage at the foot: one arc point and two flanks
    already fix the circle. Repeated until the point split stops changing. With no point on
    the arc, the foremost point stands in (the largest circle tangent to both flanks that the
    points allow: an upper bound) and ``arc_points`` is 0. None when that fails.
    """
    at_le = region == LE
    u = (seg.te - seg.le) / seg.chord
    e = seg.le if at_le else seg.te
    L = seg.chord
    # x along the camber line's tangent at the edge (into the blade): the arc is symmetric about it
    d0 = u if at_le else -u
    xc, yc = (cam - e) @ d0, (cam - e) @ np.array([-d0[1], d0[0]])
    near = xc <= 0.15 * L
    if near.sum() < 4:
        near = np.argsort(xc)[:8]
    slope = np.polyval(np.polyder(np.polyfit(xc[near], yc[near], 2)), float(rad[np.argmin(xc)]))
    ax = (d0 + slope * np.array([-d0[1], d0[0]])) / np.hypot(1.0, slope)
    ay = np.array([-ax[1], ax[0]])
    q = seg.points2d - e
    X, Y = q @ ax, q @ ay
    cq = cam - e
    cx, cy = cq @ ax, cq @ ay
    order = np.argsort(cx)
    cx, cy, rr = cx[order], cy[order], rad[order]
    r = float(rr[0])
    # start with the foremost measured point on the circle's tip: the interpolant's end (the
    # frame's origin) can lie a fraction of a radius off a sparsely measured edge
    k0 = int(np.argmin(X))
    c = np.array([X[k0] + r, Y[k0]])
    split_prev, models, by_touch, solved = None, [None, None], False, False
    fitted = {}      # flank models by their points (mask bytes): the passes meet the same splits again
    for _ in range(16):
        # first with fixed bands round the centre (robust from a poor start), then each point on
        # the piece of the profile model it lies on: the arc between the flanks' touching points
        # (feet of the G1 condition), else the flank on its side. Near a touching point both pieces
        # agree to first order, so no band need be left out: on a sparse edge those points are
        # what holds the circle's place along the camber line
        lim = [_touch_angle(c, mod if by_touch else None, sgn, r) for mod, sgn in zip(models, (1, -1))]
        phi = np.arctan2(Y - c[1], c[0] - X)
        arc = (phi <= lim[0][0]) & (phi >= -lim[1][0])
        measured_arc = bool(arc.any())
        if not measured_arc:        # the foremost point: the largest circle the points allow
            arc = X == X.min()
        side = Y - np.interp(X, cx, cy)
        models, counts, masks = [], [], []
        for sgn, (ang, x_touch) in zip((1, -1), lim):
            beyond = (np.sign(side) == sgn) & ~arc
            beyond &= (np.mod(sgn * phi, 2 * np.pi) > ang) if by_touch else (X >= c[0] + 0.5 * r)
            for width in FLANK_WINDOWS:
                m = beyond & (X <= x_touch + width * L)
                if m.sum() >= 5:
                    break
            key = m.tobytes()
            if key not in fitted:
                fitted[key] = _flank_model(X[m], Y[m])
            models.append(fitted[key])
            counts.append(int(m.sum()))
            masks.append(m)
        split = (arc.tobytes(), masks[0].tobytes(), masks[1].tobytes())
        pa = np.column_stack([X[arc], Y[arc]])

        flanks = [m for m in models if m is not None]
        if len(pa) + len(flanks) < 3:
            return None
        if split != split_prev or not solved:
            # (the same points and flank models as the pass before, whose fit ended at its minimum:
            # the same problem from its solution, nothing to solve again; ~40 % of the fits)
            z0, solved = _fit_edge_circle(pa, flanks, np.array([c[0], c[1], r]), report=True)
            c, r = z0[:2], float(z0[2])
        if split == split_prev:
            if by_touch or models[0] is None or models[1] is None:
                break
            by_touch = True
        split_prev = split
    if not (np.isfinite(r) and 0 < r < 0.5 * L):
        return None
    flank_sq = []        # the last pass's flank residuals (the noise level)
    for mod, m in zip(models, masks):
        if mod is not None and m.sum() > len(mod[0]):
            fres = np.polyval(mod[0], X[m] - mod[1]) - Y[m]
            far = X[m] >= np.median(X[m])        # the window's far half: no joint in it
            flank_sq.append(fres[far] * np.sqrt(m.sum() / (m.sum() - len(mod[0]))))
    # the shape figures away from the joints, where an edge that is not a circle (an ellipse)
    # differs most from one and its points cannot pass for the other piece's: arc points ahead
    # of the centre, and the flanks' noise from the far half of their windows
    ahead = pa[:, 0] <= c[0] - ARC_AHEAD * r
    res = np.linalg.norm((pa[ahead] if ahead.any() else pa) - c, axis=1) - r
    centre = e + c[0] * ax + c[1] * ay
    flank_rms = float(np.sqrt(np.mean(np.concatenate(flank_sq) ** 2))) if flank_sq else float("nan")
    # points on the arc by more than ARC_MARGIN (radians) from a touching point: a flank point the
    # circle was drawn through to its touching point is no evidence of the arc
    lim = [_touch_angle(c, mod, sgn, r) for mod, sgn in zip(models, (1, -1))]
    phi = np.arctan2(Y - c[1], c[0] - X)
    on_arc = int(np.sum((phi <= lim[0][0] - ARC_MARGIN) & (phi >= -lim[1][0] + ARC_MARGIN))) if measured_arc else 0
    return EdgeCircle(centre, r, on_arc, (counts[0], counts[1]),
                      float(np.sqrt(np.mean(res ** 2))), ax, flank_rms)


def _edge_radius(seg: Segmentation, region: int, name: str, cam: np.ndarray, rad: np.ndarray) -> EdgeCircle:
    ec = _edge_circle(seg, region, cam, rad)
    if ec is None:
        raise BladeReconError(
            f"section {seg.index}: no measured point on the {name} beyond its circle's centre: "
            f"measure points round the {name}")
    return ec


def _shape_words(shape: dict) -> str:
    """What the warning says an edge that is not a circle is."""
    if shape["shape"] == "ellipse":
        return (f"an ellipse fits it: semi-axes {shape['a']:.3f} × {shape['b']:.3f} mm, {shape['rms'] * 1000:.1f} µm rms; "
                "see shape in the edge's fit")
    if shape["shape"] == "flat":
        width = "" if shape["width"] is None else f"{shape['width']:.3f} mm wide between the flanks, "
        return f"a flat edge: {width}{shape['points']} points on a {shape['length']:.3f} mm flat; see shape in the edge's fit"
    return "an elliptic, square or damaged edge?"


def _shape_json(seg: Segmentation, shape: dict, u: np.ndarray) -> dict:
    """The edge's shape for its fit record (3D points and unit vectors; mm, degrees): ``shape``
    and, for an ellipse or a flat, its figures under that name."""
    v = np.array([-u[1], u[0]])

    def vec(d):             # an in-plane direction in space (unit)
        return (seg.frame.to_space(np.atleast_2d(d))[0] - seg.frame.to_space(np.zeros((1, 2)))[0]).tolist()

    def to_chord(d):        # a line's angle from the chord line (towards the LE→TE normal's left), degrees in (−90, 90]
        a = (float(np.degrees(np.arctan2(d @ v, d @ u))) + 90.0) % 180.0 - 90.0
        return 90.0 if a == -90.0 else a

    kind = shape["shape"]
    if kind == "ellipse":
        return {"shape": kind, "ellipse": {
            "a_mm": shape["a"], "b_mm": shape["b"], "ratio": shape["ratio"], "tip_radius_mm": shape["tip_radius"],
            "centre": seg.lift(shape["centre"])[0].tolist(), "tip": seg.lift(shape["tip"])[0].tolist(),
            "major_axis": vec(shape["major_axis"]), "axis_to_chord_deg": to_chord(shape["major_axis"]),
            "points": shape["points"], "rms_mm": shape["rms"]}}
    if kind == "flat":
        normal = np.array([shape["direction"][1], -shape["direction"][0]])
        return {"shape": kind, "flat": {
            "width_mm": shape["width"], "length_mm": shape["length"], "midpoint": seg.lift(shape["tip"])[0].tolist(),
            "direction": vec(shape["direction"]), "normal_to_chord_deg": to_chord(normal),
            "points": shape["points"], "rms_mm": shape["rms"]}}
    return {"shape": kind}


def _angle_deg(v: np.ndarray) -> float:
    return float(np.degrees(np.arctan2(v[1], v[0])))


def _metal_angle(seg: Segmentation, c: np.ndarray, at_le: bool, centre: np.ndarray) -> float:
    """Camber tangent direction (LE→TE sense) at one end, degrees from e1."""
    u = (seg.te - seg.le) / seg.chord
    v = np.array([-u[1], u[0]])
    x = (c - seg.le) @ u
    y = (c - seg.le) @ v
    L = seg.chord
    m = (x <= 0.15 * L) if at_le else (x >= 0.85 * L)
    if m.sum() < 4:
        m = np.argsort(x)[:8] if at_le else np.argsort(x)[-8:]
    coef = np.polyfit(x[m], y[m], 2)
    x0 = (centre - seg.le) @ u
    slope = np.polyval(np.polyder(coef), x0)
    d = u + slope * v
    return _angle_deg(d)


def _ends_from_circles(seg: Segmentation, le_c, le_r, te_c, te_r) -> tuple[np.ndarray, np.ndarray]:
    """LE and TE points: the ends of the section along its chord. With both edge circles fitted,
    the points of the circles farthest apart along the line of their centres (the sample
    generator's and the packages' chord definition, and free of the interpolant's overshoot
    where an edge is sparsely measured); otherwise the segmentation's ends."""
    if le_r is None or te_r is None:
        return seg.le, seg.te
    d = te_c - le_c
    u = d / np.linalg.norm(d)
    return le_c - le_r * u, te_c + te_r * u


def _chord_normal_thickness(loop: np.ndarray, le: np.ndarray, u: np.ndarray, xs) -> list:
    """Thickness perpendicular to the chord at chordwise distances xs from the LE (mm): the
    distance between the outermost crossings of the profile with that line; None off the profile."""
    return [None if c is None else c[1] - c[0] for c in chord_normal_crossings(loop, le, u, xs)]


def measure_section(seg: Segmentation, offsets: tuple[float, ...] = (), n_points: int | None = None,
                    strict_radius: bool = True, fractions: tuple[float, ...] = (),
                    axis=None, axis_point=None) -> SectionParameters:
    """All parameters of one segmented section (see the module docstring). mm, degrees.

    An edge with no measured point beyond its circle's centre raises :class:`BladeReconError`
    (section, edge); with ``strict_radius=False`` that radius is None instead and the message
    goes to ``warnings``. ``offsets``: distances (mm) from LE and TE, ``fractions``: chord
    fractions, where the thickness is measured in both conventions (camber-line normal:
    the inscribed circle's diameter; chord normal: across the line ⟂ chord).

    A non-planar section (``projection`` ``span_normal``) that lies on a surface of revolution
    about the machine axis (``axis`` direction through ``axis_point``; default z through the
    origin) is also measured in m′–θ: ``gauges["meridional"]``
    (:func:`~bladerecon.core.sections.meridional_frame.measure_meridional`); None, with the reason
    in ``warnings``, when it is not on one. Planar sections get no such key.
    """
    c, r = inscribed_circles(seg)
    edges, warnings, fits, axes, shapes = [], [], [], [], []
    for region, name in ((LE, "leading edge"), (TE, "trailing edge")):
        try:
            ec = _edge_radius(seg, region, name, c, r)
            edges.append((ec.centre, ec.radius, ec.arc_points))
            fits.append({"arc_points": ec.arc_points, "flank_points": list(ec.flank_points), "rms": ec.rms,
                         "flank_rms": None if not np.isfinite(ec.flank_rms) else ec.flank_rms})
            shape = {"shape": "circle"}
            if ec.arc_points >= 5 and np.isfinite(ec.flank_rms) and ec.rms > 4 * ec.flank_rms + NOT_ROUND:
                shape = edge_shape(seg.points2d, ec.centre, ec.radius, ec.axis, ec.flank_rms, NOT_ROUND, ec.rms)
                warnings.append(f"section {seg.index}: the {name} is not a circle: its arc points scatter "
                                f"{ec.rms * 1000:.1f} µm rms about the fitted circle against {ec.flank_rms * 1000:.1f} µm "
                                f"on the flanks ({_shape_words(shape)})")
            shapes.append(shape)
            axes.append(ec.axis)
            if ec.arc_points == 0:
                warnings.append(f"section {seg.index}: no measured point lies on the {name}'s arc: its radius is "
                                "that of the largest circle tangent to both flanks that the points allow (an upper "
                                "bound; the chord end as uncertain): measure points round the edge")
            elif ec.arc_points < 2:
                warnings.append(f"section {seg.index}: the {name} radius rests on {ec.arc_points} measured point "
                                "on its arc and the flanks' tangency: measure more points round the edge")
        except BladeReconError as err:
            if strict_radius:
                raise
            warnings.append(str(err))
            edges.append((seg.le if region == LE else seg.te, None, 0))
            fits.append(None)
            axes.append(None)
            shapes.append(None)
    (le_c, le_r, le_n), (te_c, te_r, te_n) = edges
    le2, te2 = _ends_from_circles(seg, le_c, le_r, te_c, te_r)
    # an elliptic or flat edge ends at its ellipse's tip or its flat's midpoint, not on its best circle
    tips = [sh["tip"] if sh is not None and "tip" in sh else None for sh in shapes]
    le2 = le2 if tips[0] is None else tips[0]
    te2 = te2 if tips[1] is None else tips[1]
    chord2 = float(np.linalg.norm(te2 - le2))
    u = (te2 - le2) / chord2
    x = (c - le2) @ u
    order = np.argsort(x)
    c, r, x = c[order], r[order], x[order]
    r_max, x_max = _max_circle(x, r)
    lo, hi = seg.curve.domain
    loop = seg.table_points(_LOOP_SAMPLES)
    if loop is None:
        loop = evaluate_curve(seg.curve, lo + (hi - lo) * np.arange(_LOOP_SAMPLES) / _LOOP_SAMPLES)
    thickness_at, thickness_cn = {}, {}
    for off in offsets:
        for name, xx in (("le", off), ("te", chord2 - off)):
            val = float(2 * np.interp(xx, x, r)) if x[0] <= xx <= x[-1] else None
            thickness_at[f"{name}+{off:g}"] = val
            thickness_cn[f"{name}+{off:g}"] = _chord_normal_thickness(loop, le2, u, [xx])[0]
    frac_cam, frac_cn = {}, {}
    for f in fractions:
        xx = f * chord2
        frac_cam[f"{f:g}"] = float(2 * np.interp(xx, x, r)) if x[0] <= xx <= x[-1] else None
        frac_cn[f"{f:g}"] = _chord_normal_thickness(loop, le2, u, [xx])[0]
    # camber height: the inscribed centres' largest distance from the chord (towards the suction side > 0)
    v = np.array([-u[1], u[0]])
    yc = (c - le2) @ v
    k_c = int(np.argmax(np.abs(yc)))
    area, centroid = _area_centroid(loop)
    le3, te3 = seg.lift(le2)[0], seg.lift(te2)[0]
    inlet = _metal_angle(seg, c, True, le_c)
    outlet = _metal_angle(seg, c, False, te_c)
    ends_camber = [None if (cc is None or rr_ is None or ax is None) else seg.lift(cc - rr_ * ax if tip is None else tip)[0].tolist()
                   for cc, rr_, ax, tip in ((le_c, le_r, axes[0], tips[0]), (te_c, te_r, axes[1], tips[1]))]
    for fit, sh in zip(fits, shapes):
        if fit is not None and sh is not None:
            fit.update(_shape_json(seg, sh, u))
    from bladerecon.core.sections.segmentation import NONPLANAR_LIMIT
    projection = "span_normal" if seg.frame.flatness > NONPLANAR_LIMIT else "section_plane"
    gauges = {"projection": projection, "thickness_at_chord_normal": thickness_cn, "thickness_at_fraction": frac_cam,
              "thickness_at_fraction_chord_normal": frac_cn, "camber_height": float(abs(yc[k_c])),
              "camber_height_pos_frac": float(x[k_c] / chord2), "area": area,
              "centroid": seg.lift(centroid)[0].tolist(), "le_camber": ends_camber[0], "te_camber": ends_camber[1]}
    if projection == "span_normal":
        from bladerecon.core.sections.meridional_frame import measure_meridional
        block, why = measure_meridional(seg, measure_section, axis, axis_point, strict_radius, fractions, offsets)
        gauges["meridional"] = block
        if why:
            warnings.append(why)
    return SectionParameters(
        index=seg.index, points=int(n_points if n_points is not None else len(seg.points2d)),
        le=le3, te=te3, chord=float(np.linalg.norm(te3 - le3)), chord_in_plane=chord2,
        stagger_deg=_angle_deg(u), max_thickness=2 * r_max, max_thickness_pos=x_max,
        max_thickness_pos_frac=x_max / chord2, le_radius=le_r, te_radius=te_r,
        inlet_angle_deg=inlet, outlet_angle_deg=outlet, camber=seg.lift(c), camber_thickness=2 * r,
        thickness_at=thickness_at, le_fit_points=le_n, te_fit_points=te_n,
        le_center=seg.lift(le_c)[0], te_center=seg.lift(te_c)[0],
        throat=None if seg.throat is None else {**seg.throat, "point": seg.lift(seg.throat["point"])[0]},
        warnings=tuple(warnings), le_fit=fits[0], te_fit=fits[1], gauges=gauges)


_LOOP_SAMPLES = 8000


def _max_circle(x: np.ndarray, r: np.ndarray) -> tuple[float, float]:
    """Largest inscribed radius and its chordwise position (vertex of the parabola through the top three)."""
    k = int(np.argmax(r))
    if 0 < k < len(r) - 1:
        x3, r3 = x[k - 1:k + 2], r[k - 1:k + 2]
        co = np.polyfit(x3 - x3[1], r3, 2)
        if co[0] < 0:
            xv = -co[1] / (2 * co[0])
            if abs(xv) <= abs(x3[2] - x3[0]):
                return float(np.polyval(co, xv)), float(x3[1] + xv)
    return float(r[k]), float(x[k])


def _area_centroid(loop: np.ndarray) -> tuple[float, np.ndarray]:
    """Area (mm²) and centroid of a closed polygon (shoelace)."""
    x, y = loop[:, 0], loop[:, 1]
    x2, y2 = np.roll(x, -1), np.roll(y, -1)
    cr = x * y2 - x2 * y
    a = 0.5 * cr.sum()
    cx = ((x + x2) * cr).sum() / (6 * a)
    cy = ((y + y2) * cr).sum() / (6 * a)
    return float(abs(a)), np.array([cx, cy])


def stacking(params: list[SectionParameters], span_axis: np.ndarray, axial: np.ndarray | None = None) -> list[dict]:
    """Stacking of every section relative to the first (issue 24 §4), mm and degrees.

    The stacking axis runs along ``span_axis`` through the first section's centroid. ``sweep``:
    the centroid's offset along the axial direction (``axial``, e.g. the flow direction, made
    normal to the span; default +x), ``lean``: along span × axial (tangential), ``twist_deg``:
    stagger minus the first section's stagger, in (−180, 180].
    """
    a = np.asarray(span_axis, float) / np.linalg.norm(span_axis)
    ax = np.array([1.0, 0.0, 0.0]) if axial is None else np.asarray(axial, float)
    ax = ax - (ax @ a) * a
    if np.linalg.norm(ax) < 1e-9:
        ax = np.array([0.0, 1.0, 0.0]) - a[1] * a
    ax /= np.linalg.norm(ax)
    tg = np.cross(a, ax)
    c0 = np.asarray(params[0].gauges["centroid"])
    out = []
    for p in params:
        d = np.asarray(p.gauges["centroid"]) - c0
        tw = (p.stagger_deg - params[0].stagger_deg + 180.0) % 360.0 - 180.0
        out.append({"sweep": float(d @ ax), "lean": float(d @ tg), "height": float(d @ a),
                    "twist_deg": float(180.0 if tw == -180.0 else tw)})
    return out


#: the parameters compared measured vs nominal (mm, degrees)
PARAMETER_KEYS = ("chord", "stagger_deg", "max_thickness", "max_thickness_pos", "le_radius", "te_radius",
                  "inlet_angle_deg", "outlet_angle_deg")


def compare_with_nominal(measured: dict, nominal: dict) -> dict:
    """``measured`` (a :meth:`SectionParameters.as_dict` row) with ``"nominal"`` (the nominal
    section's values) and ``"difference"`` (measured − nominal, None where either is missing;
    ``le_shift``/``te_shift``: distances between the LE/TE points, mm) added."""
    row = dict(measured)
    row["nominal"] = {k: nominal[k] for k in ("points", "le", "te", *PARAMETER_KEYS, "thickness_at")}
    row["difference"] = {k: (None if row[k] is None or nominal[k] is None else row[k] - nominal[k])
                         for k in PARAMETER_KEYS}
    row["difference"]["le_shift"] = float(np.linalg.norm(np.subtract(row["le"], nominal["le"])))
    row["difference"]["te_shift"] = float(np.linalg.norm(np.subtract(row["te"], nominal["te"])))
    return row


#: how the leading edge was chosen (``"le_rule"`` in the JSON): the flow direction given;
#: the end nearest the nominal's LE in the same section; the end where the file's first point lies (a guess); the blunter end by a vote of all
#: sections (a guess)
LE_RULES = ("flow", "nominal", "first_point", "blunter_edge")


@dataclass(frozen=True)
class BladeSegmentation:
    """Every section segmented with one leading-edge rule for the whole blade."""

    sections: list
    le_rule: str                 # one of :data:`LE_RULES`
    warning: str | None          # set when the rule was a guess


def canonical_loop(points: np.ndarray, span_axis: np.ndarray | None = None) -> np.ndarray:
    """The same closed loop (n, 3) counter-clockwise about the span axis (or its best-fit
    normal), starting at its point of largest x (then y, z): the rows are bitwise the same
    whichever point the measurement started at and whichever way it ran, so every figure
    measured from them is too (issue 24 §5)."""
    P = np.asarray(points, float)
    a = np.array([0.0, 0.0, 1.0]) if span_axis is None else np.asarray(span_axis, float)
    c = P - P.mean(axis=0)
    n = np.linalg.svd(c, full_matrices=False)[2][-1]
    if abs(n @ a) < 0.2:            # a section lying along the span axis: use its own normal,
        # its sign fixed by its largest component (the SVD's sign is LAPACK's choice: it
        # differed with the rows' order on FreeCAD 1.0's numpy 2.2, and the loop ran the other way)
        k = int(np.argmax(np.abs(n)))
        a = n if n[k] > 0 else -n
    nxt = np.roll(c, -1, axis=0)
    area = float(np.cross(c, nxt).sum(axis=0) @ a)
    if area < 0:
        P = P[::-1]
    start = int(np.lexsort((P[:, 2], P[:, 1], P[:, 0]))[-1])
    return np.roll(P, -start, axis=0)


def _region_mean_curvature(seg: Segmentation, region: int) -> float:
    from bladerecon.core.sections.segmentation import signed_curvature
    a, b = seg.region_interval(region)
    t = a + (b - a) * (np.arange(64) + 0.5) / 64
    lo, hi = seg.curve.domain
    return float(np.mean(signed_curvature(seg.curve, lo + np.mod(t - lo, hi - lo))))


def segment_blade(section_points: list[np.ndarray], span_axis: np.ndarray | None = None,
                  first_point_is_measured: bool = False, throat=None, max_gap: float | None = None,
                  flow: np.ndarray | None = None, canonical: bool = True,
                  le_points: list[np.ndarray] | None = None) -> BladeSegmentation:
    """Segment every section with one leading-edge rule for the whole blade (issue 24 §1).

    ``flow`` (3D direction the fluid travels): the LE of every section is its upstream end.
    Without it, ``first_point_is_measured`` names the end where the first section's first
    point lies the LE (when it lies at an end), and otherwise all sections vote: the LE is
    the end that is blunter (lower mean curvature over its edge region) on most sections.
    Every further section takes the end nearest the previous LE, so no section is turned
    the other way. ``le_points`` (one 3D point per section, e.g. the nominal's LE in the
    same section; used when no ``flow`` is given): each section's LE is its end nearest
    that point (rule ``"nominal"``). ``canonical``: measure each loop from :func:`canonical_loop` (figures
    independent of the start point and direction).
    """
    from bladerecon.core.sections.segmentation import segment_section

    hint = None
    if first_point_is_measured and flow is None:
        # imported only here: the reconstruction module (and its skinning) costs `sections` 0.015 s
        from bladerecon.core.reconstruct import first_point_edge_hint
        hint = first_point_edge_hint(section_points[0])
    if flow is not None:
        f = np.asarray(flow, float)
        if f.shape != (3,) or not np.all(np.isfinite(f)) or np.linalg.norm(f) < 1e-12:
            raise BladeReconError(f"flow direction {f.tolist()}: give three numbers X,Y,Z, not all zero")
        flow = f / np.linalg.norm(f)
        rule, warning = "flow", None
    elif le_points is not None:
        if len(le_points) != len(section_points):
            raise BladeReconError(f"{len(le_points)} leading-edge points for {len(section_points)} sections")
        rule, warning = "nominal", None
    elif hint is not None:
        rule = "first_point"
        warning = ("leading edge guessed: the end where the first section's first point lies; "
                   "give the flow direction (--flow X,Y,Z) to be sure")
    else:
        rule = "blunter_edge"
        warning = ("leading edge guessed: the blunter end on most sections; "
                   "give the flow direction (--flow X,Y,Z) to be sure")
    loops = [canonical_loop(p, span_axis) if canonical else np.asarray(p, float) for p in section_points]

    def run(first_hint):
        out, h = [], first_hint
        for k, p in enumerate(loops):
            if rule == "nominal":
                h = np.asarray(le_points[k], float)
            seg = segment_section(p, k, span_axis, le_hint=h, throat=throat, max_gap=max_gap, flow=flow)
            h = seg.lift(seg.le)[0]
            out.append(seg)
        return out

    segs = run(hint)
    if rule == "blunter_edge":
        sharper_le = sum(_region_mean_curvature(s, LE) > _region_mean_curvature(s, TE) for s in segs)
        if 2 * sharper_le > len(segs):       # most sections say the other end is the LE
            segs = run(segs[0].lift(segs[0].te)[0])
    return BladeSegmentation(segs, rule, warning)


def segment_sections(section_points: list[np.ndarray], span_axis: np.ndarray | None = None,
                     first_point_is_measured: bool = True, throat=None, max_gap: float | None = None,
                     flow: np.ndarray | None = None, canonical: bool = False) -> list[Segmentation]:
    """Segment every section of a blade, keeping the LE on the same end from section to section
    (:func:`segment_blade`; this keeps the measured order of the points unless ``canonical``)."""
    return segment_blade(section_points, span_axis, first_point_is_measured, throat, max_gap, flow,
                         canonical).sections
