# SPDX-License-Identifier: LGPL-2.1-or-later
"""A synthetic blisk from the sample blade: N copies of :class:`~bladerecon.samples.blade.SampleBlade`
about the z axis, each with its own small deviation, chosen pitch errors and noise (mm, degrees).

The sample blade's own frame is x axial, y tangential, z along the span. On the blisk the
span runs radially: blade 0 is placed with its hub section at ``hub_radius`` on the +x axis
(:func:`placement`), the rotor axis is z; blade ``k`` is blade 0 turned by
``k * 360/N + pitch_error[k]`` degrees about z. The truth of every blade (pitch error,
normal offset) is returned with the points, so tests check what the blisk command recovers.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bladerecon.core.analysis.alignment import apply_transform, rotation_about, transform_surface
from bladerecon.samples.blade import SampleBlade, nominal_surface, section_heights, t_at_length_fraction

__all__ = ["BliskScan", "placement", "blisk_scan", "blisk_nominal_surface", "HUB_RADIUS"]

HUB_RADIUS = 300.0          # mm: blades 15 deg apart (N = 24) do not overlap in angle at this radius


@dataclass(frozen=True)
class BliskScan:
    """The scan of a whole blisk: points (m, 3) mm, a section index per point (blade k's
    section j is ``k * n_sections + j``), and per blade the true pitch error (°) and the
    normal offset of its surface (mm, + material added)."""

    points: np.ndarray
    section: np.ndarray
    pitch_error_deg: np.ndarray
    offset_mm: np.ndarray
    n_sections: int


def placement(hub_radius: float = HUB_RADIUS) -> np.ndarray:
    """4x4 rigid motion from the sample blade's frame to blade 0 on the blisk: span (z) ->
    radial (+x, hub at ``hub_radius``), axial (x) -> z, tangential (y) -> -y (a rotation)."""
    M = np.zeros((4, 4))
    M[0, 2], M[1, 1], M[2, 0], M[3, 3] = 1.0, -1.0, 1.0, 1.0
    M[0, 3] = hub_radius
    return M


def blisk_scan(n_blades: int = 24, hub_radius: float = HUB_RADIUS, n_sections: int = 4, n_points: int = 200,
               noise: float = 0.002, pitch_errors: dict[int, float] | None = None,
               offset_sigma: float = 0.003, seed: int = 0, blade: SampleBlade | None = None) -> BliskScan:
    """Measured-like sections of every blade of the blisk (uniform in arc length from a
    random start, as :func:`~bladerecon.samples.blade.sample_sections`).

    ``pitch_errors``: ``{blade index: degrees}`` (others 0). Each blade's surface is offset
    along its normal by a draw of ``N(0, offset_sigma)`` mm (a per-blade deviation), then
    ``noise`` (sigma, mm) is added to each coordinate.
    """
    blade = blade or SampleBlade()
    rng = np.random.default_rng(seed)
    pitch = np.zeros(n_blades)
    for k, err in (pitch_errors or {}).items():
        pitch[k] = err
    offsets = offset_sigma * rng.standard_normal(n_blades)
    place = placement(hub_radius)
    points, labels = [], []
    for k in range(n_blades):
        motion = rotation_about((0.0, 0.0, 1.0), k * 360.0 / n_blades + pitch[k]) @ place
        for j, h in enumerate(section_heights(n_sections)):
            t = t_at_length_fraction(blade, h, (rng.random() + np.arange(n_points)) / n_points)
            p = blade.point(h, t) + offsets[k] * blade.normal(h, t) + noise * rng.standard_normal((n_points, 3))
            points.append(apply_transform(p, motion))
            labels.append(np.full(n_points, k * n_sections + j))
    return BliskScan(np.vstack(points), np.concatenate(labels), pitch, offsets, n_sections)


def blisk_nominal_surface(hub_radius: float = HUB_RADIUS, blade: SampleBlade | None = None, **kwargs):
    """Blade 0's nominal on the blisk: the sample nominal B-spline surface placed (mm)."""
    return transform_surface(nominal_surface(blade or SampleBlade(), **kwargs), placement(hub_radius))
