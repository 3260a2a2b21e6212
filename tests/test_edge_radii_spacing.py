# SPDX-License-Identifier: LGPL-2.1-or-later
"""Issue 24 §3 at random point spacing: edge radii and chord against the analytic blade's truth.

Random spacing (uniform random arc-length positions, as a scanner or a hand-held probe gives)
leaves some edges with one or two points on the arc, or none, and puts points just behind the
flanks' touching points. Each test draws several seeds (not one tuned draw) of the issue's
blade (6 sections, chord 40 -> 32 mm, r_LE 0.55 -> 0.30 mm, r_TE 0.40 -> 0.25 mm).
"""
from __future__ import annotations

import numpy as np
import pytest

from bladerecon.core.sections.parameters import measure_section, segment_blade
from bladerecon.samples.blade import SampleBlade, section_heights, t_at_length_fraction

BLADE = SampleBlade(chord_hub=40.0, chord_tip=32.0, le_radius_hub=0.55, le_radius_tip=0.3, te_radius_hub=0.4,
                    te_radius_tip=0.25, thickness_hub=0.06, thickness_tip=0.05)
AXIS, FLOW = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])


def _edges(n: int, noise: float, spacing: str, seed: int) -> list[dict]:
    """One row per edge: relative radius error, chord error (mm), points on the true arc."""
    rng = np.random.default_rng(seed)
    secs, ts = [], []
    for h in section_heights(6):
        f = (rng.random() + np.arange(n)) / n if spacing == "even" else np.sort(rng.random(n))
        t = t_at_length_fraction(BLADE, h, f)
        p = BLADE.point(h, t)
        secs.append(p + noise * rng.standard_normal(p.shape))
        ts.append(t)
    rows = []
    for seg, h, t in zip(segment_blade(secs, AXIS, flow=FLOW).sections, section_heights(6), ts):
        m = measure_section(seg)
        laws = BLADE.section_laws(h)
        b = BLADE.segment_bounds(h)       # the LE arc is t < b[1] or t >= b[4]; the TE arc b[2] <= t < b[3]
        on = {"le": int(np.sum((t < b[1]) | (t >= b[4]))), "te": int(np.sum((t >= b[2]) & (t < b[3])))}
        for end in ("le", "te"):
            r_true = float(getattr(laws, f"{end}_radius"))
            rows.append({"seed": seed, "section": seg.index, "edge": end, "on_arc": on[end],
                         "radius": getattr(m, f"{end}_radius") / r_true - 1, "chord": m.chord - float(laws.chord)})
    return rows


@pytest.mark.timeout(180)
def test_400_points_2um_noise_random_spacing_radii_and_chord():
    """8 seeds x 12 edges. The radius error here is noise-limited: at even spacing the same fit
    scatters with σ ≈ 0.25 % (worst of 96 edges 0.7 %), so 1 % is 4 σ; the chord end moves with
    the tip of the circle, a few µm (even: worst 4 µm, random: 16 µm), held to 30 µm. Before the
    fit took the touching points as the arc's limits, started on the foremost point and damped
    its steps, a random draw could leave the circle at its start or in front of the measured
    tip: seed 1 gave −33 % and 98 µm, seed 7 −10 % and 290 µm."""
    rows = [r for seed in range(8) for r in _edges(400, 0.002, "random", seed)]
    worst = max(rows, key=lambda r: abs(r["radius"]))
    assert abs(worst["radius"]) <= 0.01, worst
    worst = max(rows, key=lambda r: abs(r["chord"]))
    assert abs(worst["chord"]) <= 0.030, worst


@pytest.mark.timeout(180)
def test_120_exact_points_random_spacing_radii_where_the_arc_was_measured():
    """Seeds 0-9 and the bench's 121, exact points. Where at least one point lies on the true
    arc: ≤ 1 % (issue 24's figure; the flanks on exact points are good to 0.2 µm with cubic
    models, 0.1 % of these radii, so 1 % leaves room for a point near a touching point). The
    cubic needs 6 flank points, not 12: a quadratic over a third of the chord missed the flank
    by up to 8 µm and gave −1.3 % on seed 121 (1 arc point) and −1.1 % on seed 7.

    Where no point lies on the arc, nothing measured fixes the circle's place along the camber
    line: every circle tangent to both flanks ahead of the foremost flank point fits all the
    points. The fit gives the largest of them (the one through the foremost point), so the
    radius may only be too large: held to no more than 0.2 % too small."""
    rows = [r for seed in (*range(10), 121) for r in _edges(120, 0.0, "random", seed)]
    measured = [r for r in rows if r["on_arc"] >= 1]
    worst = max(measured, key=lambda r: abs(r["radius"]))
    assert abs(worst["radius"]) <= 0.01, worst
    unmeasured = [r for r in rows if r["on_arc"] == 0]
    assert unmeasured and min(r["radius"] for r in unmeasured) >= -0.002


@pytest.mark.timeout(120)
def test_120_exact_points_even_spacing_radii_and_chord():
    """Even spacing, 3 seeds: ≤ 1 % radius (issue 24) and ≤ 5 µm chord (measured worst 0.2 µm)."""
    rows = [r for seed in range(3) for r in _edges(120, 0.0, "even", seed)]
    assert max(abs(r["radius"]) for r in rows) <= 0.01
    assert max(abs(r["chord"]) for r in rows) <= 0.005
