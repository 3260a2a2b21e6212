# SPDX-License-Identifier: LGPL-2.1-or-later
"""Test blades as a user brings them: whole-surface clouds with a hub fillet and a tip cap (issue 25).

The airfoil part of every blade here is a :class:`~bladerecon.samples.blade.SampleBlade`
(true surface in closed form), turned so that its span runs along another axis, plus
what a scan or a CFD surface mesh of a real blade also holds but is no airfoil:

* a **hub fillet** below the hub section: a quarter circle of radius ``fillet_radius``
  (mm) that widens the hub section outwards, ``offset(d) = rf - sqrt(rf² - d²)`` at a
  distance ``d`` below the hub (taken to ``0.8 rf``, where the offset is 0.4 rf);
* a **rounded tip cap** above the tip section: every tip point moves towards its nearest
  camber-line point as ``sqrt(1 - (d/c)²)``, ``c`` the tip's largest half thickness.

:func:`propeller_blade` has its span along +x (hub at x = 40 mm, 160 mm long, fillet
and cap), :func:`fan_blade` along -y with 60° of twist (fillet, open tip).
:func:`blade_cloud` gives the nodes in mm (unordered), with a label per node (airfoil,
fillet, cap); :func:`write_cloud` writes them as ``x y z`` lines in metres, like a CFD
export. The true airfoil surface: :meth:`CloudBlade.truth` (mm).

Units: mm and degrees at every interface.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bladerecon.samples.blade import SampleBlade, t_at_length_fraction

__all__ = ["CloudBlade", "propeller_blade", "fan_blade", "blade_cloud", "write_cloud",
           "AIRFOIL", "FILLET", "CAP"]

AIRFOIL, FILLET, CAP = 0, 1, 2


@dataclass(frozen=True)
class CloudBlade:
    """A sample blade placed in the world: ``world = rotation @ local + offset`` (mm)."""

    name: str
    blade: SampleBlade
    rotation: np.ndarray = field(repr=False)
    offset: np.ndarray = field(repr=False)
    fillet_radius: float = 0.0          # mm; 0: no fillet
    cap: bool = False

    def to_world(self, p: np.ndarray) -> np.ndarray:
        return np.asarray(p, float) @ self.rotation.T + self.offset

    @property
    def span_axis(self) -> np.ndarray:
        """Unit world direction from hub to tip."""
        return self.rotation[:, 2].copy()

    def airfoil_range(self) -> tuple[float, float]:
        """The airfoil span along :attr:`span_axis` (mm, world coordinate along the axis)."""
        base = float(self.offset @ self.span_axis)
        return base + self.blade.hub_z, base + self.blade.hub_z + self.blade.span

    def truth(self, h0: float = 0.0, h1: float = 1.0, n_span: int = 41, n_profile: int = 600) -> np.ndarray:
        """True airfoil points (n_span * n_profile, 3) mm between span fractions h0 and h1,
        dense on the round edges (curvature-weighted arc length)."""
        frac = np.arange(n_profile) / n_profile
        rows = [self.blade.point(h, t_at_length_fraction(self.blade, h, frac, 1.5))
                for h in np.linspace(h0, h1, n_span)]
        return self.to_world(np.concatenate(rows))


def _turn(cols) -> np.ndarray:
    return np.column_stack([np.asarray(c, float) for c in cols])


def propeller_blade() -> CloudBlade:
    """Span along +x from 40 to 200 mm, chord 42 -> 26 mm, 40° of twist, fillet r 6 mm, tip cap."""
    blade = SampleBlade(span=160.0, chord_hub=42.0, chord_tip=26.0, camber_hub=22.0, camber_tip=10.0,
                        thickness_hub=0.12, thickness_tip=0.075, le_radius_hub=0.8, le_radius_tip=0.45,
                        te_radius_hub=0.45, te_radius_tip=0.3, stagger_hub=35.0, twist=40.0,
                        sweep_tip=6.0, lean_tip=4.0)
    # local (x, y, z) -> world (z + 40, x, y): span along +x
    rot = _turn([(0, 1, 0), (0, 0, 1), (1, 0, 0)])
    return CloudBlade("propeller", blade, rot, np.array([40.0, 0.0, 0.0]), fillet_radius=6.0, cap=True)


def fan_blade() -> CloudBlade:
    """Span along -y from -60 to -180 mm, chord 50 -> 64 mm, 60° of twist, fillet r 5 mm, open tip."""
    blade = SampleBlade(span=120.0, chord_hub=50.0, chord_tip=64.0, camber_hub=40.0, camber_tip=12.0,
                        thickness_hub=0.10, thickness_tip=0.05, le_radius_hub=0.9, le_radius_tip=0.5,
                        te_radius_hub=0.5, te_radius_tip=0.35, stagger_hub=15.0, twist=60.0,
                        sweep_tip=8.0, lean_tip=-5.0)
    # local (x, y, z) -> world (x, -z - 60, y): span along -y
    rot = _turn([(1, 0, 0), (0, 0, 1), (0, -1, 0)])
    return CloudBlade("fan", blade, rot, np.array([0.0, -60.0, 0.0]), fillet_radius=5.0, cap=False)


def _in_plane_normal(blade: SampleBlade, h: float, t: np.ndarray) -> np.ndarray:
    n = blade.normal(h, t).copy()
    n[:, 2] = 0.0
    return n / np.linalg.norm(n, axis=1, keepdims=True)


def _edge_weighted_t(blade: SampleBlade, h: np.ndarray, rng, edge_share: float) -> np.ndarray:
    """Profile parameters: uniform, plus ``edge_share`` of them on the LE/TE arcs (CFD clustering)."""
    t = rng.random(h.size)
    k = rng.random(h.size) < edge_share
    b = blade.segment_bounds(h[k])
    piece = rng.integers(0, 3, k.sum())            # LE lower, TE, LE upper
    lo = np.choose(piece, [b[:, 0], b[:, 2], b[:, 4]])
    hi = np.choose(piece, [b[:, 1], b[:, 3], b[:, 5]])
    t[k] = lo + (hi - lo) * rng.random(k.sum())
    return t


def blade_cloud(cb: CloudBlade, n_points: int = 30000, noise: float = 0.0, seed: int = 0,
                edge_share: float = 0.1, rows: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Unordered nodes of the whole blade surface: ``(points (N, 3) mm, label (N,))``.

    Airfoil nodes at random span fraction and profile parameter (``edge_share`` of them on
    the round edges, as a CFD mesh clusters there); fillet and cap nodes at the same
    density; Gaussian ``noise`` (mm, per coordinate) for a scan. ``rows > 0``: the airfoil
    nodes lie on that many planes across the span instead (a CFD mesh's node rows). Shuffled.
    """
    rng = np.random.default_rng(seed)
    b = cb.blade
    h = rng.random(n_points) if rows <= 0 else np.repeat(np.linspace(0.0, 1.0, rows), -(-n_points // rows))[:n_points]
    parts = [b.point(h, _edge_weighted_t(b, h, rng, edge_share))]
    labels = [np.full(n_points, AIRFOIL)]
    if cb.fillet_radius > 0:
        rf = cb.fillet_radius
        n_f = int(n_points * 0.8 * rf / b.span * 1.3)
        d = 0.8 * rf * rng.random(n_f)
        t = _edge_weighted_t(b, np.zeros(n_f), rng, edge_share)
        p = b.point(0.0, t) + _in_plane_normal(b, 0.0, t) * (rf - np.sqrt(rf * rf - d * d))[:, None]
        p[:, 2] -= d
        parts.append(p)
        labels.append(np.full(n_f, FILLET))
    if cb.cap:
        xi = np.linspace(0.0, 1.0, 801)
        camber = b.camber_point(1.0, xi)
        c = float(b.half_thickness(1.0, xi).max())
        n_c = max(int(n_points * 2.0 * c / b.span), 50)
        t = _edge_weighted_t(b, np.ones(n_c), rng, edge_share)
        p = b.point(1.0, t)
        near = camber[np.argmin(((p[:, None, :2] - camber[None, :, :2]) ** 2).sum(-1), axis=1)]
        d = c * np.sqrt(rng.random(n_c))              # denser towards the rim, like the area
        shrink = np.sqrt(np.clip(1.0 - (d / c) ** 2, 0.0, 1.0))
        p[:, :2] = near[:, :2] + (p[:, :2] - near[:, :2]) * shrink[:, None]
        p[:, 2] += d
        parts.append(p)
        labels.append(np.full(n_c, CAP))
    pts = cb.to_world(np.concatenate(parts))
    lab = np.concatenate(labels)
    pts = pts + noise * rng.standard_normal(pts.shape)
    order = rng.permutation(len(pts))
    return pts[order], lab[order]


def write_cloud(path: str, points: np.ndarray, metres: bool = True) -> None:
    """``x y z`` lines (metres by default, as a CFD export; mm with ``metres=False``)."""
    scale = 1e-3 if metres else 1.0
    np.savetxt(path, np.asarray(points) * scale, fmt="%.9f" if metres else "%.6f",
               header="x y z (" + ("m" if metres else "mm") + "), unordered surface nodes")


def main(argv: list[str] | None = None) -> int:
    """``python3 -m bladerecon.samples.propeller BLADE OUT.xyz``: write a test blade's cloud (metres)."""
    import argparse

    p = argparse.ArgumentParser(prog="python3 -m bladerecon.samples.propeller",
                                description="Write a test blade of issue 25 as an unordered cloud in metres.")
    p.add_argument("blade", choices=("propeller", "fan", "radial"))
    p.add_argument("output", help="x y z file to write (metres)")
    p.add_argument("--noise", type=float, default=0.0, metavar="MM", help="Gaussian noise per coordinate (mm)")
    p.add_argument("--points", type=int, default=None, help="airfoil nodes (default 30000; radial 15000)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--mm", action="store_true", help="write millimetres instead of metres")
    p.add_argument("--every", type=int, default=1, metavar="K", help="keep every K-th node (a lighter file)")
    a = p.parse_args(argv)
    if a.blade == "radial":
        from bladerecon.samples.radial import radial_cloud, radial_rotor

        pts = radial_cloud(radial_rotor(), a.points or 15000, a.noise, a.seed)
    else:
        cb = propeller_blade() if a.blade == "propeller" else fan_blade()
        pts = blade_cloud(cb, a.points or 30000, a.noise, a.seed)[0]
    write_cloud(a.output, pts[:: max(1, a.every)], metres=not a.mm)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
