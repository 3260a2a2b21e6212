# SPDX-License-Identifier: LGPL-2.1-or-later
"""``bladerecon blisk``: a synthetic blisk from the sample blade (N = 24, per-blade normal
offsets, one blade 0.2° out of pitch, 2 µm noise) split, compared and every blade's pitch
error recovered within 0.01°; the sector split and the position errors against the truth
the generator returns."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bladerecon.core.analysis.alignment import apply_transform, rotation_about
from bladerecon.core.io.readers import write_points_csv
from bladerecon.core.lot.blisk import point_angles, position_errors, split_sectors
from bladerecon.samples.blisk import HUB_RADIUS, blisk_nominal_surface, blisk_scan

ROOT = Path(__file__).resolve().parents[1]
Z = np.array([0.0, 0.0, 1.0])


def run(*args, timeout=300):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "bladerecon", *map(str, args)], capture_output=True,
                          text=True, env=env, timeout=timeout)


# --------------------------------------------------------------------------- core (numpy only)
def test_sectors_hold_each_generated_blade():
    scan = blisk_scan(24, n_sections=3, n_points=60, pitch_errors={5: 0.2}, seed=2)
    blade0 = float(np.degrees(np.arctan2(0.0, HUB_RADIUS + 50.0)))
    got = split_sectors(scan.points, Z, 24, blade0)
    assert np.array_equal(got, scan.section // 3)
    assert np.allclose(point_angles(np.array([[0.0, 1.0, 5.0]]), Z), 90.0)


def test_position_errors_of_known_motions():
    c = np.array([HUB_RADIUS + 50.0, 0.0, 0.0])
    pitch = position_errors(rotation_about(Z, 0.2), c, Z)
    assert pitch["pitch_deg"] == pytest.approx(0.2, abs=1e-12)
    assert abs(pitch["stagger_deg"]) < 1e-12 and abs(pitch["radial_mm"]) < 1e-9
    turn = position_errors(rotation_about((1.0, 0.0, 0.0), 0.3, c), c, Z)     # about the radial line
    assert turn["stagger_deg"] == pytest.approx(0.3, abs=1e-12) and abs(turn["pitch_deg"]) < 1e-12
    shift = np.eye(4)
    shift[:3, 3] = (0.05, 0.0, 0.02)
    moved = position_errors(shift, c, Z)
    assert moved["radial_mm"] == pytest.approx(0.05) and moved["axial_mm"] == pytest.approx(0.02)


# --------------------------------------------------------------------------- the command
@pytest.fixture(scope="module")
def blisk_files(tmp_path_factory):
    from fc_fixtures import require_freecad

    require_freecad()
    from bladerecon.fc.convert import make_face
    from bladerecon.fc.export import write_step

    folder = tmp_path_factory.mktemp("blisk")
    scan = blisk_scan(24, n_sections=4, n_points=100, noise=0.002, pitch_errors={7: 0.2}, seed=3)
    write_points_csv(folder / "scan.csv", scan.points, scan.section)
    write_step(make_face(blisk_nominal_surface()), str(folder / "blade0.step"))
    return folder, scan


@pytest.mark.timeout(300)
def test_blisk_recovers_every_pitch_error(blisk_files, tmp_path):
    folder, scan = blisk_files
    out = tmp_path / "out"
    r = run("blisk", folder / "scan.csv", "--nominal", folder / "blade0.step", "--blades", 24, "-o", out,
            "--workers", 2, "--json")
    assert r.returncode == 0, r.stderr
    data = json.loads((out / "lot" / "lot.json").read_text())
    assert data["blisk"]["blades"] == 24 and data["lot"]["ok"] == 24
    pitch = np.array([b["position"]["pitch_deg"] for b in data["blades"]])
    assert np.all(np.abs(pitch - scan.pitch_error_deg) < 0.01), pitch - scan.pitch_error_deg
    stagger = np.array([b["position"]["stagger_deg"] for b in data["blades"]])
    assert np.all(np.abs(stagger) < 0.01), stagger                       # none was turned
    means = np.array([b["stats"]["mean"] for b in data["blades"]])
    other = np.arange(24) != 7                                           # its pitch error is a deviation too
    assert np.allclose(means[other], scan.offset_mm[other], atol=0.0015)  # each blade's own offset
    st = data["statistics"]["position.pitch_deg"]
    assert st["worst"][0]["blade"] == "blade_07" and st["max"] == pytest.approx(0.2, abs=0.01)
    # blade 7's file holds its points turned back by 7 * 15°, i.e. near blade 0's place
    P = np.loadtxt(out / "scan" / "blade_07.csv", delimiter=",", skiprows=1)[:, 1:]
    k7 = apply_transform(scan.points[scan.section // 4 == 7], rotation_about(Z, -105.0))
    assert np.allclose(np.sort(P[:, 0]), np.sort(k7[:, 0]))


def test_blisk_with_empty_sectors_names_them(blisk_files, tmp_path):
    folder, scan = blisk_files
    two = scan.section // 4 < 2                                   # only blades 0 and 1 scanned
    write_points_csv(tmp_path / "two.csv", scan.points[two], scan.section[two])
    r = run("blisk", tmp_path / "two.csv", "--nominal", folder / "blade0.step", "--blades", 24, "-o", tmp_path / "o",
            "--workers", 2, timeout=300)
    assert r.returncode == 2 and "22 of 24 sectors hold no points" in r.stderr and "Traceback" not in r.stderr
    data = json.loads((tmp_path / "o" / "lot" / "lot.json").read_text())
    assert [b["blade"] for b in data["blades"]] == ["blade_00", "blade_01"]
    assert data["blisk"]["empty_sectors"][0] == "blade_02"


def test_example_scan_is_the_generators():
    """resources/blisk/points.csv is what tools/make_blisk_example.py's generator call gives."""
    from bladerecon.core.io.readers import read_points

    scan = blisk_scan(12, n_sections=4, n_points=50, pitch_errors={5: 0.2}, seed=3)
    ps = read_points(ROOT / "resources" / "blisk" / "points.csv")
    assert np.allclose(ps.points, scan.points, atol=6e-7)
    assert [int(ps.section_names[i]) for i in ps.section] == scan.section.tolist()


def test_sectors_about_the_x_axis():
    """The same blisk turned so that its axis is x: the split about --axis x is the same."""
    scan = blisk_scan(12, n_sections=2, n_points=40, seed=4)
    z_to_x = rotation_about((1.0, 1.0, 1.0), 120.0)            # x -> y -> z -> x: the z axis becomes x
    P = apply_transform(scan.points, z_to_x)
    X = np.array([1.0, 0.0, 0.0])
    blade0 = float(point_angles(apply_transform(np.array([[HUB_RADIUS + 50.0, 0.0, 0.0]]), z_to_x), X)[0])
    assert np.array_equal(split_sectors(P, X, 12, blade0), scan.section // 2)
