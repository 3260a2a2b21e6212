# SPDX-License-Identifier: LGPL-2.1-or-later
"""The measured surface where the blade is undamaged, the adapted nominal where it is not.

Units: mm, 1/mm. Issue 18 §4.

* **Measured correction** ``e(u, v)`` (mm, along the outward normal): the undamaged points'
  residuals from the adapted nominal, fitted by a tensor-product cubic B-spline in the
  nominal's (u, v) (periodic in u) with a second-difference penalty (P-spline; stiffness
  by generalised cross-validation). Where there is damage there are no data; the penalty
  carries e smoothly across.
* **Blend weight** ``b``: 1 farther than the band width from the damage, 0 in it, and
  ``6x^5 - 15x^4 + 10x^3`` (x = distance / band) between: C2 at both band boundaries, so the
  target ``adapted + b e n`` is curvature continuous where b is (the distance is measured
  on the damage grid, so b is smooth except on the distance's medial lines, where e·b is
  of the size of the correction, µm).
* The target is interpolated through a dense grid of target points
  (:func:`bladerecon.core.surface.skinning.interpolate_grid`, as the sample nominal).
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.interpolate import BSpline

from bladerecon.core.geometry.bspline import evaluate_surface
from bladerecon.core.geometry.spline import BSplineSurface

__all__ = ["Correction", "fit_correction", "blend_weight", "smootherstep"]


def smootherstep(x) -> np.ndarray:
    """0 at x <= 0, 1 at x >= 1, C2 (Perlin's quintic) between."""
    x = np.clip(np.asarray(x, float), 0.0, 1.0)
    return x * x * x * (x * (6 * x - 15) + 10)


class Correction:
    """e(u, v) (mm) as a periodic-in-u x clamped-in-v cubic tensor B-spline."""

    def __init__(self, u_dom, v_dom, n_u: int, n_v: int, coef: np.ndarray | None = None):
        self.u_dom, self.v_dom, self.n_u, self.n_v = u_dom, v_dom, n_u, n_v
        hu = (u_dom[1] - u_dom[0]) / n_u
        self.tu = u_dom[0] + hu * np.arange(-3, n_u + 4)
        self.tv = np.concatenate([[v_dom[0]] * 3, np.linspace(v_dom[0], v_dom[1], n_v - 2), [v_dom[1]] * 3])
        self.coef = np.zeros((n_u, n_v)) if coef is None else coef

    def basis(self, u, v) -> tuple[np.ndarray, np.ndarray]:
        period = self.u_dom[1] - self.u_dom[0]
        u = self.u_dom[0] + np.mod(np.asarray(u, float) - self.u_dom[0], period)
        Bu_ext = BSpline(self.tu, np.eye(self.n_u + 3), 3, extrapolate=False)(u)
        Bu = Bu_ext[:, :self.n_u].copy()
        Bu[:, :3] += Bu_ext[:, self.n_u:]          # periodic: the last 3 are the first 3 again
        v = np.clip(np.asarray(v, float), *self.v_dom)
        Bv = BSpline(self.tv, np.eye(self.n_v), 3, extrapolate=False)(v)
        return np.nan_to_num(Bu), np.nan_to_num(Bv)

    def __call__(self, u, v) -> np.ndarray:
        Bu, Bv = self.basis(u, v)
        return np.einsum("mi,ij,mj->m", Bu, self.coef, Bv)


def _penalty(n_u: int, n_v: int) -> np.ndarray:
    Du = np.roll(np.eye(n_u), -1, axis=1) - 2 * np.eye(n_u) + np.roll(np.eye(n_u), 1, axis=1)
    Dv = np.diff(np.eye(n_v), 2, axis=0)
    return np.kron(Du.T @ Du, np.eye(n_v)) + np.kron(np.eye(n_u), Dv.T @ Dv)


def fit_correction(u, v, r, w, u_dom, v_dom, n_u: int = 48, n_v: int = 12) -> Correction:
    """P-spline fit of residuals r (mm) at (u, v) with weights w >= 0; stiffness by GCV."""
    corr = Correction(u_dom, v_dom, n_u, n_v)
    keep = w > 0
    u, v, r, w = u[keep], v[keep], r[keep], w[keep]
    if len(r) < n_u * n_v:
        return corr
    N = np.zeros((n_u * n_v, n_u * n_v))
    rhs = np.zeros(n_u * n_v)
    for s in range(0, len(r), 8000):
        Bu, Bv = corr.basis(u[s:s + 8000], v[s:s + 8000])
        A = (Bu[:, :, None] * Bv[:, None, :]).reshape(len(Bu), -1)
        N += (A.T * w[s:s + 8000]) @ A
        rhs += (A.T * w[s:s + 8000]) @ r[s:s + 8000]
    K = _penalty(n_u, n_v)
    scale = np.trace(N) / np.trace(K)
    m = float(w.sum())
    rr = float((w * r * r).sum())
    best = None
    for lam in scale * np.logspace(-6, 1, 8):
        M = N + lam * K
        c = np.linalg.solve(M, rhs)
        rss = rr - 2 * c @ rhs + c @ N @ c
        edf = float(np.trace(np.linalg.solve(M, N)))
        gcv = m * max(rss, 0.0) / max(m - edf, 1.0) ** 2
        if best is None or gcv < best[0]:
            best = (gcv, c)
    corr.coef = best[1].reshape(n_u, n_v)
    return corr


def blend_weight(grid: dict, band: float, u, z) -> np.ndarray:
    """b at nominal parameter u and height z (mm): 0 in damage and the tip, 1 beyond ``band``
    (mm) from them, smootherstep between. Distances on the damage grid (cell sizes in mm)."""
    damaged = grid["damaged"]
    z_rows = grid["z_rows"]
    n_rows, n_u = damaged.shape
    ds = float(np.mean(grid["ds"])) if "ds" in grid else 1.0
    dz = float(np.mean(np.diff(z_rows))) if n_rows > 1 else 1.0
    if damaged.any():
        tiled = np.concatenate([damaged] * 3, axis=1)                 # periodic in u
        dist = ndimage.distance_transform_edt(~tiled, sampling=(dz, ds))[:, n_u:2 * n_u]
    else:
        dist = np.full(damaged.shape, np.inf)
    u_edges = grid["u_edges"]
    col = (np.asarray(u, float) - u_edges[0]) / (u_edges[-1] - u_edges[0]) * n_u - 0.5
    row = np.interp(np.asarray(z, float), z_rows, np.arange(n_rows))
    # the Euclidean distance has kinks (cell edges, medial lines): smoothed and read by a
    # cubic spline, so b has continuous second derivatives and the blend adds no curvature
    # spikes (a bilinear read gave 0.4 1/mm jumps from 0.2 µm moves at the TE)
    dist = ndimage.gaussian_filter(np.minimum(dist, 4.0 * band), sigma=2.0, mode=("nearest", "wrap"))
    d = ndimage.map_coordinates(dist, [row, np.mod(col, n_u)], order=3, mode="grid-wrap")
    d = np.minimum(d, np.maximum(grid["cut_mm"] - np.asarray(z, float), 0.0))
    return smootherstep(d / band)


def grid_points(surface: BSplineSurface, n_u: int, n_v: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(u, v) parameter grid and the surface points (n_v, n_u, 3) on it."""
    u = np.linspace(*surface.u_domain, n_u, endpoint=False)
    v = np.linspace(*surface.v_domain, n_v)
    uu, vv = np.meshgrid(u, v)
    return uu, vv, evaluate_surface(surface, uu.ravel(), vv.ravel()).reshape(n_v, n_u, 3)
