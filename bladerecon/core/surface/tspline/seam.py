# SPDX-License-Identifier: LGPL-2.1-or-later
"""The closed seam for blades (our addition to seed 002): both u-ends of the T-mesh given the
same v lines, and the poles restricted to those that make S and ∂S/∂u equal at u = 0 and 1.

Closed seam (``fit_tspline(seam="closed-c1")``): u is periodic with period 1, but the T-mesh
is not a periodic T-mesh. :func:`mirror_seam` gives both u-ends the same v lines, and every
solve is over the null space of the seam equations S(0,v) = S(1,v), ∂S/∂u(0,v) = ∂S/∂u(1,v)
(:func:`seam_reduction`). Seam elements are cut at the same v values on both ends
(:func:`bezier_elements`), so the exported patches meet there.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from bladerecon.core.errors import BladeReconError
from bladerecon.core.surface.tspline.basis import _BERN_INV, _BERN_T, bspline_basis_1d
from bladerecon.core.surface.tspline.editing import _split, make_analysis_suitable
from bladerecon.core.surface.tspline.least_squares import _least_squares
from bladerecon.core.surface.tspline.tmesh import TMesh

__all__ = [
    "SEAMS", "mirror_seam", "seam_rows", "seam_reduction", "_seam_suitable", "_least_squares_closed",
]

SEAMS = ("open", "closed", "closed-c1")


def mirror_seam(faces: np.ndarray) -> np.ndarray:
    """Closed-seam blades: give the faces along u = 1 every horizontal line (v = const)
    that the faces along u = 0 have, and vice versa, so the two ends of the T-mesh see the
    same v knots. Without this the seam constraint (:func:`seam_reduction`) would leave
    only the v splines common to both ends near the seam, and refining one end alone
    could not lower the error there. Faces ``[u0,u1,v0,v1]`` over [-mu,1+mu]²."""
    while True:
        f = faces
        inner = (f[:, 0] >= 0) & (f[:, 1] <= 1) & (f[:, 2] >= 0) & (f[:, 3] <= 1)
        left = np.flatnonzero(inner & (f[:, 0] == 0))
        right = np.flatnonzero(inner & (f[:, 1] == 1))
        seen: dict[int, float] = {}
        for this, other in ((left, right), (right, left)):
            marks = np.unique(f[other][:, 2:4])
            for k in this:
                inside = marks[(marks > f[k, 2]) & (marks < f[k, 3])]
                if inside.size:
                    seen.setdefault(int(k), float(inside[0]))
        if not seen:
            return faces
        idx = np.array(list(seen))
        faces = _split(faces, idx, np.ones(len(idx), int), np.array([seen[k] for k in idx]))


def _seam_suitable(mesh: TMesh, max_candidates: int) -> tuple[TMesh, int]:
    """AST conversion alternated with :func:`mirror_seam` until both hold."""
    steps = 0
    for _ in range(50):
        mirrored = mirror_seam(mesh.faces)
        if len(mirrored) == len(mesh.faces) and steps:
            return mesh, steps
        mesh, s = make_analysis_suitable(TMesh(mirrored, mesh.mu), max_candidates)
        steps += s
        if len(mirror_seam(mesh.faces)) == len(mesh.faces):
            return mesh, steps
    raise BladeReconError("closing the T-mesh seam did not settle; use --seam open")


def seam_rows(ku: np.ndarray, kv: np.ndarray, c1: bool = True) -> np.ndarray:
    """Dense rows C (k, n) with C P = S(0,v_k) − S(1,v_k) (and, with ``c1``, the same for
    ∂S/∂u) for the blending functions ``ku``, ``kv``. The v_k are 4 points in each span
    between all v knots in [0,1] plus the knots, so C P = 0 makes the two u-ends equal
    identically: both sides are cubic in v on each span. ∂/∂u at an end is exact: every
    N_u is one cubic on [0, h] (h = the nearest positive u knot), whose Bernstein
    coefficients come from 4 samples; the end derivative is 3(c1 − c0)/h (NURBS Book eq. 1.9)."""
    br = np.unique(kv[(kv >= 0) & (kv <= 1)])
    vk = np.concatenate([br, (br[:-1, None] + np.diff(br)[:, None] * _BERN_T).ravel()])
    n, k = len(ku), len(vk)
    d0 = ku[ku > 1e-12]
    d1 = 1.0 - ku[ku < 1 - 1e-12]
    h0 = min(float(d0.min()) if d0.size else 1.0, 0.5)
    h1 = min(float(d1.min()) if d1.size else 1.0, 0.5)
    # u samples and their weights: value rows use u = 0 and u = 1; derivative rows use the
    # 4 Bernstein samples on [0, h0] and [1 - h1, 1]
    ends = [(np.array([0.0]), np.array([1.0]), np.array([1.0]), np.array([1.0]))]
    if c1:
        ends.append((_BERN_T * h0, 3.0 * (_BERN_INV[1] - _BERN_INV[0]) / h0,
                     1.0 - h1 + _BERN_T * h1, 3.0 * (_BERN_INV[3] - _BERN_INV[2]) / h1))
    near = np.flatnonzero(((ku[:, 0] < h0) & (ku[:, 4] > 0)) | ((ku[:, 0] < 1) & (ku[:, 4] > 1 - h1)))
    r = len(near)
    nv = bspline_basis_1d(np.repeat(kv[near], k, axis=0), np.tile(vk, r)).reshape(r, k)

    def nu_weighted(us, w):
        vals = bspline_basis_1d(np.repeat(ku[near], len(us), axis=0), np.tile(us, r)).reshape(r, len(us))
        return vals @ w                                              # (r,)

    rows = []
    for u0, w0, u1, w1 in ends:
        block = np.zeros((k, n))
        block[:, near] = ((nu_weighted(u0, w0) - nu_weighted(u1, w1))[:, None] * nv).T
        rows.append(block)
    return np.concatenate(rows)


def seam_reduction(ku: np.ndarray, kv: np.ndarray, c1: bool = True) -> sp.csc_matrix:
    """Sparse T (n, n') whose columns span the poles with :func:`seam_rows` C P = 0:
    identity on the poles C does not touch, an orthonormal null-space basis of C (SVD,
    relative threshold 1e-10) on those it does. P = T z closes the seam for every z."""
    C = seam_rows(ku, kv, c1)
    n = len(ku)
    J = np.flatnonzero(np.any(np.abs(C) > 0, axis=0))
    free = np.setdiff1d(np.arange(n), J)
    CJ = C[:, J]
    norm = np.linalg.norm(CJ, axis=1)
    CJ = CJ[norm > 0] / norm[norm > 0, None]
    _, sv, vt = np.linalg.svd(CJ, full_matrices=True)
    rank = int(np.sum(sv > 1e-10 * sv[0])) if sv.size else 0
    NJ = vt[rank:].T                                               # (|J|, |J| - rank)
    rows = np.concatenate([free, np.repeat(J, NJ.shape[1])])
    cols = np.concatenate([np.arange(len(free)), np.tile(len(free) + np.arange(NJ.shape[1]), len(J))])
    vals = np.concatenate([np.ones(len(free)), NJ.ravel()])
    keep = np.abs(vals) > 1e-15
    return sp.csc_matrix((vals[keep], (rows[keep], cols[keep])), shape=(n, len(free) + NJ.shape[1]))


def _least_squares_closed(A: sp.csc_matrix, rhs: np.ndarray, guess: np.ndarray, T: sp.csc_matrix,
                          ridge: float | None = None) -> np.ndarray:
    """:func:`_least_squares` over P = T z (seed 002 eq. 7 with the seam closed): solve for z
    with the ridge pulling T z towards the orthogonal projection of ``guess``; T is
    orthonormal column by column, so Tᵀ guess is that projection's coordinates."""
    z = _least_squares((A @ T).tocsc(), rhs, T.T @ guess, ridge)
    return T @ z
