# SPDX-License-Identifier: LGPL-2.1-or-later
"""Section parameters of a blade section, as CMM blade packages report them (mm, degrees).

Measured on a :class:`~bladerecon.core.sections.segmentation.Segmentation` (section in its own
best-fit plane; see there for LE/TE, regions and the frame):

* **LE / TE points**: ends of the section along its chord (tangent ⟂ chord).
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
* **LE / TE radius**: least-squares circle (algebraic fit of Kåsa, then Gauss-Newton on the
  geometric distance) through the measured points of the edge region, the 15 % of the
  region next to each joint left out (the joint blends into the flank).
* **thickness at offsets**: inscribed-circle diameter at given chordwise distances from
  the LE and from the TE.
* **inlet / outlet metal angle**: direction of the camber-line tangent (LE→TE sense) at
  its ends, from a quadratic fit of the camber points over 15 % of the chord next to each
  edge, evaluated at the edge-circle centre; degrees from e1 like the stagger.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from bladerecon.core.geometry.bspline import curve_derivatives, evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.sections.segmentation import LE, PRESSURE, SUCTION, TE, Segmentation

__all__ = ["SectionParameters", "measure_section", "segment_sections", "fit_circle", "inscribed_circles", "MIN_EDGE_POINTS",
           "PARAMETER_KEYS", "compare_with_nominal",
           "LE_RULES", "BladeSegmentation", "canonical_loop", "segment_blade"]

#: measured points an edge region needs for a radius fit (3 define a circle; 5 give redundancy)
MIN_EDGE_POINTS = 5
_HALF_SAMPLES = 5000


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

    def as_dict(self) -> dict:
        d = {"index": self.index, "points": self.points, "le": self.le.tolist(), "te": self.te.tolist(),
             "chord": self.chord, "stagger_deg": self.stagger_deg, "max_thickness": self.max_thickness,
             "max_thickness_pos": self.max_thickness_pos, "max_thickness_pos_frac": self.max_thickness_pos_frac,
             "le_radius": self.le_radius, "te_radius": self.te_radius,
             "inlet_angle_deg": self.inlet_angle_deg, "outlet_angle_deg": self.outlet_angle_deg,
             "chord_in_plane": self.chord_in_plane, "thickness_at": self.thickness_at, "le_fit_points": self.le_fit_points,
             "te_fit_points": self.te_fit_points, "warnings": list(self.warnings)}
        if self.throat is not None:
            d["throat"] = {k: (v.tolist() if isinstance(v, np.ndarray) else v) for k, v in self.throat.items()}
        return d


def fit_circle(q: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Least-squares circle through 2D points: Kåsa algebraic fit, then Gauss-Newton on the
    geometric distances. Returns (centre, radius, rms residual), mm."""
    q = np.asarray(q, float)
    A = np.column_stack([2 * q, np.ones(len(q))])
    b = (q ** 2).sum(axis=1)
    sol = np.linalg.lstsq(A, b, rcond=None)[0]
    c = sol[:2]
    r = np.sqrt(max(sol[2] + c @ c, 1e-30))
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


