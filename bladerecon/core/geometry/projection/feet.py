# SPDX-License-Identifier: LGPL-2.1-or-later
"""The feet: the best feet found so far for each point (:class:`_Feet`), the focal ratio that
marks a point near a centre of curvature, and the largest curvature at a foot.

Near a centre of curvature (``_FOCAL``) a second root of seed 001 eq. 10 may lie right next
to the foot found; far off a tight edge (distance x curvature, :func:`_surface_turn`,
:func:`_curve_turn`) a closer one may lie round it (eq. 11).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.projection.evaluation import _dot

__all__ = ["_Feet", "_surface_turn", "_curve_turn", "_FOCAL", "_KEPT"]

_FOCAL = 0.5                # (1 - k1 d)(1 - k2 d) below this: near a centre of curvature
_KEPT = 3                   # derivatives kept per foot for all points (S, S_u, S_v / C, C', C'')


@dataclass
class _Feet:
    """The best feet found so far for m points: parameters (n_dirs, m), derivatives at the
    foot (n_ders, dim, m), converged, focal ratio, distance, the first start sample, and
    ``bend``: distance x largest curvature at the foot (near 1: P near a centre of
    curvature, where feet may lie side by side). Only the first ``_KEPT`` derivatives are kept for all points (S, S_u, S_v: what the
    normals need); second derivatives are evaluated again where they are needed."""

    params: np.ndarray
    ders: np.ndarray
    conv: np.ndarray
    focal: np.ndarray
    dist: np.ndarray
    k0: np.ndarray
    bend: np.ndarray

    def take(self, rows: np.ndarray) -> _Feet:
        return _Feet(self.params[:, rows], self.ders[:, :, rows], self.conv[rows], self.focal[rows],
                     self.dist[rows], self.k0[rows], self.bend[rows])

    def put(self, rows: np.ndarray | slice, other: _Feet) -> None:
        self.params[:, rows], self.ders[:, :, rows], self.conv[rows] = other.params, other.ders[:_KEPT], other.conv
        self.focal[rows], self.dist[rows], self.k0[rows], self.bend[rows] = other.focal, other.dist, other.k0, other.bend

    def update(self, rows: np.ndarray, run: tuple, dist: np.ndarray, turn, noise: float) -> None:
        """Take the feet of a later Newton run (``solve``'s output) for the points ``rows``
        where they are closer (``dist``)."""
        params, ders, conv, focal = run
        win = dist < self.dist[rows] - noise
        w = rows[win]
        for a, b in zip(self.params, params):
            a[w] = b[win]
        self.ders[:, :, w] = ders[:_KEPT, :, win]
        self.conv[w], self.focal[w], self.dist[w] = conv[win], focal[win], dist[win]
        self.bend[w] = dist[win] * turn(ders[:, :, win])[0]


def _surface_turn(D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Largest |principal curvature| (1/mm) at the feet, from the derivatives D (6, 3, m),
    and its direction as a parameter step (2, m) that moves the foot by 1 mm."""
    _, Su, Sv, Suu, Suv, Svv = D
    E, F, G = _dot(Su, Su), _dot(Su, Sv), _dot(Sv, Sv)
    n = np.cross(Su, Sv, axis=0)
    n /= np.maximum(np.sqrt(_dot(n, n)), 1e-300)
    L, M, N = _dot(Suu, n), _dot(Suv, n), _dot(Svv, n)
    det = np.maximum(E * G - F * F, 1e-300)
    K = (L * N - M * M) / det
    H = (E * N - 2.0 * F * M + G * L) / (2.0 * det)
    root = np.sqrt(np.maximum(H * H - K, 0.0))
    k = np.where(H >= 0, H + root, H - root)                  # the principal curvature of larger size
    # null vector of II - k I, in the better-conditioned of its two forms
    a1u, a1v = M - k * F, -(L - k * E)
    a2u, a2v = N - k * G, -(M - k * F)
    first = a1u * a1u + a1v * a1v >= a2u * a2u + a2v * a2v
    au, av = np.where(first, a1u, a2u), np.where(first, a1v, a2v)
    size = np.sqrt(np.maximum(au * au * E + 2.0 * au * av * F + av * av * G, 0.0))
    umbilic = size <= 1e-12 * np.sqrt(E * G)
    au = np.where(umbilic, 1.0 / np.sqrt(np.maximum(E, 1e-300)), au / np.where(umbilic, 1.0, size))
    av = np.where(umbilic, 0.0, av / np.where(umbilic, 1.0, size))
    return np.abs(k), np.stack([au, av])


def _curve_turn(D: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Curvature (1/mm) at the feet from [C, C', C''] (3, dim, m), and the parameter step
    (1, m) that moves the foot by 1 mm along the curve."""
    _, C1, C2 = D
    g = _dot(C1, C1)
    cross = np.maximum(g * _dot(C2, C2) - _dot(C1, C2) ** 2, 0.0)
    speed = np.sqrt(np.maximum(g, 1e-300))
    return np.sqrt(cross) / speed ** 3, (1.0 / speed)[None, :]
