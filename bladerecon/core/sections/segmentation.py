# SPDX-License-Identifier: LGPL-2.1-or-later
"""Section segmentation: leading-edge region, trailing-edge region, suction side, pressure side.

Seed 000 §2.2. Every closed section is worked on in its own plane (best-fit plane of its
points, normal oriented along the span axis; :func:`section_frame`), so planar and tilted
sections are treated alike; a non-planar (stream-surface) section is projected on the plane
normal to the span axis (its best-fit plane would lean with the twist and turn the chord).
Units: mm, angles in degrees at the interface.

Steps (:func:`segment_section`):

1. **Closure check.** The largest distance between consecutive points (the closing one
   included) must stay below ``max_gap`` (default 15 % of the section's extent): an open
   section or a section with a hole is refused with a message naming the gap.
2. **Section curve.** A periodic cubic B-spline (seed 000 eq. 1): interpolation for sparse,
   accurate points, least squares with adaptive knots for dense noisy points (the choice of
   :func:`bladerecon.core.surface.section_curves.choose_method`).
3. **LE/TE points.** The two ends of the section along its chord (chord direction iterated
   to a fixed point, each end refined to where the tangent is perpendicular to the chord:
   the same definition as :func:`bladerecon.core.surface.skinning.find_le_te`). On a round edge this
   is the point of the edge circle farthest along the chord, where the curvature itself has
   no unique peak.
4. **Curvature peaks.** Parametric curvature ``κ = (x'y'' − y'x'') / |C'|³`` (the
   parametric form of seed 000 eq. 4, derivatives by eqs. 2-3 as in NURBS Book A3.2). The
   maximum of κ near each end is the edge's curvature extremum; a profile whose end
   curvature does not stand out from the flanks (``peak_ratio``) is refused.
5. **Key geometric points (joints).** Walking outward from each edge point, the joint is
   where the curvature falls fastest: the extremum of the change rate ``dκ/ds`` (seed 000
   §2.2). On a circular edge it is the tangent point of circle and flank.
6. **Throat point** (optional, eq. 5): ``o/b = C_L / (2 cos²β2 (tanβ1 − tanβ2))`` gives the
   throat width o from the chord b; the neighbouring blade (this section shifted along the
   circumferential direction e2) is placed so that its TE is o away from the suction side;
   the foot of that distance is the throat point, and the TE region starts there on the
   suction side. Defaults: ``C_L = 1.0`` (middle of 0.8-1.2, seed 000), flow angles are
   measured from the axial direction +e1 (= global +x projected on the section plane).

Which end is the leading edge: the end nearest ``le_hint`` when given (a measurement that
starts at the LE, or the previous section's LE), otherwise the blunter end (lower mean
curvature over its edge region). Which side is the suction side: the one the camber bulges
towards (mean offset from the chord on the same side as the mean of both sides).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from scipy.ndimage import median_filter
from scipy.spatial import cKDTree

from bladerecon.core.geometry.bspline import curve_derivatives, evaluate_curve
from bladerecon.core.errors import BladeReconError
from bladerecon.core.surface.section_curves import choose_method, fit_section_approximate, fit_section_interpolate
from bladerecon.core.geometry.spline import BSplineCurve

__all__ = [
    "SectionFrame",
    "ThroatSpec",
    "Segmentation",
    "section_frame",
    "segment_section",
    "signed_curvature",
    "throat_chord_ratio",
    "LE", "TE", "SUCTION", "PRESSURE", "REGION_NAMES",
]

LE, SUCTION, TE, PRESSURE = 0, 1, 2, 3
REGION_NAMES = ("le", "suction", "te", "pressure")
_TABLE = 8000          # dense samples of the section curve
#: a section whose points leave their best-fit plane by more than this (mm) is non-planar
NONPLANAR_LIMIT = 0.05


@dataclass(frozen=True)
class SectionFrame:
    """Plane of a section: origin (centroid), e1 (+x projected), e2 = n x e1, n (unit normal)."""

    origin: np.ndarray
    e1: np.ndarray
    e2: np.ndarray
    normal: np.ndarray
    flatness: float        # largest distance of a point from the plane (mm)

    def to_plane(self, points: np.ndarray) -> np.ndarray:
        """(m, 3) mm -> (m, 2) coordinates in the plane."""
        d = np.asarray(points, float) - self.origin
        return np.column_stack([d @ self.e1, d @ self.e2])

    def to_space(self, q: np.ndarray) -> np.ndarray:
        """(m, 2) plane coordinates -> (m, 3) points on the plane (mm)."""
        q = np.atleast_2d(np.asarray(q, float))
        return self.origin + q[:, :1] * self.e1 + q[:, 1:2] * self.e2

    def vector_to_space(self, v: np.ndarray) -> np.ndarray:
        v = np.atleast_2d(np.asarray(v, float))
        return v[:, :1] * self.e1 + v[:, 1:2] * self.e2


@dataclass(frozen=True)
class ThroatSpec:
    """Inputs of seed 000 eq. 5: inlet/outlet flow angles (degrees from axial) and C_L."""

    beta1_deg: float
    beta2_deg: float
    lift_coefficient: float = 1.0


@dataclass(frozen=True)
class Segmentation:
    """One segmented section; parameters t are those of ``curve`` (2D, periodic on [0, 1))."""

    index: int
    frame: SectionFrame
    points2d: np.ndarray        # measured points in the plane (n, 2)
    curve: BSplineCurve         # 2D periodic cubic through/near the points
    method: str                 # 'interpolate' | 'approximate'
    t_points: np.ndarray        # parameter of each measured point
    t_le: float
    t_te: float
    le: np.ndarray              # 2D
    te: np.ndarray
    t_le_peak: float            # curvature maxima of the edge regions
    t_te_peak: float
    # joints: parameter where each region ends, in +t order around the loop
    t_joints: dict = field(default_factory=dict)   # le_suction, le_pressure, te_suction, te_pressure
    suction_forward: bool = True     # True: going +t from the LE runs along the suction side
    labels: np.ndarray | None = None  # region of every measured point (LE, SUCTION, TE, PRESSURE)
    throat: dict | None = None
    offsets: np.ndarray | None = None  # distance of each measured point from the plane (mm)
    # the curve at _TABLE equal parameter steps from its start (mm), as segmentation computed it,
    # with the curve it belongs to: measuring reuses it (:meth:`table_points`) instead of evaluating again
    table: tuple | None = field(default=None, repr=False, compare=False)

    def table_points(self, samples: int) -> np.ndarray | None:
        """The curve at ``samples`` equal parameter steps, when segmentation kept that table of this curve."""
        if self.table is None or self.table[0] is not self.curve or len(self.table[1]) != samples:
            return None
        return self.table[1]

    def lift(self, q: np.ndarray) -> np.ndarray:
        """Plane points (m, 2) -> 3D, with the out-of-plane offset of a non-planar section
        interpolated from the two nearest measured points (inverse distance)."""
        q = np.atleast_2d(np.asarray(q, float))
        base = self.frame.to_space(q)
        if self.offsets is None or self.frame.flatness <= NONPLANAR_LIMIT:   # planar: offsets are noise
            return base
        d, i = cKDTree(self.points2d).query(q, k=2)
        w = (self.offsets[i[:, 0]] * d[:, 1] + self.offsets[i[:, 1]] * d[:, 0]) / np.maximum(d.sum(axis=1), 1e-300)
        return base + w[:, None] * self.frame.normal

    @property
    def chord(self) -> float:
        return float(np.linalg.norm(self.te - self.le))

    @property
    def period(self) -> float:
        lo, hi = self.curve.domain
        return hi - lo

    def forward(self, t_from: float, t_to: float) -> float:
        """Parameter distance from t_from to t_to going +t around the loop."""
        return float(np.mod(t_to - t_from, self.period))

    def side_interval(self, side: int) -> tuple[float, float]:
        """(start, end) parameters (start < end, possibly > domain) of LE->TE on a side."""
        fwd = (side == SUCTION) == self.suction_forward
        if fwd:
            return self.t_le, self.t_le + self.forward(self.t_le, self.t_te)
        return self.t_te, self.t_te + self.forward(self.t_te, self.t_le)

    def region_interval(self, region: int) -> tuple[float, float]:
        """(start, end) parameters of a region in +t order (end may exceed the domain)."""
        j = self.t_joints
        if self.suction_forward:
            order = {LE: ("le_pressure", "le_suction"), SUCTION: ("le_suction", "te_suction"),
                     TE: ("te_suction", "te_pressure"), PRESSURE: ("te_pressure", "le_pressure")}
        else:
            order = {LE: ("le_suction", "le_pressure"), PRESSURE: ("le_pressure", "te_pressure"),
                     TE: ("te_pressure", "te_suction"), SUCTION: ("te_suction", "le_suction")}
        a, b = order[region]
        return j[a], j[a] + self.forward(j[a], j[b])

    def label_parameters(self, t: np.ndarray) -> np.ndarray:
        """Region (LE, SUCTION, TE, PRESSURE) of curve parameters t."""
        t = np.asarray(t, float)
        out = np.full(t.shape, -1, dtype=int)
        for region in (LE, SUCTION, TE, PRESSURE):
            a, b = self.region_interval(region)
            inside = np.mod(t - a, self.period) <= (b - a)
            out[(out < 0) & inside] = region
        return out


def section_frame(points: np.ndarray, span_axis: np.ndarray | None = None) -> SectionFrame:
    """Best-fit plane of a section (least squares, SVD), normal pointing along ``span_axis``.

    A non-planar section (points farther than :data:`NONPLANAR_LIMIT` from their best-fit
    plane, e.g. a stream-surface section) is projected on the plane normal to ``span_axis``
    instead, when one is given: the best-fit plane of a twisted stream-surface section leans
    and would turn its chord angle by degrees (NASA Rotor 67 tip: 20°).

    e1 is global +x projected on the plane (+y if the plane is nearly normal to x), so
    angles measured from e1 about the normal are "from +x about +z" for a section in a
    plane z = const. Units mm.
    """
    P = np.asarray(points, float)
    a = np.array([0.0, 0.0, 1.0]) if span_axis is None else np.asarray(span_axis, float)
    a = a / np.linalg.norm(a)
    origin = P.mean(axis=0)
    n = np.linalg.svd(P - origin, full_matrices=False)[2][-1]
    if n @ a < 0:
        n = -n
    if span_axis is not None and np.abs((P - origin) @ n).max() > NONPLANAR_LIMIT:
        # a stream-surface section: its best-fit plane leans with the blade's twist and would
        # turn the chord; the plane normal to the span axis keeps angles about the span
        n = a
    ref = np.array([1.0, 0.0, 0.0])
    if np.linalg.norm(np.cross(ref, n)) < 0.3:
        ref = np.array([0.0, 1.0, 0.0])
    e1 = ref - (ref @ n) * n
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(n, e1)
    flat = float(np.abs((P - origin) @ n).max())
    return SectionFrame(origin, e1, e2, n, flat)


def signed_curvature(curve: BSplineCurve, t: np.ndarray) -> np.ndarray:
    """Signed curvature (1/mm) of a 2D curve, > 0 where it turns left (seed 000 eq. 4, parametric)."""
    d = curve_derivatives(curve, np.asarray(t, float), 2)
    c1, c2 = d[:, 1], d[:, 2]
    num = c1[:, 0] * c2[:, 1] - c1[:, 1] * c2[:, 0]
    return num / np.maximum(np.linalg.norm(c1, axis=1) ** 3, 1e-300)


def throat_chord_ratio(spec: ThroatSpec) -> float:
    """Seed 000 eq. 5: ``o/b = C_L / (2 cos²β2 (tanβ1 − tanβ2))`` (angles in degrees)."""
    b1, b2 = np.radians(spec.beta1_deg), np.radians(spec.beta2_deg)
    den = 2.0 * np.cos(b2) ** 2 * (np.tan(b1) - np.tan(b2))
    if abs(den) < 1e-6:
        raise BladeReconError(f"throat: inlet and outlet angles ({spec.beta1_deg}°, {spec.beta2_deg}°) "
                              "give no flow turning, eq. 5 is undefined: give different angles")
    return float(spec.lift_coefficient / abs(den))


def _check_closed(index: int, q: np.ndarray, max_gap: float | None) -> None:
    gaps = np.linalg.norm(np.roll(q, -1, axis=0) - q, axis=1)
    extent = float(np.ptp(q @ np.linalg.svd(q - q.mean(0), full_matrices=False)[2][0]))
    limit = 0.15 * extent if max_gap is None else max_gap
    k = int(np.argmax(gaps))
    if gaps[k] > limit:
        if k == q.shape[0] - 1:
            raise BladeReconError(
                f"section {index}: the section is open: its last and first points are {gaps[k]:.3f} mm apart "
                f"(limit {limit:.3f} mm); measure the whole profile round to the start")
        raise BladeReconError(
            f"section {index}: gap of {gaps[k]:.3f} mm between points {k + 1} and {k + 2} "
            f"(limit {limit:.3f} mm); measure points in the gap or raise the gap limit")


def _fit_curve(index: int, q: np.ndarray, method: str | None):
    """Periodic cubic section curve in the plane; the fitting code works on 3D points (z = 0)."""
    q3 = np.column_stack([q, np.zeros(len(q))])
    choice = choose_method([q3])
    method = method or choice.method
    if method == "interpolate":
        sc = fit_section_interpolate(index, q3)
    else:
        sigma = max(choice.noise_mm, 1e-6)
        sc = fit_section_approximate(index, q3, 5.0 * sigma * np.sqrt(2.0), rms_target=1.3 * sigma * np.sqrt(2.0))
    c = sc.curve
    curve2 = BSplineCurve(np.ascontiguousarray(c.poles[:, :2]), c.knots, c.mults, c.degree, c.periodic)
    return sc, curve2, method


def _chord_ends(curve: BSplineCurve, t: np.ndarray, pts: np.ndarray) -> tuple[float, float]:
    """The two ends along the chord, refined to tangent ⟂ chord (fixed point; cf. surface.find_le_te)."""
    c = pts - pts.mean(axis=0)
    d = np.linalg.svd(c, full_matrices=False)[2][0]
    for _ in range(8):
        along = pts @ d
        i_a, i_b = int(np.argmin(along)), int(np.argmax(along))
        nd = pts[i_b] - pts[i_a]
        nd /= np.linalg.norm(nd)
        if np.all(np.abs(nd - d) <= 1e-13 + 1e-5 * np.abs(d)):     # np.allclose(nd, d, atol=1e-13), less overhead
            break
        d = nd
    lo, hi = curve.domain
    step_max = (hi - lo) / t.size
    ts = np.array([t[i_a], t[i_b]])
    U = curve.full_knots()          # once, not at each of the ~20 evaluations
    for _ in range(6):
        for _k in range(20):   # Newton on C'(t)·d = 0, both ends at once
            der = curve_derivatives(curve, ts, 2, U)
            f, fp = der[:, 1] @ d, der[:, 2] @ d
            step = np.minimum(np.maximum(-f / np.where(np.abs(fp) > 1e-300, fp, 1e-300), -step_max), step_max)
            ts = ts + step
            if np.abs(step).max() < 1e-14:
                break
        ends = evaluate_curve(curve, ts, U)
        nd = ends[1] - ends[0]
        nd /= np.linalg.norm(nd)
        moved = np.linalg.norm(nd - d)
        d = nd
        if moved < 1e-13:
            break
    ts = lo + np.mod(ts - lo, hi - lo)
    return float(ts[0]), float(ts[1])


def _smoothed_curvature(kappa: np.ndarray, perimeter: float, chord: float,
                        ends: tuple[int, ...] | None = None) -> tuple[np.ndarray, int]:
    """The curvature table median-filtered over ~0.5 % of the chord, and the half width (samples):
    a spike of the interpolant (a seam, a bad point) neither makes the peak nor the joint, while
    a true step of curvature stays sharp. One filter serves both ends (it is most of their cost).

    ``ends`` (table indices): only the stretches :func:`_edge_analysis` reads round them are
    filtered (the rest is NaN), each by the same filter on the stretch and the filter's half
    width beyond it, so every value is its own window's median as in the whole table's filter,
    at about half the cost (issue 24)."""
    n = kappa.size
    w = max(int(0.0025 * chord / (perimeter / n)), 1)
    size = 2 * w + 1
    reach = _reach(perimeter, chord, n)
    if ends is None or 2 * len(ends) * (reach + w + 1) >= n or not np.all(np.isfinite(kappa)):
        return median_filter(kappa, size=size, mode="wrap"), w
    out = np.full(n, np.nan)
    for i in ends:
        idx = np.arange(i - reach - w, i + reach + w + 1)
        part = median_filter(np.take(kappa, idx, mode="wrap"), size=size)
        out[idx[w:-w] % n] = part[w:-w]          # windows wholly inside the stretch
    return out, w


def _reach(perimeter: float, chord: float, n: int) -> int:
    """How far (table samples) :func:`_edge_analysis` looks from an end."""
    return int(min(0.25 * chord, 0.2 * perimeter) / (perimeter / n))


def _edge_analysis(ksm_all: np.ndarray, w: int, i_end: int, perimeter: float, chord: float, flank_level: float):
    """Curvature peak and the two joints (steepest curvature drop) around one end.

    ``ksm_all``, ``w``: the dense curvature table (equal steps in the curve parameter, close
    to arc length) median-filtered, and the filter's half width (:func:`_smoothed_curvature`);
    ``i_end`` the index of the edge point. Returns
    (i_peak, i_minus, i_plus, peak) with i_minus before, i_plus after the end (table indices,
    may wrap).
    """
    n = ksm_all.size
    ds = perimeter / n
    reach = _reach(perimeter, chord, n)
    off = np.arange(-reach, reach + 1)
    near = np.abs(off) <= max(int(0.03 * chord / ds), 2)
    idx = (i_end + off[near]) % n
    i_peak = int(idx[np.argmax(ksm_all[idx])])
    peak = float(ksm_all[idx].max())
    out = []
    for sign in (-1, 1):
        ksm = ksm_all[(i_end + sign * np.arange(0, reach + 1)) % n]
        level = flank_level + 0.05 * (peak - flank_level)
        below = np.flatnonzero(ksm < level)
        stop = int(below[0]) if below.size else reach
        stop = max(min(int(stop * 1.3) + 2 * w, reach), 3)
        rate = -np.gradient(ksm[: stop + 1], ds)       # curvature drop per mm outward
        j = int(np.argmax(rate[1:])) + 1
        out.append(int((i_end + sign * j) % n))
    return i_peak, out[0], out[1], peak


def segment_section(points: np.ndarray, index: int = 0, span_axis: np.ndarray | None = None,
                    le_hint: np.ndarray | None = None, throat: ThroatSpec | None = None,
                    method: str | None = None, max_gap: float | None = None,
                    peak_ratio: float = 4.0, flow: np.ndarray | None = None) -> Segmentation:
    """Segment one closed, ordered section (n, 3) mm into LE, suction, TE and pressure regions.

    See the module docstring for the steps. ``le_hint``: a 3D point near the LE (e.g. the
    first measured point when the measurement starts at the LE). ``method``: 'interpolate'
    or 'approximate' to force the section curve, default chosen from the data.
    ``peak_ratio``: the curvature maximum at each end must exceed this multiple of the
    median curvature of the section. ``flow``: the direction the fluid travels (3D); the
    LE is then the upstream end (before ``le_hint``). Raises :class:`BladeReconError` for open sections,
    gaps, and profiles without clear edge curvature peaks.
    """
    P = np.asarray(points, float)
    if P.ndim != 2 or P.shape[0] < 8:
        raise BladeReconError(f"section {index}: {P.shape[0] if P.ndim == 2 else 0} points, "
                              "segmentation needs at least 8: measure more points on the section")
    frame = section_frame(P, span_axis)
    q = frame.to_plane(P)
    _check_closed(index, q, max_gap)
    sc, curve, method = _fit_curve(index, q, method)
    lo, hi = curve.domain
    t = lo + (hi - lo) * np.arange(_TABLE) / _TABLE
    der = curve_derivatives(curve, t, 2)
    # contiguous: a strided view made every ``pts @ d`` of the chord search 4 ms (numpy's
    # matmul leaves BLAS for strided operands), 20 ms a section, half of `sections`' own time
    pts = np.ascontiguousarray(der[:, 0])
    speed = np.linalg.norm(der[:, 1], axis=1)
    kappa = (der[:, 1, 0] * der[:, 2, 1] - der[:, 1, 1] * der[:, 2, 0]) / np.maximum(speed ** 3, 1e-300)
    if np.mean(kappa) < 0:      # a clockwise loop in the plane: convex ends get κ > 0 all the same
        kappa = -kappa
    perimeter = float(np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1).sum())

    t_a, t_b = _chord_ends(curve, t, pts)
    ends = evaluate_curve(curve, np.array([t_a, t_b]))
    chord = float(np.linalg.norm(ends[1] - ends[0]))
    flank_level = float(np.median(np.abs(kappa)))
    i_ends = [int(np.round((t_end - lo) / (hi - lo) * _TABLE)) % _TABLE for t_end in (t_a, t_b)]
    ksm, w = _smoothed_curvature(kappa, perimeter, chord, tuple(i_ends))
    info = []
    for t_end, i_end in zip((t_a, t_b), i_ends):
        i_peak, i_m, i_p, peak = _edge_analysis(ksm, w, i_end, perimeter, chord, flank_level)
        if not peak > peak_ratio * max(flank_level, 1e-12):
            raise BladeReconError(
                f"section {index}: no clear LE/TE curvature peak (end curvature {peak:.4g}/mm is not "
                f"{peak_ratio:g}x the median {flank_level:.4g}/mm): is this a blade profile? check the section")
        span = np.mod(np.arange(i_m, i_m + np.mod(i_p - i_m, _TABLE) + 1), _TABLE)
        info.append({"t_end": t_end, "t_peak": t[i_peak], "t_minus": t[i_m], "t_plus": t[i_p],
                     "peak": peak, "mean_kappa": float(np.mean(kappa[span]))})

    if flow is not None:
        f2 = frame.to_plane(frame.origin + np.asarray(flow, float).reshape(1, 3))[0]
        swap = bool((ends[1] - ends[0]) @ f2 < 0)      # LE upstream: smaller coordinate along the flow
    elif le_hint is not None:
        hint2 = frame.to_plane(np.asarray(le_hint, float).reshape(1, 3))[0]
        swap = np.linalg.norm(ends[1] - hint2) < np.linalg.norm(ends[0] - hint2)
    else:
        swap = info[1]["mean_kappa"] < info[0]["mean_kappa"]   # blunter end = LE
    le_info, te_info = (info[1], info[0]) if swap else (info[0], info[1])
    le, te = (ends[1], ends[0]) if swap else (ends[0], ends[1])

    # suction side: the side the camber bulges towards
    dvec = (te - le) / np.linalg.norm(te - le)
    per = hi - lo
    fwd_span = np.mod(te_info["t_end"] - le_info["t_end"], per)
    tt = np.mod(t - le_info["t_end"], per)
    fwd_mask = tt < fwd_span
    off = (pts - le) @ np.array([-dvec[1], dvec[0]])
    m_fwd, m_back = float(off[fwd_mask].mean()), float(off[~fwd_mask].mean())
    bulge = 0.5 * (m_fwd + m_back)          # mean camber offset from the chord
    suction_forward = bool(np.sign(m_fwd - m_back) == np.sign(bulge)) if abs(bulge) > 1e-9 else True

    # joints: *_minus is before the end in +t, *_plus after
    if suction_forward:
        joints = {"le_pressure": le_info["t_minus"], "le_suction": le_info["t_plus"],
                  "te_suction": te_info["t_minus"], "te_pressure": te_info["t_plus"]}
    else:
        joints = {"le_suction": le_info["t_minus"], "le_pressure": le_info["t_plus"],
                  "te_pressure": te_info["t_minus"], "te_suction": te_info["t_plus"]}
    seg = Segmentation(index, frame, q, curve, method, sc.t_points, le_info["t_end"], te_info["t_end"],
                       le, te, le_info["t_peak"], te_info["t_peak"], joints, bool(suction_forward),
                       offsets=(P - frame.origin) @ frame.normal, table=(curve, pts))
    if throat is not None:
        info_throat = _throat_point(seg, throat, pts, t)
        # the TE region starts at the throat point on the suction side (seed 000 Fig. 3)
        seg = replace(seg, t_joints={**joints, "te_suction": info_throat["t"]}, throat=info_throat)
    return replace(seg, labels=seg.label_parameters(sc.t_points))


def _throat_point(seg: Segmentation, spec: ThroatSpec, pts: np.ndarray, t: np.ndarray) -> dict:
    """Throat point on the suction side (seed 000 eq. 5 and Fig. 4).

    o = (o/b)·b with b the chord. The neighbouring blade is this section moved by the pitch s
    along ±e2 (towards the suction side); s is found so that the distance from the
    neighbour's TE to the suction side equals o; the foot of that distance is the throat.
    """
    ratio = throat_chord_ratio(spec)
    b = seg.chord
    o = ratio * b
    a, e = seg.side_interval(SUCTION)
    per = seg.period
    on_side = np.mod(t - a, per) <= (e - a)
    side_pts = pts[on_side]
    side_t = t[on_side]
    # direction towards the suction side along e2
    mid = side_pts.mean(axis=0) - 0.5 * (seg.le + seg.te)
    sign = 1.0 if mid[1] >= 0 else -1.0
    tree = cKDTree(side_pts)
    s_grid = np.linspace(0.02, 4.0, 400) * b
    te_n = seg.te[None, :] + sign * s_grid[:, None] * np.array([0.0, 1.0])[None, :]
    dist, idx = tree.query(te_n)
    ok = np.flatnonzero(dist >= o)
    if not ok.size:
        raise BladeReconError(f"section {seg.index}: throat width {o:.3f} mm (eq. 5, o/b={ratio:.3f}) is larger "
                              "than any neighbour distance: check the inlet/outlet angles and C_L")
    k = int(ok[0])
    if k > 0:
        f = (o - dist[k - 1]) / max(dist[k] - dist[k - 1], 1e-12)
        s = s_grid[k - 1] + f * (s_grid[k] - s_grid[k - 1])
    else:
        s = s_grid[0]
    te_nb = seg.te + sign * s * np.array([0.0, 1.0])
    d, i = tree.query(te_nb)
    return {"t": float(side_t[i]), "point": side_pts[i], "width": float(o), "ratio": float(ratio),
            "pitch": float(s), "lift_coefficient": spec.lift_coefficient,
            "beta1_deg": spec.beta1_deg, "beta2_deg": spec.beta2_deg}
