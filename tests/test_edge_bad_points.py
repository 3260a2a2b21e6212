# SPDX-License-Identifier: LGPL-2.1-or-later
"""Bad points at the leading and trailing edges (issue 16 item 6, seed 001 §1.1, seed 004 §2.1).

Hard data from the analytic sample blade, whose truth is known: 400-point sections at even
or random spacing, with runs of 1-5 consecutive points displaced along the true normal by
10, 15 or 30 µm at 0-3 % and 97-100 % of the chord (either flank, across the edge's tip
too) and one run on the flanks; every injected point is known, so a miss or a clean point
flagged fails.
"""
from __future__ import annotations

import numpy as np
import pytest

from bladerecon.samples.blade import SampleBlade, t_at_length_fraction

BLADE = SampleBlade()
DISPLACEMENTS = (0.010, 0.015, 0.030)      # mm
EDGE_BANDS = ((0.0, 0.03), (0.97, 1.0))     # chord fractions of the edge runs


def true_chord_fraction(h: float, points: np.ndarray) -> np.ndarray:
    """Fraction of the chord (0 LE point, 1 TE point) of each point's foot on the chord line."""
    le, te = BLADE.le_te(h)
    c = te - le
    return (points - le) @ c / (c @ c)


def in_plane_normal(h: float, t: np.ndarray) -> np.ndarray:
    n = BLADE.normal(h, t)
    n[:, 2] = 0.0
    return n / np.linalg.norm(n, axis=1)[:, None]


def section_with_runs(h: float, seed: int, n: int = 400, spacing: str = "even", noise: float = 0.0,
                      flank_run: bool = True, clean: bool = False, displacements=DISPLACEMENTS):
    """One section with a run at the LE band, one at the TE band (and one on the flanks).

    Returns ``(points (n, 3) mm, injected (n,) bool, runs)``, each run a dict with its first
    and last index, length, displacement (mm, signed along the outward normal) and the true
    chord fractions of its points. Reproducible for a seed; ``clean`` gives the same points
    without runs.
    """
    rng = np.random.default_rng(seed)
    if spacing == "even":
        f = (rng.random() + np.arange(n)) / n
    else:
        f = np.sort(rng.random(n))
    t = t_at_length_fraction(BLADE, h, f)
    P = BLADE.point(h, t)
    N = in_plane_normal(h, t)
    chord = true_chord_fraction(h, P)
    te = BLADE.te_parameter(h)
    pressure_half = t < te            # LE point -> pressure flank -> TE point
    out = P + noise * rng.standard_normal(P.shape) if noise else P.copy()
    if clean:
        return out, np.zeros(n, bool), []
    injected = np.zeros(n, bool)
    runs = []
    bands = list(EDGE_BANDS) + ([(0.1, 0.9)] if flank_run else [])
    for lo, hi in bands:
        k = int(rng.integers(1, 6))
        side = pressure_half if rng.random() < 0.5 else ~pressure_half
        d = float(rng.choice(displacements)) * (1.0 if rng.random() < 0.5 else -1.0)
        cand = np.flatnonzero(side & (chord >= lo) & (chord <= hi))
        first = int(rng.choice(cand))
        # the run goes from there towards the edge's tip or away from it, whichever the draw says
        step = 1 if rng.random() < 0.5 else -1
        idx = first + step * np.arange(k)
        if idx.min() < 1 or idx.max() > n - 2 or injected[idx.min() - 1:idx.max() + 2].any():
            continue                  # not across the loop's start, never touching another run
        injected[idx] = True
        out[idx] += d * N[idx]
        idx = np.sort(idx)
        runs.append({"first": int(idx[0]), "last": int(idx[-1]), "length": k, "displacement": d,
                     "chord": chord[idx], "band": (lo, hi)})
    return out, injected, runs


# ---------------------------------------------------------------------------- the tests
from bladerecon.core.sections.fairing import describe_runs, fair_section  # noqa: E402

THRESHOLD_NOISY = 0.008      # 4 x the 2 µm noise sigma: the threshold the noisy sections are run with
GRID = [(h, seed, spacing) for h in (0.0, 0.5, 1.0) for seed in (1, 2) for spacing in ("even", "random")]


def _found(f, runs):
    return [int(f.bad[r["first"]:r["last"] + 1].sum()) for r in runs]


