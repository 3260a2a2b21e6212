# SPDX-License-Identifier: LGPL-2.1-or-later
"""Test blades with known profile errors for the verdict tests (wraps bladerecon.samples.blade).

The truth is the analytic sample blade: each measured point is made from a known surface
point (h, t), moved along the exact outward normal by a known error, then by a known rigid
motion. :class:`AnalyticProjector` is the exact closest-point map onto that analytic
surface (Gauss-Newton on (h, t) from each point's own parameters), so deviations measured
with it are exact, independent of any B-spline nominal.
"""
from __future__ import annotations

import numpy as np

from bladerecon.samples.blade import SampleBlade, section_heights, t_at_length_fraction

N_SECTIONS = 6
N_POINTS = 160


def section_parameters(blade: SampleBlade, n_sections: int = N_SECTIONS, n_points: int = N_POINTS):
    """(h, t) of every point: the 'plan' layout of ``sample_sections`` (starts at the LE point,
    denser on the edges), hub section first; arrays (n_sections, n_points)."""
    hs = section_heights(n_sections)
    t = np.stack([t_at_length_fraction(blade, h, np.arange(n_points) / n_points, 1.0) for h in hs])
    return np.repeat(hs[:, None], n_points, axis=1), t


def analytic_zone(blade: SampleBlade, h: np.ndarray, t: np.ndarray) -> np.ndarray:
    """0 leading edge, 1 trailing edge, 2 flanks: the analytic pieces of the section."""
    b = blade.segment_bounds(h)
    z = np.full(t.shape, 2)
    z[(t < b[..., 1]) | (t >= b[..., 4])] = 0
    z[(t >= b[..., 2]) & (t < b[..., 3])] = 1
    return z


def le_window(blade: SampleBlade, h: np.ndarray, t: np.ndarray) -> np.ndarray:
    """1 at the LE point falling smoothly (cos²) to 0 at the LE arc's joints, 0 elsewhere."""
    b = blade.segment_bounds(h)
    s = np.where(t < b[..., 1], t / b[..., 1], (1.0 - t) / (1.0 - b[..., 4]))
    w = np.cos(0.5 * np.pi * np.clip(s, 0.0, 1.0)) ** 2
    return np.where((t < b[..., 1]) | (t >= b[..., 4]), w, 0.0)


class AnalyticProjector:
    """Exact ``project(P) -> (foot, outward normal)`` onto the analytic blade surface."""

    def __init__(self, blade: SampleBlade, h: np.ndarray, t: np.ndarray):
        self.blade = blade
        self.h, self.t = np.asarray(h, float).ravel().copy(), np.asarray(t, float).ravel().copy()

    def __call__(self, P: np.ndarray):
        P = np.asarray(P, float)
        h, t = self.h.copy(), self.t.copy()
        eh, et = 1e-6, 1e-7
        for _ in range(30):
            S = self.blade.point(h, t)
            Sh = (self.blade.point(h + eh, t) - self.blade.point(h - eh, t)) / (2 * eh)
            St = (self.blade.point(h, t + et) - self.blade.point(h, t - et)) / (2 * et)
            e = P - S
            a11, a12, a22 = (St * St).sum(1), (St * Sh).sum(1), (Sh * Sh).sum(1)
            b1, b2 = (St * e).sum(1), (Sh * e).sum(1)
            det = a11 * a22 - a12 * a12
            dt, dh = (a22 * b1 - a12 * b2) / det, (a11 * b2 - a12 * b1) / det
            t, h = np.mod(t + dt, 1.0), h + dh
            if max(np.abs(dt).max() * 100, np.abs(dh).max() * 100) < 1e-13:
                break
        self.h, self.t = h, t
        return self.blade.point(h, t), self.blade.normal(h, t)
