# SPDX-License-Identifier: LGPL-2.1-or-later
"""The hand-off types between the core and FreeCAD: plain, frozen B-spline data.

Convention is OpenCASCADE's (``Part.BSplineCurve/Surface.buildFromPolesMultsKnots``) so
that the FreeCAD adapter is a one-to-one copy:

* ``knots`` are the *distinct* knot values, ``mults`` their multiplicities.
* clamped (non-periodic): ``sum(mults) == len(poles) + degree + 1``, end mults ``degree+1``.
* periodic: poles are *not* repeated, ``mults[0] == mults[-1]`` and
  ``sum(mults[:-1]) == len(poles)``; the parameter period is ``knots[-1] - knots[0]``.

Units: poles in millimetres. Weights are always 1 (non-rational).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["BSplineCurve", "BSplineSurface", "full_knot_vector"]


def full_knot_vector(knots: np.ndarray, mults: np.ndarray, degree: int, periodic: bool) -> np.ndarray:
    """Expanded knot vector t_0..t_{n+p} (The NURBS Book notation).

    For a periodic spline, the distinct knots are extended by ``degree`` knots on each side
    by periodicity (seed 000 eq. 7), so that the result is the knot vector of the equivalent
    "unwrapped" spline whose poles are the periodic poles followed by the first ``degree``
    poles again.
    """
    knots = np.asarray(knots, dtype=float)
    mults = np.asarray(mults, dtype=int)
    if not periodic:
        return np.repeat(knots, mults)
    period = knots[-1] - knots[0]
    core = np.repeat(knots[:-1], mults[:-1])          # one period: len == n_poles
    n = core.size
    # wrap: t_{n+j} = t_j + period ; need degree knots before and degree+1 after
    ext = np.concatenate([core[n - degree:] - period, core, core[: degree + 1] + period])
    return ext


@dataclass(frozen=True)
class BSplineCurve:
    """Non-rational B-spline curve in 3D (poles (n, 3), mm)."""

    poles: np.ndarray
    knots: np.ndarray
    mults: np.ndarray
    degree: int
    periodic: bool = False

    @property
    def n_poles(self) -> int:
        return int(self.poles.shape[0])

    @property
    def domain(self) -> tuple[float, float]:
        return float(self.knots[0]), float(self.knots[-1])

    def full_knots(self) -> np.ndarray:
        return full_knot_vector(self.knots, self.mults, self.degree, self.periodic)

    def unwrapped_poles(self) -> np.ndarray:
        """Poles of the equivalent non-periodic representation (periodic: first p repeated)."""
        if not self.periodic:
            return self.poles
        return np.concatenate([self.poles, self.poles[: self.degree]], axis=0)


@dataclass(frozen=True)
class BSplineSurface:
    """Non-rational tensor-product B-spline surface (poles (nu, nv, 3), mm).

    u runs around the blade section (periodic for a closed section), v runs along the span.
    """

    poles: np.ndarray
    u_knots: np.ndarray
    u_mults: np.ndarray
    v_knots: np.ndarray
    v_mults: np.ndarray
    u_degree: int
    v_degree: int
    u_periodic: bool = False
    v_periodic: bool = False

    @property
    def shape(self) -> tuple[int, int]:
        return int(self.poles.shape[0]), int(self.poles.shape[1])

    @property
    def u_domain(self) -> tuple[float, float]:
        return float(self.u_knots[0]), float(self.u_knots[-1])

    @property
    def v_domain(self) -> tuple[float, float]:
        return float(self.v_knots[0]), float(self.v_knots[-1])

    def full_u_knots(self) -> np.ndarray:
        return full_knot_vector(self.u_knots, self.u_mults, self.u_degree, self.u_periodic)

    def full_v_knots(self) -> np.ndarray:
        return full_knot_vector(self.v_knots, self.v_mults, self.v_degree, self.v_periodic)

    def unwrapped_poles(self) -> np.ndarray:
        p = self.poles
        if self.u_periodic:
            p = np.concatenate([p, p[: self.u_degree]], axis=0)
        if self.v_periodic:
            p = np.concatenate([p, p[:, : self.v_degree]], axis=1)
        return p
