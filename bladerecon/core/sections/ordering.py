# SPDX-License-Identifier: LGPL-2.1-or-later
"""Stage 2 of the pipeline: :class:`PointSet` -> ordered, oriented closed sections (mm).

The output is what seed 000 §2.4 needs before interpolation: sections listed along the
span (v, eq. 8) and, in each, the points as a closed loop in a consistent direction
(u, periodic, eq. 7), so that S_u x S_v of the surface points out of the blade.

Per section:

1. a closing point equal to the first is dropped; any other repeated point is an error;
2. the points are projected on the plane normal to the span axis
   (:func:`section_plane_frame`); sections need not be planar (the NASA rotors are
   measured on stream surfaces of revolution);
3. the measurement order is kept when it is a sensible loop, otherwise a loop is
   computed from a camber line (see :func:`_camber_order`);
4. the loop is turned counter-clockwise about +span axis.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.readers import PointSet
from bladerecon.core.tolerances import POINT_TOL

__all__ = ["Section", "SectionSet", "build_sections", "section_plane_frame"]

KEEP_ORDER_RATIO = 1.2   # the given order is kept if its loop is at most this x the computed one
_PAIR_BUDGET = 1 << 20   # segment pairs tested at once in the crossing search (memory bound)


@dataclass(frozen=True, eq=False)
class Section:
    """One blade section as a closed loop (closing point not repeated).

    Attributes:
        index: 0-based position along the span, as given in the file.
        name: the section's name from the file.
        points: (n, 3) mm, in loop order, counter-clockwise about +span axis.
        lines: (n,) 1-based file line number of each point, in the same order.
        reordered: True if the measurement order was replaced by a computed one
            (turning a loop round to orient it does not count).
    """

    index: int
    name: str
    points: np.ndarray
    lines: np.ndarray
    reordered: bool

    def __post_init__(self) -> None:
        self.points.flags.writeable = False
        self.lines.flags.writeable = False

    @property
    def line_range(self) -> tuple[int, int]:
        """First and last file line of the section's points (for messages)."""
        return int(self.lines.min()), int(self.lines.max())


@dataclass(frozen=True, eq=False)
class SectionSet:
    """The sections of one blade, first to last along the span.

    ``span_axis`` is a unit (3,) vector pointing from the first section to the last.
    """

    sections: tuple[Section, ...]
    span_axis: np.ndarray
    source: str

    def __post_init__(self) -> None:
        self.span_axis.flags.writeable = False


