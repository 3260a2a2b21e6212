# SPDX-License-Identifier: LGPL-2.1-or-later
"""A serviced, damaged sample blade whose true shape is known: the truth for ``repair``.

Units: millimetres and degrees at every interface.

The sample blade (:mod:`bladerecon.samples.blade`, not changed) is first **damaged**, then
**deformed**, both in closed form:

* **Damage**: each true profile point moves inwards along the section's in-plane unit
  normal by a depth ``delta(h, t) >= 0``, a sum of smooth bumps (a cos² fall-off, C1):

  - *LE erosion*: over a span band, the first ``le_erosion_chord`` fraction of the chord;
  - *a nick*: a short (``nick_length_mm`` along the span) deep dent on the LE or TE;
  - *TE burn-off*: over a span band, the last ``te_burn_chord`` fraction of the chord;
  - *tip loss*: everything above ``z = span - tip_loss_mm`` is gone (a flat cut).

  Moving along the in-plane normal keeps every section planar, so the missing material of
  a section is the difference of two polygon areas (:func:`true_missing_volume`).
* **Service deformation**: per span fraction ``h`` a rigid motion in the section plane,
  a twist ``twist_tip_deg * h²`` about the z axis through ``centre`` and a bend (shift)
  ``bend_tip_mm * h²``: smooth along the span, zero at the hub (the root is held).

Measurements: :func:`damaged_sections` (planar sections, as a CMM measures) and
:func:`damaged_cloud` (a jittered grid over the surface, as a scanner measures), both
with isotropic Gaussian noise (default 2 µm per coordinate).

``python3 -m bladerecon.samples.damaged DIR`` writes ``damaged_sections.csv``,
``damaged_cloud.csv`` and ``truth.json`` (the known deformation and missing volume) into DIR.
"""
from __future__ import annotations

import json
import os
import sys
from dataclasses import asdict, dataclass, field

import numpy as np
from scipy.integrate import trapezoid

from bladerecon.samples.blade import SampleBlade, t_at_length_fraction

__all__ = ["ServiceDamage", "damage_depth", "true_point", "damaged_point", "damaged_sections",
           "damaged_cloud", "true_missing_volume", "section_area", "main"]

_DEG = np.pi / 180.0


@dataclass(frozen=True)
class ServiceDamage:
    """Known service deformation and damage of the sample blade (mm, degrees, span fractions)."""

    blade: SampleBlade = field(default_factory=SampleBlade)
    twist_tip_deg: float = 0.3               # twist at the tip, grows as h²
    bend_tip_mm: tuple = (0.15, -0.10)       # in-plane shift at the tip, grows as h²
    centre: tuple = (0.0, 0.0)               # xy of the twist axis (parallel to z)
    tip_loss_mm: float = 2.5
    le_erosion_depth_mm: float = 0.2
    le_erosion_span: tuple = (0.35, 0.65)    # h range (30 % of the span)
    le_erosion_chord: float = 0.04           # fraction of the chord from the LE
    nick_depth_mm: float = 0.35
    nick_length_mm: float = 1.5              # along the span
    nick_h: float = 0.25
    nick_edge: str = "te"                    # 'le' or 'te'
    nick_chord: float = 0.03
    te_burn_depth_mm: float = 0.3
    te_burn_span: tuple = (0.78, 0.93)
    te_burn_chord: float = 0.05

    @property
    def cut_z(self) -> float:
        """Height (mm) of the flat tip cut: nothing of the blade is left above it."""
        return float(self.blade.z_of(1.0) - self.tip_loss_mm)

    def twist_deg(self, h) -> np.ndarray:
        return self.twist_tip_deg * np.asarray(h, float) ** 2

    def shift_mm(self, h) -> np.ndarray:
        h = np.asarray(h, float)
        return np.stack([self.bend_tip_mm[0] * h ** 2, self.bend_tip_mm[1] * h ** 2], axis=-1)


def _fall_off(x) -> np.ndarray:
    """1 at x = 0, 0 for |x| >= 1, cos² in between (C1)."""
    x = np.clip(np.abs(np.asarray(x, float)), 0.0, 1.0)
    return np.cos(0.5 * np.pi * x) ** 2


