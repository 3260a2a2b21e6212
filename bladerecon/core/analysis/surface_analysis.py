# SPDX-License-Identifier: LGPL-2.1-or-later
"""Surface analysis of a B-spline blade: curvatures, principal directions, combs, zebra (1/mm).

Issue 4 §3. All from the first and second fundamental forms at (u, v), vectorised over
points (do Carmo, *Differential Geometry of Curves and Surfaces* §3-3; NURBS Book §2.5
for the derivatives S_u, S_v, S_uu, S_uv, S_vv):

    E = S_u·S_u, F = S_u·S_v, G = S_v·S_v;   L = S_uu·n, M = S_uv·n, N = S_vv·n
    K = (LN - M^2) / (EG - F^2),   H = (EN - 2FM + GL) / (2 (EG - F^2))
    k1,2 = H ± sqrt(H^2 - K); principal direction a: (II - k I) a = 0, in 3D a_u S_u + a_v S_v.

Sign: curvatures are positive where the surface is convex seen from the side its normal
points to (a sphere of radius R with outward normal has K = 1/R^2, H = k1 = k2 = 1/R), so
with the outward normal a blade's leading edge is strongly positive. This is minus the
textbook sign of L, M, N. ``normal_sign=-1`` flips the normal S_u x S_v (use
``fc.compare.outward_sign``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.geometry.bspline import surface_derivatives
from bladerecon.core.geometry.spline import BSplineSurface

__all__ = ["Curvature", "curvature_from_derivatives", "surface_curvature", "section_curvature", "zebra"]


@dataclass(frozen=True)
class Curvature:
    """Curvatures (1/mm) at m surface points; directions are (m, 3) unit vectors."""

    gaussian: np.ndarray
    mean: np.ndarray
    k1: np.ndarray          # larger principal curvature
    k2: np.ndarray
    dir1: np.ndarray        # direction of k1 (tangent to the surface)
    dir2: np.ndarray
    normal: np.ndarray


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def curvature_from_derivatives(Su, Sv, Suu, Suv, Svv, normal_sign: float = 1.0) -> Curvature:
    """Gaussian, mean and principal curvatures and directions from the (m, 3) derivatives."""
    Su, Sv, Suu, Suv, Svv = (np.atleast_2d(np.asarray(a, dtype=float)) for a in (Su, Sv, Suu, Suv, Svv))
    n = normal_sign * np.cross(Su, Sv)
    n /= np.linalg.norm(n, axis=1)[:, None]
    E, F, G = _dot(Su, Su), _dot(Su, Sv), _dot(Sv, Sv)
    L, M, N = -_dot(Suu, n), -_dot(Suv, n), -_dot(Svv, n)     # convex positive
    det = E * G - F * F
    K = (L * N - M * M) / det
    H = (E * N - 2 * F * M + G * L) / (2 * det)
    root = np.sqrt(np.maximum(H * H - K, 0.0))
    k1, k2 = H + root, H - root
    # rounding in H² - K (~1e-16 H²) becomes ~1e-8 H under the square root: principal curvatures
    # equal to 6 digits are an umbilic, where the null vector below is only rounding noise
    equal = root <= 1e-6 * np.abs(H)

    def direction(k: np.ndarray) -> np.ndarray:
        # two forms of the null vector of II - k I; take the better-conditioned one
        a1 = np.column_stack([M - k * F, -(L - k * E)])
        a2 = np.column_stack([N - k * G, -(M - k * F)])
        a = np.where((np.linalg.norm(a1, axis=1) >= np.linalg.norm(a2, axis=1))[:, None], a1, a2)
        d = a[:, :1] * Su + a[:, 1:] * Sv
        # at an umbilic every direction is principal: take S_u (and its perpendicular); elsewhere
        # k1 != k2 and the better-conditioned form of the null vector is not zero
        d = np.where(equal[:, None], Su, d)
        return d / np.linalg.norm(d, axis=1)[:, None]

    d1 = direction(k1)
    d2 = np.cross(n, d1)
    return Curvature(K, H, k1, k2, d1, d2, n)


def surface_curvature(surface: BSplineSurface, u, v, normal_sign: float = 1.0) -> Curvature:
    """Curvatures (1/mm) of ``surface`` at parameters (u, v) (arrays of equal length)."""
    from bladerecon.core.geometry.projection import surface_derivatives_fast

    _, Su, Sv, Suu, Suv, Svv = surface_derivatives_fast(surface, u, v)
    return curvature_from_derivatives(Su, Sv, Suu, Suv, Svv, normal_sign)


def section_curvature(surface: BSplineSurface, v: float, n_points: int = 400,
                      normal_sign: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Curvature comb of the section (iso-v curve) at ``v``: (u, points, curvature, tooth direction).

    curvature = |C' x C''| / |C'|^3 (1/mm) of the curve C(u) = S(u, v), signed + where convex
    seen from the surface normal; the comb's teeth run along the unit surface normal
    (perpendicular to the curve), length proportional to the signed curvature.
    """
    u0, u1 = surface.u_domain
    u = np.linspace(u0, u1, n_points, endpoint=not surface.u_periodic)
    d = surface_derivatives(surface, u, np.full_like(u, v), 2)
    C1, C2 = d[:, 1, 0], d[:, 2, 0]
    n = normal_sign * np.cross(C1, d[:, 0, 1])
    n /= np.linalg.norm(n, axis=1)[:, None]
    kappa = np.linalg.norm(np.cross(C1, C2), axis=1) / np.linalg.norm(C1, axis=1) ** 3
    kappa = np.where(_dot(C2, n) > 0, -kappa, kappa)
    return u, d[:, 0, 0], kappa, n


def zebra(normals: np.ndarray, view=(0.0, 0.0, -1.0), stripe_axis=(0.0, 0.0, 1.0),
          stripes: int = 12, smooth: bool = False) -> np.ndarray:
    """Zebra intensity in [0, 1] per unit normal (m, 3): reflection of parallel light bands.

    The viewing ray ``view`` reflects off the surface, r = d - 2 (d·n) n; the light is an
    infinite cylinder of alternating black and white bands parallel to ``stripe_axis``
    around the part, so the band seen depends only on the angle of r about that axis:
    ``stripes`` white bands per turn. ``smooth`` gives 0.5 + 0.5 cos instead of 0/1, for
    anti-aliased images. A G1 break shows as a kink in the stripes, a G2 break as a jump
    in their width.
    """
    n = np.asarray(normals, dtype=float).reshape(-1, 3)
    d = np.asarray(view, float) / np.linalg.norm(view)
    a = np.asarray(stripe_axis, float) / np.linalg.norm(stripe_axis)
    r = d[None, :] - 2.0 * (n @ d)[:, None] * n
    e1 = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(a, e1)
    phase = np.cos(stripes * np.arctan2(r @ e2, r @ e1))
    return 0.5 + 0.5 * phase if smooth else (phase >= 0).astype(float)
