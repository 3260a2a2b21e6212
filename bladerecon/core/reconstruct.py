# SPDX-License-Identifier: LGPL-2.1-or-later
"""The reconstruction job: ordered sections in, one periodic × clamped cubic B-spline surface out.

points → sections (``sections.build_sections``) → section curves (``section_curves``) →
surface (``surface``) → fit statistics. Everything here is numpy/scipy; the CLI and the
workbench call :func:`reconstruct` and convert the result with ``bladerecon.fc``.
Units: mm.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.surface.section_curves import (
    MethodChoice,
    SectionCurve,
    choose_method,
    fit_section_approximate,
    fit_section_interpolate,
    merge_groups,
    repeated_measurements,
)
from bladerecon.core.geometry.spline import BSplineSurface
from bladerecon.core.surface.skinning import (
    AnchoredSection,
    anchor_section,
    common_parameter,
    fit_compatible_sections,
    s_to_t,
    skin_surface,
    span_parameters,
    t_to_s,
)
from bladerecon.core.geometry.bspline import evaluate_curve

__all__ = ["Reconstruction", "reconstruct", "first_point_edge_hint", "METHODS", "DEFAULT_REFIT_TOL"]

METHODS = ("auto", "interpolate", "approximate")
#: how closely the compatible (common-knot) section curves reproduce the fitted ones, mm
DEFAULT_REFIT_TOL = 0.0003


@dataclass(frozen=True)
class Reconstruction:
    surface: BSplineSurface
    choice: MethodChoice
    tolerance: float | None              # per-point tolerance used by the smoothing fit (mm)
    anchored: tuple[AnchoredSection, ...]
    s_te: float
    v_params: np.ndarray                 # span parameter of each section
    refit_error: float                   # compatible curves vs section curves, max (mm)
    point_u: np.ndarray                  # (N,) start parameters of the measured points on the surface
    point_v: np.ndarray
    section_residual: np.ndarray         # (N,) distance of each point to its section curve (mm)
    seconds: dict = field(default_factory=dict)
    added_points: int | None = None      # points inserted by the angle pairing (seed 000 §2.3)


def _ungroup(sc: SectionCurve, points: np.ndarray, index: np.ndarray) -> SectionCurve:
    """The section curve fitted to merged points, with a foot parameter and a distance for
    every measured point (the foot of its group's mean)."""
    t = np.asarray(sc.t_points)[index]
    return SectionCurve(sc.index, sc.curve, t, np.linalg.norm(evaluate_curve(sc.curve, t) - points, axis=1))


def _fit_sections(pts: list[np.ndarray], choice: MethodChoice, tolerance: float | None) -> list[SectionCurve]:
    if choice.method == "interpolate":
        return [fit_section_interpolate(k, p) for k, p in enumerate(pts)]
    sigma = max(choice.noise_mm, 1e-6)
    if tolerance is None:
        # noise-consistent: no point beyond 5 sigma, no span whose RMS exceeds the noise's
        tol = 5.0 * sigma * np.sqrt(2.0)
        rms = 1.3 * sigma * np.sqrt(2.0)
    else:
        tol, rms = 0.7 * tolerance, None
    return [fit_section_approximate(k, p, tol, rms_target=rms) for k, p in enumerate(pts)]


def first_point_edge_hint(points: np.ndarray) -> np.ndarray | None:
    """The first point, if it sits at one end of the section (within 3 % of its extent).

    Section tables (NASA, seed 000 plans) and most CMM plans start at the leading edge;
    when the data says so, that end is the LE. Otherwise None: the blunter edge is taken.
    """
    p = np.asarray(points, float)
    c = p - p.mean(axis=0)
    axis = np.linalg.svd(c, full_matrices=False)[2][0]
    x = c @ axis
    extent = np.ptp(x)
    if min(abs(x[0] - x.min()), abs(x.max() - x[0])) <= 0.03 * extent:
        return p[0]
    return None


def start_upstream(section_points: list[np.ndarray], flow: np.ndarray) -> list[np.ndarray]:
    """Each closed loop rolled to start at its most upstream point (least along ``flow``, the
    direction the fluid travels): that end is the LE for ``first_point_is_measured`` (issue 24)."""
    f = np.asarray(flow, float)
    return [np.roll(p, -int(np.argmin(np.asarray(p, float) @ f)), axis=0) for p in section_points]


def reconstruct(section_points: list[np.ndarray], span_axis: np.ndarray, method: str = "auto",
                tolerance: float | None = None, refit_tol: float | None = None,
                first_point_is_measured: bool = True) -> Reconstruction:
    """Reconstruct the blade surface from ordered, consistently oriented closed sections.

    ``section_points``: one (n_k, 3) array per section, hub to tip, each ordered around the
    profile counter-clockwise about ``span_axis`` (as ``build_sections`` delivers them).
    ``method``: ``auto`` (chosen from spacing against noise, see
    :func:`~bladerecon.core.surface.section_curves.choose_method`), ``interpolate`` or
    ``approximate``; ``tolerance`` (mm) is the largest distance a measured point may have
    from the surface with ``approximate`` (fewest poles that keep it).
    ``first_point_is_measured``: the first section starts where the measurement started (not
    a computed order), so a start at an edge names that edge the LE
    (:func:`first_point_edge_hint`).
    """
    if method not in METHODS:
        raise BladeReconError(f"unknown method '{method}': use one of {', '.join(METHODS)}")
    if len(section_points) < 2:
        raise BladeReconError("a surface needs at least 2 sections")
    if tolerance is not None and not tolerance > 0:
        raise BladeReconError(f"--tolerance must be a positive distance in mm, got {tolerance}")
    t0 = time.perf_counter()
    measured = [np.asarray(p, float) for p in section_points]
    # a spot measured twice (points closer than the noise, a few of them): one point, their mean;
    # two points microns apart would decide the method and make an interpolation wiggle
    groups = repeated_measurements(measured)
    if groups is not None:
        section_points = [merge_groups(p, g) for p, g in zip(measured, groups)]
    choice = choose_method(section_points)
    if method != "auto":
        choice = MethodChoice(method, f"{method} requested", choice.noise_mm, choice.min_spacing_mm,
                              choice.tangent_noise)
    if groups is not None:
        merged = sum(len(g) - (g.max() + 1) for g in groups)
        choice = MethodChoice(choice.method, f"{merged} repeated measurement(s) of one spot averaged; "
                              + choice.reason, choice.noise_mm, choice.min_spacing_mm, choice.tangent_noise)
    if choice.method == "approximate" and tolerance is None and method == "approximate":
        tolerance = max(4.0 * choice.noise_mm * np.sqrt(2.0), 0.001)
    curves = _fit_sections(section_points, choice, tolerance)
    if groups is not None:      # back to every measured point: its group's foot, its own distance
        curves = [_ungroup(sc, p, np.unique(g, return_inverse=True)[1].ravel())
                  for sc, p, g in zip(curves, measured, groups)]
    t1 = time.perf_counter()

    anchored: list[AnchoredSection] = []
    hint = first_point_edge_hint(section_points[0]) if first_point_is_measured else None
    for sc in curves:
        a = anchor_section(sc, span_axis, le_hint=hint)
        anchored.append(a)
        hint = a.le
    s_te = common_parameter(anchored)
    if refit_tol is None:
        refit_tol = DEFAULT_REFIT_TOL if tolerance is None else max(DEFAULT_REFIT_TOL, 0.25 * tolerance)
    knots, mults, poles, refit_err = fit_compatible_sections(anchored, s_te, refit_tol)
    t2 = time.perf_counter()

    s_grid = np.linspace(0.0, 1.0, 256, endpoint=False)
    grid = np.stack([evaluate_curve(a.curve, s_to_t(a, s_grid, s_te)) for a in anchored])
    v = span_parameters(grid)
    surface = skin_surface(knots, mults, poles, v)
    pu = np.concatenate([t_to_s(a, sc.t_points, s_te) for a, sc in zip(anchored, curves)])
    pv = np.concatenate([np.full(sc.t_points.size, v[k]) for k, sc in enumerate(curves)])
    res = np.concatenate([sc.residual for sc in curves])
    t3 = time.perf_counter()
    return Reconstruction(surface, choice, tolerance, tuple(anchored), s_te, v, refit_err, pu, pv, res,
                          {"sections": t1 - t0, "compatible": t2 - t1, "skin": t3 - t2, "total": t3 - t0})
