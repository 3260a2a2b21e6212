# SPDX-License-Identifier: LGPL-2.1-or-later
"""The initial mesh (seed 002 §2.2.2-2.2.3), a tensor-product mesh, and the location of
parameter points in the faces of a mesh (:class:`_FaceLocator`).

Initial mesh (§2.2.2): split a cell across its longer side at the midpoint while it holds
more than N_d parameter points or more than N_f feature points (the 10 % of points with the
largest |Gaussian curvature|, §2.2.1).
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.surface.tspline.editing import add_strip, split_longer_side
from bladerecon.core.surface.tspline.tmesh import TMesh

__all__ = ["initial_mesh", "tensor_mesh", "_FaceLocator"]


class _FaceLocator:
    """Face of the reduced domain holding each parameter point (points in [0,1]²)."""

    def __init__(self, mesh: TMesh) -> None:
        rf = mesh.reduced_faces()
        f = mesh.faces[rf]
        self.U = np.unique(f[:, :2])
        self.V = np.unique(f[:, 2:])
        table = np.full((len(self.U) - 1, len(self.V) - 1), -1, int)
        iu0 = np.searchsorted(self.U, f[:, 0])
        iu1 = np.searchsorted(self.U, f[:, 1])
        iv0 = np.searchsorted(self.V, f[:, 2])
        iv1 = np.searchsorted(self.V, f[:, 3])
        for k in range(len(f)):
            table[iu0[k]:iu1[k], iv0[k]:iv1[k]] = rf[k]
        self.table = table

    def __call__(self, uv: np.ndarray) -> np.ndarray:
        iu = np.clip(np.searchsorted(self.U, uv[:, 0], side="right") - 1, 0, len(self.U) - 2)
        iv = np.clip(np.searchsorted(self.V, uv[:, 1], side="right") - 1, 0, len(self.V) - 2)
        return self.table[iu, iv]


def initial_mesh(uv: np.ndarray, features: np.ndarray, n_data: int, n_feature: int, mu: float = 0.05,
                 min_size: float = 1.0 / 1024, lengths: tuple[float, float] = (1.0, 1.0),
                 order: str = "longer-side") -> TMesh:
    """Seed 002 §2.2.2–2.2.3: split [0,1]² cells across their longer side at the midpoint
    while a cell holds > ``n_data`` points or > ``n_feature`` feature points (cells are not
    split below ``min_size``), then add the strip of width ``mu``."""
    faces = np.array([[0.0, 1.0, 0.0, 1.0]])
    while True:
        mesh = TMesh(add_strip(faces, mu), mu)
        loc = _FaceLocator(mesh)(uv)
        nd = np.bincount(loc, minlength=len(mesh.faces))
        nf = np.bincount(loc[features], minlength=len(mesh.faces))
        inner_idx = np.arange(len(faces))  # inner faces come first in add_strip
        f = faces
        big = np.maximum(f[:, 1] - f[:, 0], f[:, 3] - f[:, 2]) > min_size
        split = inner_idx[((nd[inner_idx] > n_data) | (nf[inner_idx] > n_feature)) & big]
        if len(split) == 0:
            return TMesh(add_strip(faces, mu), mu)
        new = split_longer_side(faces, split, uv, loc, lengths, order=order)
        if len(new) == len(faces):      # no cell can be cut with data on both halves
            return TMesh(add_strip(faces, mu), mu)
        faces = new


def tensor_mesh(u_lines: np.ndarray, v_lines: np.ndarray, mu: float = 0.05) -> TMesh:
    """A tensor-product mesh (no T-junctions) with the given lines in [0,1], plus the strip."""
    u = np.concatenate([[-mu], np.asarray(u_lines, float), [1 + mu]])
    v = np.concatenate([[-mu], np.asarray(v_lines, float), [1 + mu]])
    U0, V0 = np.meshgrid(u[:-1], v[:-1], indexing="ij")
    U1, V1 = np.meshgrid(u[1:], v[1:], indexing="ij")
    return TMesh(np.column_stack([U0.ravel(), U1.ravel(), V0.ravel(), V1.ravel()]), mu)
