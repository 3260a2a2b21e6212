# SPDX-License-Identifier: LGPL-2.1-or-later
"""Fairness measures of section curves and surfaces as numbers (seed 004 §1 and §3 criteria).

* inflections per section — sign changes of the in-plane curvature (seed 004 criterion 3;
  a blade section designed from arcs and flanks has a few, near the edge joints);
* strain energy ``∫|C''|² ds`` (criterion 4), in 1/mm (arc-length parameter);
* curvature jump at the knots (criterion 1, G2): the largest |κ(k⁺) − κ(k⁻)|;
* Gaussian-curvature evenness of a surface (seed 004 surface criterion 4): the RMS of the
  change of K between neighbouring samples, relative to the RMS of K.

Units: mm, curvature 1/mm.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.geometry.bspline import curve_derivatives
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

__all__ = [
    "signed_curvature",
    "count_inflections",
    "strain_energy",
    "knot_curvature_jumps",
    "gaussian_evenness",
    "surface_knot_curvature_jumps",
    "curve_fairness",
    "surface_fairness",
]


def signed_curvature(curve: BSplineCurve, t: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """In-plane signed curvature ``(C' × C'')·a / |C'|³`` (1/mm); > 0 turning left about ``a``."""
    d = curve_derivatives(curve, t, 2)
    c1, c2 = d[:, 1], d[:, 2]
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    return (np.cross(c1, c2) @ a) / np.maximum(np.linalg.norm(c1, axis=1) ** 3, 1e-300)


def count_inflections(curve: BSplineCurve, axis: np.ndarray, samples: int = 4000,
                      eps: float | None = None, edge_fraction: float = 0.04) -> int:
    """Number of sign changes of the signed curvature around a closed section curve.

    Counted along the flanks: the round edges (the ends within ``edge_fraction`` of the
    chord, :func:`bladerecon.core.sections.fairing.edge_zones`) count as convex, because a cubic fit
    rings around the curvature jumps where edge circles meet flanks, and those wiggles are
    the data's sampling, not the blade's shape. A change is counted when κ crosses from
    below −eps to above +eps or back (hysteresis); ``eps`` defaults to 0.05 / chord (1/mm),
    i.e. a radius of 20 chords counts as straight. A designed section has a few, near the
    edge joints (seed 004 criterion 3); each bump on a flank adds two.
    """
    from bladerecon.core.sections.fairing import edge_zones

    lo, hi = curve.domain
    t = lo + (hi - lo) * np.arange(samples) / samples
    pts = curve_derivatives(curve, t, 0)[:, 0]
    k = signed_curvature(curve, t, axis)
    edge = edge_zones(pts, edge_fraction)
    chord = float(np.ptp((pts - pts.mean(axis=0)) @ np.linalg.svd(pts - pts.mean(axis=0), full_matrices=False)[2][0]))
    eps = 0.05 / max(chord, 1e-300) if eps is None else eps
    if edge.any():
        k = np.where(edge, np.sign(np.median(k[edge])) * (2 * eps + 1.0), k)
    s = np.where(k > eps, 1, np.where(k < -eps, -1, 0))
    s = s[s != 0]
    if s.size == 0:
        return 0
    changes = np.count_nonzero(s != np.roll(s, 1)) if curve.periodic else np.count_nonzero(np.diff(s))
    return int(changes)


def strain_energy(curve: BSplineCurve, samples_per_span: int = 8) -> float:
    """``∫ κ² ds`` (1/mm) over the curve: the bending energy of seed 004 criterion 4.

    Gauss-Legendre on every knot span (``samples_per_span`` nodes), with ``ds = |C'| dt``.
    """
    gx, gw = np.polynomial.legendre.leggauss(samples_per_span)
    k = np.asarray(curve.knots, float)
    a, h = k[:-1], np.diff(k)
    live = h > 0
    a, h = a[live], h[live]
    t = (a[:, None] + 0.5 * h[:, None] * (gx[None, :] + 1.0)).ravel()
    w = (0.5 * h[:, None] * gw[None, :]).ravel()
    d = curve_derivatives(curve, t, 2)
    sp = np.linalg.norm(d[:, 1], axis=1)
    kap = np.linalg.norm(np.cross(d[:, 1], d[:, 2]), axis=1) / np.maximum(sp**3, 1e-300)
    return float(np.sum(kap**2 * sp * w))


def knot_curvature_jumps(curve: BSplineCurve) -> np.ndarray:
    """|κ(k⁺) − κ(k⁻)| (1/mm) at every interior knot (zero for a C² cubic with simple knots)."""
    k = np.asarray(curve.knots, float)
    inner = k[1:-1] if not curve.periodic else k[:-1]
    if inner.size == 0:
        return np.zeros(0)
    delta = 1e-9 * (k[-1] - k[0])      # one-sided limits, well inside the neighbouring spans
    lo, hi = curve.domain

    def kappa(t):
        d = curve_derivatives(curve, t, 2)
        return np.linalg.norm(np.cross(d[:, 1], d[:, 2]), axis=1) / np.maximum(
            np.linalg.norm(d[:, 1], axis=1) ** 3, 1e-300)

    plus = inner + delta
    minus = inner - delta
    if curve.periodic:
        minus = lo + np.mod(minus - lo, hi - lo)
    return np.abs(kappa(plus) - kappa(minus))


def gaussian_evenness(surface: BSplineSurface, n_u: int = 200, n_v: int = 40) -> dict:
    """Gaussian curvature K on an (n_u, n_v) parameter grid and how evenly it varies.

    Returns ``{"k_min", "k_max", "k_rms", "unevenness"}`` with unevenness = RMS of the
    differences of K between neighbouring grid samples divided by the RMS of K (0 for a
    constant K; grows with ripples). K in 1/mm².
    """
    from bladerecon.core.analysis.surface_analysis import surface_curvature

    u0, u1 = surface.u_domain
    v0, v1 = surface.v_domain
    u = u0 + (u1 - u0) * (np.arange(n_u) / n_u if surface.u_periodic else np.linspace(0, 1, n_u))
    v = np.linspace(v0, v1, n_v)
    U, V = np.meshgrid(u, v, indexing="ij")
    K = surface_curvature(surface, U.ravel(), V.ravel()).gaussian.reshape(n_u, n_v)
    du = np.diff(K, axis=0)
    dv = np.diff(K, axis=1)
    rms = float(np.sqrt(np.mean(K**2)))
    jump = float(np.sqrt(np.mean(np.concatenate([du.ravel(), dv.ravel()]) ** 2)))
    return {"k_min": float(K.min()), "k_max": float(K.max()), "k_rms": rms,
            "unevenness": jump / max(rms, 1e-300)}


def surface_knot_curvature_jumps(surface: BSplineSurface, samples: int = 25) -> dict:
    """Largest jump of the principal curvatures (1/mm) across the interior knot lines
    (seed 004 surface criterion 3): ~0 for a C2 cubic with simple knots, finite for C1
    patches (double knots)."""
    from bladerecon.core.analysis.surface_analysis import surface_curvature

    out = {}
    for name, knots, periodic, other in (("u", surface.u_knots, surface.u_periodic, surface.v_domain),
                                         ("v", surface.v_knots, surface.v_periodic, surface.u_domain)):
        k = np.asarray(knots, float)
        inner = k[:-1] if periodic else k[1:-1]
        if inner.size == 0:
            out[name] = 0.0
            continue
        delta = 1e-8 * (k[-1] - k[0])
        lo, hi = other
        w = lo + (hi - lo) * (np.arange(samples) + 0.5) / samples
        K, W = np.meshgrid(inner, w, indexing="ij")
        K, W = K.ravel(), W.ravel()
        if name == "u":
            a = surface_curvature(surface, K + delta, W)
            b = surface_curvature(surface, np.where(K - delta < k[0], K - delta + (k[-1] - k[0]), K - delta), W)
        else:
            a = surface_curvature(surface, W, K + delta)
            b = surface_curvature(surface, W, K - delta)
        out[name] = float(max(np.abs(a.k1 - b.k1).max(), np.abs(a.k2 - b.k2).max()))
    return out


def curve_fairness(curve: BSplineCurve, axis: np.ndarray) -> dict:
    """Inflections, strain energy (1/mm) and the largest knot curvature jump (1/mm) of a curve."""
    jumps = knot_curvature_jumps(curve)
    return {"inflections": count_inflections(curve, axis), "strain_energy": strain_energy(curve),
            "max_curvature_jump": float(jumps.max()) if jumps.size else 0.0}


def surface_fairness(surface: BSplineSurface, span_axis: np.ndarray, n_sections: int = 11) -> dict:
    """Seed 004's surface criteria as numbers: inflections of the u mesh curves (iso-v
    sections), strain energy per mesh curve, Gaussian-curvature evenness."""
    from bladerecon.core.geometry.bspline import evaluate_surface
    from bladerecon.core.geometry.fitting import interpolate_closed_curve, interpolate_curve

    v0, v1 = surface.v_domain
    u0, u1 = surface.u_domain
    n = 600
    u = u0 + (u1 - u0) * (np.arange(n) / n if surface.u_periodic else np.linspace(0, 1, n))
    infl, energy = [], []
    for v in np.linspace(v0, v1, n_sections):
        pts = evaluate_surface(surface, u, np.full(n, v))
        c = interpolate_closed_curve(pts) if surface.u_periodic else interpolate_curve(pts)
        infl.append(count_inflections(c, span_axis))
        energy.append(strain_energy(c))
    jumps = surface_knot_curvature_jumps(surface)
    return {"mesh_inflections": infl, "mesh_strain_energy": energy, **gaussian_evenness(surface),
            "max_principal_curvature_jump_u": jumps["u"], "max_principal_curvature_jump_v": jumps["v"]}
