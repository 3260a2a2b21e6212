# SPDX-License-Identifier: LGPL-2.1-or-later
"""Point pairing between sections by angles (seed 000 §2.3, Fig. 5) and the paired-grid surface.

Adjacent sections A, B have different point counts. On each side of the blade (LE → TE and
TE → LE) the boundary points are the edges: the lines (a_1, b_1) through the two leading
edges and (a_n, b_m) through the two trailing edges meet at ``o`` (in 3D: the middle of
their common perpendicular). A point's angle is the angle at ``o`` between it and the LE
line; normalised by the LE–TE angle it runs from 0 to 1 along the side on both sections,
so points of A and B with the same normalised angle correspond (a central projection
from ``o``). Points within the pairing accuracy are paired; every other point gets a
partner inserted on the other section's curve. Done over all sections through the section
with the most points, every section ends with the same number of corresponding points,
and the surface interpolates that rectangular grid (seed 000 §2.4, eqs. 7-10).
Units: mm.
"""
from __future__ import annotations

import time

import numpy as np

from bladerecon.core.geometry.bspline import evaluate_curve
from bladerecon.core.surface.section_curves import MethodChoice, choose_method, fit_section_interpolate
from bladerecon.core.surface.skinning import AnchoredSection, anchor_section, closed_grid_parameters, interpolate_grid, span_parameters

__all__ = ["edge_lines_meeting_point", "normalised_angles", "pair_sections", "reconstruct_paired"]

PAIR_FRACTION = 0.3  # points closer than this fraction of the local spacing are a pair


def edge_lines_meeting_point(le_a, le_b, te_a, te_b) -> np.ndarray:
    """Point ``o`` where the LE line (le_a, le_b) and TE line (te_a, te_b) meet (seed 000 Fig. 5).

    Skew lines: the middle of the common perpendicular. Parallel lines: a point far out
    along them, which turns the central projection into a parallel one.
    """
    d1, d2 = le_b - le_a, te_b - te_a
    w = le_a - te_a
    a, b, c = d1 @ d1, d1 @ d2, d2 @ d2
    d, e = d1 @ w, d2 @ w
    den = a * c - b * b
    scale = np.linalg.norm(te_a - le_a)
    if den < 1e-10 * a * c:
        return le_a - 1e4 * scale * d1 / np.sqrt(a)
    s = (b * e - c * d) / den
    t = (a * e - b * d) / den
    o = 0.5 * ((le_a + s * d1) + (te_a + t * d2))
    if np.linalg.norm(o - le_a) > 1e6 * scale:
        return le_a - 1e4 * scale * d1 / np.sqrt(a)
    return o


def normalised_angles(points: np.ndarray, o: np.ndarray, le: np.ndarray, te: np.ndarray) -> np.ndarray:
    """Angle at ``o`` from the LE ray to each point, divided by the LE–TE angle (0 at LE, 1 at TE)."""
    def ang(x, y):
        return np.arctan2(np.linalg.norm(np.cross(x, y), axis=-1), np.einsum("...d,...d->...", x, y))
    ref = le - o
    return ang(points - o, ref) / ang(te - o, ref)


def _side_tables(a: AnchoredSection, n: int = 2000):
    """Dense arc positions and points of both sides: side 0 = LE→TE along +t, side 1 = TE→LE."""
    out = []
    for lo, hi in ((0.0, a.arc_te), (a.arc_te, a.perimeter)):
        arc = np.linspace(lo, hi, n)
        t = np.interp(arc, a.arc_table, a.t_table)
        out.append((arc, evaluate_curve(a.curve, t)))
    return out


def _correspondence(points: np.ndarray, own: AnchoredSection, o: np.ndarray | None) -> np.ndarray:
    """0..1 coordinate along a side: normalised angle at ``o``, or chord fraction when o is None."""
    if o is None:
        chord = own.te - own.le
        return (points - own.le) @ chord / (chord @ chord)
    return normalised_angles(points, o, own.le, own.te)


def _meeting_point(a: AnchoredSection, b: AnchoredSection) -> np.ndarray | None:
    """``o`` of seed 000 Fig. 5 when it lies beyond both sections on both edge lines, else None.

    If the LE and TE lines cross between the two sections (or are parallel), a central
    projection from ``o`` is not defined; its limit, the parallel projection, is the chord
    fraction, used instead.
    """
    o = edge_lines_meeting_point(a.le, b.le, a.te, b.te)
    for p, q in ((a.le, b.le), (a.te, b.te)):
        d = q - p
        s = (o - p) @ d / (d @ d)
        if -0.05 < s < 1.05:
            return None
    if np.linalg.norm(o - a.le) > 1e3 * np.linalg.norm(a.te - a.le):
        return None
    return o


def _transfer(arc, k: int, j: int, side: int, anchored, tables):
    """Arc positions on section k → corresponding arc positions on adjacent section j."""
    o = _meeting_point(anchored[k], anchored[j])
    ak, pk = tables[k][side]
    aj, pj = tables[j][side]
    sign = -1.0 if side == 1 else 1.0  # TE → LE: the coordinate falls from 1 to 0 along +t
    ck = np.maximum.accumulate(sign * _correspondence(pk, anchored[k], o))
    cj = np.maximum.accumulate(sign * _correspondence(pj, anchored[j], o))
    c = np.interp(arc, ak, ck)
    return np.interp(c, cj + 1e-15 * np.arange(cj.size), aj)


