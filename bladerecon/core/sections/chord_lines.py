# SPDX-License-Identifier: LGPL-2.1-or-later
"""Where lines perpendicular to a profile's chord cross the profile (the chord-normal thickness
convention of blade drawings), shared by the planar gauges
(:mod:`bladerecon.core.sections.parameters`) and the m′–θ ones
(:mod:`bladerecon.core.sections.meridional_frame`). numpy only; mm in the profile's plane.
"""
from __future__ import annotations

import numpy as np

__all__ = ["chord_normal_crossings"]


def chord_normal_crossings(loop: np.ndarray, le: np.ndarray, u: np.ndarray, xs) -> list:
    """For each chordwise distance x of ``xs`` from ``le`` along the unit chord direction ``u``:
    ``(y_low, y_high)``, the outermost crossings of the closed polygon ``loop`` (n, 2) with the
    line perpendicular to the chord there (signed distances from the chord line, towards
    ``(-u_y, u_x)``); None where the line misses the profile."""
    v = np.array([-u[1], u[0]])
    X, Y = (loop - le) @ u, (loop - le) @ v
    X2, Y2 = np.roll(X, -1), np.roll(Y, -1)
    out = []
    for x in xs:
        m = (X - x) * (X2 - x) <= 0
        m &= X != X2
        if m.sum() < 2:
            out.append(None)
            continue
        y = Y[m] + (x - X[m]) * (Y2[m] - Y[m]) / (X2[m] - X[m])
        out.append((float(y.min()), float(y.max())))
    return out
