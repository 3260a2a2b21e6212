# SPDX-License-Identifier: LGPL-2.1-or-later
"""Distance statistics: max / mean / std / rms / min of point-to-surface distances, as seed 000
Tables 1-2 report them (:func:`distance_stats`).
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.errors import BladeReconError

__all__ = ["distance_stats"]


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
