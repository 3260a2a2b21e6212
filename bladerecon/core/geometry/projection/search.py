# SPDX-License-Identifier: LGPL-2.1-or-later
"""The global search for the closest foot of every point (seed 001 §2 eq. 11): Newton from the
nearest grid sample in parallel blocks, then the suspects' extra starts and the restarts.
"""
from __future__ import annotations

import numpy as np

import bladerecon.core.geometry.projection.parallel as parallel
from bladerecon.core.geometry.projection.evaluation import _dot
from bladerecon.core.geometry.projection.feet import _FOCAL, _KEPT, _Feet
from bladerecon.core.geometry.projection.grid import _StartGrid
from bladerecon.core.geometry.projection.parallel import _for_each_block, _shared
from bladerecon.core.geometry.projection.restarts import _more_starts, _turn_starts

__all__ = ["_search", "_first_feet", "_MIN_BATCH", "_TURN"]

_MIN_BATCH = 4096           # suspects are searched in blocks of at least this many
_MAX_BATCH = 8_192         # ... and at most this many: a suspect holds up to _N_WIDE candidate
                            # samples (~2.5 kB in all), so this bounds their memory (issue 23 §4)
_TURN = 0.25                # distance x curvature above this: try feet moved round the edge


def _search(grid: _StartGrid, solve, start_at, turn, P: np.ndarray, noise: float, emit=None):
    """Global search for the closest feet of the points P (m, dim) (seed 001 eq. 11).

    1. Newton from the nearest grid sample of every point (:func:`_first_feet`), in blocks
       of ``_CHUNK`` in parallel;
    2. the points that could have a closer foot elsewhere (suspects) all together: Newton
       from other samples in reach (:func:`_more_starts`), in as few blocks as there are
       workers, so that their many short Newton runs cost few numpy calls;
    3. points farther from their foot than ``_TURN`` times the local radius of curvature
       (off a thin edge): Newton from the foot moved round the edge (:func:`_turn_starts`).

    ``solve(P, start)`` -> (params, derivatives at the foot, converged, focal);
    ``start_at(params)`` evaluates a Newton start; ``turn(ders)`` gives the largest
    curvature and its direction (:func:`_surface_turn`). Returns params, derivatives,
    converged. With ``emit(rows, params, derivatives, converged)`` the feet are also handed
    over as they are found: each block's in the first pass (in its worker, while it is at
    hand), then again those of the points the later passes may have moved.
    """
    m, dim = P.shape
    feet = _Feet(_shared((len(grid.sizes), m)), _shared((_KEPT, dim, m)), _shared((m,), bool), _shared((m,)),
                 _shared((m,)), _shared((m,), np.intp), _shared((m,)))
    suspect = _shared((m,), bool)

    def first(s: int, e: int, workers: int) -> None:
        block, suspect[s:e] = _first_feet(grid, solve, turn, np.ascontiguousarray(P[s:e].T), noise, workers)
        feet.put(slice(s, e), block)
        if emit is not None:
            emit(slice(s, e), list(block.params), block.ders, block.conv)

    _for_each_block(m, first, shared=True)
    rows = np.flatnonzero(suspect)
    # runs of 1024 suspects dealt to the workers in turn: suspects crowd round the thin
    # edges, and contiguous halves of them can hold twice the work of each other
    runs = np.arange(rows.size) // 1024
    rows = np.concatenate([rows[runs % parallel._THREADS == k] for k in range(parallel._THREADS)])
    if rows.size and grid.size > 1:
        def more(s: int, e: int, workers: int) -> None:
            r = rows[s:e]
            sub = feet.take(r)
            _more_starts(grid, solve, turn, np.ascontiguousarray(P[r].T), sub, noise, workers)
            feet.put(r, sub)

        batch = min(_MAX_BATCH, max(_MIN_BATCH, -(-rows.size // parallel._THREADS)))
        _for_each_block(rows.size, more, batch, shared=True)
    turned = np.flatnonzero(feet.bend > _TURN)
    if turned.size:
        sub = feet.take(turned)
        _turn_starts(solve, start_at, turn, np.ascontiguousarray(P[turned].T), sub, noise)
        feet.put(turned, sub)
    if emit is not None:
        moved = np.union1d(np.flatnonzero(suspect), turned)
        if moved.size:
            sub = feet.take(moved)
            emit(moved, list(sub.params), sub.ders, sub.conv)
    return list(feet.params), feet.ders, feet.conv


def _first_feet(grid: _StartGrid, solve, turn, P: np.ndarray, noise: float, workers: int) -> tuple[_Feet, np.ndarray]:
    """Newton from the nearest grid sample of each point P (dim, m); and which points are
    suspects, that is, could have a closer foot elsewhere.

    A closer foot F' than the foot F found (distance d) lies within 2d of F, so the
    nearest corner X_j of its cell lies within 2d + cell_cover + cover[j] of the nearest
    corner of F's cell; if no sample outside the corners' grid windows comes that close
    (``cell_separation``), F' could only be a second root next to F, which needs P near a
    centre of curvature of F (``focal``). Neither holds for a foot held on a clamped end
    or a crease (there eq. 10 does not hold and minima may lie side by side).
    """
    _, k0 = grid.tree.query(P.T, k=1, workers=workers)
    k0 = np.atleast_1d(k0)
    params, ders, conv, focal = solve(P, grid.start(k0))
    d = np.sqrt(_dot(ders[0] - P, ders[0] - P))
    corner = grid.flat_index(grid.param_cells(params))
    inside = ~grid.on_end(params)
    safe = inside & (focal >= _FOCAL) & (2.0 * d + grid.cell_cover[corner] < grid.cell_separation[corner])
    return _Feet(np.stack(params), ders, conv, focal, d, k0, d * turn(ders)[0]), ~safe
