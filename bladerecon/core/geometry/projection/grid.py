# SPDX-License-Identifier: LGPL-2.1-or-later
"""Start grids: samples of a surface or curve (with derivatives) in a k-d tree, the Newton
start points, and the cell covers and separations that say where a closer foot may lie.

Seed 001 §2: eq. 10 is solved by Newton started from the nearest sample of a grid on the
spline, with square cells of about a sixth of a median knot span (more samples on long or
sharply turning spans). Eq. 11: the covers and separations of the cells bound where another
part of the spline comes close enough to hold a closer foot (the other side of a thin
leading or trailing edge); the thin covers round a tight nose
(:meth:`_SurfaceGrid.strip_gap`) bound it more tightly there.

Units: millimetres.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from bladerecon.core.geometry.bspline import collocation_matrix, wrap_parameters
from bladerecon.core.geometry.projection.evaluation import (
    _CurveModel,
    _dot,
    _Intervals,
    _SpanPolynomials,
    _SurfaceModel,
)

__all__ = [
    "_StartGrid", "_SurfaceGrid", "_CurveGrid", "_segment_distance", "_sample_parameters", "_grid_parameters",
    "_polyline_measures", "_span_measures", "_sample_spacing", "_span_costs", "_grid_size", "_cell_cover",
    "_neighbour_reduce",
]

_WINDOW = 2                 # grid steps within which samples count as the same part of the spline
_SAMPLES_PER_SPAN = 6       # start grid density on a span of median length
_MAX_SAMPLES_PER_SPAN = 256
_MAX_GRID_SAMPLES = 60_000     # more samples give closer starts but cost more to build than they save
_MAX_TURN_PER_SAMPLE = np.radians(20.0)   # tight edges get a sample every 20 degrees


def _segment_distance(P: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Distance from points P to the segments A -> B, all (3, m), mm."""
    AB = B - A
    AP = P - A
    t = _dot(AP, AB) / np.maximum(_dot(AB, AB), 1e-300)
    AP -= np.minimum(np.maximum(t, 0.0), 1.0) * AB
    return np.sqrt(_dot(AP, AP))


def _sample_parameters(d: _SpanPolynomials, counts: np.ndarray) -> np.ndarray:
    """``counts[s]`` equally spaced parameters in span s (and the end of a clamped domain)."""
    start = np.repeat(d.breaks[:-1], counts)
    step = np.repeat(d.lengths / counts, counts)
    k = np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)
    params = start + step * k
    return params if d.periodic else np.append(params, d.hi)