def _side_samples(seg: Segmentation, side: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    a, b = seg.side_interval(side)
    lo, hi = seg.curve.domain
    t = a + (b - a) * (np.arange(n) + 0.5) / n
    t = lo + np.mod(t - lo, hi - lo)
    return t, evaluate_curve(seg.curve, t)


def inscribed_circles(seg: Segmentation, stations: int = 2000) -> tuple[np.ndarray, np.ndarray]:
    """Centres (m, 2) and radii (m,) of the maximal inscribed circles, LE to TE (in-plane mm).

    Each circle is tangent to the pressure side at a station and touches the suction half
    (bisection on ``dist(p + r n, suction) − r``, vectorised over the stations).
    """
    _, s_pts = _side_samples(seg, SUCTION, _HALF_SAMPLES)
    tree = cKDTree(s_pts)
    t, _ = _side_samples(seg, PRESSURE, stations)
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
    d0, _ = tree.query(p)
    lo_r = np.zeros(len(p))
    hi_r = np.full(len(p), 0.5 * seg.chord)
    r = 0.5 * d0
    for _ in range(40):      # safeguarded Newton: f(r) = dist(p + r n, S) - r, f' = n·(c - s)/|c - s| - 1
        c = p + r[:, None] * n
        d, i = tree.query(c)
        f = d - r
        lo_r = np.where(f > 0, r, lo_r)
        hi_r = np.where(f > 0, hi_r, r)
        g = ((c - s_pts[i]) * n).sum(axis=1) / np.maximum(d, 1e-300) - 1.0
        step = -f / np.where(g < -1e-12, g, -1e-12)
        r_new = r + step
        bad = ~((r_new > lo_r) & (r_new < hi_r))
        r_new[bad] = 0.5 * (lo_r + hi_r)[bad]
        if np.abs(r_new - r).max() < 1e-7:
            r = r_new
            break
        r = r_new
    c = p + r[:, None] * n
    d, _ = tree.query(c)
    # a station whose circle never touches the other side (a loop of the interpolant at a
    # sharp, sparsely measured edge) has no inscribed circle: drop it
    ok = (np.abs(d - r) < 1e-3) & (r < 0.25 * seg.chord) & _inside(c, loop)
    if ok.sum() < 10:
        raise BladeReconError(f"section {seg.index}: no inscribed circles found between the suction and pressure "
                              "sides: check that the section is one closed blade profile")
    c, r = c[ok], r[ok]
    order = np.argsort((c - seg.le) @ chord_dir)
    return c[order], r[order]


def _inside(pts: np.ndarray, loop: np.ndarray) -> np.ndarray:
    """Points inside a closed polygon (crossing number, vectorised over points and edges)."""
    a, b = loop, np.roll(loop, -1, axis=0)
    x, y = pts[:, :1], pts[:, 1:2]
    crosses = (a[None, :, 1] > y) != (b[None, :, 1] > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        xi = a[None, :, 0] + (y - a[None, :, 1]) * (b[None, :, 0] - a[None, :, 0]) / (b[None, :, 1] - a[None, :, 1])
    return (crosses & (x < xi)).sum(axis=1) % 2 == 1


def _edge_points(seg: Segmentation, region: int, trim: float = 0.15) -> np.ndarray:
    """Measured points of an edge region, without the ``trim`` fraction next to each joint
    when enough remain (2x :data:`MIN_EDGE_POINTS`); sparse plans keep every edge point."""
    a, b = seg.region_interval(region)
    w = b - a
    rel = np.mod(seg.t_points - a, seg.period)
    m = (rel >= trim * w) & (rel <= (1 - trim) * w)
    if m.sum() < 2 * MIN_EDGE_POINTS:
        m = rel <= w
    return seg.points2d[m]


def _edge_radius(seg: Segmentation, region: int, name: str) -> tuple[np.ndarray, float, int]:
    q = _edge_points(seg, region)
    if len(q) < MIN_EDGE_POINTS:
        raise BladeReconError(
            f"section {seg.index}: the {name} region has {len(q)} measured points, a radius fit needs at least "
            f"{MIN_EDGE_POINTS}: measure more points on the {name}")
    c, r, _ = fit_circle(q)
    if not np.isfinite(r) or r > 0.5 * seg.chord:
        raise BladeReconError(f"section {seg.index}: the {name} points do not fit a circle (radius {r:.3g} mm): "
                              "check the edge measurement")
    return c, r, len(q)


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


def measure_section(seg: Segmentation, offsets: tuple[float, ...] = (), n_points: int | None = None,
                    strict_radius: bool = True) -> SectionParameters:
    """All parameters of one segmented section (see the module docstring). mm, degrees.

    An edge region with fewer than :data:`MIN_EDGE_POINTS` measured points raises
    :class:`BladeReconError` (section, edge, points had/needed); with ``strict_radius=False``
    that radius is None instead and the message goes to ``warnings``.
    """
    u = (seg.te - seg.le) / seg.chord
    c, r = inscribed_circles(seg)
    x = (c - seg.le) @ u
    k = int(np.argmax(r))
    if 0 < k < len(r) - 1:      # vertex of the parabola through the top three
        x3, r3 = x[k - 1:k + 2], r[k - 1:k + 2]
        co = np.polyfit(x3 - x3[1], r3, 2)
        if co[0] < 0:
            xv = -co[1] / (2 * co[0])
            if abs(xv) <= abs(x3[2] - x3[0]):
                r_max, x_max = float(np.polyval(co, xv)), float(x3[1] + xv)
            else:
                r_max, x_max = float(r[k]), float(x[k])
        else:
            r_max, x_max = float(r[k]), float(x[k])
    else:
        r_max, x_max = float(r[k]), float(x[k])
    edges, warnings = [], []
    for region, name in ((LE, "leading edge"), (TE, "trailing edge")):
        try:
            edges.append(_edge_radius(seg, region, name))
        except BladeReconError as err:
            if strict_radius:
                raise
            warnings.append(str(err))
            q = _edge_points(seg, region)
            centre = q.mean(axis=0) if len(q) else (seg.le if region == LE else seg.te)
            edges.append((centre, None, len(q)))
    (le_c, le_r, le_n), (te_c, te_r, te_n) = edges
    thickness_at = {}
    for off in offsets:
        for name, xx in (("le", off), ("te", seg.chord - off)):
            val = float(2 * np.interp(xx, x, r)) if x[0] <= xx <= x[-1] else None
            thickness_at[f"{name}+{off:g}"] = val
    le3, te3 = seg.lift(seg.le)[0], seg.lift(seg.te)[0]
    inlet = _metal_angle(seg, c, True, le_c)
    outlet = _metal_angle(seg, c, False, te_c)
    return SectionParameters(
        index=seg.index, points=int(n_points if n_points is not None else len(seg.points2d)),
        le=le3, te=te3, chord=float(np.linalg.norm(te3 - le3)), chord_in_plane=seg.chord,
        stagger_deg=_angle_deg(u), max_thickness=2 * r_max, max_thickness_pos=x_max,
        max_thickness_pos_frac=x_max / seg.chord, le_radius=le_r, te_radius=te_r,
        inlet_angle_deg=inlet, outlet_angle_deg=outlet, camber=seg.lift(c), camber_thickness=2 * r,
        thickness_at=thickness_at, le_fit_points=le_n, te_fit_points=te_n,
        le_center=seg.lift(le_c)[0], te_center=seg.lift(te_c)[0],
        throat=None if seg.throat is None else {**seg.throat, "point": seg.lift(seg.throat["point"])[0]},
        warnings=tuple(warnings))


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
#: the end where the file's first point lies (a guess); the blunter end by a vote of all
#: sections (a guess)
LE_RULES = ("flow", "first_point", "blunter_edge")


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
    if abs(n @ a) < 0.2:            # a section lying along the span axis: use its own normal
        a = n
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
                  flow: np.ndarray | None = None, canonical: bool = True) -> BladeSegmentation:
    """Segment every section with one leading-edge rule for the whole blade (issue 24 §1).

    ``flow`` (3D direction the fluid travels): the LE of every section is its upstream end.
    Without it, ``first_point_is_measured`` names the end where the first section's first
    point lies the LE (when it lies at an end), and otherwise all sections vote: the LE is
    the end that is blunter (lower mean curvature over its edge region) on most sections.
    Every further section takes the end nearest the previous LE, so no section is turned
    the other way. ``canonical``: measure each loop from :func:`canonical_loop` (figures
    independent of the start point and direction).
    """
    from bladerecon.core.reconstruct import first_point_edge_hint
    from bladerecon.core.sections.segmentation import segment_section

    hint = first_point_edge_hint(section_points[0]) if (first_point_is_measured and flow is None) else None
    if flow is not None:
        f = np.asarray(flow, float)
        if f.shape != (3,) or not np.all(np.isfinite(f)) or np.linalg.norm(f) < 1e-12:
            raise BladeReconError(f"flow direction {f.tolist()}: give three numbers X,Y,Z, not all zero")
        flow = f / np.linalg.norm(f)
        rule, warning = "flow", None
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
