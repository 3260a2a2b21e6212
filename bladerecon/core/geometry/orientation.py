# SPDX-License-Identifier: LGPL-2.1-or-later
"""Which side of a closed-in-u blade surface is outside: the sign of S_u x S_v relative to the
blade (moved here from :mod:`bladerecon.fc.compare`, which still exports it)."""
from __future__ import annotations

import numpy as np

from bladerecon.core.geometry.spline import BSplineSurface

__all__ = ["outward_sign"]


def outward_sign(surface: BSplineSurface) -> float:
    """+1 if S_u × S_v points out of a closed-in-u blade surface, −1 if it points in.

    Majority vote over a grid: the normal should point away from the centroid of its own
    iso-v section. (A blade section is not star-shaped, but most of it faces away.)
    """
    from bladerecon.core.geometry.bspline import surface_derivatives

    u = np.linspace(*surface.u_domain, 64, endpoint=False)
    v = np.linspace(*surface.v_domain, 9)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    d = surface_derivatives(surface, uu.ravel(), vv.ravel(), 1)
    p = d[:, 0, 0].reshape(64, 9, 3)
    n = np.cross(d[:, 1, 0], d[:, 0, 1]).reshape(64, 9, 3)
    away = np.einsum("ijk,ijk->ij", n, p - p.mean(axis=0, keepdims=True))
    return 1.0 if np.mean(away > 0) >= 0.5 else -1.0
