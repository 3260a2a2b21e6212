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


def position_fit(points: np.ndarray, project, reference: np.ndarray, axis: np.ndarray,
                 max_iter: int = 60) -> np.ndarray:
    """The blade's best fit onto its nominal with the radial slide locked: 4x4 motion
    (measured -> nominal) of rotations about ``reference`` and shifts along the axis and
    the tangent only (point-to-plane Gauss-Newton, as
    :func:`bladerecon.core.analysis.alignment.best_fit`).

    Why locked: on a twisted blade measured on its flanks, sliding along the span while
    turning with the twist is almost a symmetry (a screw), so a free rigid fit trades a
    few micrometres of form error for tenths of a millimetre of radial shift and the
    matching stagger. Pitch is unaffected either way.
    """
    from bladerecon.core.analysis.alignment import _rodrigues, _signed

    P0 = np.asarray(points, float)
    a = np.asarray(axis, float)
    c = np.asarray(reference, float)
    radial = c - (c @ a) * a
    radial /= max(np.linalg.norm(radial), 1e-300)
    tangent = np.cross(a, radial)
    M = np.eye(4)
    size = float(np.max(np.linalg.norm(P0 - c, axis=1))) or 1.0
    for _ in range(max_iter):
        P = P0 @ M[:3, :3].T + M[:3, 3]
        r, n = _signed(P, project)
        J = np.column_stack([np.cross(P - c, n), n @ a, n @ tangent])
        scale = np.linalg.norm(J, axis=0)
        scale[scale == 0] = 1.0
        x = np.linalg.lstsq(J / scale, -r, rcond=None)[0] / scale
        w, t = x[:3], x[3] * a + x[4] * tangent
        R = _rodrigues(w)
        step = np.eye(4)
        step[:3, :3] = R
        step[:3, 3] = c - R @ c + t
        M = step @ M
        if np.linalg.norm(w) * size + np.linalg.norm(t) < 1e-9:
            return M
    raise BladeReconError(f"the blade's position fit did not converge in {max_iter} iterations: "
                          "check that the points belong to this nominal")
