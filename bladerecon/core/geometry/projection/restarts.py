# SPDX-License-Identifier: LGPL-2.1-or-later
"""Restarts: more Newton starts for the points that may have a closer foot elsewhere (seed 001
eq. 11), from other grid samples in reach and from the foot moved round a thin edge.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.geometry.projection.evaluation import _dot
from bladerecon.core.geometry.projection.feet import _FOCAL, _Feet
from bladerecon.core.geometry.projection.grid import _StartGrid

__all__ = [
    "_samples_in_reach", "_more_starts", "_first_least", "_turn_starts", "_N_FEW", "_N_WIDE", "_MAX_STARTS",
    "_TURN_STEPS",
]

_N_FEW = 16                 # nearest samples looked at for a point that may have a closer foot elsewhere
_N_WIDE = 64                # ... where the first 16 are all within its reach
_MAX_STARTS = 6             # ... of which at most this many more Newton starts per point
_TURN_STEPS = (-3.0, -2.0, -1.0, -0.5, -0.25, 0.25, 0.5, 1.0, 2.0, 3.0)   # arc, in radii of curvature


def _samples_in_reach(grid: _StartGrid, P: np.ndarray, d: np.ndarray, workers: int) -> tuple[np.ndarray, ...]:
    """Grid samples within d + reach of each point P (dim, m), at most ``_N_WIDE`` per point,
    as flat (point, sample, distance) arrays sorted by point and then by distance."""
    radius = d + grid.reach
    n_near = min(_N_FEW, grid.size)
    cand_d, cand_k = grid.tree.query(P.T, k=n_near, distance_upper_bound=float(radius.max()), workers=workers)
    cand_d, cand_k = cand_d.reshape(P.shape[1], -1), cand_k.reshape(P.shape[1], -1)
    inside = cand_d < radius[:, None]
    full = np.flatnonzero(inside[:, -1]) if grid.size > n_near else np.zeros(0, dtype=np.intp)
    inside[full] = False                    # these come from the wider query below
    row, col = np.nonzero(inside)
    rows, ks, ds = [row], [cand_k[row, col]], [cand_d[row, col]]
    if full.size:
        wd, wk = grid.tree.query(P[:, full].T, k=min(_N_WIDE, grid.size),
                                 distance_upper_bound=float(radius[full].max()), workers=workers)
        wd, wk = wd.reshape(full.size, -1), wk.reshape(full.size, -1)
        row, col = np.nonzero(wd < radius[full, None])
        rows.append(full[row])
        ks.append(wk[row, col])
        ds.append(wd[row, col])
    row = np.concatenate(rows)
    order = np.argsort(row, kind="stable")          # each part is sorted by point, then distance
    return row[order], np.concatenate(ks)[order], np.concatenate(ds)[order]


def _more_starts(grid: _StartGrid, solve, turn, P: np.ndarray, feet: _Feet, noise: float, workers: int) -> None:
    """Newton again for the suspect points P (dim, m) from other samples in reach; the
    closest root wins (``feet`` updated in place).

    Of the ``_N_WIDE`` nearest samples of a point, the nearest one closer than d + cover,
    not tried yet, not next to an interior foot already found and whose cells may come
    within d of P by their thin covers (:meth:`_SurfaceGrid.strip_gap`) starts Newton again, up
    to ``_MAX_STARTS`` more times per point. (Most of these runs end at the foot already
    known. The thin covers cut them by three quarters on the sample nominal, whose cells
    round the trailing edge are 0.001-0.02 mm across and 0.54 mm long. Stopping a run once
    it comes within a cell of the known foot halves their cost but was seen to miss a foot
    95 nm closer beside it, where a circular edge meets a flank: they run to the end.) The
    candidates are kept as a flat list of (point, sample) pairs, sorted by point and then
    by distance: a point has ~8 of them on average but up to 64, so a dense table would be
    mostly padding.
    """
    params, d = list(feet.params), feet.dist
    row, k, dk = _samples_in_reach(grid, P, d, workers)
    cover = grid.cover[k]
    keep = dk < d[row] + cover                                     # d only shrinks: these are all
    if not keep.any():
        return
    row, k, dk, cover = row[keep], k[keep], dk[keep], cover[keep]
    cells = grid.sample_cells(k)
    # a foot blocks the samples next to it (Newton from there would find it again), except
    # near a centre of curvature, where a second root may lie in the very next cell
    blocks = ~grid.on_end(params) & (feet.focal >= _FOCAL)
    # nor does it block samples on a clamped end or crease: Newton held there finds a
    # boundary minimum that may lie right beside an interior one
    free = ~grid.on_end([g[c] for g, c in zip(grid.params, cells)])
    blocked = (blocks[row] & free & grid.close(cells, grid.param_cells(params)[:, row])) | (k == feet.k0[row])
    # blocked pairs stay blocked: drop them, then those whose cells are too far from P
    keep = np.flatnonzero(~blocked)
    keep = keep[grid.may_reach(P[:, row[keep]], k[keep], d[row[keep]])]
    if not keep.size:
        return
    row, k, dk, cover, cells, free = row[keep], k[keep], dk[keep], cover[keep], cells[:, keep], free[keep]
    blocked = np.zeros(row.size, dtype=bool)
    promise = grid.promise(P[:, row], k, dk)
    starts = np.flatnonzero(np.r_[True, row[1:] != row[:-1]])        # each point's first pair
    slot = np.full(d.size, -1)
    for attempt in range(_MAX_STARTS):
        fresh = ~blocked & (dk < d[row] + cover)
        if not fresh.any():
            break
        # alternately the fresh sample with the nearest tangent plane (a second smooth minimum
        # round a blunt nose) and the nearest fresh sample (minima on creases and corners,
        # where tangent planes mislead)
        j = _first_least(np.where(fresh, promise if attempt % 2 == 0 else dk, np.inf), row, starts)
        loc = row[j]
        run = solve(P[:, loc], grid.start(k[j]))
        p2, D2, c2, f2 = run
        d2 = np.sqrt(_dot(D2[0] - P[:, loc], D2[0] - P[:, loc]))
        blocked[j] = True
        slot[loc] = np.arange(loc.size)
        pairs = np.flatnonzero(slot[row] >= 0)                          # all pairs of the points just run
        at = slot[row[pairs]]
        found = ~grid.on_end(p2) & (f2 >= _FOCAL)
        blocked[pairs] |= found[at] & free[pairs] & grid.close(cells[:, pairs], grid.param_cells(p2)[:, at])
        slot[loc] = -1
        feet.update(loc, run, d2, turn, noise)


def _first_least(key: np.ndarray, row: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """Per point (pairs grouped by ``row``, groups beginning at ``starts``), the first pair
    with the least finite ``key``; points whose keys are all inf get none."""
    least = np.minimum.reduceat(key, starts)
    group = np.cumsum(np.r_[0, np.diff(row) != 0])              # group index of each pair
    hit = np.flatnonzero((key == least[group]) & np.isfinite(key))
    return hit[np.r_[True, row[hit][1:] != row[hit][:-1]]] if hit.size else hit


def _turn_starts(solve, start_at, turn, P: np.ndarray, feet: _Feet, noise: float) -> None:
    """Newton from each foot moved round the edge, for points P (dim, m) farther from
    their foot than ``_TURN`` times its radius of curvature R: off a thin leading edge
    a closer foot may lie round the nose, beyond the grid samples the other starts use
    (on Rotor 37's 0.12 mm LE radius one was seen 4 µm closer). The foot is moved along
    the direction of largest curvature by ``_TURN_STEPS`` x R of arc (about 14 to 170
    degrees round the nose, both ways); the closest foot wins (``feet`` in place)."""
    kmax, step = turn(np.stack(start_at(list(feet.params))[-1]))
    radius = 1.0 / np.maximum(kmax, 1e-300)
    m, n = P.shape[1], len(_TURN_STEPS)
    shift = np.repeat(np.asarray(_TURN_STEPS), m)                  # all moves in one Newton run
    params = np.tile(feet.params, n) + shift * np.tile(radius * step, n)
    Pn = np.tile(P, n)
    p2, D2, c2, f2 = solve(Pn, start_at(params))
    d2 = np.sqrt(_dot(D2[0] - Pn, D2[0] - Pn))
    best = np.argmin(d2.reshape(n, m), axis=0) * m + np.arange(m)   # closest of the moves per point
    feet.update(np.arange(m), ([p[best] for p in p2], D2[:, :, best], c2[best], f2[best]), d2[best], turn, noise)
