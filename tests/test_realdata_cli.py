# SPDX-License-Identifier: LGPL-2.1-or-later
"""reconstruct --fair / --poles / --slice-radii as a user runs them (JSON summary, errors)."""
from __future__ import annotations

import json

import numpy as np

from bladerecon.core.io.readers import write_points_csv
from realdata_fixtures import RUNS, clean_section, nongrid_counts, nongrid_rows, with_bad_runs
from test_cli import DATA, run

R67_CLOUD = DATA / "parablade_r67_cloud" / "NASA_R67_MoveSurface.txt"


def _bad_file(path, shuffle_section=None):
    pts, sec, injected = [], [], []
    for k, h in enumerate(np.linspace(0.0, 1.0, 6)):
        c, nrm, _ = clean_section(h, 300, start=0.011 + 0.01 * k)
        inj = np.zeros(len(c), dtype=bool)
        if k in (1, 4):
            c, inj = with_bad_runs(c, nrm)
        pts.append(c)
        sec.append(np.full(len(c), k))
        injected += [[k, int(i)] for i in np.flatnonzero(inj)]
    write_points_csv(path, np.concatenate(pts), np.concatenate(sec))
    return injected


def test_fair_reports_every_replaced_point(tmp_path):
    injected = _bad_file(tmp_path / "bad.csv")
    r = run("reconstruct", tmp_path / "bad.csv", "--fair", "--json", "--quiet", "--report", tmp_path / "rep")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    f = s["fairing"]
    assert [[a, b] for a, b, _ in f["replaced"]] == injected
    disp = {(a, b): d for a, b, d in f["replaced"]}
    for k in (1, 4):
        for frac, n, dd in RUNS:
            i = int(frac * 300)
            for j in range(i, i + n):
                assert abs(disp[(k, j)] - abs(dd)) < 0.003
    assert f["inflections_after"] == [2] * 6
    assert f["inflections_before"][1] > 10 and f["inflections_before"][4] > 10
    assert s["fit"]["max"] < 0.001                  # the faired points are fitted
    table = np.genfromtxt(tmp_path / "rep" / "faired_points.csv", delimiter=",", names=True)
    assert len(table) == 1800 and int(table["bad"].sum()) == len(injected)
    moved = table["bad"] == 1
    orig = np.c_[table["x"], table["y"], table["z"]]
    new = np.c_[table["x_faired"], table["y_faired"], table["z_faired"]]
    assert np.allclose(np.linalg.norm(orig - new, axis=1), table["displacement"], atol=2e-6)
    assert np.all(table["displacement"][~moved] == 0)
    for key in ("sections", "surface"):
        assert key in s["fairness"]
    assert s["fairness"]["sections"]["inflections"] == [2] * 6


def test_fair_refuses_a_gross_move(tmp_path):
    c, nrm, _ = clean_section(0.5, 300)
    c2, _, _ = clean_section(0.0, 300)
    c = c.copy()
    c[50] += 1.0 * nrm[50]
    write_points_csv(tmp_path / "g.csv", np.r_[c2, c], np.r_[np.zeros(300), np.ones(300)])
    r = run("reconstruct", tmp_path / "g.csv", "--fair", "--fair-limit", "0.3")
    assert r.returncode == 2
    assert "fairing refused: section 1, point 50 would move" in r.stderr
    r = run("reconstruct", tmp_path / "g.csv", "--fair-threshold", "0.01")
    assert r.returncode == 2 and "add one of them" in r.stderr and "--fair-surface" in r.stderr


def test_poles_fits_non_grid_rows(tmp_path):
    counts = nongrid_counts()
    rows, _ = nongrid_rows(counts, closed=True)
    write_points_csv(tmp_path / "rows.csv", np.concatenate(rows), np.repeat(np.arange(21), counts))
    r = run("reconstruct", tmp_path / "rows.csv", "--method", "approximate", "--poles", "24x9", "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["input"]["points"] == 2255 and s["input"]["sections"] == 21
    assert (s["surface"]["u_poles"], s["surface"]["v_poles"]) == (24, 9)
    assert s["surface"]["method"] == "approximate-nongrid"
    r = run("reconstruct", tmp_path / "rows.csv", "--poles", "24x9")
    assert r.returncode == 2 and "--method approximate" in r.stderr


def test_slice_the_rotor67_cloud_by_cylinders(tmp_path):
    radii = "150,165,180,194,208.5,222.5,237"
    r = run("reconstruct", R67_CLOUD, "--cloud-scale", "1000", "--slice-radii", radii, "--slab", "12",
            "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["slicing"]["kind"] == "cylinders" and len(s["slicing"]["points"]) == 7
    assert s["input"]["sections"] == 7 and min(s["slicing"]["points"]) >= 100
    r = run("reconstruct", R67_CLOUD, "--cloud-scale", "1000", "--slice-radii", "150,200", "--slab", "0.01")
    assert r.returncode == 2 and "needs at least" in r.stderr


def test_local_bicubic_writes_a_sewn_shell(tmp_path):
    from test_cli import SAMPLE
    r = run("reconstruct", SAMPLE / "measured_plan.csv", "--surface", "local-bicubic", "--patches-around", "80",
            "-o", tmp_path / "lb.step", "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["surface"]["method"] == "local-bicubic" and s["surface"]["u_poles"] == 160
    from bladerecon.fc.freecad_env import import_freecad
    import_freecad()
    from bladerecon.fc.export import read_shape
    shape = read_shape(str(tmp_path / "lb.step"))
    assert len(shape.Faces) == 80 * 5 and len(shape.Shells) == 1
    r = run("reconstruct", SAMPLE / "measured_plan.csv", "--surface", "local-bicubic", "--solid", "-o", tmp_path / "x.step")
    assert r.returncode == 2 and "sewn shell" in r.stderr


def test_slice_a_plain_cloud_by_planes(tmp_path):
    from realdata_fixtures import BLADE
    rng = np.random.default_rng(5)
    pts = BLADE.point(rng.random(60000), rng.random(60000))
    far = np.array([[80.0, 80.0, 50.0]])                       # one stray point in the 50 mm slab
    np.savetxt(tmp_path / "cloud.xyz", np.vstack([pts, far]), fmt="%.6f")
    r = run("reconstruct", tmp_path / "cloud.xyz", "--slice-at", "10,30,50,70,90", "--slab", "0.5", "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["input"]["sections"] == 5 and s["slicing"]["kind"] == "planes"
    assert s["slicing"]["outliers"] == [[2, 60001]]            # slice 2, file line of the stray point
    r = run("reconstruct", tmp_path / "cloud.xyz", "--slice", "4", "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["input"]["sections"] == 4
    r = run("reconstruct", tmp_path / "cloud.xyz", "--slice-at", "10,150")
    assert r.returncode == 2 and "slice at 150.0000 mm: 0 points" in r.stderr
