# SPDX-License-Identifier: LGPL-2.1-or-later
"""Shared B-spline test surfaces (core types only) and the FreeCAD import for tests/test_fc_*.py.

FreeCAD tests skip only if :func:`bladerecon.fc.freecad_env.import_freecad` cannot find
FreeCAD at all; on a machine with FreeCAD installed they must run.
"""
from __future__ import annotations

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.spline import BSplineSurface


def require_freecad():
    """(FreeCAD, Part), or skip the module when FreeCAD is not installed."""
    from bladerecon.fc.freecad_env import import_freecad

    try:
        return import_freecad()
    except BladeReconError as err:
        pytest.skip(f"FreeCAD not available: {err}", allow_module_level=True)


def periodic_knots(n_poles: int, rng: np.random.Generator, double_at: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Non-uniform distinct knots on [0, 1] and mults for a periodic spline with ``n_poles`` poles.

    ``double_at``: give that interior knot multiplicity 2 (one distinct knot fewer).
    """
    n_distinct = n_poles + 1 - (1 if double_at is not None else 0)
    steps = rng.uniform(0.5, 1.5, n_distinct - 1)
    knots = np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()
    mults = np.ones(n_distinct, dtype=int)
    if double_at is not None:
        mults[double_at] = 2
    assert mults[:-1].sum() == n_poles
    return knots, mults


def clamped_knots(n_poles: int, degree: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Non-uniform clamped knots on [0, 1] (distinct values + mults)."""
    n_inner = n_poles - degree - 1
    inner = np.sort(rng.uniform(0.1, 0.9, n_inner))
    knots = np.concatenate([[0.0], inner, [1.0]])
    mults = np.concatenate([[degree + 1], np.ones(n_inner, dtype=int), [degree + 1]])
    return knots, mults


def section_poles(n: int, rng: np.random.Generator, a: float = 30.0, b: float = 8.0, noise: float = 0.3) -> np.ndarray:
    """Poles (n, 2) around an ellipse-ish closed blade section (mm), counter-clockwise."""
    t = np.linspace(0, 2 * np.pi, n, endpoint=False) + rng.uniform(-0.02, 0.02, n)
    r = 1 + noise * 0.05 * rng.standard_normal(n)
    return np.column_stack([a * r * np.cos(t), b * r * np.sin(t)])


def blade_surface(seed: int = 0, n_u: int = 40, twist: float = 0.3, double_knot: bool = True) -> BSplineSurface:
    """Periodic cubic in u (``n_u`` poles, non-uniform knots), clamped cubic in v (6 poles).

    Sections are twisted and shifted along z so the surface is no simple extrusion.
    """
    rng = np.random.default_rng(seed)
    u_knots, u_mults = periodic_knots(n_u, rng, double_at=n_u // 3 if double_knot else None)
    v_knots, v_mults = np.array([0.0, 0.27, 0.61, 1.0]), np.array([4, 1, 1, 4])
    base = section_poles(n_u, rng)
    poles = np.zeros((n_u, 6, 3))
    for j in range(6):
        angle = twist * j / 5
        rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
        poles[:, j, :2] = base @ rot.T * (1 - 0.05 * j) + [0.5 * j, 0.2 * j]
        poles[:, j, 2] = 18.0 * j + 0.3 * rng.standard_normal(n_u)
    return BSplineSurface(poles, u_knots, u_mults, v_knots, v_mults, 3, 3, True, False)


def clamped_surface(seed: int = 1) -> BSplineSurface:
    """Clamped x clamped: cubic in u (12 poles), quadratic in v (5 poles), a wavy sheet."""
    rng = np.random.default_rng(seed)
    u_knots, u_mults = clamped_knots(12, 3, rng)
    v_knots, v_mults = clamped_knots(5, 2, rng)
    x, y = np.meshgrid(np.linspace(0, 110, 12), np.linspace(0, 40, 5), indexing="ij")
    z = 5 * np.sin(x / 20) * np.cos(y / 15) + rng.normal(0, 0.5, x.shape)
    poles = np.stack([x, y, z], axis=-1)
    return BSplineSurface(poles, u_knots, u_mults, v_knots, v_mults, 3, 2, False, False)


def tapered_tube(seed: int = 2, n_u: int = 24, z: tuple = (0.0, 8.0, 20.0, 41.0, 55.0, 70.0),
                 scale: tuple = (1.0, 0.97, 0.9, 0.85, 0.8, 0.76)) -> BSplineSurface:
    """Closed section C(u) scaled by s(v) along a straight axis: S = (s(v) C(u), z(v)).

    Both end sections lie exactly in planes z = z[0] and z = z[-1].
    """
    rng = np.random.default_rng(seed)
    u_knots, u_mults = periodic_knots(n_u, rng)
    base = section_poles(n_u, rng, a=25.0, b=10.0)
    v_knots, v_mults = np.array([0.0, 0.4, 0.7, 1.0]), np.array([4, 1, 1, 4])
    poles = np.zeros((n_u, len(z), 3))
    for j, (zj, sj) in enumerate(zip(z, scale)):
        poles[:, j, :2] = sj * base
        poles[:, j, 2] = zj
    return BSplineSurface(poles, u_knots, u_mults, v_knots, v_mults, 3, 3, True, False)
