# SPDX-License-Identifier: LGPL-2.1-or-later
"""Points left out of a deviation on purpose, counted and reported apart (issue 25 §5).

A whole-blade scan holds the hub fillet and the tip cap; the nominal (or the surface rebuilt
from the airfoil span) does not. Their distances are not a shape error of the airfoil:
:func:`crop_points` leaves them out by a span range along an axis and/or by the nominal's
bounding box (grown by a margin), and says how many went where. Units: mm.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.errors import BladeReconError

__all__ = ["crop_points"]


def crop_points(points: np.ndarray, axis=None, span_range=None, box=None, margin: float = 1.0
                ) -> tuple[np.ndarray, dict]:
    """Mask of the points kept, and the counts left out.

    ``axis`` (3,) and ``span_range`` (lo, hi) mm: keep ``lo <= p·axis <= hi``. ``box``
    ((xmin, ymin, zmin), (xmax, ymax, zmax)) mm: keep points inside it grown by ``margin`` mm.
    """
    P = np.asarray(points, float)
    keep = np.ones(len(P), dtype=bool)
    info: dict = {"points_in": int(len(P))}
    if span_range is not None:
        a = np.asarray(axis, float)
        a = a / np.linalg.norm(a)
        lo, hi = map(float, span_range)
        if not lo < hi:
            raise BladeReconError(f"--span-range {lo:g}:{hi:g}: give A:B with A < B (mm)")
        h = P @ a
        below, above = h < lo, h > hi
        info["span_range_mm"] = [lo, hi]
        info["left_out_below"] = int(below.sum())
        info["left_out_above"] = int(above.sum())
        keep &= ~(below | above)
    if box is not None:
        lo, hi = np.asarray(box[0], float) - margin, np.asarray(box[1], float) + margin
        outside = np.any((P < lo) | (P > hi), axis=1) & keep
        info["nominal_box_margin_mm"] = float(margin)
        info["left_out_outside_nominal"] = int(outside.sum())
        keep &= ~outside
    info["points_kept"] = int(keep.sum())
    if not keep.any():
        raise BladeReconError("the crop leaves no point: check --span-range / --span-axis against the points")
    return keep, info
