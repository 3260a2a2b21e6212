# SPDX-License-Identifier: LGPL-2.1-or-later
"""Point-in-face in a face's (u, v) parameter plane: its trimming loops as polygons, and an
even-odd test vectorised over many points (the slab method).

A trimmed face is the part of its surface inside the loops of its pcurves (the outer loop
and any holes). Each pcurve is sampled into a polyline in (u, v) (by the caller, finely
enough that the polygon lies within the wanted tolerance of the true loop); the even-odd
rule then needs neither the loops' orientation nor their order, only their segments.

The slab method: the v values of all polygon vertices cut the plane into horizontal slabs;
inside a slab the segments that cross it do so from bottom to top without ending, so a
point (u, v) is inside iff an odd number of them pass to the right of it at height v. The
segments of every slab are stored once in a padded table (slab x crossings), so a point
costs one ``searchsorted`` and a row of that table: O(m k) for m points and k crossings
per slab (a handful for a face), whatever the number of polygon vertices.

Periodic surfaces: a foot's u (v) is first moved by whole periods into the period that
starts just below the polygon's smallest u (v), where the loops live.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["UVRegion"]

_CHUNK = 1 << 17


@dataclass(frozen=True)
class UVRegion:
    """The inside of closed polygons in (u, v): slab table for the even-odd rule."""

    slab_v: np.ndarray        # (n_slabs + 1,) increasing v of the slab limits
    u_at: np.ndarray          # (n_slabs, k): u of each crossing segment at the slab's lower v (nan: none)
    du_dv: np.ndarray         # (n_slabs, k): its slope du/dv
    v_base: np.ndarray        # (n_slabs,): the slab's lower v
    u_period: float | None
    v_period: float | None
    u_lo: float               # polygon's smallest u, v (periodic shifts)
    v_lo: float
    bounds: tuple[float, float, float, float]   # u_min, u_max, v_min, v_max of the polygons

    @classmethod
    def from_loops(cls, loops: list[np.ndarray], u_period: float | None = None,
                   v_period: float | None = None) -> "UVRegion":
        """From closed polylines (each (k, 2) in (u, v); the closing segment is implied,
        a repeated first point is fine) or open polylines whose union closes (the pcurves
        of one face's edges, in any order and direction)."""
        a_list, b_list = [], []
        for loop in loops:
            pts = np.asarray(loop, float).reshape(-1, 2)
            if len(pts) < 2:
                continue
            a_list.append(pts[:-1])
            b_list.append(pts[1:])
        if not a_list:
            raise ValueError("UVRegion: no trimming segments")
        a, b = np.concatenate(a_list), np.concatenate(b_list)
        return cls.from_segments(a, b, u_period, v_period)

    @classmethod
    def from_segments(cls, a: np.ndarray, b: np.ndarray, u_period: float | None = None,
                      v_period: float | None = None) -> "UVRegion":
        """From segments a[i] -> b[i] (n, 2) that together form closed loops."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        pts = np.concatenate([a, b])
        bounds = (float(pts[:, 0].min()), float(pts[:, 0].max()), float(pts[:, 1].min()), float(pts[:, 1].max()))
        keep = a[:, 1] != b[:, 1]                       # horizontal segments cross no slab
        a, b = a[keep], b[keep]
        lo = np.where((a[:, 1] < b[:, 1])[:, None], a, b)       # lower end
        hi = np.where((a[:, 1] < b[:, 1])[:, None], b, a)
        ys = np.unique(np.concatenate([lo[:, 1], hi[:, 1]]))
        n_slabs = max(len(ys) - 1, 0)
        first = np.searchsorted(ys, lo[:, 1])                   # slabs [first, last) of each segment
        last = np.searchsorted(ys, hi[:, 1])
        count = last - first
        per_slab = np.zeros(n_slabs + 1, dtype=np.int64)
        np.add.at(per_slab, first, 1)
        np.add.at(per_slab, last, -1)
        per_slab = np.cumsum(per_slab)[:n_slabs]
        k = int(per_slab.max()) if n_slabs else 1
        slope = (hi[:, 0] - lo[:, 0]) / (hi[:, 1] - lo[:, 1])
        seg = np.repeat(np.arange(len(lo)), count)
        slab = np.repeat(first - np.cumsum(count) + count, count) + np.arange(count.sum())
        # column of each (segment, slab) entry: its rank among the entries of that slab
        order = np.argsort(slab, kind="stable")
        slab_sorted = slab[order]
        starts = np.searchsorted(slab_sorted, np.arange(n_slabs))
        col = np.empty_like(slab)
        col[order] = np.arange(len(slab)) - starts[slab_sorted]
        u_at = np.full((n_slabs, max(k, 1)), np.nan)
        du_dv = np.zeros((n_slabs, max(k, 1)))
        v_base = ys[:-1] if n_slabs else np.zeros(0)
        u_at[slab, col] = lo[seg, 0] + (v_base[slab] - lo[seg, 1]) * slope[seg]
        du_dv[slab, col] = slope[seg]
        return cls(ys, u_at, du_dv, v_base, u_period, v_period, bounds[0], bounds[2], bounds)

    def normalise(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(u, v) moved by whole periods into the period where the loops are."""
        u, v = np.asarray(u, float), np.asarray(v, float)
        eps_u = 1e-12 * (self.u_period or 1.0)
        eps_v = 1e-12 * (self.v_period or 1.0)
        if self.u_period:
            u = self.u_lo - eps_u + np.mod(u - (self.u_lo - eps_u), self.u_period)
        if self.v_period:
            v = self.v_lo - eps_v + np.mod(v - (self.v_lo - eps_v), self.v_period)
        return u, v

    def contains(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """True where (u, v) lies inside the loops (even-odd rule), shape of u."""
        u, v = self.normalise(u, v)
        shape = u.shape
        u, v = u.ravel(), v.ravel()
        out = np.zeros(u.size, dtype=bool)
        n_slabs = len(self.v_base)
        u0, u1, v0, v1 = self.bounds
        near = np.flatnonzero((u >= u0) & (u <= u1) & (v >= v0) & (v <= v1))   # NaN compares False
        for s in range(0, near.size, _CHUNK):
            idx = near[s:s + _CHUNK]
            uc, vc = u[idx], v[idx]
            slab = np.searchsorted(self.slab_v, vc, side="right") - 1
            ok = (slab >= 0) & (slab < n_slabs)
            idx, uc, vc, sl = idx[ok], uc[ok], vc[ok], slab[ok]
            cross = self.u_at[sl] + (vc - self.v_base[sl])[:, None] * self.du_dv[sl]
            right = np.count_nonzero(cross > uc[:, None], axis=1)      # nan compares False
            out[idx] = (right & 1) == 1
        return out.reshape(shape)
