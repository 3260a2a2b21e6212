# SPDX-License-Identifier: LGPL-2.1-or-later
"""The material to add in each shallow damaged region (erosion, nick, burn-off) as two grids of
points: the repair target over the region and the damaged floor under it (mm).

A region is a set of cells of the damage grid (rows of span height x bins of the nominal's u,
:func:`bladerecon.core.repair.target._damage_grid`) with a mean in-plane depth δ each. Over
the region's box (its rows, and its u bins, across the periodic seam where it wraps) the
target is sampled on a grid ``n_sub`` times finer than the cells, and the floor is each
sample moved δ into the material along the target's unit normal projected into the section
plane (the depth is measured in the section plane, module doc of ``target`` §3), with δ
interpolated bilinearly between the cell centres of the region (0 outside it) and at least
``_SKIN`` so that the two grids never touch (a closed solid needs side faces of non-zero
area). The solid between the grids (``bladerecon.fc.repair``) holds the region's volume of
:func:`~bladerecon.core.repair.target.repair_target` to the interpolation of δ.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.projection import surface_derivatives_fast

__all__ = ["RegionGrids", "missing_region_grids"]

_SKIN = 1e-3        # mm: the floor's least depth (adds at most area x 1 µm to a region)


@dataclass(frozen=True)
class RegionGrids:
    """One region's material to add: ``top`` (on the target) and ``floor`` (the damaged
    surface), both (rows, columns, 3) mm in the measured frame, corresponding point to point."""

    kind: str
    volume_mm3: float
    top: np.ndarray
    floor: np.ndarray
    closed: bool = False            # the region runs all round the section (a ring, not a box)


def _region_box(cells: np.ndarray) -> tuple[int, int, int, int]:
    """First row, row count, first u bin and bin count of a region's cells (rows, bins), the
    bins taken round the periodic seam when the region wraps (the largest empty gap of
    bins, read circularly, is left out)."""
    rows = np.flatnonzero(cells.any(axis=1))
    cols = cells.any(axis=0)
    n = cols.size
    if cols.all():
        return int(rows[0]), int(rows[-1] - rows[0] + 1), 0, n
    empty = np.flatnonzero(~cols)
    # the longest run of empty bins, circularly: the box starts just after it
    gaps = np.diff(np.concatenate([empty, [empty[0] + n]]))
    k = int(np.argmax(gaps))
    start = (empty[k] + 1) % n
    width = int(gaps[k] - 1)
    return int(rows[0]), int(rows[-1] - rows[0] + 1), int(start), width


def missing_region_grids(result, n_sub: int = 4) -> list[RegionGrids]:
    """Top and floor grids of every non-tip region of a
    :class:`~bladerecon.core.repair.target.RepairResult` (mm, measured frame)."""
    g = result.depth_map
    depth, labels = g["depth"], g["labels"]
    z_rows, u_edges = np.asarray(g["z_rows"]), np.asarray(g["u_edges"])
    n_rows, n_bins = depth.shape
    u0, u1 = float(u_edges[0]), float(u_edges[-1])
    du = (u1 - u0) / n_bins
    dz = np.gradient(z_rows) if n_rows > 1 else np.array([1.0])
    surface = result.adapted
    # the span axis of the nominal frame, seen in the measured frame (the depth is in its planes)
    axis = np.linalg.inv(result.alignment.matrix)[:3, :3] @ np.array([0.0, 0.0, 1.0])
    axis /= np.linalg.norm(axis)
    row_index = np.arange(n_rows, dtype=float)
    out = []
    non_tip = [r for r in result.regions if r["kind"] != "tip"]
    for region, label in zip(non_tip, g["region_labels"]):
        cells = labels == label
        r0, nr, b0, nb = _region_box(cells)
        field = np.where(cells, np.maximum(depth, 0.0), 0.0)
        z_lo = z_rows[r0] - 0.5 * dz[r0]
        z_hi = z_rows[r0 + nr - 1] + 0.5 * dz[r0 + nr - 1]
        zs = np.linspace(z_lo, z_hi, max(2, n_sub * nr) + 1)
        bins = b0 + np.linspace(0.0, nb, n_sub * nb + 1)            # in bins, may pass the seam
        # bilinear δ between cell centres: rows clamped at the ends, bins periodic
        fr = np.interp(zs, z_rows, row_index) if n_rows > 1 else np.zeros_like(zs)
        fc = bins - 0.5
        i0 = np.clip(np.floor(fr).astype(int), 0, n_rows - 1)
        i1 = np.minimum(i0 + 1, n_rows - 1)
        a = (fr - i0)[:, None]
        j0 = np.floor(fc).astype(int)
        b = (fc - j0)[None, :]
        j0, j1 = j0 % n_bins, (j0 + 1) % n_bins
        delta = ((1 - a) * ((1 - b) * field[i0][:, j0] + b * field[i0][:, j1])
                 + a * ((1 - b) * field[i1][:, j0] + b * field[i1][:, j1]))
        delta = np.maximum(delta, _SKIN)
        u = u0 + np.mod(bins * du, u1 - u0)
        if nb == n_bins:
            u[-1] = u[0]                                 # a band all round: closed in u
        v = np.interp(zs, *g["z_to_v"])                  # the nominal's v at each height
        uu, vv = np.meshgrid(u, v)                        # (rows, columns)
        S, Su, Sv = surface_derivatives_fast(surface, uu.ravel(), vv.ravel())[:3]
        n = result.sign * np.cross(Su, Sv)
        n -= np.outer(n @ axis, axis)                     # into the section plane
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        top = S.reshape(uu.shape + (3,))
        floor = (S - delta.reshape(-1, 1) * n).reshape(uu.shape + (3,))
        out.append(RegionGrids(region["kind"], float(region["volume_mm3"]), top, floor, nb == n_bins))
    return out
