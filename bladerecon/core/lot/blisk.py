# SPDX-License-Identifier: LGPL-2.1-or-later
"""A blisk: one scan split into N blades by angular sector about the axis, and the
blade-to-blade position errors (pitch, stagger, radial) from a blade's best-fit motion
(mm, degrees).

Blade ``k`` nominally sits at ``k * 360/N`` degrees from blade 0 (counter-clockwise about
the axis). Its points are turned back by ``-k * 360/N`` and compared with blade 0's nominal,
which is the same as comparing them with the nominal turned by ``k * 360/N``.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.analysis.alignment import rotation_about
from bladerecon.core.errors import BladeReconError

__all__ = ["AXES", "axis_vector", "point_angles", "split_sectors", "turn", "position_errors"]

AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def axis_vector(name: str) -> np.ndarray:
    try:
        return np.array(AXES[name])
    except KeyError:
        raise BladeReconError(f"--axis {name}: give x, y or z") from None


def _frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors e1, e2 with (e1, e2, axis) right-handed: angles are measured from e1."""
    a = np.asarray(axis, float)
    e1 = np.roll(a, 1)                    # x -> y... for the coordinate axes: z -> x, x -> y, y -> z
    e2 = np.cross(a, e1)
    return e1, e2


def point_angles(points: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Angle (degrees, -180..180) of each point about the axis through the origin."""
    e1, e2 = _frame(axis)
    P = np.asarray(points, float)
    return np.degrees(np.arctan2(P @ e2, P @ e1))


def split_sectors(points: np.ndarray, axis: np.ndarray, n_blades: int, blade0_deg: float) -> np.ndarray:
    """Blade index 0..N-1 of each point: the sector of width 360/N centred on
    ``blade0_deg + k*360/N`` its angle falls in."""
    if n_blades < 1:
        raise BladeReconError(f"--blades {n_blades}: give at least 1 blade")
    pitch = 360.0 / n_blades
    rel = np.mod(point_angles(points, axis) - blade0_deg + 0.5 * pitch, 360.0)
    return np.minimum((rel // pitch).astype(int), n_blades - 1)


def turn(points: np.ndarray, axis: np.ndarray, angle_deg: float) -> np.ndarray:
    """The points turned by ``angle_deg`` about the axis through the origin."""
    M = rotation_about(axis, angle_deg)
    P = np.asarray(points, float)
    return P @ M[:3, :3].T + M[:3, 3]


def position_errors(error_motion: np.ndarray, reference: np.ndarray, axis: np.ndarray) -> dict:
    """Pitch, stagger, radial and axial error of a blade whose measured position is its
    nominal moved by the 4x4 ``error_motion`` (the inverse of its best fit onto the nominal).

    ``reference``: a point of the nominal blade (its middle). Pitch: the change of the
    reference point's angle about the axis (°); radial: of its distance from the axis (mm);
    axial: its shift along the axis (mm); stagger: the turn of the blade about the radial
    line through the reference point (°, the rotation vector's radial component).
    """
    E = np.asarray(error_motion, float)
    a = np.asarray(axis, float)
    c = np.asarray(reference, float)
    moved = E[:3, :3] @ c + E[:3, 3]
    e1, e2 = _frame(a)

    def polar(p):
        return np.arctan2(p @ e2, p @ e1), np.hypot(p @ e1, p @ e2)

    (t0, r0), (t1, r1) = polar(c), polar(moved)
    pitch = (np.degrees(t1 - t0) + 180.0) % 360.0 - 180.0
    radial_dir = c - (c @ a) * a
    radial_dir /= max(np.linalg.norm(radial_dir), 1e-300)
    R = E[:3, :3]
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])   # 2 sin(angle) * axis
    sin_angle = 0.5 * np.linalg.norm(w)
    angle = np.arctan2(sin_angle, 0.5 * (np.trace(R) - 1.0))
    rotvec = w * (angle / (2.0 * sin_angle)) if sin_angle > 1e-300 else np.zeros(3)
    return {"pitch_deg": float(pitch), "stagger_deg": float(np.degrees(rotvec @ radial_dir)),
            "radial_mm": float(r1 - r0), "axial_mm": float((moved - c) @ a)}
