# SPDX-License-Identifier: LGPL-2.1-or-later
"""The parameters of the points: mapped onto [0,1]², points sharing one (u, v), and the model
length of a unit step in u and in v (for the longer-side rule of the cell splits).
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.errors import BladeReconError

__all__ = ["normalise_parameters", "duplicate_parameters", "parameter_lengths"]


def normalise_parameters(uv: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Map parameters affinely onto [0,1]² (per axis). Returns (uv01, origin, scale)."""
    uv = np.asarray(uv, float)
    lo, hi = uv.min(axis=0), uv.max(axis=0)
    span = hi - lo
    if np.any(span <= 0):
        axis = "u" if span[0] <= 0 else "v"
        raise BladeReconError(f"degenerate parameterisation: every point has the same {axis}; "
                              "the points do not span a surface")
    return np.clip((uv - lo) / span, 0.0, 1.0), lo, span


def duplicate_parameters(uv: np.ndarray, values: np.ndarray, tol: float = 1e-9) -> dict:
    """Points sharing one (u, v): how many, and how many with different values (> tol)
    — those no surface can fit; the fit then approximates their mean."""
    _, inverse, counts = np.unique(uv, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    dup = counts[inverse] > 1
    n_dup = int(dup.sum())
    conflicting = 0
    if n_dup:
        idx = np.flatnonzero(dup)
        groups = inverse[idx]
        vals = values[idx]
        mean = np.zeros((counts.size, values.shape[1]))
        np.add.at(mean, groups, vals)
        mean /= counts[:, None]
        spread = np.linalg.norm(vals - mean[groups], axis=1)
        conflicting = int(np.unique(groups[spread > tol]).size)
    return {"points_sharing_parameters": n_dup, "conflicting_groups": conflicting}


def parameter_lengths(uv: np.ndarray, xyz: np.ndarray, bands: int = 16, steps: int = 64) -> tuple[float, float]:
    """Model length (mm) of the unit step in u and in v: in each of ``bands`` bands of the
    other parameter, the points are averaged in ``steps`` bins of this one and the length
    of the polyline of the means is divided by its parameter span; the median over bands.
    For a z-map over (x, y) this is about the x and y extents."""
    out = []
    for col in (0, 1):
        band = np.minimum((uv[:, 1 - col] * bands).astype(int), bands - 1)
        step = np.minimum((uv[:, col] * steps).astype(int), steps - 1)
        key = band * steps + step
        count = np.bincount(key, minlength=bands * steps)
        mean_p = np.stack([np.bincount(key, xyz[:, c], bands * steps) for c in range(3)], axis=1)
        mean_t = np.bincount(key, uv[:, col], bands * steps)
        ok = count > 0
        mean_p[ok] /= count[ok, None]
        mean_t[ok] /= count[ok]
        lengths = []
        for b in range(bands):
            sl = slice(b * steps, (b + 1) * steps)
            sel = ok[sl]
            if sel.sum() < 2:
                continue
            p, t = mean_p[sl][sel], mean_t[sl][sel]
            if np.ptp(t) > 0:
                lengths.append(np.linalg.norm(np.diff(p, axis=0), axis=1).sum() / np.ptp(t))
        out.append(float(np.median(lengths)) if lengths else 1.0)
    return out[0], out[1]
