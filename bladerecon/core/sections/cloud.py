# SPDX-License-Identifier: LGPL-2.1-or-later
"""A whole blade cloud -> sections with no slicing options (issue 25).

A scan or a CFD surface export of a blade is an unordered cloud that also holds what is no
airfoil: the hub fillet, the rounded tip cap. :func:`auto_sections` finds, from the cloud
alone, and says why:

1. **the span direction**: of the cloud's principal axes (snapped to x, y or z when within
   3°, or when that axis cuts at least 90 % as well), the one whose thin slabs are smallest
   against the cloud's extent along it (a blade is cut into airfoils across its span, into
   long strips along it), pointed from hub to tip;
2. **the airfoil span**: the area of each thin slab's convex hull along the span follows a
   smooth trend over the airfoil; the fillet makes it grow and the cap makes it shrink.
   A quadratic trend of the middle half is extended both ways; the span ends where two
   slabs in a row leave it by more than ``max(4 x its scatter, 3 %)``, less a margin of
   one slab (``span_range`` overrides);
3. **the sections**: when most nodes lie on common planes across the span (node rows of a
   CFD mesh, a measurement plan: :func:`node_rows`), those rows are the sections; else the
   slab width from the density (each slab about ``SLAB_POINTS`` points) and 6 to 21 sections
   covering at most a quarter of the span;
4. **every slab's points in order, by geometry**, never the file's: split into pieces by
   proximity, pieces closer than the spacing along the loop or the blade's own thickness
   merged, a piece farther off and as large as a fifth of the slab refused as a second blade,
   small ones dropped as outliers (:func:`order_slab`); the kept points put in a loop by their
   camber line (:func:`bladerecon.core.sections.ordering._camber_order`) and untangled;
5. **onto the plane along the surface**: each slab point slid along the blade by the
   section's normal speed, fitted in a window of neighbours along the loop
   (:func:`_slide_to_plane`), not along the axis.

Units: mm.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import ConvexHull, QhullError, cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.readers import PointSet
from bladerecon.core.sections.ordering import _camber_order, _first_crossing, _uncross, section_plane_frame

__all__ = ["CloudSections", "auto_sections", "span_direction", "airfoil_span", "order_slab", "node_rows",
           "SLAB_POINTS"]

SLAB_POINTS = 300            # points a section slab should hold
MAX_SECTION_POINTS = 600     # a denser slab is thinned evenly along its loop
#: a node row is a section as it is, thinned only beyond this (the common knots' pole cap, 1500):
#: a fan's rows of 732 nodes thinned to 600 lost their clustered edge nodes and the surface
#: missed them by 0.020 mm; kept whole, 0.006 mm (2026-11-27)
MAX_ROW_POINTS = 1400
_SNAP_DEG = 3.0


@dataclass(frozen=True)
class CloudSections:
    """Sections cut out of a cloud, each an ordered loop (mm), and what was chosen and why."""

    sections: list = field(repr=False)      # (n_k, 3) arrays, hub to tip, in loop order
    rows: list = field(repr=False)          # cloud row of each section point
    axis: np.ndarray
    positions: np.ndarray                   # plane heights along axis (mm)
    info: dict = field(repr=False)
    unrolled: list | None = field(default=None, repr=False)   # stream surfaces: (x m', y r·θ, z s·H) mm
    to_world: object = field(default=None, repr=False)        # maps unrolled points (n, 3) back to mm
    between: np.ndarray | None = field(default=None, repr=False)  # cloud rows between the end sections
    cloud: np.ndarray | None = field(default=None, repr=False)    # the whole cloud (N, 3) mm the sections came from

    def pointset(self, lines: np.ndarray, source: str) -> PointSet:
        pts = np.concatenate(self.sections)
        sec = np.concatenate([np.full(len(s), k) for k, s in enumerate(self.sections)])
        names = tuple(f"plane@{p:.3f}" for p in self.positions)
        return PointSet(pts, sec, np.asarray(lines)[np.concatenate(self.rows)], names, source, "cloud-auto")

    def section_set(self, lines: np.ndarray, source: str):
        """The sections as a :class:`~bladerecon.core.sections.ordering.SectionSet` in their
        own order, each turned so that its vector area points along the span (first -> last
        centroid): for sections on curved stream surfaces, whose projection on one plane may
        cross itself, this replaces ``build_sections``."""
        from bladerecon.core.sections.ordering import Section, SectionSet

        cent = np.array([p.mean(axis=0) for p in self.sections])
        span = cent[-1] - cent[0]
        span /= np.linalg.norm(span)
        out = []
        for k, (p, r) in enumerate(zip(self.sections, self.rows)):
            area = 0.5 * np.cross(p - cent[k], np.roll(p, -1, axis=0) - cent[k]).sum(axis=0)
            if area @ span < 0:
                p, r = np.concatenate([p[:1], p[:0:-1]]), np.concatenate([r[:1], r[:0:-1]])
            name = f"{self.info.get('kind', 'section')}@{self.positions[k]:.3f}"
            out.append(Section(index=k, name=name, points=np.array(p), lines=np.asarray(lines)[r], reordered=True))
        return SectionSet(sections=tuple(out), span_axis=span, source=source)


# ------------------------------------------------------------------ span direction
def _slab_diameter(Q: np.ndarray, a: np.ndarray) -> float:
    d = Q - Q.mean(axis=0)
    d -= np.outer(d @ a, a)
    return float(np.ptp(d @ np.linalg.svd(d, full_matrices=False)[2][0]))


def span_direction(P: np.ndarray) -> tuple[np.ndarray, str]:
    """Unit span direction (sign: towards the end where the cloud's slabs are smaller, the tip)
    and the reason, from the cloud's principal axes."""
    P = np.asarray(P, float)
    c = P - P.mean(axis=0)
    axes = np.linalg.svd(c[:: max(1, len(c) // 20000)], full_matrices=False)[2]
    k_near = max(30, len(c) // 60)

    def near(h: np.ndarray, z: float) -> np.ndarray:
        """The points nearest the height z (a slab that holds points even when the cloud lies in rows)."""
        return np.argpartition(np.abs(h - z), k_near)[:k_near]

    def score(a: np.ndarray) -> float:
        h = c @ a
        lo, hi = np.percentile(h, [1, 99])
        diam = [_slab_diameter(c[near(h, lo + f * (hi - lo))], a) for f in np.linspace(0.2, 0.8, 7)]
        return (hi - lo) / float(np.median(diam))

    scores = [score(a) for a in axes]
    a = axes[int(np.argmax(scores))].copy()
    k = int(np.argmax(np.abs(a)))
    # a swept or leaning blade tilts the principal axis: a coordinate axis that cuts nearly
    # as well is the user's frame, and gives sections at round heights
    snapped = np.degrees(np.arccos(min(1.0, abs(a[k])))) < _SNAP_DEG or score(np.eye(3)[k]) >= 0.9 * max(scores)
    if snapped:
        a = np.sign(a[k]) * np.eye(3)[k]
    h = c @ a
    lo, hi = np.percentile(h, [2, 98])
    ends = [_slab_diameter(c[near(h, z)], a) for z in (lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo))]
    # span direction points hub -> tip: the hub end is the one nearer the rotor axis when the
    # cloud is placed about it, else the larger end
    r_lo, r_hi = (np.linalg.norm(P[near(h, z)].mean(axis=0)) for z in (lo, hi))
    if abs(r_hi - r_lo) > 0.05 * (hi - lo):
        flip = r_hi < r_lo
    else:
        flip = ends[1] > ends[0]
    if flip:
        a = -a
    name = "xyz"[k] if snapped else "({:.4f}, {:.4f}, {:.4f})".format(*a)
    reason = (f"principal axis with slabs {max(scores):.1f}x smaller than the extent along it "
              f"(others {sorted(scores)[-2]:.1f}x, {sorted(scores)[0]:.1f}x)"
              + (f", taken as {name} (within {_SNAP_DEG:g}° or cutting at least 90 % as well)" if snapped else ""))
    return a, reason


# ------------------------------------------------------------------ airfoil span
def _hull_area(q: np.ndarray) -> float:
    try:
        return float(ConvexHull(q).volume) if len(q) >= 3 else 0.0
    except QhullError:
        return 0.0


def _trend_ends(z: np.ndarray, area: np.ndarray, lo: float, hi: float, local: bool = False) -> tuple[int, int, float]:
    """First and last probe (indices) still on the trend of log(area), and the limit (log area)
    that was used. The trend: the quadratic of the middle half, extended both ways.

    ``local`` (node rows, each a whole section of the blade): a probe is off the trend when the
    departure from that quadratic bends there, the second difference over a twentieth of the
    span (whatever the row spacing) beyond its noise (√6 x the scatter's limit): a smooth
    airfoil whose area bends away from the quadratic near its ends (a fan's tip row 4 % off it)
    is kept, a fillet or cap, which grows or shrinks the area within a few mm, is still left."""
    n_probe = len(z)
    mid = slice(n_probe // 4, 3 * n_probe // 4)
    good = area > 0
    x = (z - z.mean()) / (hi - lo)
    ok = good & (np.arange(n_probe) >= mid.start) & (np.arange(n_probe) < mid.stop)
    if ok.sum() < 6:
        raise BladeReconError(f"the cloud's slabs along the span axis hold too few points to find the airfoil "
                              f"span ({int(ok.sum())} of the middle {mid.stop - mid.start} slabs have an area): "
                              "give --span-range A:B (mm) or a denser cloud")
    coef = np.polyfit(x[ok], np.log(area[ok]), 2)
    rel = np.full(n_probe, np.inf)
    rel[good] = np.log(area[good]) - np.polyval(coef, x[good])
    scatter = 1.4826 * float(np.median(np.abs(rel[ok] - np.median(rel[ok]))))
    limit = max(4.0 * scatter, np.log(1.03))
    reach = (hi - lo) / 20.0
    bend_limit = max(4.0 * scatter * np.sqrt(6.0), np.log(1.03))

    def off(known: np.ndarray, j: int, step: int) -> bool:
        if not local:
            return abs(rel[j]) > limit
        # the second difference over a twentieth of the span, back towards the middle: a smooth
        # airfoil bends its log(area) by ~0.005 over it, a fillet's growth by 0.3 and more
        zs = z[known]
        order = np.argsort(zs)
        back = np.interp(z[j] - step * np.array([reach, 2.0 * reach]) * np.sign(z[-1] - z[0]),
                         zs[order], rel[known][order])
        return abs(rel[j] - 2.0 * back[0] + back[1]) > bend_limit

    def walk(start: int, step: int) -> int:
        k = start
        known = list(np.flatnonzero(ok))          # the middle half, and what the walk accepts
        while 0 <= k + step < n_probe:
            nxt, nxt2 = k + step, k + 2 * step
            base = np.array(known)
            if off(base, nxt, step) and (not 0 <= nxt2 < n_probe or off(base, nxt2, step)):
                return k
            k = nxt
            if np.isfinite(rel[k]):        # a probe without an area is stepped over, not a base
                known.append(k)
        return k

    return walk(n_probe // 2, -1), walk(n_probe // 2, +1), float(limit)


def airfoil_span(P: np.ndarray, axis: np.ndarray, n_probe: int = 80) -> tuple[float, float, dict]:
    """(lo, hi) heights (mm along ``axis``) of the airfoil span and why (see module doc, 2.)."""
    h = P @ axis
    lo, hi = float(h.min()), float(h.max())
    w = (hi - lo) / n_probe
    z = lo + (np.arange(n_probe) + 0.5) * w
    e1 = np.cross(axis, np.eye(3)[np.argmin(np.abs(axis))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    area = np.zeros(n_probe)
    order = np.argsort(h)
    hs = h[order]
    for k, zk in enumerate(z):
        i0, i1 = np.searchsorted(hs, [zk - 0.5 * w, zk + 0.5 * w])
        q = P[order[i0:i1]]
        area[k] = _hull_area(np.column_stack([q @ e1, q @ e2]))
    k_lo, k_hi, limit = _trend_ends(z, area, lo, hi)
    # keep one probe slab off where the trend was left (the growth starts inside it)
    a_lo = z[k_lo] - 0.5 * w + (w if k_lo > 0 else 0.0)
    a_hi = z[k_hi] + 0.5 * w - (w if k_hi < n_probe - 1 else 0.0)
    why = {"method": "convex-hull area of thin slabs against a quadratic trend of the middle half",
           "probe_slab_mm": w, "limit_relative": float(np.expm1(limit)),
           "trimmed_at_start": bool(k_lo > 0), "trimmed_at_end": bool(k_hi < n_probe - 1),
           "cloud_range_mm": [lo, hi]}
    return a_lo, a_hi, why


def node_rows(h: np.ndarray, tol: float = 1e-5, min_row: int = 30) -> np.ndarray | None:
    """Heights (mm) of the rows when most nodes lie on common planes (a CFD mesh's node rows, a
    CMM plan): groups of heights equal within ``tol`` mm holding ``min_row`` nodes or more,
    together at least 80 % of the nodes; else None."""
    order = np.argsort(h)
    hs = h[order]
    starts = np.concatenate([[0], np.flatnonzero(np.diff(hs) > tol) + 1])
    sizes = np.diff(np.concatenate([starts, [len(hs)]]))
    big = sizes >= min_row
    if big.sum() < 3 or sizes[big].sum() < 0.8 * len(h):
        return None
    return np.array([hs[a:a + n].mean() for a, n in zip(starts[big], sizes[big])])


def _row_span(P: np.ndarray, h: np.ndarray, axis: np.ndarray, rows: np.ndarray) -> tuple[float, float, dict]:
    """The airfoil span from the rows themselves: each row's hull area against the trend."""
    e1 = np.cross(axis, np.eye(3)[np.argmin(np.abs(axis))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    area = np.array([_hull_area(np.column_stack([P[m] @ e1, P[m] @ e2]))
                     for m in (np.abs(h - r) <= 1e-5 for r in rows)])
    k_lo, k_hi, _ = _trend_ends(rows, area, float(rows[0]), float(rows[-1]), local=True)
    lo = float(rows[min(k_lo + 1, k_hi)] if k_lo > 0 else rows[0])
    hi = float(rows[max(k_hi - 1, k_lo)] if k_hi < len(rows) - 1 else rows[-1])
    return lo, hi, {"method": "convex-hull area of every node row against the continued trend from the middle half",
                    "trimmed_at_start": bool(k_lo > 0), "trimmed_at_end": bool(k_hi < len(rows) - 1)}


# ------------------------------------------------------------------ one slab
def _slide_to_plane(q: np.ndarray, delta: np.ndarray, half_window: int = 3) -> np.ndarray:
    """Loop points ``q`` (2D, projected along the axis, in loop order) of heights ``delta``
    (mm off the plane) moved onto the section in the plane: in a window of neighbours along
    the loop, ``y = a + b x + c x² + v δ`` (x along the local chord, y across) is fitted by
    least squares and ``v δ`` taken off across — the section's normal speed along the span,
    so a point slides along the blade surface, not off it."""
    n = len(q)
    k = min(half_window, (n - 1) // 2)
    idx = (np.arange(n)[:, None] + np.arange(-k, k + 1)[None, :]) % n
    w = q[idx]                                        # (n, 2k+1, 2)
    t = w[:, -1] - w[:, 0]
    t /= np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-12)
    nrm = np.column_stack([-t[:, 1], t[:, 0]])
    rel = w - q[:, None, :]
    x = np.einsum("nkj,nj->nk", rel, t)
    y = np.einsum("nkj,nj->nk", rel, nrm)
    d = delta[idx]
    A = np.stack([np.ones_like(x), x, x * x, d], axis=-1)
    AtA = np.einsum("nki,nkj->nij", A, A) + 1e-9 * np.eye(4)
    Aty = np.einsum("nki,nk->ni", A, y)
    v = np.linalg.solve(AtA, Aty[..., None])[..., 3, 0]
    ok = np.isfinite(v) & (np.ptp(d, axis=1) > 1e-9)
    v = np.where(ok, v, 0.0)
    return q - (v * delta)[:, None] * nrm


def _thickness(q: np.ndarray) -> float:
    """Largest thickness (mm) of a thin 2D section: spread about a quadratic camber through
    the points, in ten bins along the chord."""
    u = q - q.mean(axis=0)
    e = np.linalg.svd(u, full_matrices=False)[2]
    x, y = u @ e[0], u @ e[1]
    c = np.polyfit(x, y, 2)
    r = y - np.polyval(c, x)
    bins = np.linspace(x.min(), x.max(), 11)
    idx = np.clip(np.digitize(x, bins) - 1, 0, 9)
    spans = [np.ptp(r[idx == i]) for i in range(10) if np.sum(idx == i) >= 3]
    return float(max(spans)) if spans else float(np.ptp(y))


def _gaps(q: np.ndarray, lab: np.ndarray) -> dict:
    """Smallest distance (mm) of every piece to the largest one."""
    sizes = np.bincount(lab)
    big = int(np.argmax(sizes))
    main = cKDTree(q[lab == big])
    return {int(k): float(main.query(q[lab == k])[0].min()) for k in np.flatnonzero(sizes) if k != big}


def _merge_pieces(q: np.ndarray, lab: np.ndarray, reach: float) -> tuple[np.ndarray, int]:
    """Join to the largest piece, nearest first, every piece within ``reach`` (mm) of it."""
    lab = lab.copy()
    merged = 0
    while True:
        gaps = _gaps(q, lab)
        if not gaps:
            return lab, merged
        k = min(gaps, key=gaps.get)
        if gaps[k] > reach:
            return lab, merged
        lab[lab == k] = int(np.argmax(np.bincount(lab)))
        merged += 1


def order_slab(q: np.ndarray, where: str, link: float = 6.0, second_share: float = 0.2
               ) -> tuple[np.ndarray, np.ndarray, dict]:
    """Keep and order the 2D points of one slab (mm): ``(order of kept points, rows dropped,
    info)``. Pieces are joined when closer than ``link`` x the median spacing; pieces closer
    than the section's thickness are merged (a thin sparse slab breaks up); a piece farther
    off and holding ``second_share`` of the points is a second blade (error)."""
    tree = cKDTree(q)
    dnn, _ = tree.query(q, 2)
    spacing = float(np.median(dnn[:, 1]))
    pairs = tree.query_pairs(link * spacing, output_type="ndarray")
    n = len(q)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, lab = connected_components(g, directed=False)
    # a thin sparse slab leaves gaps along the loop of about its perimeter / point count
    # (perimeter ~ 2.2 x the section's diameter): pieces that close are one section; then
    # pieces closer than the thickness of the section so joined
    loop_step = 2.2 * float(np.linalg.norm(np.ptp(q, axis=0))) / n
    reach = max(link * spacing, 3.0 * loop_step)
    lab, merged = _merge_pieces(q, lab, reach)
    # the thickness of the whole slab, at most a fifth of its size (a blade is thinner than a
    # fifth of its chord; a second blade in the slab inflates the estimate)
    thick = min(_thickness(q), 0.2 * float(np.linalg.norm(np.ptp(q, axis=0))))
    reach = max(reach, thick)
    lab, more = _merge_pieces(q, lab, reach)
    merged += more
    big = int(np.argmax(np.bincount(lab)))
    rest = np.flatnonzero(lab != big)
    if rest.size:        # what is left, joined among itself: a second blade is one large piece
        pr = cKDTree(q[rest]).query_pairs(reach, output_type="ndarray")
        gr = coo_matrix((np.ones(len(pr)), (pr[:, 0], pr[:, 1])), shape=(rest.size, rest.size))
        lab[rest] = lab.max() + 1 + connected_components(gr, directed=False)[1]
    gaps = _gaps(q, lab)
    sizes = np.bincount(lab)
    for k in np.flatnonzero(sizes):
        if k != big and sizes[k] >= second_share * n:
            raise BladeReconError(
                f"{where}: a second piece of {sizes[k]} points stands {gaps[k]:.3f} mm off the section "
                f"({sizes[big]} points), farther than the blade's thickness {thick:.3f} mm and the spacing "
                f"along it: a second blade? "
                "crop the cloud to one blade or give --span-range")
    keep = np.flatnonzero(lab == big)
    order = _uncross(q[keep], _camber_order(q[keep]))
    hit = _first_crossing(q[keep][order])
    if hit is not None:
        raise BladeReconError(f"{where}: its {len(keep)} points could not be put in a loop that does not "
                              "cross itself: give --span-range to leave this part of the blade out")
    loop = q[keep][order]
    steps = np.linalg.norm(loop - np.roll(loop, -1, axis=0), axis=1)
    return keep[order], np.flatnonzero(lab != big), {"thickness_mm": thick, "pieces_merged": merged,
                                                     "spacing_mm": spacing,
                                                     "largest_gap_mm": float(steps.max()),
                                                     "gap_ratio": float(steps.max() / np.median(steps))}


def _thin(order: np.ndarray, q: np.ndarray, most: int) -> np.ndarray:
    """At most ``most`` points of a loop, evenly spaced in arc length (the points are dense)."""
    if len(order) <= most:
        return order
    p = q[order]
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])
    pick = np.unique(np.searchsorted(s, np.linspace(0.0, s[-1], most, endpoint=False)))
    return order[np.clip(pick, 0, len(order) - 1)]


def _drop_close(order: np.ndarray, q: np.ndarray, share: float = 0.5) -> tuple[np.ndarray, np.ndarray]:
    """Leave out loop points closer than ``share`` x the median spacing to the previous kept one
    (random clouds hold near-duplicates, which make a curve through them wiggle)."""
    step = np.linalg.norm(np.diff(q, axis=0, append=q[:1]), axis=1)
    limit = share * float(np.median(step))
    keep = [0]
    for i in range(1, len(q)):
        if np.linalg.norm(q[i] - q[keep[-1]]) >= limit:
            keep.append(i)
    keep = np.asarray(keep)
    return order[keep], q[keep]


# ------------------------------------------------------------------ everything
def auto_sections(P: np.ndarray, span_range: tuple[float, float] | None = None, n_sections: int | None = None,
                  axis: np.ndarray | None = None) -> CloudSections:
    """Sections of an unordered blade cloud (mm), with no other input; see the module doc."""
    P = np.asarray(P, float)
    info: dict = {"kind": "auto-planes", "cloud_points": int(len(P))}
    if axis is None:
        axis, why_axis = span_direction(P)
    else:
        axis = np.asarray(axis, float) / np.linalg.norm(axis)
        why_axis = "given"
    info["axis"] = [float(v) for v in axis]
    info["axis_reason"] = why_axis
    h = P @ axis
    rows_h = node_rows(h)
    if span_range is None:
        lo, hi, why = airfoil_span(P, axis) if rows_h is None else _row_span(P, h, axis, rows_h)
        info["span_reason"] = why
    else:
        lo, hi = map(float, span_range)
        if not lo < hi:
            raise BladeReconError(f"--span-range {lo:g}:{hi:g}: give A:B with A < B (mm along the span axis)")
        if hi <= h.min() or lo >= h.max():
            raise BladeReconError(f"--span-range {lo:g}:{hi:g} mm lies outside the cloud, which spans "
                                  f"{h.min():.3f} to {h.max():.3f} mm along the span axis")
        lo, hi = max(lo, float(h.min())), min(hi, float(h.max()))
        info["span_reason"] = {"method": "--span-range"}
    inside = (h >= lo) & (h <= hi)
    n_in = int(inside.sum())
    length = hi - lo
    if n_in < 4 * SLAB_POINTS // 3:
        raise BladeReconError(f"the airfoil span {lo:.3f} to {hi:.3f} mm holds {n_in} points; slicing a "
                              f"cloud needs a few thousand: give a denser cloud or a wider --span-range")
    slab = SLAB_POINTS * length / n_in
    if rows_h is not None:
        use = rows_h[(rows_h >= lo - 1e-9) & (rows_h <= hi + 1e-9)]
        if n_sections is not None and n_sections < len(use):
            use = use[np.unique(np.linspace(0, len(use) - 1, n_sections).round().astype(int))]
        if len(use) < 2:
            raise BladeReconError(f"the airfoil span {lo:.3f} to {hi:.3f} mm holds {len(use)} node row: "
                                  "give a wider --span-range")
        pos, slab, n_sections = use, 2e-5, len(use)
        why_sections = (f"the nodes lie on {len(rows_h)} rows normal to the axis (CFD node rows or a measurement "
                        f"plan): the {len(use)} rows in the airfoil span are the sections, as they are")
    else:
        if n_sections is None:
            n_sections = int(np.clip(length / (4.0 * slab), 6, 21))
        slab = min(slab, length / (3.0 * n_sections))
        pos = np.linspace(lo + 0.5 * slab, hi - 0.5 * slab, n_sections)
        why_sections = (f"{SLAB_POINTS} points a slab from the density ({n_in} points over {length:.2f} mm); "
                        "sections cover at most a quarter of the span (6 to 21)")
    info.update({"airfoil_span_mm": [lo, hi], "points_in_span": n_in,
                 "points_left_out": {"below": int((h < lo).sum()), "above": int((h > hi).sum())},
                 "sections": int(n_sections), "slab_mm": float(slab), "positions_mm": [float(p) for p in pos],
                 "node_rows": rows_h is not None, "sections_reason": why_sections})
    sections, rows, counts, dropped, merged, thick, gaps = [], [], [], [], 0, [], []
    for z in pos:
        m = np.flatnonzero(np.abs(h - z) <= 0.5 * slab)
        where = f"slice at {z:.3f} mm"
        if len(m) < 12:
            raise BladeReconError(f"{where}: {len(m)} points in the slab, needs at least 12: give a denser cloud")
        delta = h[m] - z
        Q = P[m] - np.outer(delta, axis)
        o, e1, e2 = section_plane_frame(Q, axis)
        q = (Q - o) @ np.column_stack([e1, e2])
        order, out, sinfo = order_slab(q, where)
        order = _thin(order, q, MAX_SECTION_POINTS if rows_h is None else MAX_ROW_POINTS)
        q2 = _slide_to_plane(q[order], delta[order])
        order, q2 = _drop_close(order, q2)
        fix = _uncross(q2, np.arange(len(q2)))        # a slid point may pass its neighbour
        if _first_crossing(q2[fix]) is not None:
            fix = _uncross(q2, _camber_order(q2))
        order, q2 = order[fix], q2[fix]
        sections.append(o + q2 @ np.vstack([e1, e2]))
        rows.append(m[order])
        counts.append(int(len(m)))
        dropped.append(int(len(out)))
        merged += sinfo["pieces_merged"]
        thick.append(sinfo["thickness_mm"])
        gaps.append(sinfo["gap_ratio"])
    info.update({"slab_points": counts, "outliers_dropped": dropped, "pieces_merged": int(merged),
                 "thickness_mm": [float(t) for t in thick], "moved_onto_plane": "along the surface",
                 "largest_gap_ratio": [float(g) for g in gaps]})
    between = np.flatnonzero((h >= pos[0]) & (h <= pos[-1]))
    return CloudSections(sections, rows, axis, pos, info, between=between, cloud=P)