def _path(k: int, ref: int) -> list[int]:
    step = 1 if ref > k else -1
    return list(range(k, ref + step, step))


def pair_sections(anchored: list[AnchoredSection], point_arcs: list[np.ndarray]):
    """Corresponding points on all sections (seed 000 §2.3).

    ``point_arcs[k]``: arc position (mm from the LE along +t) of each measured point of
    section k. All points are carried to the section with the most points through the
    chain of adjacent-section projections, paired there (points of different sections
    closer than ``PAIR_FRACTION`` of the spacing are one pair), and every pair without a
    point on some section gets one inserted on that section's curve. Returns
    ``(columns, owners, added)``: ``columns[k]`` the arc positions on section k (same length
    for every k, loop order from the LE), ``owners[k]`` the measured point index of each
    column (−1 where inserted), ``added`` the number of inserted points.
    """
    S = len(anchored)
    ref = int(np.argmax([p.size for p in point_arcs]))
    tables = [_side_tables(a) for a in anchored]
    cols_all, owners_all = [[] for _ in range(S)], [[] for _ in range(S)]
    added = 0
    for side in (0, 1):
        items = []
        for k in range(S):
            a = anchored[k]
            arcs = point_arcs[k]
            idx = np.flatnonzero((arcs <= a.arc_te) if side == 0 else (arcs > a.arc_te))
            r = arcs[idx]
            path = _path(k, ref)
            for x, y in zip(path[:-1], path[1:]):
                r = _transfer(r, x, y, side, anchored, tables)
            items += [(float(x), k, int(i)) for x, i in zip(r, idx)]
        items.sort()
        pos = np.array([x for x, _, _ in items])
        own_spacing = np.median(np.diff(np.sort(pos[[it[1] == ref for it in items]]))) if pos.size > 2 else 1.0
        tol = PAIR_FRACTION * own_spacing
        clusters: list[list[tuple[float, int, int]]] = []
        for it in items:
            if clusters and it[0] - clusters[-1][0][0] < tol and all(m[1] != it[1] for m in clusters[-1]):
                clusters[-1].append(it)
            else:
                clusters.append([it])
        ref_pos = np.array([np.mean([m[0] for m in c]) for c in clusters])
        for k in range(S):
            arcs = ref_pos.copy()
            path = _path(k, ref)[::-1]
            for x, y in zip(path[:-1], path[1:]):
                arcs = _transfer(arcs, x, y, side, anchored, tables)
            own = np.full(len(clusters), -1)
            for c_i, c in enumerate(clusters):
                for m in c:
                    if m[1] == k:
                        arcs[c_i] = point_arcs[k][m[2]]
                        own[c_i] = m[2]
            added += int((own < 0).sum())
            cols_all[k].append(arcs)
            owners_all[k].append(own)
    columns = [np.concatenate(c) for c in cols_all]
    owners = [np.concatenate(o) for o in owners_all]
    return columns, owners, added


def reconstruct_paired(section_points: list[np.ndarray], span_axis: np.ndarray,
                       first_point_is_measured: bool = True):
    """Seed 000's own pipeline: interpolate each section, pair points by angles, interpolate the grid.

    Returns a :class:`~bladerecon.core.reconstruct.Reconstruction` with ``added_points``.
    """
    from bladerecon.core.reconstruct import Reconstruction

    from bladerecon.core.reconstruct import first_point_edge_hint

    t0 = time.perf_counter()
    curves = [fit_section_interpolate(k, p) for k, p in enumerate(section_points)]
    anchored = []
    hint = first_point_edge_hint(section_points[0]) if first_point_is_measured else None
    for sc in curves:
        a = anchor_section(sc, span_axis, le_hint=hint)
        anchored.append(a)
        hint = a.le
    point_arcs = []
    for a, sc in zip(anchored, curves):
        lo, hi = a.curve.domain
        tt = a.t_le + np.mod(sc.t_points - a.t_le, hi - lo)
        point_arcs.append(np.interp(tt, a.t_table, a.arc_table))
    columns, owners, added = pair_sections(anchored, point_arcs)
    grid = np.stack([evaluate_curve(a.curve, np.interp(c, a.arc_table, a.t_table))
                     for a, c in zip(anchored, columns)])                       # (S, N, 3)
    for k, own in enumerate(owners):  # measured points exactly, not re-evaluated
        m = own >= 0
        grid[k, m] = section_points[k][own[m]]
    surface = interpolate_grid(grid)
    v = span_parameters(grid)
    u = closed_grid_parameters(grid)
    pu = np.concatenate([_point_params(own, u, len(p)) for own, p in zip(owners, section_points)])
    pv = np.concatenate([np.full(len(p), v[k]) for k, p in enumerate(section_points)])
    choice = choose_method(section_points)
    choice = MethodChoice("interpolate", f"angle pairing (seed 000 Fig. 5), {added} points added; "
                          + choice.reason, choice.noise_mm, choice.min_spacing_mm, choice.tangent_noise)
    t1 = time.perf_counter()
    rec = Reconstruction(surface, choice, None, tuple(anchored), float("nan"), v, 0.0, pu, pv,
                         np.zeros(pu.size), {"total": t1 - t0}, added_points=added)
    return rec


def _point_params(owner: np.ndarray, u: np.ndarray, n: int) -> np.ndarray:
    """Surface u of each measured point (by its grid column)."""
    out = np.zeros(n)
    m = owner >= 0
    out[owner[m]] = u[m]
    return out

