# SPDX-License-Identifier: LGPL-2.1-or-later
"""Synthetic real-data cases on the analytic SampleBlade (exact truth): bad points, non-grid rows."""
from __future__ import annotations

import numpy as np

from bladerecon.samples.blade import SampleBlade, t_at_length_fraction

BLADE = SampleBlade()

#: (fraction of the section's points where the run starts, run length, normal displacement mm)
RUNS = ((0.12, 1, 0.010), (0.20, 2, -0.015), (0.30, 3, 0.020), (0.42, 4, -0.025),
        (0.62, 5, 0.030), (0.75, 3, 0.012), (0.85, 1, 0.200))


def clean_section(h: float, n: int, start: float = 0.013, noise: float = 0.0, seed: int = 0):
    """n true points (mm) equally spaced in arc length from ``start``, their normals and t."""
    t = t_at_length_fraction(BLADE, h, (start + np.arange(n)) / n)
    pts = BLADE.point(h, t)
    if noise:
        pts = pts + noise * np.random.default_rng(seed).standard_normal(pts.shape)
    return pts, BLADE.normal(h, t), t


def with_bad_runs(points: np.ndarray, normals: np.ndarray, runs=RUNS):
    """Displace runs of consecutive points along the surface normal; returns (points, injected mask)."""
    n = len(points)
    out = points.copy()
    inj = np.zeros(n, dtype=bool)
    for frac, k, d in runs:
        i = int(frac * n)
        out[i:i + k] += d * normals[i:i + k]
        inj[i:i + k] = True
    return out, inj


def nongrid_counts(n_rows: int = 21, total: int = 2255, lo: int = 97, hi: int = 118, seed: int = 3):
    """Row point counts in [lo, hi] summing to ``total`` (seed 003: 21 rows, 97-118, 2255)."""
    rng = np.random.default_rng(seed)
    counts = rng.integers(lo, hi + 1, n_rows)
    while counts.sum() != total:
        k = rng.integers(n_rows)
        step = int(np.sign(total - counts.sum()))
        if lo <= counts[k] + step <= hi:
            counts[k] += step
    return counts


def nongrid_rows(counts, closed: bool = True, seed: int = 3):
    """Rows at 21 equally spaced heights: whole closed sections from a random start, or the
    suction flank only (open rows, one side as in-situ machines measure in parts)."""
    rng = np.random.default_rng(seed)
    heights = np.linspace(0.0, 1.0, len(counts))
    rows = []
    for h, n in zip(heights, counts):
        if closed:
            rows.append(BLADE.point(h, t_at_length_fraction(BLADE, h, (rng.random() + np.arange(n)) / n)))
        else:
            b = BLADE.segment_bounds(h)
            rows.append(BLADE.point(h, np.linspace(b[3], b[4], n)))
    return rows, heights
