# SPDX-License-Identifier: LGPL-2.1-or-later
"""Global tolerances in one place (millimetres unless stated)."""
from __future__ import annotations

__all__ = ["POINT_TOL", "PARAM_TOL", "NEWTON_MAX_ITER", "PLANAR_TOL"]

POINT_TOL = 1e-9        # two points closer than this are the same point (mm)
PARAM_TOL = 1e-12       # parametric tolerance on [0, 1] parameters
NEWTON_MAX_ITER = 30    # cap for vectorised Newton projections
PLANAR_TOL = 0.01       # an end section is planar if all points lie within this of a plane (mm)
