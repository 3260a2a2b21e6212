# SPDX-License-Identifier: LGPL-2.1-or-later
"""Section parameters against analytic sections with known answers and against the NASA tables."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.readers import read_points
from bladerecon.samples.blade import SampleBlade, sample_sections
from bladerecon.core.sections.parameters import fit_circle, measure_section, segment_sections
from bladerecon.core.sections.ordering import build_sections

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(__file__).resolve().parent / "data"
R37 = DATA / "nasa_rotor37" / "rotor37_sections_xyz_mm.txt"
R67 = DATA / "nasa_rotor67" / "rotor67_sections_xyz_mm.txt"

BLADES = {
    "default": SampleBlade(),
    # thin, small edges, negative stagger: another corner of the family
    "thin": SampleBlade(thickness_hub=0.05, thickness_tip=0.035, le_radius_hub=0.45, le_radius_tip=0.35,
                        te_radius_hub=0.3, te_radius_tip=0.25, stagger_hub=-20.0, twist=15.0, camber_hub=30.0,
                        camber_tip=20.0),
}


def _truth(blade: SampleBlade, h: float) -> dict:
    laws = blade.section_laws(h)
    le, te = blade.le_te(h)
    u = (te - le) / np.linalg.norm(te - le)
    return {"chord": float(laws.chord), "max_thickness": float(laws.max_thickness),
            "le_radius": float(laws.le_radius), "te_radius": float(laws.te_radius),
            "stagger": float(laws.stagger), "le": le, "te": te,
            "tmax_pos": float((blade.camber_point(h, blade.tmax_position) - le) @ u),
            "inlet": float(laws.stagger + laws.camber / 2), "outlet": float(laws.stagger - laws.camber / 2)}


def _measure(blade, n_points, layout, seed, strict=True):
    secs = sample_sections(blade, 6, n_points, layout, noise=0.002, seed=seed)
    segs = segment_sections(secs, np.array([0.0, 0.0, 1.0]), first_point_is_measured=(layout == "plan"))
    return [measure_section(s, (2.0,), strict_radius=strict) for s in segs]


@pytest.mark.parametrize("name", sorted(BLADES))
def test_dense_noisy_sections_give_the_known_parameters(name):
    """2000 points, 2 µm noise: chord 0.02 mm, t_max 5 µm, radii 5 %, stagger 0.05°."""
    blade = BLADES[name]
    for k, m in enumerate(_measure(blade, 2000, "uniform", seed=11)):
        tr = _truth(blade, k / 5)
        assert abs(m.chord - tr["chord"]) < 0.02
        assert abs(m.max_thickness - tr["max_thickness"]) < 0.005
        assert abs(m.le_radius / tr["le_radius"] - 1) < 0.05
        assert abs(m.te_radius / tr["te_radius"] - 1) < 0.05
        assert abs(m.stagger_deg - tr["stagger"]) < 0.05
        assert np.linalg.norm(m.le - tr["le"]) < 0.03 and np.linalg.norm(m.te - tr["te"]) < 0.03
        assert abs(m.max_thickness_pos - tr["tmax_pos"]) < 0.5      # flat maximum: position is soft
        assert abs(m.inlet_angle_deg - tr["inlet"]) < 0.3
        assert abs(m.outlet_angle_deg - tr["outlet"]) < 0.3
        # thickness 2 mm behind the LE: the inscribed circle there, against the analytic disk
        assert m.thickness_at["le+2"] is not None


@pytest.mark.parametrize("name", sorted(BLADES))
def test_sparse_plan_sections_give_chord_thickness_stagger(name):
    """~65 points (the measurement plan), 2 µm noise: chord 0.02 mm and stagger 0.05° on every section.

    The max thickness through 65 noisy points is noise-limited: the interpolant passes through
    the points, so t_max carries the normal noise of both sides (σ ≈ 2.8 µm). Over 4 noise
    draws x 6 sections at least 90 % must be within 5 µm and none beyond 8 µm (≈ 3σ).
    """
    blade = BLADES[name]
    errs = []
    for seed in range(4):
        for k, m in enumerate(_measure(blade, 65, "plan", seed=seed, strict=False)):
            tr = _truth(blade, k / 5)
            assert abs(m.chord - tr["chord"]) < 0.02
            assert abs(m.stagger_deg - tr["stagger"]) < 0.05
            errs.append(abs(m.max_thickness - tr["max_thickness"]))
    errs = np.array(errs)
    assert np.mean(errs < 0.005) >= 0.9 and errs.max() < 0.008


def test_thickness_at_offset_matches_the_disk_of_the_analytic_section():
    blade = SampleBlade()
    secs = sample_sections(blade, 6, 2000, "uniform", noise=0.0, seed=2)
    seg = segment_sections(secs, np.array([0.0, 0.0, 1.0]), False)[2]
    m = measure_section(seg, (5.0,))
    # the analytic disk whose centre is 5 mm along the chord from the LE
    h = 0.4
    le, te = blade.le_te(h)
    u = (te - le) / np.linalg.norm(te - le)
    xi = np.linspace(0, 1, 20001)
    x = (blade.camber_point(h, xi) - le) @ u
    want = 2 * blade.half_thickness(h, xi[np.argmin(np.abs(x - 5.0))])
    assert abs(m.thickness_at["le+5"] - want) < 0.003


def test_circle_fit_is_exact_on_a_circle_arc():
    a = np.linspace(0.3, 2.5, 9)
    c, r, rms = fit_circle(np.column_stack([3 + 0.7 * np.cos(a), -1 + 0.7 * np.sin(a)]))
    assert np.allclose(c, [3, -1], atol=1e-10) and abs(r - 0.7) < 1e-10 and rms < 1e-10


def test_two_or_three_points_on_an_edge_circle_still_give_its_radius():
    """Issue 24 §3: a plan of 30 points (2-3 on each edge circle) gives both radii (never null):
    the flanks' G1 condition carries the fit. Within 6 % of the analytic radius, saying how
    many arc and flank points it used."""
    blade = SampleBlade()
    secs = sample_sections(blade, 2, 30, "plan", noise=0.0, seed=0)
    for k, seg in enumerate(segment_sections(secs, np.array([0.0, 0.0, 1.0]), True)):
        m = measure_section(seg)
        tr = _truth(blade, k)
        assert abs(m.le_radius / tr["le_radius"] - 1) < 0.06 and abs(m.te_radius / tr["te_radius"] - 1) < 0.06
        assert 1 <= m.le_fit["arc_points"] <= 4 and min(m.le_fit["flank_points"]) >= 2 and not m.warnings


def _nasa_sections(path):
    ss = build_sections(read_points(path))
    return [s.points for s in ss.sections], ss.span_axis


@pytest.mark.parametrize("path,n_sections", [(R37, 13), (R67, 14)])
def test_nasa_rotor_parameter_table(path, n_sections):
    """Every section gets a table row; LE/TE agree with the table's own LE/TE points (J=1 and the last J)."""
    pts, axis = _nasa_sections(path)
    assert len(pts) == n_sections
    segs = segment_sections(pts, axis, True)
    rows = [measure_section(s, strict_radius=False) for s in segs]
    raw = read_points(path)
    for k, (m, p) in enumerate(zip(rows, pts)):
        file_pts = raw.section_points(k)
        le_file = file_pts[0]
        # the table's TE is the point farthest from its LE
        te_file = file_pts[np.argmax(np.linalg.norm(file_pts - le_file, axis=1))]
        assert np.linalg.norm(m.le - le_file) < 1.0, k
        assert np.linalg.norm(m.te - te_file) < 1.0, k
        assert abs(m.chord / np.linalg.norm(te_file - le_file) - 1) < 0.01, k
        assert 0.01 * m.chord < m.max_thickness < 0.12 * m.chord, k
        assert 0.1 < m.max_thickness_pos_frac < 0.9, k
    t = np.array([m.max_thickness for m in rows])
    assert t[0] > t[len(t) // 2] > t[-3]          # thick at the hub, thin at the tip


def _cli(*args):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "bladerecon", *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=600)