def _grid_parameters(d: _SpanPolynomials, costs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start-grid parameters of direction d and the piece each sample belongs to.

    ``costs[s]`` is how many grid steps span s is worth (its length over the spacing, or its
    turning over 20 degrees, whichever is more; fractions allowed). Samples are spread evenly
    in that measure over each piece, so that many short spans (a profile of 900 poles) can
    share one grid step and the cells stay square; every piece gets both its ends, so a
    sample on a crease is there twice, once for each piece (a foot just on either side of a
    fold must find a start on its own side).
    """
    params, pieces = [], []
    for k, (first, last) in enumerate(zip(d.piece_first, d.piece_last)):
        c = costs[first: last + 1]
        cum = np.concatenate([[0.0], np.cumsum(c)])
        n = max(int(np.ceil(cum[-1] - 1e-9)), 1)
        targets = np.linspace(0.0, cum[-1], n + 1)
        t = np.interp(targets, cum, d.breaks[first: last + 2]) if cum[-1] > 0 else d.breaks[[first, last + 1]]
        if d.wraps:
            t = t[:-1]                      # the end is the start again
        params.append(t)
        pieces.append(np.full(t.size, k))
    return np.concatenate(params), np.concatenate(pieces)


def _polyline_measures(X: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """Segment lengths and turning angles at segment starts along axis 0 of X (n, ..., 3)."""
    if closed:
        X = np.concatenate([X, X[:1]], axis=0)
    seg = np.diff(X, axis=0)
    length = np.linalg.norm(seg, axis=-1)
    unit = seg / np.maximum(length, 1e-300)[..., None]
    nxt = np.roll(unit, -1, axis=0) if closed else np.concatenate([unit[1:], unit[-1:]], axis=0)
    turn = np.arccos(np.clip(np.sum(unit * nxt, axis=-1), -1.0, 1.0))
    return length, turn


def _span_measures(d: _SpanPolynomials, X: np.ndarray, per: int) -> tuple[np.ndarray, np.ndarray]:
    """Length (mm) and turning angle of each span of direction d, from ``per`` samples per
    span along axis 0 of X; the largest over the other direction (axis 1) if there is one."""
    length, turn = _polyline_measures(X, d.periodic)
    shape = (d.n_spans, per) + length.shape[1:]
    L = length[: per * d.n_spans].reshape(shape).sum(axis=1)
    A = turn[: per * d.n_spans].reshape(shape).sum(axis=1)
    if L.ndim > 1:
        L, A = L.max(axis=1), A.max(axis=1)
    return L, A


def _sample_spacing(lengths: list[np.ndarray]) -> float:
    """One sample spacing (mm) for all directions: ~6 samples on a median span of the
    finer direction. The same spacing both ways keeps grid cells square, so that the few
    nearest samples of a point surround its foot and a second sheet of surface (the other
    side of a thin edge) closer than the first shows up among them."""
    refs = [np.median(L[L > 0]) for L in lengths if np.any(L > 0)]
    spacing = min(refs) / _SAMPLES_PER_SPAN if refs else 1.0
    for _ in range(64):      # coarser until the grid fits (within the sample budget)
        if np.prod([_grid_size(L, spacing) for L in lengths]) <= _MAX_GRID_SAMPLES:
            break
        spacing *= 1.25
    return spacing


def _span_costs(lengths: np.ndarray, turns: np.ndarray, spacing: float) -> np.ndarray:
    """Grid steps per span: one per ``spacing`` mm and per 20 degrees of turning (fractional)."""
    return np.clip(np.maximum(lengths / spacing, turns / _MAX_TURN_PER_SAMPLE), 0.0, _MAX_SAMPLES_PER_SPAN)


def _grid_size(lengths: np.ndarray, spacing: float) -> int:
    return int(np.ceil(lengths.sum() / spacing)) + 1


def _cell_cover(X: np.ndarray, periodic: tuple[bool, ...]) -> np.ndarray:
    """Per grid cell: how far a point of the spline in it can be from the nearest corner
    sample, mm: half the longer diagonal (half the chord for a curve), plus 10 % for the
    bulge of a curved cell."""
    for axis, closed in enumerate(periodic):
        if closed:
            X = np.concatenate([X, np.take(X, [0], axis=axis)], axis=axis)
    if len(periodic) == 1:
        return 0.55 * np.linalg.norm(X[1:] - X[:-1], axis=-1)
    return 0.55 * np.maximum(
        np.linalg.norm(X[1:, 1:] - X[:-1, :-1], axis=-1), np.linalg.norm(X[1:, :-1] - X[:-1, 1:], axis=-1)
    )


def _neighbour_reduce(A: np.ndarray, periodic: tuple[bool, ...], fn, offsets: tuple[int, ...]) -> np.ndarray:
    """``fn`` (np.minimum / np.maximum) over A and A shifted by each offset along every grid
    axis (wrapped where periodic, repeating the edge where clamped)."""
    for axis, closed in enumerate(periodic):
        n = A.shape[axis]
        out = A
        for off in offsets:
            idx = np.arange(n) + off
            idx = idx % n if closed else np.clip(idx, 0, n - 1)
            out = fn(out, np.take(A, idx, axis=axis))
        A = out
    return A


class _StartGrid:
    """Samples of a spline (with derivatives) in a k-d tree: the Newton start points.

    Grid cell c spans the samples c .. c+1 in every direction (c is its lower corner).

    * ``cell_cover[c]``: how far a spline point in cell c can be from its nearest corner
      sample (half the longer diagonal), mm;
    * ``cover[k]``: the largest cell cover around sample k; ``reach`` the largest of all;
    * ``cell_separation[c]``: for the corners i of cell c, the least of |X_i - X_j| - cover[j]
      over samples j more than ``_WINDOW`` grid steps from i or across a C0 knot: how close
      another part of the spline comes (the other side of a thin edge, a tight nose
      curling round, the other face of a crease).
    """

    sizes: tuple[int, ...]
    periodic: tuple[bool, ...]
    params: tuple[np.ndarray, ...]      # sample parameters per direction
    segments: tuple[np.ndarray, ...]    # piece of each sample per direction

    def _finish(self, X: np.ndarray, domains: list[_SpanPolynomials]) -> None:
        """Build the tree and the per-sample measures from the sample points X (*sizes, dim)."""
        self.cells = [_Intervals(np.append(g, d.hi) if g[-1] < d.hi else g) for g, d in zip(self.params, domains)]
        self.ends = [np.empty(0) if d.wraps else np.append(d.piece_lo, d.hi) for d in domains]
        flat = X.reshape(-1, X.shape[-1])
        self.tree = cKDTree(flat)
        cells = _cell_cover(X, self.periodic)
        pad = [(0, 1) if not closed else (0, 0) for closed in self.periodic]
        self.cell_cover = np.pad(cells, pad, mode="edge").ravel()         # indexed by lower corner
        self.cover = _neighbour_reduce(np.pad(cells, pad, mode="edge"), self.periodic, np.maximum, (-1,)).ravel()
        self.reach = float(self.cover.max()) if self.cover.size else 0.0
        separation = self._separation(flat).reshape(self.sizes)
        self.cell_separation = _neighbour_reduce(separation, self.periodic, np.minimum, (1,)).ravel()

    def _set_axes(self, X: np.ndarray, axis: np.ndarray) -> None:
        """Unit normals (surface) or tangents (curve) of the samples X (dim, n), and their
        offsets n·X, for :meth:`promise` (zero where the direction vanishes)."""
        length = np.sqrt(_dot(axis, axis))
        self.axis = np.ascontiguousarray(axis / np.where(length > 0, length, 1.0))
        self.offset = _dot(self.axis, X)

    def _separation(self, flat: np.ndarray) -> np.ndarray:
        n = flat.shape[0]
        k = min((2 * _WINDOW + 1) ** len(self.sizes) + 1, n)
        dist, idx = self.tree.query(flat, k=k, workers=-1)
        dist, idx = dist.reshape(n, k), idx.reshape(n, k).astype(np.int32)
        # grid indices by divmod on 32-bit integers, last axis first (it varies fastest):
        # ~8x faster than unravel_index on the n x k table
        inside = np.ones((n, k), dtype=bool)
        rest_other, rest_own = idx, np.arange(n, dtype=np.int32)[:, None]
        for axis in range(len(self.sizes) - 1, -1, -1):
            size, closed = self.sizes[axis], self.periodic[axis]
            if axis:
                other, rest_other = rest_other % size, rest_other // size
                own, rest_own = rest_own % size, rest_own // size
            else:
                other, own = rest_other, rest_own
            diff = np.abs(other - own)
            if closed:
                diff = np.minimum(diff, size - diff)
            inside &= diff <= _WINDOW
            pieces = self.segments[axis]
            if pieces.size and pieces.max() > 0:
                inside &= pieces[other] == pieces[own]
        gap = dist - self.cover[idx]
        gap[inside] = np.inf
        near = gap.min(axis=1)
        beyond = dist[:, -1] - self.reach if k < n else np.inf     # samples past the k nearest
        return np.minimum(near, beyond)

    @property
    def size(self) -> int:
        return int(self.cover.size)

    def sample_cells(self, k: np.ndarray) -> np.ndarray:
        """Grid indices (n_dirs, m) of samples k."""
        return np.stack(np.unravel_index(k, self.sizes))

    def param_cells(self, params: list[np.ndarray]) -> np.ndarray:
        """Grid cells (n_dirs, m) that hold the parameters (index of the lower corner)."""
        return np.stack([cells(t) for cells, t in zip(self.cells, params)])

    def flat_index(self, cells: np.ndarray) -> np.ndarray:
        return np.ravel_multi_index(tuple(cells), self.sizes)

    def on_end(self, params: list[np.ndarray]) -> np.ndarray:
        """True where a foot sits on an end of a piece: a clamped end or a crease, where
        Newton holds it, and where eq. 10 and so the local uniqueness argument do not hold."""
        out = np.zeros(params[0].shape, dtype=bool)
        for t, ends in zip(params, self.ends):
            if ends.size:
                out |= np.isin(t, ends)
        return out

    def close(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """True where grid cells a and b (n_dirs, m) lie next to each other, pairwise: at
        most one cell apart on one side and two on the other (a cell is named by its lower
        corner), wrapping round a closed direction, and in the same piece."""
        close = np.ones(a.shape[1:], dtype=bool)
        for axis, (n, closed) in enumerate(zip(self.sizes, self.periodic)):
            diff = a[axis] - b[axis]
            if closed:
                diff = (diff + 1) % n - 1
            close &= (diff >= -1) & (diff <= 2)
            close &= self.segments[axis][a[axis]] == self.segments[axis][b[axis]]
        return close


class _SurfaceGrid(_StartGrid):
    """The start grid of a surface: square cells of about a sixth of a median knot span."""

    def __init__(self, model: _SurfaceModel):
        per = 4
        pu = _sample_parameters(model.u, np.full(model.u.n_spans, per))
        pv = _sample_parameters(model.v, np.full(model.v.n_spans, per))
        X = self._points(model, pu, pv)
        Lu, Au = _span_measures(model.u, X, per)
        Lv, Av = _span_measures(model.v, np.swapaxes(X, 0, 1), per)
        spacing = _sample_spacing([Lu, Lv])
        (gu, pieces_u), (gv, pieces_v) = (
            _grid_parameters(model.u, _span_costs(Lu, Au, spacing)),
            _grid_parameters(model.v, _span_costs(Lv, Av, spacing)),
        )
        self.params, self.segments = (gu, gv), (pieces_u, pieces_v)
        self.sizes = (gu.size, gv.size)
        self.periodic = (model.u.periodic, model.v.periodic)
        UU, VV = np.meshgrid(gu, gv, indexing="ij")
        PU, PV = np.meshgrid(pieces_u, pieces_v, indexing="ij")
        pieces = (PU.ravel(), PV.ravel())
        uu, vv, su, sv, ders = model.evaluate(UU.ravel(), VV.ravel(), 2, pieces)
        collapsed = self._collapsed(ders, UU.shape)
        if any(c.any() for c in collapsed):
            UU, VV = self._off_collapsed_edges(UU, VV, collapsed)
            uu, vv, su, sv, ders = model.evaluate(UU.ravel(), VV.ravel(), 2, pieces)
        self.state = (uu, vv, su, sv, np.stack(ders).reshape(18, -1))
        self._set_axes(ders[0], np.cross(ders[1], ders[2], axis=0))
        X = ders[0].T.reshape(self.sizes + (3,))
        self._finish(X, [model.u, model.v])
        # the strips need the samples where the grid parameters put them
        moved = any(c.any() for c in collapsed)
        self.strips = None if moved else self._strips(X, self._midpoints(model, gu, gv))

    def _midpoints(self, model: _SurfaceModel, gu: np.ndarray, gv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """S half way between neighbouring samples: along u (sizes[0] - 1 or, closed, sizes[0]
        rows) and along v."""
        def halves(g: np.ndarray, d: _SpanPolynomials) -> np.ndarray:
            nxt = np.append(g[1:], g[0] + (d.hi - d.lo)) if d.periodic else g[1:]
            return wrap_parameters(0.5 * (g[: nxt.size] + nxt), d.lo, d.hi) if d.periodic else 0.5 * (g[:-1] + nxt)
        return self._points(model, halves(gu, model.u), gv), self._points(model, gu, halves(gv, model.v))

    def _strips(self, X: np.ndarray, mids: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
        """Thin covers for :meth:`strip_gap` (mm), shape (2 axes, 2 sides, samples).

        Near a tight nose the grid cells are long strips (20 degrees across, a whole step
        along the span), and the ball of ``cover`` round a sample holds many samples round
        the nose and along the flanks. So, for sample j, grid axis a and side s = -1, +1:
        the two cells on that side of j along a lie within r of the chord X_j -> X_j+s: r is
        the largest distance of their other corners from the chord, plus 1.5 times the largest
        sagitta (midpoint's distance from its chord) of their edges, which bounds how far a
        cell bulges out of the bilinear sheet through its corners. r = inf where there is no
        cell on that side (a clamped end).
        """
        sizes, closed = X.shape[:2], self.periodic
        sag = []                        # sagitta of each edge, by axis and lower end
        for axis, M in enumerate(mids):
            ends = [slice(None), slice(None)]
            ends[axis] = slice(0, M.shape[axis])
            A, B = X[tuple(ends)], np.roll(X, -1, axis=axis)[tuple(ends)]
            sag.append(_segment_distance(*(Y.reshape(-1, 3).T for Y in (M, A, B))).reshape(M.shape[:2]))
        I, J = np.meshgrid(np.arange(sizes[0]), np.arange(sizes[1]), indexing="ij")

        def step(idx: tuple, axis: int, off: int) -> tuple:
            """Grid indices idx moved ``off`` along ``axis`` (wrapped, or held at a clamped end)."""
            out = list(idx)
            i = idx[axis] + off
            out[axis] = i % sizes[axis] if closed[axis] else np.clip(i, 0, sizes[axis] - 1)
            return tuple(out)

        def edge_sag(idx: tuple, axis: int, off: int) -> np.ndarray:
            """Sagitta of the edge from idx one step ``off`` along ``axis``."""
            lo = list(step(idx, axis, min(off, 0)))
            lo[axis] = np.minimum(lo[axis], sag[axis].shape[axis] - 1)
            return sag[axis][tuple(lo)]

        out = np.empty((2, 2) + sizes)
        for axis in (0, 1):
            other = 1 - axis
            for side, s in enumerate((-1, 1)):
                far = step((I, J), axis, s)                    # X_j+s, the chord's other end
                A, B = X.reshape(-1, 3).T, X[far].reshape(-1, 3).T
                r, sagitta = np.zeros(sizes), edge_sag((I, J), axis, s)
                for o in (-1, 1):                              # the cells on either side of the chord
                    for end in ((I, J), far):
                        corner = X[step(end, other, o)].reshape(-1, 3).T
                        np.maximum(r, _segment_distance(corner, A, B).reshape(sizes), out=r)
                        np.maximum(sagitta, edge_sag(end, other, o), out=sagitta)
                    np.maximum(sagitta, edge_sag(step((I, J), other, o), axis, s), out=sagitta)
                r += 1.5 * sagitta
                if not closed[axis]:                           # no cell beyond a clamped end
                    r[((I, J)[axis] + s < 0) | ((I, J)[axis] + s >= sizes[axis])] = np.inf
                out[axis, side] = r
        return out.reshape(2, 2, -1)

    def strip_gap(self, P: np.ndarray, k: np.ndarray) -> np.ndarray:
        """A lower bound of the distance from points P (3, n) to the surface in the four
        cells round samples k (mm), from the thin covers of :meth:`_strips` (-inf without)."""
        if self.strips is None:
            return np.full(k.size, -np.inf)
        return np.maximum(self._axis_gap(P, k, 0), self._axis_gap(P, k, 1))

    def may_reach(self, P: np.ndarray, k: np.ndarray, d: np.ndarray) -> np.ndarray:
        """False where the cells round sample k surely hold no point within d of P
        (:meth:`strip_gap` >= d); one axis at a time, the second only where the first left
        it open (the strips along the span are the thin ones round an edge)."""
        out = np.ones(k.size, dtype=bool)
        if self.strips is None:
            return out
        for axis in (1, 0):
            open_ = np.flatnonzero(out)
            out[open_[self._axis_gap(P[:, open_], k[open_], axis) >= d[open_]]] = False
        return out

    def _axis_gap(self, P: np.ndarray, k: np.ndarray, axis: int) -> np.ndarray:
        """The bound of :meth:`strip_gap` from the chords along one grid axis."""
        X = self.tree.data
        size, closed = self.sizes[axis], self.periodic[axis]
        cells = self.sample_cells(k)
        A = X[k].T
        near = np.full(k.size, np.inf)
        for side, s in enumerate((-1, 1)):
            c = cells.copy()
            c[axis] = c[axis] + s
            c[axis] = c[axis] % size if closed else np.clip(c[axis], 0, size - 1)
            gap = _segment_distance(P, A, X[self.flat_index(c)].T) - self.strips[axis, side][k]
            np.minimum(near, gap, out=near)
        return near

    @staticmethod
    def _collapsed(ders: list, shape: tuple) -> tuple[np.ndarray, np.ndarray]:
        """Samples where S_v (first) or S_u (second) vanishes: a collapsed edge in u / in v."""
        lengths = [np.linalg.norm(a, axis=0).reshape(shape) for a in ders[1:3]]
        return tuple(L <= 1e-9 * max(float(np.median(L)), 1e-300) for L in lengths[::-1])

    @staticmethod
    def _off_collapsed_edges(UU: np.ndarray, VV: np.ndarray, collapsed: tuple) -> tuple:
        """Samples where S_u or S_v vanishes (a cone apex, a tip collapsed to a point) are
        all one point, so the k-d tree could not tell which of them faces P: move them a
        quarter of a grid step into the surface, across the collapsed direction."""
        out = [UU.copy(), VV.copy()]
        for axis, (mask, G) in enumerate(zip(collapsed, (UU, VV))):
            if not mask.any():
                continue
            step = np.diff(G, axis=axis)
            forward = np.concatenate([step, -np.take(step, [-1], axis=axis)], axis=axis)
            out[axis] = np.where(mask, G + 0.25 * forward, G)
        return out[0], out[1]

    @staticmethod
    def _points(model: _SurfaceModel, pu: np.ndarray, pv: np.ndarray) -> np.ndarray:
        """S on the tensor grid pu x pv as N_u P N_v^T (sparse collocation matrices): far
        cheaper than point-wise evaluation, and positions do not depend on the piece."""
        s = model.surface
        nu, nv = s.shape
        Nu = collocation_matrix(s.u_knots, s.u_mults, s.u_degree, s.u_periodic, nu, pu)
        Nv = collocation_matrix(s.v_knots, s.v_mults, s.v_degree, s.v_periodic, nv, pv)
        T = (Nu @ np.asarray(s.poles, dtype=float).reshape(nu, nv * 3)).reshape(pu.size, nv, 3)
        X = Nv @ np.ascontiguousarray(T.transpose(1, 0, 2)).reshape(nv, pu.size * 3)
        return np.ascontiguousarray(X.reshape(pv.size, pu.size, 3).transpose(1, 0, 2))

    def start(self, k: np.ndarray) -> tuple:
        uu, vv, su, sv, ders = self.state
        return uu[k], vv[k], su[k], sv[k], np.take(ders, k, axis=1).reshape(6, 3, -1)

    def promise(self, P: np.ndarray, k: np.ndarray, dist: np.ndarray) -> np.ndarray:
        """For points P (3, n) paired with samples k (n) at distances ``dist`` (n): the
        distance from P to the tangent plane of the sample, its foot kept within the
        sample's cover. Ranks the extra Newton starts: near a blunt nose a sample
        on the far side of the closer foot is nearer to P than the samples that lead to it,
        so nearest-first would try the wrong ones.

        With q = n·(P - X) the height over the plane (n the sample's unit normal), the
        in-plane offset is sqrt(dist^2 - q^2); the foot may move ``cover`` of it, so what
        is left is sqrt(max(in-plane - cover, 0)^2 + q^2): four numbers per sample.
        """
        q = _dot(self.axis[:, k], P) - self.offset[k]
        plane = np.sqrt(np.maximum(dist * dist - q * q, 0.0))
        left = np.maximum(plane - self.cover[k], 0.0)
        return np.sqrt(left * left + q * q)


class _CurveGrid(_StartGrid):
    """The start grid of a curve: about six samples on a knot span of median length."""

    def __init__(self, model: _CurveModel):
        per = 4
        p0 = _sample_parameters(model.t, np.full(model.t.n_spans, per))
        X = model.evaluate(p0, 0)[2][0].T
        L, A = _span_measures(model.t, X, per)
        g, pieces = _grid_parameters(model.t, _span_costs(L, A, _sample_spacing([L])))
        self.params, self.segments = (g,), (pieces,)
        self.sizes = (g.size,)
        self.periodic = (model.t.periodic,)
        tt, span, ders = model.evaluate(g, 2, pieces)
        self.state = (tt, span, np.stack(ders).reshape(3 * model.dim, -1))
        self._set_axes(ders[0], ders[1])
        self._finish(ders[0].T, [model.t])

    def may_reach(self, P: np.ndarray, k: np.ndarray, d: np.ndarray) -> np.ndarray:
        return np.ones(k.size, dtype=bool)     # no thin covers for a curve's grid

    def start(self, k: np.ndarray) -> tuple:
        tt, span, ders = self.state
        return tt[k], span[k], np.take(ders, k, axis=1).reshape(3, -1, k.size)

    def promise(self, P: np.ndarray, k: np.ndarray, dist: np.ndarray) -> np.ndarray:
        """The curve form of :meth:`_SurfaceGrid.promise`: distance from P to the sample's
        tangent line, the foot kept within the sample's cover (t the unit tangent, q = t·(P - X)
        the offset along it)."""
        q = _dot(self.axis[:, k], P) - self.offset[k]
        across = np.maximum(dist * dist - q * q, 0.0)
        left = np.maximum(np.abs(q) - self.cover[k], 0.0)
        return np.sqrt(across + left * left)
