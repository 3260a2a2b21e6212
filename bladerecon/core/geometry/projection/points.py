# SPDX-License-Identifier: LGPL-2.1-or-later
"""The points to project: checks of their shape and coordinates and of start parameters, the
voxel order the search visits them in, and the rounding noise of their distances.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.projection.grid import _StartGrid

__all__ = ["_check_points", "_start_parameters", "_spatial_order", "_inverse", "_rounding_noise"]


def _check_points(points: np.ndarray, dim: int) -> np.ndarray:
    P = np.asarray(points, dtype=float)
    if P.ndim == 1 and P.size == dim:
        P = P[None, :]
    if P.ndim != 2 or P.shape[1] != dim:
        raise BladeReconError(f"points must be an (m, {dim}) array of coordinates in mm; got shape {P.shape}")
    flat = P.ravel()
    with np.errstate(over="ignore", invalid="ignore"):
        # one cheap pass: finite and small only when no coordinate is NaN or infinite and none
        # near where squared distances overflow (from ~1e154 mm the k-d tree found no neighbour)
        square = np.dot(flat, flat)
        if np.isfinite(square) and square <= _LARGEST * _LARGEST:
            return P
    bad = ~np.isfinite(P).all(axis=1)
    if bad.any():
        rows = np.flatnonzero(bad)
        raise BladeReconError(
            f"{rows.size} point(s) have NaN or infinite coordinates (first at row {rows[0]}): "
            "remove them before measuring distances"
        )
    rows = np.flatnonzero((np.abs(P) > _LARGEST).any(axis=1))
    if rows.size:
        raise BladeReconError(
            f"{rows.size} point(s) have coordinates beyond {_LARGEST:g} mm (first at row {rows[0]}): "
            "check the file's units and remove them before measuring distances"
        )
    return P


#: mm: farther coordinates are refused (their squared distances overflow with enough of them)
_LARGEST = 1e100


def _start_parameters(values: np.ndarray | None, m: int, name: str) -> np.ndarray | None:
    if values is None:
        return None
    a = np.asarray(values, dtype=float).ravel()
    if a.size != m:
        raise ValueError(f"{name} must hold one parameter per point ({m}); got {a.size}")
    return a


def _spatial_order(P: np.ndarray, grid: _StartGrid) -> np.ndarray:
    """A permutation that visits the points voxel by voxel (32 voxels along the longest
    side of the spline's box, points outside it in the voxels on its faces): neighbouring
    points then share k-d tree branches and patches, which makes the searches about a
    quarter faster than in scan or random order. The box is the k-d tree's (the points' own
    would cost two passes over them). The voxel index fits 15 bits, so numpy sorts it by
    radix (twice as fast as a 64-bit key)."""
    lo, hi = grid.tree.mins, grid.tree.maxes
    size = max(float((hi - lo).max()) / 31.999, 1e-300)
    key = np.clip((P - lo) * (1.0 / size), 0.0, 31.0).astype(np.int16)
    flat = key[:, 0].copy()
    for axis in range(1, P.shape[1]):
        flat *= 32
        flat += key[:, axis]
    return np.argsort(flat, kind="stable")


def _inverse(order: np.ndarray) -> np.ndarray:
    inverse = np.empty_like(order)
    inverse[order] = np.arange(order.size)
    return inverse


def _rounding_noise(scale: float, P: np.ndarray) -> float:
    """Distance differences below this are rounding (mm)."""
    return 64.0 * np.finfo(float).eps * max(scale, float(np.abs(P).max()) if P.size else 0.0, 1.0)