@pytest.mark.parametrize("h,seed,spacing", GRID)
def test_clean_sections_no_point_flagged(h, seed, spacing):
    points, _, _ = section_with_runs(h, seed, spacing=spacing, clean=True)
    f = fair_section(points)
    assert not f.bad.any(), f"clean points flagged: {np.flatnonzero(f.bad)}"


@pytest.mark.parametrize("h,seed,spacing", GRID)
def test_every_edge_run_found_and_no_clean_point_flagged(h, seed, spacing):
    points, injected, runs = section_with_runs(h, seed, spacing=spacing)
    assert sum(r["band"][0] in (0.0, 0.97) for r in runs) >= 1        # the generator put edge runs in
    f = fair_section(points)
    missed = [(r["first"], r["length"], r["displacement"]) for r, k in zip(runs, _found(f, runs)) if k < r["length"]]
    assert not missed, f"runs missed (first, length, mm): {missed}"
    assert not (f.bad & ~injected).any(), f"clean points flagged: {np.flatnonzero(f.bad & ~injected)}"
    # and put back onto the true section, within 2 µm, by the edge model or the auxiliary cubic
    dense = BLADE.point(h, t_at_length_fraction(BLADE, h, np.arange(200000) / 200000))
    from scipy.spatial import cKDTree
    assert cKDTree(dense).query(f.faired[injected])[0].max() < 0.002


@pytest.mark.xfail(strict=True, reason="issue 16 item 6 not met yet on 2 µm noise: edge runs of 15 µm are "
                                       "missed or leave clean neighbours flagged (bench table 3)")
@pytest.mark.parametrize("h,seed,spacing", [(0.0, 3, "even"), (0.5, 3, "random"), (1.0, 4, "even")])
def test_noisy_sections_runs_of_15um_found(h, seed, spacing):
    """2 µm noise, runs of 15 and 30 µm, the threshold at 4 sigma."""
    points, injected, runs = section_with_runs(h, seed, spacing=spacing, noise=0.002,
                                               displacements=(0.015, 0.030))
    f = fair_section(points, THRESHOLD_NOISY)
    missed = [(r["first"], r["length"], r["displacement"]) for r, k in zip(runs, _found(f, runs)) if k < r["length"]]
    assert not missed, f"runs missed (first, length, mm): {missed}"


def test_runs_are_reported_with_lines_chord_and_displacement():
    points, injected, runs = section_with_runs(0.5, 1, flank_run=False)
    f = fair_section(points)
    lines = np.arange(len(points)) + 2           # a header line, lines counted from 1
    described = describe_runs(points, f.bad, f.displacement, lines)
    assert len(described) == len(runs)
    for r, d in zip(sorted(runs, key=lambda r: r["first"]), described):
        assert (d["first_line"], d["last_line"], d["points"]) == (r["first"] + 2, r["last"] + 2, r["length"])
        # chord fraction from the end nearer the first point (here the LE: the loop starts near it)
        assert np.allclose(sorted(d["chord_fraction"]), sorted(r["chord"][[0, -1]]), atol=0.01)
        assert abs(d["displacement_mm"] - abs(r["displacement"])) < 0.003


def test_an_edge_that_is_no_circle_is_not_judged():
    """A leading edge squeezed along the chord (by up to half, smoothly to nothing 1.5 mm
    from the LE point): its curvature grows and falls along it, the circle model does not
    fit it, so the edge is left unjudged and no clean point is flagged."""
    points, _, _ = section_with_runs(0.5, 1, clean=True)
    le, te = BLADE.le_te(0.5)
    c = (te - le) / np.linalg.norm(te - le)
    x = (points - le) @ c
    e = points.copy()
    near = x < 1.5                                 # within 1.5 mm of the LE, pulled in along the chord
    e[near] = points[near] - (x[near] * 0.5 * (1.0 - x[near] / 1.5) ** 2)[:, None] * c
    f = fair_section(e)
    assert not f.bad.any()
    notes = [j.note for j in f.edges]
    assert any("not judged" in n for n in notes), notes