def section_plane_frame(points: np.ndarray, span_axis: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Orthonormal frame (origin, e1, e2) of a section in the plane normal to the span axis.

    origin is the centroid of the points (mm); e1 is the principal direction (PCA) of
    the points projected on the plane, e2 = a x e1, so that e1 x e2 = a (unit span axis).
    The sign of e1 is fixed (largest component positive) so the frame is reproducible.
    2D coordinates of a point p are ((p - origin)·e1, (p - origin)·e2).
    """
    pts = np.asarray(points, dtype=float)
    a = np.asarray(span_axis, dtype=float)
    a = a / np.linalg.norm(a)
    origin = pts.mean(axis=0)
    d = pts - origin
    d -= np.outer(d @ a, a)
    e1 = np.linalg.svd(d, full_matrices=False)[2][0]
    e1 -= (e1 @ a) * a   # keep it exactly in the plane despite round-off
    norm = np.linalg.norm(e1)
    if norm < 0.5:       # no spread in the plane: any direction normal to a will do
        e1 = np.cross(a, np.eye(3)[np.argmin(np.abs(a))])
        norm = np.linalg.norm(e1)
    e1 /= norm
    if e1[np.argmax(np.abs(e1))] < 0:
        e1 = -e1
    return origin, e1, np.cross(a, e1)


def build_sections(pointset: PointSet, *, min_points: int = 5) -> SectionSet:
    """Ordered, oriented closed sections (mm) from a :class:`PointSet`.

    Sections keep the file's order (index 0 first along the span); the span axis is the
    direction of the least-squares line through the section centroids, first -> last.
    In each section the measurement order is kept if it is a sensible loop (see
    :func:`_loop_order`), and every loop is turned counter-clockwise about +span axis.

    Raises:
        BladeReconError: repeated points, a section with fewer than ``min_points``
            points, fewer than 2 sections, sections out of span order, neighbouring
            sections that cross, a section with no area, or a section that crosses itself.
    """
    if min_points < 3:
        raise ValueError("min_points must be at least 3 (a closed loop)")
    src = pointset.source
    groups = []
    for k, name in enumerate(pointset.section_names):
        mask = pointset.section == k
        pts, lines = _drop_closing_point(pointset.points[mask], pointset.line[mask])
        if len(pts) < min_points:
            where = f" (lines {lines.min()}–{lines.max()})" if len(lines) else ""
            raise BladeReconError(
                f"{src}: section '{name}'{where} has {len(pts)} points, needs at least "
                f"{min_points}: measure more points on it or remove the section")
        _check_no_duplicates(src, name, pts, lines)
        groups.append((name, pts, lines))
    if len(groups) < 2:
        found = (f"only 1 section (lines {groups[0][2].min()}–{groups[0][2].max()})"
                 if groups else "no sections")
        raise BladeReconError(f"{src}: {found}, a surface needs at least 2: give the points of "
                              "more sections")

    span_axis = _span_axis(src, groups)
    for name, pts, lines in groups:     # a section on a line has no plane or loop to judge by
        _check_not_on_a_line(src, name, pts, lines, span_axis)
    _check_no_crossing(src, groups, span_axis)
    sections = []
    for k, (name, pts, lines) in enumerate(groups):
        origin, e1, e2 = section_plane_frame(pts, span_axis)
        q = (pts - origin) @ np.column_stack([e1, e2])
        order, reordered = _loop_order(src, name, q, lines)
        if _signed_area(q[order]) < 0:
            order = np.concatenate([order[:1], order[:0:-1]])   # same start, other way round
        sections.append(Section(index=k, name=name, points=pts[order], lines=lines[order],
                                reordered=reordered))
    return SectionSet(sections=tuple(sections), span_axis=span_axis, source=src)


# --- checks ----------------------------------------------------------------------------

def _drop_closing_point(pts: np.ndarray, lines: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    if len(pts) > 1 and np.array_equal(pts[0], pts[-1]):
        return pts[:-1], lines[:-1]
    return pts, lines


def _check_no_duplicates(src: str, name: str, pts: np.ndarray, lines: np.ndarray) -> None:
    order = np.lexsort(pts.T[::-1])
    same = np.flatnonzero(np.all(pts[order[1:]] == pts[order[:-1]], axis=1))
    if same.size:
        a, b = sorted((int(lines[order[same[0]]]), int(lines[order[same[0] + 1]])))
        raise BladeReconError(f"{src}: section '{name}': lines {a} and {b} hold the same point: "
                              "remove the duplicate")


def _span_axis(src: str, groups: list) -> np.ndarray:
    """Unit direction of the least-squares (total least squares, PCA) line through the
    section centroids, oriented first -> last; checks the sections are strictly
    monotonic along it."""
    centroids = np.array([pts.mean(axis=0) for _, pts, _ in groups])
    centre = centroids.mean(axis=0)
    _, sv, vt = np.linalg.svd(centroids - centre, full_matrices=False)
    if sv[0] <= POINT_TOL:
        first, last = groups[0][2].min(), groups[-1][2].max()
        raise BladeReconError(f"{src}, lines {first}–{last}: all sections have the same centre: "
                              "give sections at different span positions")
    axis = vt[0]
    if (centroids[-1] - centroids[0]) @ axis < 0:
        axis = -axis
    t = (centroids - centre) @ axis
    if np.all(np.diff(t) > POINT_TOL):
        return axis
    # Name the section to move: the first one off the longest run that is in span order.
    names = [name for name, _, _ in groups]
    run, back = _increasing_run(t), _increasing_run(-t)
    if len(back) > len(run):
        run, t = back, -t
    k = next(j for j in range(len(t)) if j not in run)
    others = np.array(run)
    below, above = others[t[others] < t[k]], others[t[others] >= t[k]]
    if below.size and above.size:
        where = (f"between section '{names[below[np.argmax(t[below])]]}' and section "
                 f"'{names[above[np.argmin(t[above])]]}'")
    elif above.size:
        where = f"before section '{names[above[np.argmin(t[above])]]}'"
    else:
        where = f"after section '{names[below[np.argmax(t[below])]]}'"
    lines = groups[k][2]
    raise BladeReconError(
        f"{src}: sections given in the wrong order: section '{names[k]}' (lines "
        f"{lines.min()}–{lines.max()}) lies {where} along the span; list sections from hub to "
        "tip")


def _plane(pts: np.ndarray, span_axis: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Best-fit plane of a section: centroid, unit normal along +span, rms out of plane."""
    c = pts.mean(axis=0)
    _, sv, vt = np.linalg.svd(pts - c, full_matrices=False)
    n = vt[-1] if vt[-1] @ span_axis >= 0 else -vt[-1]
    return c, n, float(sv[-1] / np.sqrt(len(pts)))


def _check_no_crossing(src: str, groups: list, span_axis: np.ndarray) -> None:
    """Neighbouring sections must not cross: no point of a section on the hub side of the
    plane of the section before it, nor on the tip side of the plane of the section after
    it, beyond 3 x the planes' rms out-of-plane + 1 µm (noise, stream-surface sections). A
    surface lofted through crossing sections folds over itself (issue 23 §6)."""
    planes = [_plane(pts, span_axis) for _, pts, _ in groups]
    for k in range(len(groups) - 1):
        (na, pa, la), (nb, pb, lb) = groups[k], groups[k + 1]
        (ca, ua, ra), (cb, ub, rb) = planes[k], planes[k + 1]
        tol = 3.0 * max(ra, rb) + 0.001
        below = (pb - ca) @ ua              # section b's points over a's plane
        above = (pa - cb) @ ub              # section a's points over b's plane
        j, i = int(np.argmin(below)), int(np.argmax(above))
        # two profiles at one height (the loft folds between them): b's mean height over a's
        # plane no larger than its own uncertainty (3 standard errors) + 1 µm; curved (stream
        # surface, cylinder) sections have a large spread but a mean height of the spacing
        apart = float(below.mean())
        if apart <= 3.0 * float(below.std()) / np.sqrt(len(below)) + 0.001:
            raise BladeReconError(
                f"{src}: sections '{na}' (lines {int(la.min())}–{int(la.max())}) and '{nb}' (lines "
                f"{int(lb.min())}–{int(lb.max())}) lie at one span position ({apart:.4f} mm apart): a "
                "surface through them would fold: give each section its own height, or one label to "
                "the points of one section")
        if below[j] < -tol:
            what = f"section '{nb}' (line {int(lb[j])}) reaches {-below[j]:.3f} mm below the plane of section '{na}'"
        elif above[i] > tol:
            what = f"section '{na}' (line {int(la[i])}) reaches {above[i]:.3f} mm above the plane of section '{nb}'"
        else:
            continue
        raise BladeReconError(f"{src}: sections '{na}' and '{nb}' cross: {what}; a surface through them "
                              "would fold: check the section labels and planes")


def _check_not_on_a_line(src: str, name: str, pts: np.ndarray, lines: np.ndarray, span_axis: np.ndarray) -> None:
    """A section whose points lie on a line (in the plane normal to the span, a spread across
    it under a thousandth of its length): one line, before the crossing check would blame its
    (undefined) plane or the loop ordering its missing area."""
    q = pts - pts.mean(axis=0)
    q = q - np.outer(q @ span_axis, span_axis)
    sv = np.linalg.svd(q, compute_uv=False)
    # across the line a thousandth of its length (a blade's thickness is a few per cent of
    # its chord; a measured line is off its straight line only by the noise)
    if len(sv) < 2 or sv[1] <= max(1e-3 * sv[0], POINT_TOL * np.sqrt(len(pts))):
        raise BladeReconError(
            f"{src}: section '{name}' (lines {lines.min()}–{lines.max()}) has no area in the "
            "plane normal to the span axis: its points lie on a line; check the section data")


def _increasing_run(t: np.ndarray) -> list[int]:
    """Indices of a longest strictly increasing subsequence of t (O(m²), m = sections)."""
    m = len(t)
    length, prev = np.ones(m, dtype=int), np.full(m, -1)
    for j in range(m):
        for i in range(j):
            if t[i] + POINT_TOL < t[j] and length[i] + 1 > length[j]:
                length[j], prev[j] = length[i] + 1, i
    j, run = int(np.argmax(length)), []
    while j >= 0:
        run.append(j)
        j = int(prev[j])
    return run[::-1]


# --- ordering --------------------------------------------------------------------------

def _loop_order(src: str, name: str, q: np.ndarray, lines: np.ndarray) -> tuple[np.ndarray, bool]:
    """Order of the 2D points ``q`` (mm) around the loop, and whether it was computed.

    The given order is kept when its closed polygon is at most KEEP_ORDER_RATIO times
    as long as the computed one; either way the loop must not cross itself.
    """
    n = len(q)
    given = np.arange(n)
    given_length = _loop_length(q[given])
    # any closed loop through the points is at least twice as long as their extent along any
    # direction: a given loop within KEEP_ORDER_RATIO of that bound is kept without computing the
    # other (the usual case, a measured section in order; 1.5 ms a section of `sections`)
    axis = np.linalg.svd(q - q.mean(axis=0), full_matrices=False)[2][0]
    if given_length <= KEEP_ORDER_RATIO * 2.0 * float(np.ptp(q @ axis)) * (1.0 - 1e-9):
        order, reordered = given, False
    else:
        candidate = _uncross(q, _camber_order(q))
        if given_length <= KEEP_ORDER_RATIO * _loop_length(q[candidate]):
            order, reordered = given, False
        else:
            order, reordered = candidate, True
    hit = _first_crossing(q[order], noise_radius(q[order]))
    if hit is not None:
        i, j = hit
        at = lines[order[[i, (i + 1) % n, j, (j + 1) % n]]]
        edges = f"(edge {at[0]}–{at[1]} crosses edge {at[2]}–{at[3]})"
        if reordered:
            raise BladeReconError(
                f"{src}: section '{name}' (lines {lines.min()}–{lines.max()}): its points "
                f"could not be put in a loop that does not cross itself {edges}: give its "
                "points in measurement order around the section")
        raise BladeReconError(
            f"{src}: section '{name}' crosses itself between lines {at[1]} and {at[2]} "
            f"{edges}: check the order of its points")
    return order, reordered


def _camber_order(q: np.ndarray) -> np.ndarray:
    """A loop through thin, cambered section points given in any order (2D, mm).

    1. Chord from the two farthest points (the section's diameter, :func:`_diameter`).
       In the chord frame the leading/trailing edges are the extreme points in ξ;
       t = (ξ - ξ_LE)/(ξ_TE - ξ_LE) and η is the height above the LE-TE line.
    2. A first camber line η_c = t (1 - t) (a0 + a1 t + a2 t²) is fitted by least
       squares to all points; side = sign(η - η_c).
    3. Refinement, until the sides stop changing (at most 5 rounds): each side is fitted
       by least squares with a Chebyshev series in the angle θ, t = (1 - cos θ)/2,
       which stays smooth across round edges (η ~ √t there); the new camber line is
       half-way between the two fits. Sparse sides are fitted with a low degree.
    4. Of the side splits met on the way, the one giving the shortest loop is kept: a
       point put on the wrong side makes a detour across the section.

    The loop is LE, one side by increasing ξ, TE, the other side by decreasing ξ.
    """
    n = len(q)
    a, b = _diameter(q)
    ex = (q[b] - q[a]) / np.linalg.norm(q[b] - q[a])
    d = q - q[a]
    xi, eta = d @ ex, d @ np.array([-ex[1], ex[0]])
    le, te = int(np.argmin(xi)), int(np.argmax(xi))
    t = (xi - xi[le]) / (xi[te] - xi[le])
    eta = eta - (eta[le] + t * (eta[te] - eta[le]))
    ends = np.zeros(n, dtype=bool)
    ends[[le, te]] = True

    def loop(upper: np.ndarray) -> np.ndarray:
        up, lo = np.flatnonzero(upper), np.flatnonzero(~upper & ~ends)
        return np.concatenate([[le], up[np.argsort(xi[up], kind="stable")], [te],
                               lo[np.argsort(-xi[lo], kind="stable")]])

    basis = (t * (1.0 - t))[:, None] * t[:, None] ** np.arange(min(3, n - 2))
    upper = ~ends & (eta > basis @ np.linalg.lstsq(basis, eta, rcond=None)[0])
    best = loop(upper)
    best_length = _loop_length(q[best])
    x = 2.0 / np.pi * np.arccos(1.0 - 2.0 * np.clip(t, 0.0, 1.0)) - 1.0   # θ mapped to [-1, 1]
    for _ in range(5):
        lower = ~ends & ~upper
        deg = min(10, (min(upper.sum(), lower.sum()) + 1) // 2)
        if deg < 2:
            break
        vander = np.polynomial.chebyshev.chebvander(x, deg)
        fit_u = vander @ np.linalg.lstsq(vander[upper | ends], eta[upper | ends], rcond=None)[0]
        fit_l = vander @ np.linalg.lstsq(vander[lower | ends], eta[lower | ends], rcond=None)[0]
        new = ~ends & (eta > 0.5 * (fit_u + fit_l))
        if np.array_equal(new, upper):
            break
        upper = new
        order = loop(upper)
        length = _loop_length(q[order])
        if length < best_length:
            best, best_length = order, length
    return best


def _uncross(q: np.ndarray, order: np.ndarray) -> np.ndarray:
    """Remove crossings by 2-opt moves (Croes 1958): a crossing pair of edges (i, i+1),
    (j, j+1) is replaced by (i, j), (i+1, j+1), which shortens the loop, so it ends.
    Capped at n moves; a crossing left over is reported by the caller."""
    order = order.copy()
    for _ in range(len(order)):
        hit = _first_crossing(q[order])
        if hit is None:
            break
        i, j = hit
        order[i + 1:j + 1] = order[i + 1:j + 1][::-1]
    return order


LOCAL_EDGES = 4          # a crossing of edges this close along the loop may be noise (noise_radius)


def noise_radius(poly: np.ndarray) -> float:
    """The scale (mm) below which a closed loop's wiggles are measurement noise: 5x the median
    distance of a point from the line through its two neighbours. Dense sections with noise
    larger than their spacing zig-zag at this scale; on a clean loop it is the sagitta of the
    spacing (h²κ/8), far smaller than the spacing itself, so no real loop fits inside it."""
    p = np.asarray(poly, float)
    if len(p) < 5:
        return 0.0
    a, c = np.roll(p, 1, axis=0), np.roll(p, -1, axis=0)
    chord = c - a
    length = np.maximum(np.hypot(chord[:, 0], chord[:, 1]), 1e-300)
    dist = np.abs(chord[:, 0] * (p[:, 1] - a[:, 1]) - chord[:, 1] * (p[:, 0] - a[:, 0])) / length
    return 5.0 * float(np.median(dist))


def _local_noise(poly: np.ndarray, i: np.ndarray, j: np.ndarray, radius: float) -> np.ndarray:
    """Which crossings (i, j) are noise: the edges at most LOCAL_EDGES apart along the loop and
    the little loop they close (the points between them, the short way round) within
    ``radius`` of its centroid."""
    n = len(poly)
    gap = np.minimum(j - i, n - (j - i))
    out = np.zeros(len(i), dtype=bool)
    for k in np.flatnonzero(gap <= LOCAL_EDGES):
        a, b = (int(i[k]), int(j[k])) if j[k] - i[k] <= n - (j[k] - i[k]) else (int(j[k]), int(i[k]) + n)
        pts = poly[np.arange(a + 1, b + 1) % n]
        out[k] = np.sqrt(((pts - pts.mean(axis=0)) ** 2).sum(axis=1)).max() <= radius
    return out


def _first_crossing(poly: np.ndarray, noise: float = 0.0) -> tuple[int, int] | None:
    """First pair (i, j), i < j, of edges (i, i+1), (j, j+1 mod n) of the closed polygon
    that cross properly, or None. With ``noise`` (mm, :func:`noise_radius`), a crossing of
    edges close along the loop whose points all lie within that radius is a zig-zag of
    measurement noise, not a crossing.

    Sweep on x: edges sorted by their lowest x are only tested against the edges whose x
    range overlaps, in chunks of at most _PAIR_BUDGET pairs, so memory stays bounded.
    """
    n = len(poly)
    p0, p1 = poly, np.roll(poly, -1, axis=0)
    lo, hi = np.minimum(p0, p1), np.maximum(p0, p1)
    by_x = np.argsort(lo[:, 0], kind="stable")
    xs = lo[by_x, 0]
    stop = np.searchsorted(xs, hi[by_x, 0], side="right")
    count = np.maximum(stop - np.arange(n) - 1, 0)
    ends = np.cumsum(count)
    best: tuple[int, int] | None = None
    start = 0
    while start < n:
        base = ends[start - 1] if start else 0
        end = max(int(np.searchsorted(ends, base + _PAIR_BUDGET, side="right")), start + 1)
        cnt = count[start:end]
        total = int(cnt.sum())
        if total:
            pos = np.repeat(np.arange(start, end), cnt)
            offset = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)
            i, j = by_x[pos], by_x[pos + 1 + offset]
            i, j = np.minimum(i, j), np.maximum(i, j)
            keep = ((j - i) > 1) & ~((i == 0) & (j == n - 1))               # not neighbours
            keep &= (lo[i, 1] <= hi[j, 1]) & (lo[j, 1] <= hi[i, 1])         # y ranges overlap
            i, j = i[keep], j[keep]
            a, b, c, d = p0[i], p1[i], p0[j], p1[j]
            crossing = ((_orient(a, b, c) * _orient(a, b, d) < 0)
                        & (_orient(c, d, a) * _orient(c, d, b) < 0))
            if noise > 0.0 and crossing.any():
                k = np.flatnonzero(crossing)
                crossing[k[_local_noise(poly, i[k], j[k], noise)]] = False
            if crossing.any():
                k = np.flatnonzero(crossing)
                k = k[np.lexsort((j[k], i[k]))[0]]
                if best is None or (int(i[k]), int(j[k])) < best:
                    best = (int(i[k]), int(j[k]))
        start = end
    return best


def _orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """z of (b - a) x (c - a), row-wise: > 0 if a, b, c turn counter-clockwise."""
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


def _diameter(q: np.ndarray) -> tuple[int, int]:
    """Indices of two points farthest apart: alternate "farthest point from the other"
    from the point farthest from the centroid until the pair stops changing (a local
    maximum of the distance; for elongated blade sections, the chord ends)."""
    a = int(np.argmax(((q - q.mean(axis=0)) ** 2).sum(axis=1)))
    b = int(np.argmax(((q - q[a]) ** 2).sum(axis=1)))
    for _ in range(10):
        a_new = int(np.argmax(((q - q[b]) ** 2).sum(axis=1)))
        if a_new == a:
            break
        a, b = b, a_new
    return a, b


def _signed_area(poly: np.ndarray) -> float:
    """Shoelace formula: > 0 for a counter-clockwise closed polygon (mm²)."""
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def _loop_length(poly: np.ndarray) -> float:
    return float(np.linalg.norm(poly - np.roll(poly, -1, axis=0), axis=1).sum())
