# SPDX-License-Identifier: LGPL-2.1-or-later
"""Adaptive ASTS fitting (seed 002 Fig. 2): :func:`fit_tspline` and its result
:class:`TSplineFit`, its limits, and the evaluation of a fitted T-spline.

Least squares for all poles (eqs. 5–8, sparse normal equations), then local refinement
(§2.5): split the cells holding a point with error > eps, convert to AST, re-solve only the
poles of new nodes and nodes whose knot vectors changed, over the points in their support
(eq. 10), until max error <= eps or a documented limit.

Values may have any dimension: a z-map fits z over (x, y) (one column); a blade fits
x, y, z over the (u, v) of the section reconstruction (three columns). Errors are the
Euclidean norm of S(u_j, v_j) - V_j (eq. 8): the vertical error for a z-map, a parametric
upper bound of the point-to-surface distance for a blade. Units: those of the values (mm).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.core.surface.tspline.basis import _PointIndex, basis_matrix
from bladerecon.core.surface.tspline.editing import CUT_ORDERS, make_analysis_suitable, split_longer_side
from bladerecon.core.surface.tspline.features import feature_mask
from bladerecon.core.surface.tspline.initial import _FaceLocator, initial_mesh
from bladerecon.core.surface.tspline.least_squares import _RIDGE, _least_squares
from bladerecon.core.surface.tspline.parameters import duplicate_parameters, parameter_lengths
from bladerecon.core.surface.tspline.seam import SEAMS, _least_squares_closed, _seam_suitable, seam_reduction
from bladerecon.core.surface.tspline.tmesh import TMesh, local_knots

__all__ = [
    "fit_tspline", "TSplineFit", "FitLimits", "evaluate", "partition_of_unity", "greville", "_nearest_data",
]


@dataclass(frozen=True)
class FitLimits:
    """When the refinement gives up (seed 002 §2.5 loops until max error <= eps)."""

    max_iterations: int = 40
    max_control_points: int = 6000
    min_cell: float = 1.0 / 2048       # cells are not split below this parameter size


@dataclass(frozen=True, eq=False)
class TSplineFit:
    """An AS T-spline S(u,v) = Σ P_i B_i(u,v) over [0,1]² and how the fit went."""

    mesh: TMesh
    nodes: np.ndarray
    knots_u: np.ndarray
    knots_v: np.ndarray
    poles: np.ndarray                   # (n, d)
    max_error: float
    mean_error: float
    refinements: int
    converged: bool
    stop_reason: str
    history: list = field(default_factory=list)
    seconds: float = 0.0
    ast_steps: int = 0
    duplicates: dict = field(default_factory=dict)
    seam: str = "open"                  # open / closed / closed-c1 in u (see fit_tspline)

    @property
    def n_control_points(self) -> int:
        return len(self.nodes)


def greville(ku: np.ndarray, kv: np.ndarray) -> np.ndarray:
    """Greville point (mean of the three middle knots) of each blending function, clipped to
    [0,1]²: where a pole sits on its surface, to second order (NURBS Book §9.2)."""
    return np.clip(np.column_stack([ku[:, 1:4].mean(axis=1), kv[:, 1:4].mean(axis=1)]), 0.0, 1.0)


def _nearest_data(uv: np.ndarray, values: np.ndarray):
    tree = cKDTree(uv)
    return lambda q: values[tree.query(q)[1]]


def fit_tspline(uv: np.ndarray, values: np.ndarray, eps: float, n_data: int | None = None,
                n_feature: int | None = None, xyz: np.ndarray | None = None, mu: float = 0.05,
                limits: FitLimits = FitLimits(), local: bool = True,
                max_candidates: int = 40, initial: TMesh | None = None,
                lengths: tuple[float, float] | None = None, prior=None, ridge: float | None = None,
                cut_order: str = "longer-side", seam: str = "open") -> TSplineFit:
    """Adaptive ASTS fitting (seed 002 Fig. 2): initial mesh → AST → least squares →
    [split cells with error > eps → AST → local least squares (eq. 10)]* .

    ``uv`` (m, 2) in [0,1]²; ``values`` (m, d); ``xyz`` (m, 3) the point positions used for
    the curvature features (default: ``values`` when d == 3). ``n_data``/``n_feature``: N_d,
    N_f of §2.2.2 (seed 002 does not state its values; defaults m/16 and m/80: no cell
    holds more than 1/16 of the points or 1/8 of the feature points).
    ``local=False`` re-solves all poles each step.
    ``prior``: a function (k, 2) parameters -> (k, d) values of a smooth reference surface;
    the tiny ridge of the solves pulls poles towards it at their Greville points, which only
    matters where the data leave poles free (between measured sections). Default: the
    nearest data point for the first solve, the current T-spline for refined poles.
    ``ridge``: weight of that pull relative to the mean diagonal of AᵀA (default 1e-10, or
    1e-4 with a ``prior``: then it also damps poles the data fix only weakly, e.g. on cells
    between two close sections).
    ``cut_order``: see :func:`_split_choice` (``longer-side`` or ``switch-side``).
    ``lengths``: model lengths of the u and v directions for the longer-side rule (default:
    estimated from ``xyz`` by :func:`parameter_lengths`).
    ``seam``: ``open`` (default), ``closed`` (S(0,v) = S(1,v) identically) or ``closed-c1``
    (also ∂S/∂u(0,v) = ∂S/∂u(1,v)), for u periodic with period 1 (a blade profile). Not a
    periodic T-mesh: the mesh keeps its mu strips in u, :func:`mirror_seam` gives both
    u-ends the same v lines, and every solve is global over the poles P = T z that
    satisfy the seam equations (:func:`seam_reduction`); eq. 10's local re-solve is not used.
    Stops at max error <= eps, or at a :class:`FitLimits` limit with ``converged=False``
    and the reason and the error reached.
    """
    t0 = time.perf_counter()
    uv = np.asarray(uv, float)
    values = np.asarray(values, float)
    if values.ndim == 1:
        values = values[:, None]
    m = len(uv)
    if m < 16:
        raise BladeReconError(f"a T-spline fit needs at least 16 points, got {m}")
    if not eps > 0:
        raise BladeReconError(f"--tolerance must be a positive distance, got {eps}")
    if cut_order not in CUT_ORDERS:
        raise BladeReconError(f"unknown cut order '{cut_order}': use one of {', '.join(CUT_ORDERS)}")
    if np.any(uv < -1e-12) or np.any(uv > 1 + 1e-12):
        raise BladeReconError("parameters must lie in [0,1]²; normalise them first")
    if seam not in SEAMS:
        raise BladeReconError(f"unknown seam '{seam}': use one of {', '.join(SEAMS)}")
    closed = seam != "open"
    c1 = seam == "closed-c1"
    if closed:
        local = False

    def suitable(mesh_):
        return _seam_suitable(mesh_, max_candidates) if closed else make_analysis_suitable(mesh_, max_candidates)

    def solve(A_, rhs_, guess_, ku_, kv_):
        if closed:
            return _least_squares_closed(A_, rhs_, guess_, seam_reduction(ku_, kv_, c1), ridge)
        return _least_squares(A_, rhs_, guess_, ridge)
    dups = duplicate_parameters(uv, values)
    if n_data is None:
        n_data = max(16, m // 16)
    if n_feature is None:
        n_feature = max(4, m // 80)
    if initial is None:
        if xyz is None:
            xyz = values if values.shape[1] == 3 else np.column_stack([uv, values[:, 0]])
        feat = feature_mask(uv, np.asarray(xyz, float))
    if lengths is None:
        lengths = parameter_lengths(uv, np.asarray(xyz, float)) if xyz is not None else (1.0, 1.0)
    if initial is None:
        mesh = initial_mesh(uv, feat, n_data, n_feature, mu, lengths=lengths, order=cut_order)
    else:
        mesh = initial
    mesh, ast_steps = suitable(mesh)
    index = _PointIndex(uv)
    cache: dict = {}
    nodes, ku, kv = local_knots(mesh)
    A = basis_matrix(uv, ku, kv, index, cache, nodes)
    if ridge is None:
        ridge = _RIDGE if prior is None else 1e-4
    nearest = _nearest_data(uv, values)
    poles = solve(A, values, (prior or nearest)(greville(ku, kv)), ku, kv)
    err = np.linalg.norm(A @ poles - values, axis=1)
    history = [{"control_points": len(nodes), "max": float(err.max()), "mean": float(err.mean()),
                "changed": len(nodes)}]
    refinements = 0
    reason = "max error <= tolerance"
    converged = bool(err.max() <= eps)
    while not converged:
        if refinements >= limits.max_iterations:
            reason = f"iteration limit ({limits.max_iterations}) reached"
            break
        loc = _FaceLocator(mesh)(uv)
        bad = np.unique(loc[err > eps])
        f = mesh.faces[bad]
        bad = bad[np.maximum(f[:, 1] - f[:, 0], f[:, 3] - f[:, 2]) > limits.min_cell]
        if len(bad) == 0:
            reason = f"cells holding points with error > tolerance are at the smallest size ({limits.min_cell:g})"
            break
        split_faces = split_longer_side(mesh.faces, bad, uv, loc, lengths, order=cut_order)
        if len(split_faces) == len(mesh.faces):
            # fall back to cuts that keep one data line per half (e.g. between two sections)
            split_faces = split_longer_side(mesh.faces, bad, uv, loc, lengths, min_lines=1, order=cut_order)
        if len(split_faces) == len(mesh.faces):
            reason = "no cell holding points with error > tolerance can be cut with data on both halves"
            break
        new_mesh, steps = suitable(TMesh(split_faces, mu))
        new_nodes, new_ku, new_kv = local_knots(new_mesh)
        if len(new_nodes) > limits.max_control_points:
            reason = f"control point limit ({limits.max_control_points}) would be exceeded ({len(new_nodes)})"
            break
        ast_steps += steps
        refinements += 1
        # unchanged blending function: same node and same local knot vectors
        old = {(tuple(p), tuple(a), tuple(b)): i for i, (p, a, b) in enumerate(zip(nodes, ku, kv))}
        keep_old = np.array([old.get((tuple(p), tuple(a), tuple(b)), -1)
                             for p, a, b in zip(new_nodes, new_ku, new_kv)])
        A = basis_matrix(uv, new_ku, new_kv, index, cache, new_nodes)
        changed = keep_old < 0
        new_poles = np.empty((len(new_nodes), values.shape[1]))
        new_poles[~changed] = poles[keep_old[~changed]]
        g = greville(new_ku[changed], new_kv[changed])
        guess = prior(g) if prior else basis_matrix(g, ku, kv) @ poles
        if local:
            # seed 002 eq. 10: P_r = (A_srᵀA_sr)⁻¹ A_srᵀ (V_s − A_s(n−r) P_(n−r))
            Ar = A[:, np.flatnonzero(changed)]
            rows = np.unique(Ar.indices)
            Ar = Ar[rows]
            Ak = A[rows][:, np.flatnonzero(~changed)]
            rhs = values[rows] - Ak @ new_poles[~changed]
            new_poles[changed] = _least_squares(Ar.tocsc(), rhs, guess, ridge)
        else:
            g = greville(new_ku, new_kv)
            new_poles = solve(A, values, prior(g) if prior else basis_matrix(g, ku, kv) @ poles, new_ku, new_kv)
        mesh, nodes, ku, kv, poles = new_mesh, new_nodes, new_ku, new_kv, new_poles
        alive = set(zip(map(tuple, nodes), map(tuple, ku), map(tuple, kv)))
        for key in [k for k in cache if k not in alive]:
            del cache[key]
        err = np.linalg.norm(A @ poles - values, axis=1)
        history.append({"control_points": len(nodes), "max": float(err.max()), "mean": float(err.mean()),
                        "changed": int(changed.sum())})
        converged = bool(err.max() <= eps)
    if not converged and reason == "max error <= tolerance":
        reason = "not converged"
    return TSplineFit(mesh, nodes, ku, kv, poles, float(err.max()), float(err.mean()), refinements,
                      converged, reason if converged else f"stopped: {reason}; max error {err.max():.4g}",
                      history, time.perf_counter() - t0, ast_steps, dups, seam)


def evaluate(fit: TSplineFit, uv: np.ndarray) -> np.ndarray:
    """S(u, v) = Σ P_i B_i(u, v) (seed 002 eq. 5) at parameters (k, 2) in [0,1]²."""
    uv = np.atleast_2d(np.asarray(uv, float))
    return basis_matrix(uv, fit.knots_u, fit.knots_v) @ fit.poles


def partition_of_unity(fit_or_mesh, uv: np.ndarray) -> np.ndarray:
    """Σ_i B_i(u, v) at the parameters (1 on the reduced domain of an AS T-mesh)."""
    mesh = fit_or_mesh.mesh if isinstance(fit_or_mesh, TSplineFit) else fit_or_mesh
    _, ku, kv = local_knots(mesh)
    return np.asarray(basis_matrix(np.atleast_2d(uv), ku, kv).sum(axis=1)).ravel()