def _band(h, lo: float, hi: float, ramp: float) -> np.ndarray:
    """1 inside [lo + ramp, hi - ramp], falling smoothly (cos²) to 0 at lo and hi."""
    h = np.asarray(h, float)
    left = np.where(h < lo + ramp, _fall_off((lo + ramp - h) / ramp), 1.0)
    right = np.where(h > hi - ramp, _fall_off((h - hi + ramp) / ramp), 1.0)
    return np.where((h <= lo) | (h >= hi), 0.0, left * right)


def _chord_fraction(blade: SampleBlade, h, p) -> np.ndarray:
    """Position of p (..., 3) along the chord, 0 at the LE point, 1 at the TE point."""
    le, te = blade.le_te(h)
    c = te[..., :2] - le[..., :2]
    return ((p[..., :2] - le[..., :2]) * c).sum(-1) / (c * c).sum(-1)


def damage_depth(sd: ServiceDamage, h, t) -> np.ndarray:
    """Depth (mm, >= 0) of the damage at (h, t), along the in-plane inward normal."""
    h, t = np.broadcast_arrays(np.asarray(h, float), np.asarray(t, float))
    blade = sd.blade
    x = _chord_fraction(blade, h, blade.point(h, t))
    ramp = 0.05
    depth = sd.le_erosion_depth_mm * _band(h, *sd.le_erosion_span, ramp) * _fall_off(x / sd.le_erosion_chord)
    depth = depth + sd.te_burn_depth_mm * _band(h, *sd.te_burn_span, ramp) * \
        _fall_off((1.0 - x) / sd.te_burn_chord)
    along = (h - sd.nick_h) * blade.span / (0.5 * sd.nick_length_mm)
    edge = x if sd.nick_edge == "le" else 1.0 - x
    return depth + sd.nick_depth_mm * _fall_off(along) * _fall_off(edge / sd.nick_chord)


def _deform(sd: ServiceDamage, h, p) -> np.ndarray:
    """Apply the service deformation (in-plane rigid motion at each h) to points p (..., 3)."""
    a = sd.twist_deg(h) * _DEG
    c = np.asarray(sd.centre, float)
    x, y = p[..., 0] - c[0], p[..., 1] - c[1]
    d = sd.shift_mm(h)
    return np.stack([c[0] + np.cos(a) * x - np.sin(a) * y + d[..., 0],
                     c[1] + np.sin(a) * x + np.cos(a) * y + d[..., 1], p[..., 2]], axis=-1)


def true_point(sd: ServiceDamage, h, t) -> np.ndarray:
    """The deformed, undamaged blade at (h, t): what the repair target should be (mm)."""
    h, t = np.broadcast_arrays(np.asarray(h, float), np.asarray(t, float))
    return _deform(sd, h, sd.blade.point(h, t))


def damaged_point(sd: ServiceDamage, h, t) -> np.ndarray:
    """The deformed, damaged blade at (h, t) (mm); the tip cut is not applied here."""
    h, t = np.broadcast_arrays(np.asarray(h, float), np.asarray(t, float))
    blade = sd.blade
    n = blade.normal(h, t)[..., :2]
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    p = blade.point(h, t).copy()
    p[..., :2] -= damage_depth(sd, h, t)[..., None] * n
    return _deform(sd, h, p)


def damaged_sections(sd: ServiceDamage, n_sections: int = 25, n_points: int = 1500,
                     noise: float = 0.002, seed: int = 0) -> list[np.ndarray]:
    """Planar sections (list of (n, 3) mm) from the hub to 0.5 mm under the tip cut."""
    rng = np.random.default_rng(seed)
    top = sd.blade.h_of_z(sd.cut_z - 0.5)
    out = []
    for h in np.linspace(0.0, float(top), n_sections):
        t = t_at_length_fraction(sd.blade, h, (rng.random() + np.arange(n_points)) / n_points, 1.0)
        out.append(damaged_point(sd, np.full_like(t, h), t) + noise * rng.standard_normal((n_points, 3)))
    return out


def damaged_cloud(sd: ServiceDamage, n_rows: int = 240, n_around: int = 400,
                  noise: float = 0.002, seed: int = 0) -> np.ndarray:
    """A scanner-like cloud (m, 3) mm: a jittered grid in (span, arc length) up to the cut.

    Rows every ``(cut height)/n_rows`` along the span, ``n_around`` points per row at
    jittered fractions of the curvature-weighted arc length (denser on the edges).
    """
    rng = np.random.default_rng(seed)
    top = float(sd.blade.h_of_z(sd.cut_z))
    dh = top / n_rows
    pts = []
    for k in range(n_rows):
        h0 = (k + 0.5) * dh
        frac = (np.arange(n_around) + rng.random(n_around)) / n_around
        t = t_at_length_fraction(sd.blade, h0, frac, 1.0)
        h = np.clip(h0 + dh * (rng.random(n_around) - 0.5), 0.0, top)
        pts.append(damaged_point(sd, h, t))
    cloud = np.concatenate(pts)
    return cloud + noise * rng.standard_normal(cloud.shape)