def test_reconstruct_fair_reports_where_each_edge_run_is(tmp_path):
    """The user's path: ``reconstruct --fair --json`` names every run (section, first and
    last line, chord fraction, displacement), edge runs included."""
    import json

    from section_files import write_sections_csv
    from test_cli import run

    sections, expected, offset = [], [], 2            # line 1 is the header
    for k, h in enumerate(np.linspace(0.0, 1.0, 6)):
        with_runs = k in (0, 5)
        pts, _, runs = section_with_runs(h, 1, flank_run=False, clean=not with_runs)
        sections.append(pts)
        expected += [(str(k), offset + r["first"], offset + r["last"]) for r in runs]
        offset += len(pts)
    r = run("reconstruct", write_sections_csv(tmp_path / "edges.csv", sections), "--fair", "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    reported = json.loads(r.stdout)["fairing"]["runs"]
    assert sorted((x["section"], x["first_line"], x["last_line"]) for x in reported) == sorted(expected)
    for x in reported:
        assert min(x["chord_fraction"]) < 0.06 or max(x["chord_fraction"]) > 0.94      # at the edges
        assert 0.005 < x["displacement_mm"] < 0.035


@pytest.mark.parametrize("run,displacement", [((0, 1), 0.015), ((0, 1), 0.010), ((1, 2), 0.015), ((399, 0, 1), 0.010),
                                              ((0, 1), -0.010)])
def test_a_run_over_the_le_apex_is_found(run, displacement):
    """A run over the foremost point pulls the first edge model into another basin, where its
    worst point lies off the run (found 2026-11-27: 2 points 15 µm out on the apex went unseen
    while 30 µm, inward, 1 or 3 points were found); the runs over the tip are now also fitted
    from a start grown without the tip."""
    from bladerecon.core.sections.fairing import fair_section

    t = t_at_length_fraction(BLADE, 0.5, (0.37 + np.arange(400)) / 400)
    P = BLADE.point(0.5, t)
    N = in_plane_normal(0.5, t)
    Q = P.copy()
    idx = list(run)
    Q[idx] += displacement * N[idx]
    assert np.all(true_chord_fraction(0.5, P[idx]) < 0.005)          # on the LE arc, round the apex
    s = fair_section(Q)
    assert np.flatnonzero(s.bad).tolist() == sorted(idx)
    assert np.flatnonzero(s.by_edge_model).tolist() == sorted(idx)
    assert np.abs(s.faired[idx] - P[idx]).max() < 1e-3             # back on the true edge within 1 µm


def test_the_start_scans_cost_every_trial_as_the_model_does():
    """The start's joint scans evaluate all their trial geometries at once (``_costs``); each
    sum of squares must be the one ``_cost`` (``_model``) gives that trial alone, to 1e-12 (bit
    for bit on this machine; another numpy build may round a stacked product differently in the
    last bit): the scan keeps the first smallest, and a trial whose joint leaves a long flank
    has an ill-conditioned flank fit, where another solver moves the sum by far more than
    rounding (1e-7 relative, measured), enough to change the start chosen."""
    from bladerecon.core.sections import edge_bad_points as E

    points, _, _ = section_with_runs(0.5, 7, spacing="random", noise=0.002)
    o, axes, q = E.section_plane(points)
    rng = np.random.default_rng(7)
    for end in (0, 1):
        z = q[E.edge_zone(q, end)]
        tip = int(np.argmin(z[:, 0]) if end == 0 else np.argmax(z[:, 0]))
        area2 = np.sum(q[:, 0] * np.roll(q[:, 1], -1) - np.roll(q[:, 0], -1) * q[:, 1])
        sense = 1.0 if area2 > 0 else -1.0
        w = np.ones(len(z))
        w[tip + 1:tip + 4] = 0.0                      # a left-out run
        c, r, lo, hi = E._grown(z, w, tip - 1, tip + 1, 0.0015)
        g = np.array([c[0], c[1], r, np.arctan2(*(z[lo] - c)[::-1]), np.arctan2(*(z[hi] - c)[::-1])])
        for k in (0, 1):                              # a scan turns one joint, as _start's do
            trial = np.repeat(g[None, :], 48, axis=0)
            trial[:, 3 + k] += (1.0 if k else -1.0) * sense * np.linspace(-0.5, 0.5 * np.pi, 48)
            expected = [E._cost(z, w, t, sense, tip) for t in trial]
            np.testing.assert_allclose(E._costs(z, w, trial, sense, tip), expected, rtol=1e-12, atol=0)
        trial = g + rng.normal(0.0, [0.002, 0.002, 0.002, 0.3, 0.3], (24, 5))     # and all of it at random
        np.testing.assert_allclose(E._costs(z, w, trial, sense, tip), [E._cost(z, w, t, sense, tip) for t in trial],
                                   rtol=1e-12, atol=0)
