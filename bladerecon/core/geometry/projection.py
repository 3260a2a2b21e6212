# SPDX-License-Identifier: LGPL-2.1-or-later
"""Exact minimum distance from many points to a B-spline surface or curve.

Seed 001 §2: the deviation of a measured point P from the reconstructed surface S is the
length of the shortest segment P -> S(u, v), whose foot satisfies the orthogonality
conditions (eq. 10)

    S_u · (S - P) = 0,    S_v · (S - P) = 0,

and where several feet satisfy them the closest one counts (eq. 11). Here eq. 10 is solved
by a trust-region Newton iteration on f = |S - P|^2 / 2, vectorised over all points (the
only Python loops run over iterations, never over points), started from the nearest
sample of a grid on the surface (a k-d tree). Eq. 11: where another part of the surface
comes close enough to hold a closer foot - the other side of a thin leading or trailing
edge, ~1 mm away - or the point lies near a centre of curvature, Newton starts again
from the nearest samples there, and from the foot moved round the edge; the closest foot
wins. Seed 000 Tables 1-2 report
max / mean / std of these distances: :func:`distance_stats`.

Evaluation uses the piecewise polynomial form of the spline: on each knot span (surface:
each patch) the basis functions are polynomials, stored once as Taylor coefficients about
the span centre (NURBS Book §2.2 and A2.3 for the derivatives that give them), so a point
costs a table look-up and two nested Horner schemes instead of the Cox-de Boor recursion.
Each Newton step is refined on the local quadratic Taylor model, and the last, tiny step
is taken by Taylor expansion with a bound on its error, so most points need only one or
two evaluations after the start sample.

Where eq. 10 has no root - the foot on a clamped edge of the surface, or on a crease (a
knot of multiplicity >= degree) - Newton holds that parameter on the edge and minimises
along the other (the boundary case of eq. 11). Collapsed edges (S_u or S_v = 0, a cone
apex) are handled too.

Units: millimetres everywhere (points, feet, distances, ``tol``).
"""
from __future__ import annotations

import mmap
import os
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from math import factorial

import numpy as np
from scipy.spatial import cKDTree

from bladerecon.core.geometry.bspline import basis_derivatives, collocation_matrix, find_spans, wrap_parameters
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface, full_knot_vector
from bladerecon.core.tolerances import NEWTON_MAX_ITER

__all__ = [
    "Projection",
    "CurveProjection",
    "project_points_to_surface",
    "project_points_to_curve",
    "distance_stats",
    "surface_derivatives_fast",
]

_CHUNK = 16_384             # points per block: cache-sized, bounds memory for a million points
_THREADS = min(4, os.cpu_count() or 1)   # blocks run in parallel: forked processes, or threads
_WINDOW = 2                 # grid steps within which samples count as the same part of the spline
_N_FEW = 16                 # nearest samples looked at for a point that may have a closer foot elsewhere
_N_WIDE = 64                # ... where the first 16 are all within its reach
_MAX_STARTS = 6             # ... of which at most this many more Newton starts per point
_SAMPLES_PER_SPAN = 6       # start grid density on a span of median length
_MAX_SAMPLES_PER_SPAN = 256
_MAX_GRID_SAMPLES = 60_000     # more samples give closer starts but cost more to build than they save
_MAX_TURN_PER_SAMPLE = np.radians(20.0)   # tight edges get a sample every 20 degrees
_TRUST_MAX = 8.0            # Newton steps are clipped to at most eight knot spans
_TRUST_START = 4.0          # ... and to four at first
_FINISH = 0.1               # Taylor-expanded steps keep their error under 0.1 tol
_INNER = 1                  # Newton iterations on the local Taylor model per evaluation
_FOCAL = 0.5                # (1 - k1 d)(1 - k2 d) below this: near a centre of curvature
_MIN_BATCH = 4096           # suspects are searched in blocks of at least this many
_KEPT = 3                   # derivatives kept per foot for all points (S, S_u, S_v / C, C', C'')
_TURN = 0.25                # distance x curvature above this: try feet moved round the edge
_TURN_STEPS = (-3.0, -2.0, -1.0, -0.5, -0.25, 0.25, 0.5, 1.0, 2.0, 3.0)   # arc, in radii of curvature


@dataclass(frozen=True)
class Projection:
    """Closest points on a surface for m points (mm).

    ``signed`` is positive on the side the normal ``S_u x S_v`` points to; ``normal`` is
    that unit normal at the foot. ``converged`` is False where Newton stopped at
    ``max_iter`` before meeting the tolerance (the result is still the best foot found).
    """

    u: np.ndarray
    v: np.ndarray
    foot: np.ndarray
    distance: np.ndarray
    signed: np.ndarray
    normal: np.ndarray
    converged: np.ndarray


@dataclass(frozen=True)
class CurveProjection:
    """Closest points on a curve for m points (mm)."""

    t: np.ndarray
    foot: np.ndarray
    distance: np.ndarray
    converged: np.ndarray


# --------------------------------------------------------------------------- evaluation
class _Intervals:
    """Index i of the interval [b_i, b_i+1) that holds each value, for values in [b_0, b_-1].

    A look-up table instead of a binary search: the range is cut into bins shorter than
    the shortest interval, each bin remembers the interval at its start, and comparing
    with the neighbouring breaks corrects values on the far side of a break (or of a
    rounding at a bin edge). The last interval is closed at the right.
    """

    _MAX_BINS = 1 << 20

    def __init__(self, breaks: np.ndarray):
        self.breaks = np.asarray(breaks, dtype=float)
        self.last = self.breaks.size - 2
        self.lo = float(self.breaks[0])
        lengths = np.diff(self.breaks)
        n_bins = 2.0 * (self.breaks[-1] - self.lo) / lengths.min() if lengths.size and lengths.min() > 0 else np.inf
        self.table = None
        if n_bins <= self._MAX_BINS:
            n_bins = max(int(np.ceil(n_bins)), 1)
            self.scale = n_bins / (self.breaks[-1] - self.lo)
            edges = self.lo + np.arange(n_bins) / self.scale
            self.table = np.clip(np.searchsorted(self.breaks, edges, side="right") - 1, 0, self.last)
            self.padded = np.append(self.breaks, np.inf)

    def __call__(self, u: np.ndarray) -> np.ndarray:
        if self.table is None:
            return np.clip(np.searchsorted(self.breaks, u, side="right") - 1, 0, self.last)
        b = ((u - self.lo) * self.scale).astype(np.intp)
        i = self.table[np.minimum(np.maximum(b, 0), self.table.size - 1)]
        i += u >= self.padded[i + 1]
        i -= u < self.breaks[i]
        return np.minimum(np.maximum(i, 0), self.last)


