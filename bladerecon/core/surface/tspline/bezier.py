# SPDX-License-Identifier: LGPL-2.1-or-later
"""Bézier extraction: the bicubic Bézier elements of a fitted T-spline and their 4x4 control
points (:func:`bezier_patches`), z-map patches in 3D, and the patches' evaluation.

Bézier extraction: the 4x4 Bernstein control points of every Bézier element — a T-mesh
face cut by any blending-function knot line that crosses it, so that every blending
function is one polynomial on it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.surface.tspline.basis import _BERN_INV, _BERN_T, _bernstein, bspline_basis_1d
from bladerecon.core.surface.tspline.fitting import TSplineFit

__all__ = ["BezierPatch", "bezier_elements", "bezier_patches", "zmap_patches", "evaluate_patches"]


@dataclass(frozen=True)
class BezierPatch:
    """One bicubic Bézier element: parameter box [u0,u1]×[v0,v1] and 4x4 control points."""

    box: tuple[float, float, float, float]
    poles: np.ndarray                  # (4, 4, d), index [i along u, j along v]
    face: int                          # the T-mesh face it lies in


def bezier_elements(fit: TSplineFit) -> list[tuple[int, float, float, float, float]]:
    """Bézier elements of the reduced domain: each T-mesh face, cut by every knot line of a
    blending function whose support covers part of the face (so every blending function is
    a single bicubic polynomial on every element)."""
    out = []
    ku, kv = fit.knots_u, fit.knots_v
    seam_v = np.empty(0)
    if fit.seam != "open":
        # closed seam: the elements along u = 0 and u = 1 are cut at the same v values so
        # their edges coincide and the sewn shell closes around the profile
        first = bezier_elements(TSplineFit(**{**fit.__dict__, "seam": "open"}))
        seam_v = np.unique([[e[3], e[4]] for e in first if e[1] == 0 or e[2] == 1])
    for k in fit.mesh.reduced_faces():
        a, b, c, d = fit.mesh.faces[k]
        act = (ku[:, 0] < b) & (ku[:, 4] > a) & (kv[:, 0] < d) & (kv[:, 4] > c)
        us = np.unique(np.concatenate([[a, b], ku[act].ravel()]))
        vs = np.unique(np.concatenate([[c, d], kv[act].ravel()] + ([seam_v] if a == 0 or b == 1 else [])))
        us = us[(us >= a) & (us <= b)]
        vs = vs[(vs >= c) & (vs <= d)]
        for i in range(len(us) - 1):
            for j in range(len(vs) - 1):
                out.append((int(k), us[i], us[i + 1], vs[j], vs[j + 1]))
    return out


def bezier_patches(fit: TSplineFit) -> list[BezierPatch]:
    """Bézier extraction: on element [a,b]×[c,d] each active B_i = N_u(u) N_v(v) is a
    product of cubics; their Bernstein coefficients (from 4 interior samples, exact up to
    rounding) give the element's control points Σ_i P_i c_u,i ⊗ c_v,i."""
    ku, kv, P = fit.knots_u, fit.knots_v, fit.poles
    patches = []
    for k, a, b, c, d in bezier_elements(fit):
        act = np.flatnonzero((ku[:, 0] < b) & (ku[:, 4] > a) & (kv[:, 0] < d) & (kv[:, 4] > c))
        su = a + (b - a) * _BERN_T
        sv = c + (d - c) * _BERN_T
        r = len(act)
        nu = bspline_basis_1d(np.repeat(ku[act], 4, axis=0), np.tile(su, r)).reshape(r, 4)
        nv = bspline_basis_1d(np.repeat(kv[act], 4, axis=0), np.tile(sv, r)).reshape(r, 4)
        cu = nu @ _BERN_INV.T                                        # Bernstein coefficients
        cv = nv @ _BERN_INV.T
        poles = np.einsum("ri,rj,rd->ijd", cu, cv, P[act])
        patches.append(BezierPatch((a, b, c, d), poles, k))
    return patches


def zmap_patches(patches: list[BezierPatch], origin: np.ndarray, scale: np.ndarray) -> list[BezierPatch]:
    """3D control points of z-map patches: x, y are affine in (u, v) (x = origin + scale u),
    so their Bernstein coefficients are the box's thirds; z is the fitted value."""
    out = []
    third = np.arange(4) / 3.0
    for p in patches:
        a, b, c, d = p.box
        x = origin[0] + scale[0] * (a + (b - a) * third)
        y = origin[1] + scale[1] * (c + (d - c) * third)
        X, Y = np.meshgrid(x, y, indexing="ij")
        out.append(BezierPatch(p.box, np.stack([X, Y, p.poles[..., 0]], axis=-1), p.face))
    return out


def evaluate_patches(patches: list[BezierPatch], uv: np.ndarray) -> np.ndarray:
    """Evaluate the Bézier patches (de Casteljau via Bernstein sums) at parameters in [0,1]²."""
    uv = np.atleast_2d(np.asarray(uv, float))
    boxes = np.array([p.box for p in patches])
    out = np.full((len(uv), patches[0].poles.shape[2]), np.nan)
    for n, p in enumerate(patches):
        a, b, c, d = p.box
        inside = (uv[:, 0] >= a) & (uv[:, 0] <= b) & (uv[:, 1] >= c) & (uv[:, 1] <= d) & np.isnan(out[:, 0])
        if inside.any():
            bu = _bernstein((uv[inside, 0] - a) / (b - a))
            bv = _bernstein((uv[inside, 1] - c) / (d - c))
            out[inside] = np.einsum("mi,mj,ijd->md", bu, bv, p.poles)
    del boxes
    return out