def test_cli_sections_json_keys_and_plots(tmp_path):
    r = _cli("sections", ROOT / "resources" / "sample" / "measured.csv", "--plots", tmp_path / "plots", "--json",
             "--quiet")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert len(rows) == 6
    for key in ("index", "points", "le", "te", "chord", "stagger_deg", "max_thickness", "max_thickness_pos",
                "le_radius", "te_radius", "inlet_angle_deg", "outlet_angle_deg"):
        assert key in rows[0]
    tr = _truth(SampleBlade(), 0.0)
    assert abs(rows[0]["chord"] - tr["chord"]) < 0.02 and rows[0]["points"] == 2000
    assert len(list((tmp_path / "plots").glob("section_*.png"))) == 6


def test_cli_sections_with_step_nominal_gives_small_differences():
    r = _cli("sections", ROOT / "resources" / "sample" / "measured.csv", "--nominal",
             ROOT / "resources" / "sample" / "nominal.step", "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    for row in rows:
        d = row["difference"]
        assert abs(d["chord"]) < 0.02 and abs(d["max_thickness"]) < 0.005 and abs(d["stagger_deg"]) < 0.05
        assert abs(d["le_radius"]) < 0.05 * row["nominal"]["le_radius"]
        assert row["nominal"]["points"] > 900          # the nominal cut is dense


def test_cli_sparse_edges_give_radii_with_their_evidence(tmp_path):
    secs = sample_sections(SampleBlade(), 2, 30, "plan", noise=0.0, seed=0)
    f = tmp_path / "sparse.csv"
    lines = ["section,x,y,z"] + [f"{k},{x},{y},{z}" for k, p in enumerate(secs) for x, y, z in p]
    f.write_text("\n".join(lines) + "\n")
    r = _cli("sections", f, "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    for row in json.loads(r.stdout):
        assert row["le_radius"] > 0 and row["te_radius"] > 0
        assert row["le_fit"]["arc_points"] >= 1 and len(row["te_fit"]["flank_points"]) == 2


@pytest.mark.parametrize("path", [R37, R67])
def test_nasa_stream_surface_sections_are_measured_across_the_span_axis(path):
    """Non-planar sections are projected along the span axis (a best-fit plane would lean with
    the twist: 20° off at the Rotor 67 tip). Stagger and in-plane chord agree with the table's
    own LE (J=1) and TE (farthest point) seen in that projection: 0.5°, 0.3 mm."""
    pts, axis = _nasa_sections(path)
    raw = read_points(path)
    for k, seg in enumerate(segment_sections(pts, axis, True)):
        m = measure_section(seg, strict_radius=False)
        fp = raw.section_points(k)
        le_f, te_f = fp[0], fp[np.argmax(np.linalg.norm(fp - fp[0], axis=1))]
        d = seg.frame.to_plane(te_f[None])[0] - seg.frame.to_plane(le_f[None])[0]
        assert abs(m.stagger_deg - np.degrees(np.arctan2(d[1], d[0]))) < 0.5, k
        assert abs(m.chord_in_plane - np.linalg.norm(d)) < 0.3, k
        assert abs(seg.frame.normal @ axis) > 0.999999          # the projection is along the span axis


def test_cli_sections_with_a_section_file_nominal_and_throat(tmp_path):
    """Nominal as a dense section file (noise-free, 3000 points a section); throat from eq. 5."""
    secs = sample_sections(SampleBlade(), 6, 3000, "uniform", noise=0.0, seed=9)
    f = tmp_path / "nominal.csv"
    lines = ["section,x,y,z"] + [f"{k},{x},{y},{z}" for k, p in enumerate(secs) for x, y, z in p]
    f.write_text("\n".join(lines) + "\n")
    r = _cli("sections", ROOT / "resources" / "sample" / "measured.csv", "--nominal", f, "--beta1", "45",
             "--beta2", "15", "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    for row in rows:
        d = row["difference"]
        assert abs(d["chord"]) < 0.02 and abs(d["max_thickness"]) < 0.005 and abs(d["stagger_deg"]) < 0.05
        assert d["le_shift"] < 0.03 and d["te_shift"] < 0.03
        th = row["throat"]
        assert th["width"] > 0 and abs(th["ratio"] - 1 / (2 * np.cos(np.radians(15)) ** 2 *
                                                          (np.tan(np.radians(45)) - np.tan(np.radians(15))))) < 1e-9


# ---------------------------------------------------------------- issue 24: edge radii and gauges
ISSUE24 = {**BLADES, "small": SampleBlade(chord_hub=40.0, chord_tip=32.0, le_radius_hub=0.55, le_radius_tip=0.3,
                                          te_radius_hub=0.4, te_radius_tip=0.25, thickness_hub=0.06,
                                          thickness_tip=0.05)}


def _even_sections(blade, n, noise, seed):
    """n points a section equally spaced in arc length from a random start, noise σ per coordinate."""
    from bladerecon.samples.blade import section_heights, t_at_length_fraction
    rng = np.random.default_rng(seed)
    out = []
    for h in section_heights(6):
        p = blade.point(h, t_at_length_fraction(blade, h, (rng.random() + np.arange(n)) / n))
        out.append(p + noise * rng.standard_normal(p.shape))
    return out


def _radius_errors(blade, n, noise, seed):
    from bladerecon.core.sections.parameters import segment_blade
    segs = segment_blade(_even_sections(blade, n, noise, seed), np.array([0.0, 0.0, 1.0]),
                         flow=np.array([1.0, 0.0, 0.0])).sections
    errs = []
    for k, seg in enumerate(segs):
        m = measure_section(seg)
        tr = _truth(blade, k / 5)
        errs += [abs(m.le_radius / tr["le_radius"] - 1), abs(m.te_radius / tr["te_radius"] - 1)]
    return np.array(errs)


@pytest.mark.timeout(180)
def test_edge_radii_at_400_noisy_points_and_120_exact_points():
    """Issue 24 §3 against the analytic radii: 400 points with 2 µm noise, 3 draws: ≤ 0.5 % on the
    default blade, ≤ 1 % on the thin and small-edged ones (measured worst 0.93 %); 120 exact
    points: ≤ 1 % on all three (measured worst 0.42 %)."""
    for name, blade in ISSUE24.items():
        noisy = np.concatenate([_radius_errors(blade, 400, 0.002, seed) for seed in range(3)])
        assert noisy.max() <= (0.005 if name == "default" else 0.01), (name, noisy.max())
        exact = _radius_errors(blade, 120, 0.0, 0)
        assert exact.max() <= 0.01, (name, exact.max())


def test_gauges_against_the_analytic_section():
    """Thickness at chord fractions (camber-normal: the generator's disk at that chordwise position),
    LE/TE on the camber line, area and centroid (dense true polygon), twist and stacking."""
    from bladerecon.core.sections.parameters import segment_blade, stacking
    from bladerecon.samples.blade import section_heights, t_at_length_fraction
    blade = SampleBlade()
    secs = sample_sections(blade, 6, 2000, "uniform", noise=0.0, seed=4)
    segs = segment_blade(secs, np.array([0.0, 0.0, 1.0]), flow=np.array([1.0, 0.0, 0.0])).sections
    params = [measure_section(s, fractions=(0.2, 0.5, 0.8)) for s in segs]
    xi = np.linspace(0.0, 1.0, 20001)
    for h, m in zip(section_heights(6), params):
        tr = _truth(blade, h)
        u = (tr["te"] - tr["le"]) / np.linalg.norm(tr["te"] - tr["le"])
        xc = (blade.camber_point(h, xi) - tr["le"]) @ u
        for f in (0.2, 0.5, 0.8):
            t_true = 2 * np.interp(f * tr["chord"], xc, blade.half_thickness(h, xi))
            assert abs(m.gauges["thickness_at_fraction"][f"{f:g}"] - t_true) < 2e-4
            assert m.gauges["thickness_at_fraction_chord_normal"][f"{f:g}"] >= t_true - 2e-4
        for end, x0, r in (("le_camber", 0.0, tr["le_radius"]), ("te_camber", 1.0, tr["te_radius"])):
            c0, c1 = blade.camber_point(h, x0), blade.camber_point(h, x0 + (1e-6 if x0 == 0 else -1e-6))
            tan = (c1 - c0) / np.linalg.norm(c1 - c0)          # into the blade
            assert np.linalg.norm(np.array(m.gauges[end]) - (c0 - r * tan)) < 2e-3
        dense = blade.point(h, t_at_length_fraction(blade, h, np.arange(40000) / 40000))
        x, y = dense[:, 0], dense[:, 1]
        cr = x * np.roll(y, -1) - np.roll(x, -1) * y
        area = 0.5 * cr.sum()
        cen = np.array([((x + np.roll(x, -1)) * cr).sum(), ((y + np.roll(y, -1)) * cr).sum()]) / (6 * area)
        assert abs(m.gauges["area"] / abs(area) - 1) < 1e-5
        assert np.linalg.norm(np.array(m.gauges["centroid"][:2]) - cen) < 1e-3
    st = stacking(params, np.array([0.0, 0.0, 1.0]))
    laws = blade.section_laws(section_heights(6))
    for s, tw in zip(st, laws.stagger - laws.stagger[0]):
        assert abs(s["twist_deg"] - tw) < 0.02


def _stadium(z, a=1.2, b=0.5, length=30.0):
    """A closed ccw profile (n, 3) with known edges: elliptic LE (semi-axes a along the chord,
    b across), straight flanks bent by a slight camber, semicircular TE of radius b."""
    xs = np.linspace(a, length, 300, endpoint=False)
    te = np.linspace(-np.pi / 2, np.pi / 2, 80, endpoint=False)
    le = np.linspace(np.pi / 2, 3 * np.pi / 2, 121)[1:-1]
    p = np.vstack([np.column_stack([xs, np.full(xs.size, -b)]),
                   np.column_stack([length + b * np.cos(te), b * np.sin(te)]),
                   np.column_stack([xs[::-1], np.full(xs.size, b)]),
                   np.column_stack([a + a * np.cos(le), b * np.sin(le)])])
    bend = 0.02 * p[:, 0] * (length - p[:, 0]) / length      # a camber that moves both sides alike
    return np.column_stack([p[:, 0], p[:, 1] + bend, np.full(len(p), z)])


def test_an_elliptic_edge_is_reported_not_round_and_a_round_one_is_not():
    """Issue 24 §3, edge shape: the arc points of an elliptic LE scatter far beyond the flanks'
    noise, which `warnings` says; the semicircular TE (r 0.5 mm) is measured within 0.5 % and
    not flagged."""
    from bladerecon.core.sections.parameters import segment_blade
    secs = [_stadium(z) for z in (0.0, 10.0)]
    segs = segment_blade(secs, np.array([0.0, 0.0, 1.0]), flow=np.array([1.0, 0.0, 0.0])).sections
    for seg in segs:
        m = measure_section(seg)
        assert any("leading edge is not a circle" in w for w in m.warnings)
        assert not any("trailing edge is not a circle" in w for w in m.warnings)
        assert abs(m.te_radius / 0.5 - 1) < 0.005
        assert m.le_fit["rms"] > 4 * m.le_fit["flank_rms"]
