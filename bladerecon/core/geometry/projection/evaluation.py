# SPDX-License-Identifier: LGPL-2.1-or-later
"""Evaluation: a B-spline surface or curve as a table of polynomial pieces (one per patch or
knot span), read by a span look-up and nested Horner schemes; and the row-wise dot product.

Evaluation uses the piecewise polynomial form of the spline: on each knot span (surface:
each patch) the basis functions are polynomials, stored once as Taylor coefficients about
the span centre (NURBS Book §2.2 and A2.3 for the derivatives that give them), so a point
costs a table look-up and two nested Horner schemes instead of the Cox-de Boor recursion.
Knots of multiplicity >= degree (creases) cut a direction into pieces, which the Newton
iteration treats like the ends of a clamped domain (:class:`_SpanPolynomials`).

Units: millimetres.
"""
from __future__ import annotations

from math import factorial

import numpy as np

from bladerecon.core.geometry.bspline import basis_derivatives, find_spans, wrap_parameters
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface, full_knot_vector

__all__ = ["_Intervals", "_SpanPolynomials", "_horner", "_SurfaceModel", "_CurveModel", "_dot"]


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
