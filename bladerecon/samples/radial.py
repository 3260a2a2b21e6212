# SPDX-License-Identifier: LGPL-2.1-or-later
"""A radial-inflow turbine rotor blade whose true surface is known (issue 25).

The meridional channel about the z axis runs from a radial inlet at r = 58 mm to an axial exit
at z = 39 mm: on the stream surface at span fraction ``s`` (0 hub, 1 shroud), at meridional
angle ``phi`` in [0, 90°],

    z = 39 - (39 - 8 s) cos(phi),   r = 58 - (48 - 20 s) sin(phi)

(hub from (z, r) = (0, 58) to (39, 10); shroud from (8, 58) to (39, 30)). The blade's section on
stream surface ``s`` is the :class:`~bladerecon.samples.blade.SampleBlade` section at h = s
(no stagger, twist, sweep or lean, chord along local x), laid onto the stream surface:
``phi = 90° (x/c + 1/2)`` along the channel and ``theta = wrap (x/c + 1/2)² (1 + 0.4 s) + y / r``
around the axis (mm of y become arc length at radius r): a strongly leaning, wrapped blade.
Every step is a closed-form map of the sample blade's closed-form points, so the true
surface is known to round-off. Units: mm, radians inside.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bladerecon.samples.blade import SampleBlade, t_at_length_fraction

__all__ = ["RadialRotor", "radial_rotor", "radial_cloud"]


@dataclass(frozen=True)
class RadialRotor:
    """The radial turbine blade: section laws of ``blade`` mapped onto the meridional channel."""

    blade: SampleBlade = field(default_factory=lambda: SampleBlade(
        span=1.0, chord_hub=56.0, chord_tip=52.0, camber_hub=30.0, camber_tip=20.0, thickness_hub=0.09,
        thickness_tip=0.06, le_radius_hub=0.9, le_radius_tip=0.7, te_radius_hub=0.6, te_radius_tip=0.45,
        stagger_hub=0.0, twist=0.0, sweep_tip=0.0, lean_tip=0.0))
    wrap: float = 0.9                      # rad of wrap from inlet to exit at the hub

    name: str = "radial"

    def meridional(self, phi, s) -> tuple[np.ndarray, np.ndarray]:
        """(z, r) mm of the stream surface ``s`` at meridional angle ``phi`` (rad)."""
        phi, s = np.asarray(phi, float), np.asarray(s, float)
        return 39.0 - (39.0 - 8.0 * s) * np.cos(phi), 58.0 - (48.0 - 20.0 * s) * np.sin(phi)

    def to_world(self, local: np.ndarray) -> np.ndarray:
        """Sample-blade points (x, y, h) -> world (mm) on the channel."""
        x, y, s = local[..., 0], local[..., 1], local[..., 2]
        c = self.blade.section_laws(s).chord
        u = x / c + 0.5
        z, r = self.meridional(0.5 * np.pi * u, s)
        theta = self.wrap * u * u * (1.0 + 0.4 * s) + y / r
        return np.stack([r * np.cos(theta), r * np.sin(theta), z], axis=-1)

    def truth(self, s0: float = 0.0, s1: float = 1.0, n_span: int = 21, n_profile: int = 600) -> np.ndarray:
        """True points (n_span * n_profile, 3) mm on the stream surfaces from s0 to s1."""
        frac = np.arange(n_profile) / n_profile
        rows = [self.blade.point(s, t_at_length_fraction(self.blade, s, frac, 1.5)) for s in np.linspace(s0, s1, n_span)]
        return self.to_world(np.concatenate(rows))


def radial_rotor() -> RadialRotor:
    return RadialRotor()


def radial_cloud(rotor: RadialRotor, n_points: int = 15000, noise: float = 0.0, seed: int = 0) -> np.ndarray:
    """Unordered nodes (N, 3) mm of the blade between hub and shroud, shuffled, with Gaussian noise."""
    rng = np.random.default_rng(seed)
    s = rng.random(n_points)
    t = rng.random(n_points)
    p = rotor.to_world(rotor.blade.point(s, t))
    return p + noise * rng.standard_normal(p.shape)
