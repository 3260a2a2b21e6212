# SPDX-License-Identifier: LGPL-2.1-or-later
"""Feature points (seed 002 §2.2.1): an estimate of |Gaussian curvature| at each point, and the
10 % of points with the largest, which the initial mesh refines towards.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

__all__ = ["gaussian_curvature", "feature_mask"]


def gaussian_curvature(uv: np.ndarray, xyz: np.ndarray, k: int = 16) -> np.ndarray:
    """|K| estimate at each point from a local quadratic fit x(u,v) over its k nearest
    parameter neighbours: K = (LN - M²)/(EG - F²) of the fitted patch.

    Seed 002 §2.2.1 takes principal curvatures from the triangle mesh (Rusinkiewicz 2004);
    this is a different, standard estimator with the same purpose (ranking points).
    """
    m = len(uv)
    k = min(k, m)
    tree = cKDTree(uv)
    _, nb = tree.query(uv, k=k)
    d = uv[nb] - uv[:, None, :]                            # (m, k, 2)
    h = np.maximum(np.abs(d).max(axis=(1, 2)), 1e-12)[:, None]
    du, dv = d[..., 0] / h, d[..., 1] / h
    D = np.stack([np.ones_like(du), du, dv, 0.5 * du * du, du * dv, 0.5 * dv * dv], axis=-1)
    X = xyz[nb] - xyz[:, None, :]
    G = np.einsum("mki,mkj->mij", D, D) + 1e-9 * np.eye(6)
    R = np.einsum("mki,mkc->mic", D, X)
    C = np.linalg.solve(G, R)                              # (m, 6, 3)
    Su, Sv = C[:, 1] / h, C[:, 2] / h
    Suu, Suv, Svv = C[:, 3] / h ** 2, C[:, 4] / h ** 2, C[:, 5] / h ** 2
    n = np.cross(Su, Sv)
    nn = np.linalg.norm(n, axis=1)
    n = n / np.maximum(nn, 1e-300)[:, None]
    E, F, Gm = (Su * Su).sum(1), (Su * Sv).sum(1), (Sv * Sv).sum(1)
    L, M, N = (Suu * n).sum(1), (Suv * n).sum(1), (Svv * n).sum(1)
    den = E * Gm - F * F
    K = np.where(den > 1e-300, (L * N - M * M) / np.where(den > 1e-300, den, 1.0), 0.0)
    return np.abs(K)


def feature_mask(uv: np.ndarray, xyz: np.ndarray, fraction: float = 0.10) -> np.ndarray:
    """The ``fraction`` (seed 002: 10 %) of points with the largest |Gaussian curvature|."""
    K = gaussian_curvature(uv, xyz)
    n = int(round(fraction * len(K)))
    mask = np.zeros(len(K), bool)
    if n > 0:
        mask[np.argsort(-K, kind="stable")[:n]] = True
    return mask