def truth_errors(sd: ServiceDamage, surface) -> tuple[np.ndarray, np.ndarray]:
    """Distance (mm) of the true deformed blade to ``surface`` (a core B-spline surface) on an
    81 x 300 (h, t) grid, and the mask of damaged places there (damage depth > 1 µm, or above
    the tip cut): how a repair target is judged against the truth."""
    from bladerecon.core.geometry.projection import project_points_to_surface

    h = np.linspace(0.0, 1.0, 81)
    t = np.linspace(0.0, 1.0, 300, endpoint=False)
    H, T = np.meshgrid(h, t, indexing="ij")
    damaged = (damage_depth(sd, H, T) > 0.001) | (sd.blade.z_of(H) > sd.cut_z)
    d = project_points_to_surface(surface, true_point(sd, H, T).reshape(-1, 3)).distance.reshape(H.shape)
    return d, damaged


def section_area(points: np.ndarray) -> float:
    """Area (mm²) enclosed by a closed planar polygon (shoelace on x, y)."""
    x, y = points[:, 0], points[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def true_missing_volume(sd: ServiceDamage, step_mm: float = 0.25, n_profile: int = 4000) -> dict:
    """Missing volume (mm³) by section areas: damage (true - damaged area, integrated over
    the span below the cut) and the tip (true area above the cut). Independent of the
    repair code: polygon areas of dense closed-form sections, trapezoid rule along z."""
    blade = sd.blade
    t = np.arange(n_profile) / n_profile

    def missing_area(h):
        hh = np.full_like(t, h)
        return section_area(true_point(sd, hh, t)) - section_area(damaged_point(sd, hh, t))

    cut_h = float(blade.h_of_z(sd.cut_z))
    half_nick = 0.5 * sd.nick_length_mm / blade.span
    supports = [(sd.le_erosion_span, step_mm), (sd.te_burn_span, step_mm),
                ((sd.nick_h - half_nick, sd.nick_h + half_nick), step_mm / 5)]
    damage = 0.0
    for (lo, hi), step in supports:          # the damage is zero outside these span bands
        lo, hi = max(lo, 0.0), min(hi, cut_h)
        if hi <= lo:
            continue
        hs = np.linspace(lo, hi, int(np.ceil((hi - lo) * blade.span / step)) + 1)
        damage += trapezoid([missing_area(h) for h in hs], hs) * blade.span
    ht = np.linspace(cut_h, 1.0, 9)
    tip = trapezoid([section_area(true_point(sd, np.full_like(t, h), t)) for h in ht], ht) * blade.span
    return {"damage_mm3": float(damage), "tip_mm3": float(tip), "total_mm3": float(damage + tip)}


def main(argv: list[str] | None = None) -> int:
    """Write damaged_sections.csv, damaged_cloud.csv and truth.json into a folder."""
    from bladerecon.core.io.readers import write_points_csv

    argv = sys.argv[1:] if argv is None else argv
    if len(argv) != 1:
        print("usage: python3 -m bladerecon.samples.damaged DIR", file=sys.stderr)
        return 2
    folder = argv[0]
    os.makedirs(folder, exist_ok=True)
    sd = ServiceDamage()
    secs = damaged_sections(sd)
    write_points_csv(os.path.join(folder, "damaged_sections.csv"), np.concatenate(secs),
                     np.repeat(np.arange(len(secs)), [len(s) for s in secs]))
    cloud = damaged_cloud(sd)
    write_points_csv(os.path.join(folder, "damaged_cloud.csv"), cloud, np.zeros(len(cloud), int), ["cloud"])
    truth = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(sd).items() if k != "blade"}
    truth["missing_volume"] = true_missing_volume(sd)
    truth["units"] = "mm, degrees"
    with open(os.path.join(folder, "truth.json"), "w", encoding="utf-8") as f:
        json.dump(truth, f, indent=2)
    print(json.dumps({"folder": folder, "sections": len(secs), "cloud_points": len(cloud),
                      "missing_volume_mm3": truth["missing_volume"]["total_mm3"]}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