class _SpanPolynomials:
    """One parameter direction cut at its distinct knots; each basis function restricted
    to a span is a polynomial, kept as Taylor coefficients about the span centre.

    Knots of multiplicity >= degree are C0 joints where the spline may fold (a crease);
    they cut the direction into pieces, smooth inside. Newton runs inside one piece and
    treats its ends like the ends of a clamped domain (evaluated from inside), so that a
    foot on a crease is found as a boundary minimum. A periodic direction without creases
    is one piece that wraps round; with creases its seam is a piece end too.
    """

    def __init__(self, knots: np.ndarray, mults: np.ndarray, degree: int, periodic: bool, n_poles: int):
        self.breaks = np.asarray(knots, dtype=float)
        self.degree = int(degree)
        self.periodic = bool(periodic)
        self.lo, self.hi = float(self.breaks[0]), float(self.breaks[-1])
        self.lengths = np.diff(self.breaks)
        self.centres = 0.5 * (self.breaks[:-1] + self.breaks[1:])
        U = full_knot_vector(knots, mults, degree, periodic)
        n_unwrapped = n_poles + degree if periodic else n_poles
        span = find_spans(U, degree, n_unwrapped, self.centres)
        idx = span[:, None] - degree + np.arange(degree + 1)[None, :]
        self.pole_index = idx % n_poles if periodic else idx
        ders = basis_derivatives(U, degree, span, self.centres, degree)   # (spans, k, basis)
        scale = np.array([1.0 / factorial(k) for k in range(degree + 1)])
        self.taylor = ders * scale[None, :, None]                         # (spans, power, basis)
        self.spans = _Intervals(self.breaks)
        sharp = np.asarray(mults) >= degree
        inner = np.flatnonzero(sharp[1:-1]) + 1                           # crease knot indices
        self.wraps = self.periodic and inner.size == 0 and not sharp[0]
        ends = np.concatenate([[0], inner, [self.n_spans]])               # piece ends as knot indices
        self.piece_of_span = np.repeat(np.arange(ends.size - 1), np.diff(ends))
        self.piece_first, self.piece_last = ends[:-1], ends[1:] - 1       # span range of each piece
        self.piece_lo, self.piece_hi = self.breaks[ends[:-1]], self.breaks[ends[1:]]
        self.one_piece = ends.size == 2        # bounds are then the domain's: scalars, no look-ups

    @property
    def n_spans(self) -> int:
        return int(self.lengths.size)

    def step(self, u: np.ndarray, du: np.ndarray, piece: np.ndarray) -> np.ndarray:
        """u + du, kept inside its piece (a wrapping direction is wrapped later)."""
        if self.wraps:
            return u + du
        if self.one_piece:
            return np.minimum(np.maximum(u + du, self.lo), self.hi)
        return np.minimum(np.maximum(u + du, self.piece_lo[piece]), self.piece_hi[piece])

    def held(self, u: np.ndarray, grad: np.ndarray, piece: np.ndarray) -> np.ndarray:
        """True where u sits on an end of its piece and the gradient pushes it outwards."""
        if self.wraps:
            return np.zeros(u.shape, dtype=bool)
        if self.one_piece:
            return ((u <= self.lo) & (grad > 0)) | ((u >= self.hi) & (grad < 0))
        return ((u <= self.piece_lo[piece]) & (grad > 0)) | ((u >= self.piece_hi[piece]) & (grad < 0))

    def locate(self, u: np.ndarray, piece: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Parameters wrapped or clipped into the domain, their span (one of the piece's
        spans, if given: the ends of a piece are evaluated from inside), offset from centre."""
        u = wrap_parameters(u, self.lo, self.hi) if self.wraps else np.minimum(np.maximum(u, self.lo), self.hi)
        span = self.spans(u)
        if piece is not None and not self.wraps and not self.one_piece:
            span = np.minimum(np.maximum(span, self.piece_first[piece]), self.piece_last[piece])
        return u, span, u - self.centres[span]


def _horner(c: np.ndarray, t: np.ndarray, order: int) -> list[np.ndarray]:
    """Value and derivatives up to ``order`` (<= 2) of sum_k c[k] t^k, c of shape (deg+1, ..., m).

    The 2nd derivative is returned halved (the caller folds the factor 2 in where it is
    cheapest). Simultaneous Horner scheme: one pass gives all three.
    """
    deg = c.shape[0] - 1
    b, d1, d2 = c[deg].copy(), None, None
    for k in range(deg - 1, -1, -1):          # in place: fewer temporaries is faster here
        if order >= 2 and d1 is not None:
            if d2 is None:
                d2 = d1.copy()
            else:
                d2 *= t
                d2 += d1
        if order >= 1:
            if d1 is None:
                d1 = b.copy()
            else:
                d1 *= t
                d1 += b
        b *= t
        b += c[k]
    zero = np.zeros_like(b)
    return [b, d1 if d1 is not None else zero, d2 if d2 is not None else zero][: order + 1]


class _SurfaceModel:
    """A BSplineSurface as a table of polynomial patches (one per pair of knot spans)."""

    def __init__(self, surface: BSplineSurface):
        nu, nv = surface.shape
        self.u = _SpanPolynomials(surface.u_knots, surface.u_mults, surface.u_degree, surface.u_periodic, nu)
        self.v = _SpanPolynomials(surface.v_knots, surface.v_mults, surface.v_degree, surface.v_periodic, nv)
        poles = np.asarray(surface.poles, dtype=float)
        G = poles[self.u.pole_index[:, None, :, None], self.v.pole_index[None, :, None, :]]
        A = np.einsum("sia,tjb,stabd->jidst", self.u.taylor, self.v.taylor, G, optimize=True)
        p1, q1 = surface.u_degree + 1, surface.v_degree + 1
        self.shape = (q1, p1, 3)                       # v power, u power, xyz
        self.table = np.ascontiguousarray(A.reshape(q1 * p1 * 3, -1))
        self.scale = float(np.abs(poles).max()) if poles.size else 1.0
        self.surface = surface
        norms = np.linalg.norm(A, axis=2)                # (v power, u power, u span, v span)
        hu = 0.5 * self.u.lengths[:, None]
        hv = 0.5 * self.v.lengths[None, :]
        bounds = np.zeros((4,) + norms.shape[2:])
        for n, (a, b) in enumerate(((3, 0), (2, 1), (1, 2), (0, 3))):
            for j in range(b, q1):
                for i in range(a, p1):
                    c = factorial(i) // factorial(i - a) * factorial(j) // factorial(j - b)
                    bounds[n] += c * norms[j, i] * hu ** (i - a) * hv ** (j - b)
        self.third = bounds.max(axis=0).ravel()          # bound of the 3rd derivatives per patch

    def patch(self, su: np.ndarray, sv: np.ndarray) -> np.ndarray:
        return su * self.v.n_spans + sv

    def evaluate(self, u: np.ndarray, v: np.ndarray, order: int, pieces: tuple | None = None) -> tuple:
        """(u, v, span_u, span_v, [S, S_u, S_v, S_uu, S_uv, S_vv][:n]) with vectors as (3, m).

        order 0 -> S; 1 -> S, S_u, S_v; 2 -> all six. u, v come back wrapped/clipped.
        ``pieces`` (piece_u, piece_v): evaluate from inside those pieces.
        """
        pu, pv = pieces if pieces is not None else (None, None)
        u, su, tu = self.u.locate(u, pu)
        v, sv, tv = self.v.locate(v, pv)
        G = np.take(self.table, self.patch(su, sv), axis=1).reshape(self.shape + (-1,))
        T = _horner(G, tv, order)                     # d^l/dv^l, each (p+1, 3, m)
        S = _horner(T[0], tu, order)
        ders = [S[0]]
        if order >= 1:
            Tv = _horner(T[1], tu, order - 1)
            ders += [S[1], Tv[0]]
        if order >= 2:
            ders += [2.0 * S[2], Tv[1], 2.0 * _horner(T[2], tu, 0)[0]]
        return u, v, su, sv, ders


class _CurveModel:
    """A BSplineCurve as a table of polynomial pieces (one per knot span)."""

    def __init__(self, curve: BSplineCurve):
        poles = np.asarray(curve.poles, dtype=float)
        self.dim = int(poles.shape[1])
        self.t = _SpanPolynomials(curve.knots, curve.mults, curve.degree, curve.periodic, curve.n_poles)
        A = np.einsum("sia,sad->ids", self.t.taylor, poles[self.t.pole_index])
        self.table = np.ascontiguousarray(A)             # (power, dim, spans)
        self.scale = float(np.abs(poles).max()) if poles.size else 1.0
        norms = np.linalg.norm(A, axis=1)
        h = 0.5 * self.t.lengths
        self.third = sum(
            (factorial(i) // factorial(i - 3)) * norms[i] * h ** (i - 3) for i in range(3, norms.shape[0])
        ) + np.zeros(self.t.n_spans)                     # bound of the 3rd derivative per span

    def evaluate(self, t: np.ndarray, order: int, piece: np.ndarray | None = None) -> tuple:
        """(t, span, [C, C', C''][:order+1]) with vectors as (dim, m), from inside ``piece``."""
        t, span, dt = self.t.locate(t, piece)
        ders = _horner(np.take(self.table, span, axis=2), dt, order)
        if order >= 2:
            ders[2] = 2.0 * ders[2]
        return t, span, ders


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of (dim, m) arrays."""
    out = a[0] * b[0]
    if a.shape[0] > 1:
        tmp = np.empty_like(out)
        for k in range(1, a.shape[0]):
            out += np.multiply(a[k], b[k], out=tmp)
    return out


def _segment_distance(P: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Distance from points P to the segments A -> B, all (3, m), mm."""
    AB = B - A
    AP = P - A
    t = _dot(AP, AB) / np.maximum(_dot(AB, AB), 1e-300)
    AP -= np.minimum(np.maximum(t, 0.0), 1.0) * AB
    return np.sqrt(_dot(AP, AP))


# --------------------------------------------------------------------------- start grids
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


# --------------------------------------------------------------------------- Newton
def _surface_step(model: _SurfaceModel, u, v, pieces, r, Su, Sv, Suu, Suv, Svv):
    """Newton step for f = |S - P|^2 / 2 at (u, v) with r = S - P (seed 001 eq. 10).

    H d = -grad f with H the exact Hessian where it is positive definite, else the
    Gauss-Newton matrix J^T J (a descent direction all the same). On the bound of a clamped
    direction or of a piece (``pieces``), where the gradient pushes outwards, that
    parameter is held and f is minimised along the other one only.

    Returns du, dv, the tangential residual max(|S_u·r|/|S_u|, |S_v·r|/|S_v|) over the free
    directions (mm), the metric (S_u·S_u, S_u·S_v, S_v·S_v) and det H / det J^T J, which
    is (1 - k1 d)(1 - k2 d): near 0 or negative where P is close to a centre of curvature.
    """
    guu, guv, gvv = _dot(Su, Su), _dot(Su, Sv), _dot(Sv, Sv)
    gu, gv = _dot(Su, r), _dot(Sv, r)
    huu, huv, hvv = guu + _dot(Suu, r), guv + _dot(Suv, r), gvv + _dot(Svv, r)
    det = huu * hvv - huv * huv
    gram = guu * gvv - guv * guv
    exact = (huu > 0) & (hvv > 0) & (det > 1e-12 * huu * hvv)
    lam = 1e-12 * (guu + gvv) + 1e-300
    muu = np.where(exact, huu, guu + lam)
    mvv = np.where(exact, hvv, gvv + lam)
    muv = np.where(exact, huv, guv)
    detm = muu * mvv - muv * muv
    fix_u, fix_v = model.u.held(u, gu, pieces[0]), model.v.held(v, gv, pieces[1])
    fix_u |= guu <= 1e-20 * gvv            # a collapsed edge: moving u does not move the foot
    fix_v |= gvv <= 1e-20 * guu
    # with one parameter held, Newton along the other uses its own second derivative
    du = np.where(fix_v, -gu / np.where(huu > 0, huu, guu + lam), -(mvv * gu - muv * gv) / detm)
    dv = np.where(fix_u, -gv / np.where(hvv > 0, hvv, gvv + lam), -(muu * gv - muv * gu) / detm)
    du[fix_u] = 0.0
    dv[fix_v] = 0.0
    res_u = np.where(fix_u, 0.0, np.abs(gu) / np.sqrt(np.maximum(guu, 1e-300)))
    res_v = np.where(fix_v, 0.0, np.abs(gv) / np.sqrt(np.maximum(gvv, 1e-300)))
    focal = det / np.maximum(gram, 1e-300)
    return du, dv, np.maximum(res_u, res_v), (guu, guv, gvv), focal


def _foot_move(du: np.ndarray, dv: np.ndarray, metric: tuple) -> np.ndarray:
    """Length (mm) of the foot displacement S_u du + S_v dv."""
    guu, guv, gvv = metric
    return np.sqrt(np.maximum(du * du * guu + 2.0 * du * dv * guv + dv * dv * gvv, 0.0))


def _finish_size(third: np.ndarray, lam_min: np.ndarray, dist: np.ndarray, tol: float) -> np.ndarray:
    """Largest foot step (mm) that may be taken by Taylor expansion instead of a new evaluation.

    With k3 = (bound of the 3rd derivatives) / lam_min^1.5 (1/mm^2; lam_min the smallest
    eigenvalue of the metric J^T J), a step s leaves an error below k3 s^2 d in the
    tangential residual and below k3 s^3 in the foot; both are kept under ``_FINISH * tol``.
    """
    k3 = third / np.maximum(lam_min, 1e-300) ** 1.5
    with np.errstate(divide="ignore", invalid="ignore"):
        s = np.minimum(np.sqrt(_FINISH * tol / (k3 * dist)), np.cbrt(_FINISH * tol / k3))
    return np.where(np.isnan(s), 0.0, s)


def _smallest_eigenvalue(metric: tuple) -> np.ndarray:
    guu, guv, gvv = metric
    lam_max = 0.5 * (guu + gvv + np.sqrt((guu - gvv) ** 2 + 4.0 * guv * guv))
    return (guu * gvv - guv * guv) / np.maximum(lam_max, 1e-300)


def _taylor(D: np.ndarray, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """S, S_u, S_v at (u + a, v + b) from the derivatives D (6, 3, m) at (u, v), to second order."""
    S, Su, Sv, Suu, Suv, Svv = D
    tmp = Suv * b
    Su2 = Suu * a
    Su2 += tmp
    Su2 += Su
    Sv2 = Svv * b
    np.multiply(Suv, a, out=tmp)
    Sv2 += tmp
    Sv2 += Sv
    S2 = Su + Su2
    S2 *= 0.5 * a
    np.add(Sv, Sv2, out=tmp)
    tmp *= 0.5 * b
    S2 += tmp
    S2 += S
    return S2, Su2, Sv2


def _model_step(model: _SurfaceModel, u, v, pieces, P, D, radius_u, radius_v):
    """Newton step from (u, v), refined by ``_INNER`` Newton iterations on the quadratic
    Taylor model of S about (u, v) (no new evaluation: the step error becomes third order),
    clipped to the trust radii and to a clamped domain.

    Returns the step (a, b) and, at (u, v), the residual, metric and focal ratio of
    :func:`_surface_step`.
    """
    S, Su, Sv, Suu, Suv, Svv = D
    du, dv, res, metric, focal = _surface_step(model, u, v, pieces, S - P, Su, Sv, Suu, Suv, Svv)
    a, b = _clip_step(model, u, v, pieces, du, dv, radius_u, radius_v)
    for _ in range(_INNER):
        S2, Su2, Sv2 = _taylor(D, a, b)
        du, dv = _surface_step(model, u + a, v + b, pieces, S2 - P, Su2, Sv2, Suu, Suv, Svv)[:2]
        a, b = _clip_step(model, u, v, pieces, a + du, b + dv, radius_u, radius_v)
    return a, b, res, metric, focal


def _clip_step(model: _SurfaceModel, u, v, pieces, a, b, radius_u, radius_v):
    """The step (a, b) shrunk to the trust radii (direction kept) and clipped to the pieces."""
    scale = np.minimum(_step_scale(a, radius_u), _step_scale(b, radius_v))
    return model.u.step(u, a * scale, pieces[0]) - u, model.v.step(v, b * scale, pieces[1]) - v


def _newton_surface(model: _SurfaceModel, P: np.ndarray, start: tuple, tol: float, max_iter: int, noise: float):
    """Trust-region Newton (:func:`_model_step`) for the points P (3, m) from ``start``.

    A step is clipped to ``trust`` knot spans and kept only if the distance does not grow
    (within the rounding ``noise``); a rejected step quarters the trust region. A step
    small enough (:func:`_finish_size`) is taken by Taylor expansion instead of a new
    evaluation; the point has converged when there the tangential residual and the next
    Newton step are both <= tol (mm).

    Returns u, v, the derivatives [S, S_u, S_v, S_uu, S_uv, S_vv] at the foot (6, 3, m) (the
    second ones from the last evaluation), converged, focal (see :func:`_surface_step`).
    """
    m = P.shape[1]
    u, v, su, sv, ders = start
    D = ders if isinstance(ders, np.ndarray) else np.stack(ders)
    pu, pv = model.u.piece_of_span[su], model.v.piece_of_span[sv]      # Newton stays in these
    out_u, out_v, out_focal = np.empty(m), np.empty(m), np.empty(m)
    out_D = np.empty((6, 3, m))
    converged = np.zeros(m, dtype=bool)
    idx = np.arange(m)
    trust = np.full(m, _TRUST_START)
    dist = np.sqrt(_dot(D[0] - P, D[0] - P))
    for it in range(max_iter + 1):
        a, b, res, metric, focal = _model_step(
            model, u, v, (pu, pv), P, D, trust * model.u.lengths[su], trust * model.v.lengths[sv]
        )
        finish = _finish_size(model.third[model.patch(su, sv)], _smallest_eigenvalue(metric), dist, tol)
        small = np.flatnonzero(_foot_move(a, b, metric) <= finish)
        done = np.zeros(u.size, dtype=bool)
        if small.size:
            Ds, Ps = D[:, :, small], P[:, small]
            T = _taylor(Ds, a[small], b[small])
            ps = (pu[small], pv[small])
            u2, su2, _ = model.u.locate(u[small] + a[small], ps[0])
            v2, sv2, _ = model.v.locate(v[small] + b[small], ps[1])
            du2, dv2, res2, metric2, focal2 = _surface_step(model, u2, v2, ps, T[0] - Ps, T[1], T[2], *Ds[3:])
            ok = (res2 <= tol) & (_foot_move(du2, dv2, metric2) <= tol)
            ok &= (su2 == su[small]) & (sv2 == sv[small])        # the expansion holds on its own patch
            take = ok | (it == max_iter)
            k, w = idx[small[take]], small[take]
            out_u[k], out_v[k], out_focal[k], converged[k] = u2[take], v2[take], focal2[take], ok[take]
            out_D[:3, :, k] = np.stack(T)[:, :, take]
            out_D[3:, :, k] = Ds[3:, :, take]
            done[w] = True
        if it == max_iter:
            rest = ~done
            k = idx[rest]
            out_u[k], out_v[k], out_focal[k] = u[rest], v[rest], focal[rest]
            out_D[:, :, k] = D[:, :, rest]
            break
        if done.any():
            keep = ~done
            if not keep.any():
                break
            idx, P, trust, dist = idx[keep], P[:, keep], trust[keep], dist[keep]
            u, v, su, sv, a, b, D = u[keep], v[keep], su[keep], sv[keep], a[keep], b[keep], D[:, :, keep]
            pu, pv = pu[keep], pv[keep]
        ut, vt, sut, svt, trial = model.evaluate(u + a, v + b, 2, (pu, pv))
        Dt = np.stack(trial)
        dt = np.sqrt(_dot(Dt[0] - P, Dt[0] - P))
        accept = dt <= dist + noise
        trust = np.where(accept, np.minimum(2.0 * trust, _TRUST_MAX), 0.25 * trust)
        if accept.all():
            u, v, su, sv, D, dist = ut, vt, sut, svt, Dt, dt
            continue
        for cur, new in zip((u, v, su, sv, dist), (ut, vt, sut, svt, dt)):
            np.copyto(cur, new, where=accept)
        np.copyto(D, Dt, where=accept)
    return out_u, out_v, out_D, converged, out_focal


def _curve_step(model: _CurveModel, t: np.ndarray, piece: np.ndarray, r: np.ndarray, C1: np.ndarray, C2: np.ndarray):
    """The 1D form of :func:`_surface_step`: step, residual |C'·r|/|C'|, |C'|^2, focal ratio."""
    g11 = _dot(C1, C1)
    g = _dot(C1, r)
    h = g11 + _dot(C2, r)
    focal = h / np.maximum(g11, 1e-300)
    h = np.where(h > 1e-12 * g11, h, g11 + 1e-300)
    fixed = model.t.held(t, g, piece)
    dt = np.where(fixed, 0.0, -g / h)
    res = np.where(fixed, 0.0, np.abs(g) / np.sqrt(np.maximum(g11, 1e-300)))
    return dt, res, g11, focal


def _curve_taylor(D: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """C, C' at t + a from the derivatives D (3, dim, m) at t, to second order."""
    C, C1, C2 = D
    return C + (C1 + 0.5 * C2 * a) * a, C1 + C2 * a


def _curve_model_step(model: _CurveModel, t, piece, P, D, radius):
    """The 1D form of :func:`_model_step`."""
    C, C1, C2 = D
    dt, res, g11, focal = _curve_step(model, t, piece, C - P, C1, C2)
    a = model.t.step(t, dt * _step_scale(dt, radius), piece) - t
    for _ in range(_INNER):
        Ca, C1a = _curve_taylor(D, a)
        dt = a + _curve_step(model, t + a, piece, Ca - P, C1a, C2)[0]
        a = model.t.step(t, dt * _step_scale(dt, radius), piece) - t
    return a, res, g11, focal


def _newton_curve(model: _CurveModel, P: np.ndarray, start: tuple, tol: float, max_iter: int, noise: float):
    """The 1D form of :func:`_newton_surface` for points P (dim, m): C'·(C - P) = 0.

    Returns t, [C, C', C''] at the foot (3, dim, m), converged, focal.
    """
    m, dim = P.shape[1], P.shape[0]
    t, span, ders = start
    D = ders if isinstance(ders, np.ndarray) else np.stack(ders)
    piece = model.t.piece_of_span[span]
    out_t, out_D, out_focal = np.empty(m), np.empty((3, dim, m)), np.empty(m)
    converged = np.zeros(m, dtype=bool)
    idx = np.arange(m)
    trust = np.full(m, _TRUST_START)
    dist = np.sqrt(_dot(D[0] - P, D[0] - P))
    for it in range(max_iter + 1):
        a, res, g11, focal = _curve_model_step(model, t, piece, P, D, trust * model.t.lengths[span])
        finish = _finish_size(model.third[span], g11, dist, tol)
        small = np.flatnonzero(np.abs(a) * np.sqrt(g11) <= finish)
        done = np.zeros(t.size, dtype=bool)
        if small.size:
            Ds = D[:, :, small]
            Cs, C1s = _curve_taylor(Ds, a[small])
            t2, span2, _ = model.t.locate(t[small] + a[small], piece[small])
            dt2, res2, g2, focal2 = _curve_step(model, t2, piece[small], Cs - P[:, small], C1s, Ds[2])
            ok = (res2 <= tol) & (np.abs(dt2) * np.sqrt(g2) <= tol) & (span2 == span[small])
            take = ok | (it == max_iter)
            k, w = idx[small[take]], small[take]
            out_t[k], out_focal[k], converged[k] = t2[take], focal2[take], ok[take]
            out_D[0][:, k], out_D[1][:, k], out_D[2][:, k] = Cs[:, take], C1s[:, take], Ds[2][:, take]
            done[w] = True
        if it == max_iter:
            rest = ~done
            k = idx[rest]
            out_t[k], out_focal[k] = t[rest], focal[rest]
            out_D[:, :, k] = D[:, :, rest]
            break
        if done.any():
            keep = ~done
            if not keep.any():
                break
            idx, P, trust, dist = idx[keep], P[:, keep], trust[keep], dist[keep]
            t, span, a, D, piece = t[keep], span[keep], a[keep], D[:, :, keep], piece[keep]
        tt, spant, trial = model.evaluate(t + a, 2, piece)
        Dt = np.stack(trial)
        dnew = np.sqrt(_dot(Dt[0] - P, Dt[0] - P))
        accept = dnew <= dist + noise
        trust = np.where(accept, np.minimum(2.0 * trust, _TRUST_MAX), 0.25 * trust)
        if accept.all():
            t, span, D, dist = tt, spant, Dt, dnew
            continue
        for cur, new in zip((t, span, dist), (tt, spant, dnew)):
            np.copyto(cur, new, where=accept)
        np.copyto(D, Dt, where=accept)
    return out_t, out_D, converged, out_focal


def _step_scale(step: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Factor (<= 1) that shrinks a step to the trust radius."""
    a = np.abs(step)
    return np.where(a > radius, radius / np.where(a > 0, a, 1.0), 1.0)


# --------------------------------------------------------------------------- public API
def _check_points(points: np.ndarray, dim: int) -> np.ndarray:
    P = np.asarray(points, dtype=float)
    if P.ndim == 1 and P.size == dim:
        P = P[None, :]
    if P.ndim != 2 or P.shape[1] != dim:
        raise BladeReconError(f"points must be an (m, {dim}) array of coordinates in mm; got shape {P.shape}")
    with np.errstate(over="ignore", invalid="ignore"):
        if np.isfinite(np.sum(P)):    # one cheap pass; a sum may overflow, so check again then
            return P
    bad = ~np.isfinite(P).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise BladeReconError(
            f"{rows.size} point(s) have NaN or infinite coordinates (first at row {rows[0]}): "
            "remove them before measuring distances"
        )
    return P


def _start_parameters(values: np.ndarray | None, m: int, name: str) -> np.ndarray | None:
    if values is None:
        return None
    a = np.asarray(values, dtype=float).ravel()
    if a.size != m:
        raise ValueError(f"{name} must hold one parameter per point ({m}); got {a.size}")
    return a


def _for_each_block(m: int, work, chunk: int = _CHUNK, shared: bool = False) -> None:
    """Call ``work(start, stop, kd_workers)`` on blocks of ``chunk`` points, in parallel
    when there are several blocks; each block writes its own rows of the outputs.

    With ``shared`` (the outputs live in shared memory, :func:`_shared`) and where a fork is
    safe (:func:`_can_fork`), the blocks are split between this process and forked
    children: numpy's many short calls scale far better over processes than over threads,
    which hand the GIL to and fro. Otherwise threads (numpy and the k-d tree release the
    GIL for their loops).
    """
    blocks = [(s, min(s + chunk, m)) for s in range(0, m, chunk)]
    n = min(_THREADS, len(blocks))
    if n <= 1:
        for s, e in blocks:
            work(s, e, -1)
    elif shared and _can_fork():
        _fork_blocks([blocks[k::n] for k in range(n)], work)
    else:
        with ThreadPoolExecutor(n) as pool:
            list(pool.map(lambda block: work(block[0], block[1], 1), blocks))


def _can_fork() -> bool:
    """A fork is safe in a single-threaded process on Linux without a GUI toolkit loaded (in
    FreeCAD's GUI, whose Qt threads Python does not see, threads are used instead; only the
    module names are looked at, nothing is imported); ``BLADERECON_PROCESSES=0`` turns it off."""
    return (sys.platform.startswith("linux") and hasattr(os, "fork") and threading.active_count() == 1
            and os.environ.get("BLADERECON_PROCESSES", "1") != "0"
            and not any(name in sys.modules for name in _GUI_MODULES))


_GUI_MODULES = ("FreeCADGui", "PySide", "PySide2", "PySide6", "PyQt5", "PyQt6", "tkinter")


def _fork_blocks(groups: list[list[tuple[int, int]]], work) -> None:
    """Run the first group of blocks here and each other group in a forked child; a child
    that fails (or cannot be forked) has its blocks run here afterwards."""
    children = []
    for group in groups[1:]:
        try:
            pid = os.fork()
        except OSError:
            children.append((None, group))
            continue
        if pid == 0:                                   # the child: its blocks, then leave at once
            code = 1
            try:
                for s, e in group:
                    work(s, e, 1)
                code = 0
            finally:
                os._exit(code)
        children.append((pid, group))
    for s, e in groups[0]:
        work(s, e, 1)
    for pid, group in children:
        if pid is None or os.waitpid(pid, 0)[1] != 0:
            for s, e in group:
                work(s, e, 1)


def _shared(shape: tuple[int, ...], dtype=float) -> np.ndarray:
    """An array in anonymous shared memory: what forked children write, the parent sees."""
    size = int(np.prod(shape)) * np.dtype(dtype).itemsize
    return np.frombuffer(mmap.mmap(-1, max(size, 1)), dtype=dtype, count=int(np.prod(shape))).reshape(shape)


def _spatial_order(P: np.ndarray, grid: _StartGrid) -> np.ndarray:
    """A permutation that visits the points voxel by voxel (32 voxels along the longest
    side of the spline's box, points outside it in the voxels on its faces): neighbouring
    points then share k-d tree branches and patches, which makes the searches about a
    quarter faster than in scan or random order. The box is the k-d tree's (the points' own
    would cost two passes over them). The voxel index fits 15 bits, so numpy sorts it by
    radix (twice as fast as a 64-bit key)."""
    lo, hi = grid.tree.mins, grid.tree.maxes
    size = max(float((hi - lo).max()) / 31.999, 1e-300)
    key = np.clip((P - lo) * (1.0 / size), 0.0, 31.0).astype(np.int16)
    flat = key[:, 0].copy()
    for axis in range(1, P.shape[1]):
        flat *= 32
        flat += key[:, axis]
    return np.argsort(flat, kind="stable")


def _inverse(order: np.ndarray) -> np.ndarray:
    inverse = np.empty_like(order)
    inverse[order] = np.arange(order.size)
    return inverse


def _rounding_noise(scale: float, P: np.ndarray) -> float:
    """Distance differences below this are rounding (mm)."""
    return 64.0 * np.finfo(float).eps * max(scale, float(np.abs(P).max()) if P.size else 0.0, 1.0)


_CACHE_SIZE = 4
_cache: list[tuple[object, object, list]] = []     # (spline, model, [grid or None]), newest last
_cache_lock = threading.Lock()


def _cached(spline, make_model):
    """The polynomial model of a spline, and a slot for its start grid, kept for the few
    splines used last: re-projecting onto the same nominal (alignment iterations, restarts,
    a second point set) then costs no rebuild. Splines are frozen dataclasses, so the
    object identity is the key; the entry holds the spline, so the id is not reused."""
    with _cache_lock:
        for k, (obj, model, slot) in enumerate(_cache):
            if obj is spline:
                _cache.append(_cache.pop(k))
                return model, slot
    model, slot = make_model(spline), [None]
    with _cache_lock:
        _cache.append((spline, model, slot))
        del _cache[:-_CACHE_SIZE]
    return model, slot


def _surface_grid(surface: BSplineSurface) -> tuple[_SurfaceModel, _SurfaceGrid]:
    model, slot = _cached(surface, _SurfaceModel)
    if slot[0] is None:
        slot[0] = _SurfaceGrid(model)
    return model, slot[0]


def surface_derivatives_fast(surface: BSplineSurface, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, ...]:
    """S, S_u, S_v, S_uu, S_uv, S_vv at (u, v), each (m, 3) (mm): the projection's
    polynomial patches, a few times faster than :func:`bspline.surface_derivatives`."""
    model, _ = _cached(surface, _SurfaceModel)
    u, v = np.atleast_1d(np.asarray(u, float)), np.atleast_1d(np.asarray(v, float))
    out = [np.empty((u.size, 3)) for _ in range(6)]
    for s in range(0, u.size, _CHUNK):
        ders = model.evaluate(u[s:s + _CHUNK], v[s:s + _CHUNK], 2)[4]
        for o, d in zip(out, ders):
            o[s:s + _CHUNK] = d.T
    return tuple(out)


def project_points_to_surface(
    surface: BSplineSurface,
    points: np.ndarray,
    u0: np.ndarray | None = None,
    v0: np.ndarray | None = None,
    *,
    tol: float = 1e-10,
    max_iter: int = NEWTON_MAX_ITER,
) -> Projection:
    """Closest point on ``surface`` for each of ``points`` (m, 3), mm (seed 001 §2 eqs. 10-11).

    Without ``u0``/``v0`` the search is global (:func:`_search`): Newton starts from the
    nearest sample of a grid on the surface with square cells (about 6 samples on a knot
    span of median length, more on long or sharply turning spans); where another part of
    the surface comes close enough to hold a closer foot (the other side of a thin leading
    or trailing edge) or the point lies near a centre of curvature, Newton starts again
    from the nearest samples there, and from feet moved round the edge; the closest foot
    wins (eq. 11). With ``u0`` and ``v0`` (one pair per point) only a local Newton
    iteration from them is run: use it to re-project after small changes.

    ``tol`` (mm) bounds both the tangential residuals |S_u·(S-P)|/|S_u|, |S_v·(S-P)|/|S_v|
    (the orthogonality cosines times the distance) and the next Newton step of the foot.
    Points are processed in blocks of ``_CHUNK`` in parallel (``_THREADS`` processes or
    threads, :func:`_for_each_block`), so a million points fit in memory.
    """
    P = _check_points(points, 3)
    m = P.shape[0]
    u0 = _start_parameters(u0, m, "u0")
    v0 = _start_parameters(v0, m, "v0")
    if (u0 is None) != (v0 is None):
        raise ValueError("give both u0 and v0, or neither")
    if u0 is None and m:
        model, grid = _surface_grid(surface)
    else:
        model, grid = _cached(surface, _SurfaceModel)[0], None
    noise = _rounding_noise(model.scale, P)

    def solve(Pc: np.ndarray, start: tuple):
        uc, vc, D, cc, focal = _newton_surface(model, Pc, start, tol, max_iter, noise)
        return [uc, vc], D, cc, focal

    out = Projection(u=_shared((m,)), v=_shared((m,)), foot=_shared((m, 3)), distance=_shared((m,)),
                     signed=_shared((m,)), normal=_shared((m, 3)), converged=_shared((m,), bool))
    order = None

    def emit(rows, params: list, D: np.ndarray, conv: np.ndarray) -> None:
        """Normals and signs of the feet of the points ``rows`` (a slice or indices of P),
        written to ``out`` in the caller's point order."""
        target = order[rows] if order is not None else rows
        S, Su, Sv = D[0], D[1], D[2]
        n = np.cross(Su, Sv, axis=0)
        n_len = np.sqrt(_dot(n, n))
        off = np.ascontiguousarray(P[rows].T) - S
        dist = np.sqrt(_dot(off, off))
        # where S_u x S_v vanishes (a collapsed edge) the offset direction is the normal
        degenerate = n_len <= 1e-14 * np.sqrt(np.maximum(_dot(Su, Su) * _dot(Sv, Sv), 1e-300))
        n = np.where(degenerate, off / np.maximum(dist, 1e-300), n / np.where(degenerate, 1.0, n_len))
        out.u[target], out.v[target], out.converged[target] = params[0], params[1], conv
        out.foot[target], out.normal[target], out.distance[target] = S.T, n.T, dist
        out.signed[target] = np.where(_dot(off, n) < 0, -dist, dist)

    if grid is not None:
        order = _spatial_order(P, grid) if m > _CHUNK else None
        if order is not None:
            P = np.take(P, order, axis=0)
        _search(grid, solve, lambda p: model.evaluate(p[0], p[1], 2), _surface_turn, P, noise, emit)
    else:
        def work(s: int, e: int, kd_workers: int) -> None:
            params, D, conv, _ = solve(np.ascontiguousarray(P[s:e].T), model.evaluate(u0[s:e], v0[s:e], 2))
            emit(slice(s, e), params, D, conv)

        _for_each_block(m, work, shared=True)
    return out


def project_points_to_curve(
    curve: BSplineCurve,
    points: np.ndarray,
    t0: np.ndarray | None = None,
    *,
    tol: float = 1e-10,
    max_iter: int = NEWTON_MAX_ITER,
) -> CurveProjection:
    """Closest point on ``curve`` for each of ``points`` (m, dim), mm.

    The 1D form of :func:`project_points_to_surface`: solve C'·(C - P) = 0 by trust-region
    Newton from the nearest curve samples (or only from ``t0``), closest root wins.
    """
    dim = int(np.asarray(curve.poles).shape[1])
    P = _check_points(points, dim)
    m = P.shape[0]
    t0 = _start_parameters(t0, m, "t0")
    model, slot = _cached(curve, _CurveModel)
    if t0 is None and m and slot[0] is None:
        slot[0] = _CurveGrid(model)
    grid = slot[0] if t0 is None and m else None
    noise = _rounding_noise(model.scale, P)

    def solve(Pc: np.ndarray, start: tuple):
        tc, D, cc, focal = _newton_curve(model, Pc, start, tol, max_iter, noise)
        return [tc], D, cc, focal

    if grid is not None:
        order = _spatial_order(P, grid) if m > _CHUNK else None
        if order is not None:
            P = np.take(P, order, axis=0)
        (t,), D, conv = _search(grid, solve, lambda p: model.evaluate(p[0], 2), _curve_turn, P, noise)
    else:
        order = None
        t, D, conv = np.empty(m), np.empty((1, dim, m)), np.empty(m, dtype=bool)

        def work(s: int, e: int, kd_workers: int) -> None:
            (t[s:e],), Dc, conv[s:e], _ = solve(np.ascontiguousarray(P[s:e].T), model.evaluate(t0[s:e], 2))
            D[:, :, s:e] = Dc[:1]

        _for_each_block(m, work)
    foot = np.ascontiguousarray(D[0].T)
    dist = np.linalg.norm(P - foot, axis=1)
    if order is not None:
        back = _inverse(order)
        t, foot, dist, conv = (np.take(a, back, axis=0) for a in (t, foot, dist, conv))
    return CurveProjection(t=t, foot=foot, distance=dist, converged=conv)


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


@dataclass
class _Feet:
    """The best feet found so far for m points: parameters (n_dirs, m), derivatives at the
    foot (n_ders, dim, m), converged, focal ratio, distance, the first start sample, and
    ``bend``: distance x largest curvature at the foot (near 1: P near a centre of
    curvature, where feet may lie side by side). Only the first ``_KEPT`` derivatives are kept for all points (S, S_u, S_v: what the
    normals need); second derivatives are evaluated again where they are needed."""

    params: np.ndarray
    ders: np.ndarray
    conv: np.ndarray
    focal: np.ndarray
    dist: np.ndarray
    k0: np.ndarray
    bend: np.ndarray

    def take(self, rows: np.ndarray) -> _Feet:
        return _Feet(self.params[:, rows], self.ders[:, :, rows], self.conv[rows], self.focal[rows],
                     self.dist[rows], self.k0[rows], self.bend[rows])

    def put(self, rows: np.ndarray | slice, other: _Feet) -> None:
        self.params[:, rows], self.ders[:, :, rows], self.conv[rows] = other.params, other.ders[:_KEPT], other.conv
        self.focal[rows], self.dist[rows], self.k0[rows], self.bend[rows] = other.focal, other.dist, other.k0, other.bend

    def update(self, rows: np.ndarray, run: tuple, dist: np.ndarray, turn, noise: float) -> None:
        """Take the feet of a later Newton run (``solve``'s output) for the points ``rows``
        where they are closer (``dist``)."""
        params, ders, conv, focal = run
        win = dist < self.dist[rows] - noise
        w = rows[win]
        for a, b in zip(self.params, params):
            a[w] = b[win]
        self.ders[:, :, w] = ders[:_KEPT, :, win]
        self.conv[w], self.focal[w], self.dist[w] = conv[win], focal[win], dist[win]
        self.bend[w] = dist[win] * turn(ders[:, :, win])[0]


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
    rows = np.concatenate([rows[runs % _THREADS == k] for k in range(_THREADS)])
    if rows.size and grid.size > 1:
        def more(s: int, e: int, workers: int) -> None:
            r = rows[s:e]
            sub = feet.take(r)
            _more_starts(grid, solve, turn, np.ascontiguousarray(P[r].T), sub, noise, workers)
            feet.put(r, sub)

        _for_each_block(rows.size, more, max(_MIN_BATCH, -(-rows.size // _THREADS)), shared=True)
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


def _surface_turn(D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Largest |principal curvature| (1/mm) at the feet, from the derivatives D (6, 3, m),
    and its direction as a parameter step (2, m) that moves the foot by 1 mm."""
    _, Su, Sv, Suu, Suv, Svv = D
    E, F, G = _dot(Su, Su), _dot(Su, Sv), _dot(Sv, Sv)
    n = np.cross(Su, Sv, axis=0)
    n /= np.maximum(np.sqrt(_dot(n, n)), 1e-300)
    L, M, N = _dot(Suu, n), _dot(Suv, n), _dot(Svv, n)
    det = np.maximum(E * G - F * F, 1e-300)
    K = (L * N - M * M) / det
    H = (E * N - 2.0 * F * M + G * L) / (2.0 * det)
    root = np.sqrt(np.maximum(H * H - K, 0.0))
    k = np.where(H >= 0, H + root, H - root)                  # the principal curvature of larger size
    # null vector of II - k I, in the better-conditioned of its two forms
    a1u, a1v = M - k * F, -(L - k * E)
    a2u, a2v = N - k * G, -(M - k * F)
    first = a1u * a1u + a1v * a1v >= a2u * a2u + a2v * a2v
    au, av = np.where(first, a1u, a2u), np.where(first, a1v, a2v)
    size = np.sqrt(np.maximum(au * au * E + 2.0 * au * av * F + av * av * G, 0.0))
    umbilic = size <= 1e-12 * np.sqrt(E * G)
    au = np.where(umbilic, 1.0 / np.sqrt(np.maximum(E, 1e-300)), au / np.where(umbilic, 1.0, size))
    av = np.where(umbilic, 0.0, av / np.where(umbilic, 1.0, size))
    return np.abs(k), np.stack([au, av])


def _curve_turn(D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Curvature (1/mm) at the feet from [C, C', C''] (3, dim, m), and the parameter step
    (1, m) that moves the foot by 1 mm along the curve."""
    _, C1, C2 = D
    g = _dot(C1, C1)
    cross = np.maximum(g * _dot(C2, C2) - _dot(C1, C2) ** 2, 0.0)
    speed = np.sqrt(np.maximum(g, 1e-300))
    return np.sqrt(cross) / speed ** 3, (1.0 / speed)[None, :]


def distance_stats(d: np.ndarray, signed: bool | None = None) -> dict[str, float | int]:
    """Max / mean / std / rms / min of point-to-surface distances (mm): seed 000 Tables 1-2.

    The statistics are of the magnitudes |d| (std with ddof=0). For signed distances
    (``signed=True``, or by default when any value is negative) ``min_signed`` and
    ``max_signed`` give the deepest point on each side. ``n`` is the number of values.
    """
    a = np.asarray(d, dtype=float).ravel()
    if a.size == 0:
        raise BladeReconError("no distances to summarise: the point set is empty")
    if signed is None:
        signed = bool(np.any(a < 0))
    mag = np.abs(a)
    stats = {
        "n": int(a.size),
        "max": float(mag.max()),
        "mean": float(mag.mean()),
        "std": float(mag.std()),
        "rms": float(np.sqrt(np.mean(mag * mag))),
        "min": float(mag.min()),
    }
    if signed:
        stats["min_signed"] = float(a.min())
        stats["max_signed"] = float(a.max())
    return stats
