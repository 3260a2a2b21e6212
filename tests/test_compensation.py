# SPDX-License-Identifier: LGPL-2.1-or-later
"""Probe-radius and coating compensation (issue 16 item 5): touch-probe ball centres simulated
from the analytic blade (in each section plane the centre path is the profile's offset curve)
come back onto the true profile; the commands take --probe-radius / --coating; what cannot be a
ball path is refused in one line."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.readers import PointSet
from bladerecon.core.sections.ordering import build_sections
from bladerecon.core.surface.compensation import compensate_sections
from bladerecon.samples.blade import SampleBlade, section_heights, t_at_length_fraction
from cli_run import run
from section_files import write_sections_csv

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "resources" / "sample"
BLADE = SampleBlade()


def _in_plane_normal(blade, h, t):
    n = blade.normal(h, t)
    n = n - np.outer(n[:, 2], [0.0, 0.0, 1.0])            # the sections lie in planes z = const
    return n / np.linalg.norm(n, axis=1)[:, None]


def ball_centres(blade, radius, n_points, plan_weight=1.0, noise=0.0, n_sections=6, seed=0):
    """Per section: centres of a ball of ``radius`` touching the profile at ``n_points`` plan
    points (``plan_weight`` 0: even in arc length), and a dense true profile."""
    rng = np.random.default_rng(seed)
    centres, truth = [], []
    for h in section_heights(n_sections):
        t = t_at_length_fraction(blade, h, np.arange(n_points) / n_points, plan_weight)
        c = blade.point(h, t) + radius * _in_plane_normal(blade, h, t)
        centres.append(c + noise * rng.standard_normal(c.shape))
        truth.append(blade.point(h, t_at_length_fraction(blade, h, np.arange(200_000) / 200_000)))
    return centres, truth


def _set(sections) -> PointSet:
    P = np.concatenate(sections)
    sec = np.repeat(np.arange(len(sections)), [len(s) for s in sections])
    return PointSet(P, sec, np.arange(len(P)) + 1, tuple(str(k) for k in range(len(sections))), "sim", "csv")


def _errors(ss, truth) -> np.ndarray:
    return np.concatenate([cKDTree(T).query(s.points)[0] for s, T in zip(ss.sections, truth)])


@pytest.mark.parametrize("blade, radius, n_points", [
    (BLADE, 1.5, 200),                                                   # LE 0.7-0.9, TE 0.45-0.6 mm
    (SampleBlade(le_radius_hub=0.3, le_radius_tip=0.3), 0.5, 100),        # a 0.3 mm LE, a 100-point plan
])
def test_ball_centres_come_back_onto_the_profile_edges_included(blade, radius, n_points):
    centres, truth = ball_centres(blade, radius, n_points)
    ss = build_sections(_set(centres))
    before = _errors(ss, truth)
    assert np.allclose(before, radius, atol=1e-6)                        # the simulation is what it says
    err = _errors(compensate_sections(ss, probe_radius=radius), truth)
    assert err.max() < 0.002, err.max()                                  # issue 16: within 2 µm


def test_coating_and_probe_add_up():
    centres, truth = ball_centres(BLADE, 1.5, 200)
    ss = build_sections(_set(centres))
    a = compensate_sections(ss, probe_radius=1.0, coating=0.5)
    b = compensate_sections(ss, probe_radius=1.5)
    assert all(np.allclose(x.points, y.points) for x, y in zip(a.sections, b.sections))
    assert compensate_sections(ss) is ss


def test_noise_is_not_amplified_on_dense_sections():
    """2000 points a section with 2 µm noise: the compensated points are as far from the profile
    as the noise puts them, no farther (the normals come from the smoothed section curve)."""
    centres, truth = ball_centres(BLADE, 1.5, 2000, plan_weight=0.0, noise=0.002, seed=3)
    ss = build_sections(_set(centres))
    exact, _ = ball_centres(BLADE, 1.5, 2000, plan_weight=0.0, seed=3)
    noise_only = np.concatenate([cKDTree(np.concatenate(exact)).query(s.points)[0] for s in ss.sections])
    err = _errors(compensate_sections(ss, probe_radius=1.5), truth)
    assert np.sqrt(np.mean(err ** 2)) < 1.2 * np.sqrt(np.mean(noise_only ** 2)) + 2e-4, \
        (np.sqrt(np.mean(err ** 2)), np.sqrt(np.mean(noise_only ** 2)))


def test_a_path_tighter_than_the_ball_is_refused():
    centres, _ = ball_centres(BLADE, 0.5, 200)        # TE path radius 0.45-0.6 + 0.5 mm
    ss = build_sections(_set(centres))
    with pytest.raises(BladeReconError, match=r"section '\d', line \d+: the measured path turns with a radius"):
        compensate_sections(ss, probe_radius=2.0)
    with pytest.raises(BladeReconError, match="zero or positive"):
        compensate_sections(ss, probe_radius=-1.0)


def test_sections_off_a_plane_are_refused():
    centres, _ = ball_centres(BLADE, 0.5, 100)
    bent = [np.array(c) for c in centres]
    bent[2] = bent[2] + np.c_[np.zeros(len(bent[2])), np.zeros(len(bent[2])), 0.002 * bent[2][:, 0] ** 2]
    ss = build_sections(_set(bent))
    with pytest.raises(BladeReconError, match="section '2' is not planar"):
        compensate_sections(ss, probe_radius=0.5)


@pytest.fixture(scope="module")
def balls(tmp_path_factory):
    """Ball centres (R = 1.5 mm, 6 sections of a 200-point plan) of the sample blade, whose true
    surface is resources/sample/nominal.step."""
    centres, _ = ball_centres(BLADE, 1.5, 200)
    return write_sections_csv(tmp_path_factory.mktemp("balls") / "balls.csv", centres)


def test_reconstruct_with_probe_radius_lands_on_the_nominal(balls, tmp_path):
    out = {}
    for name, opts in (("raw", []), ("probe", ["--probe-radius", "1.5"]), ("split", ["--probe-radius", "1",
                                                                                     "--coating", "0.5"])):
        r = run("reconstruct", balls, "-o", tmp_path / f"{name}.step", "--nominal", SAMPLE / "nominal.step",
                "--json", "--quiet", *opts)
        assert r.returncode == 0, r.stderr
        out[name] = json.loads(r.stdout)
    assert 1.4 < out["raw"]["nominal"]["mean"] < 1.6 and "compensation" not in out["raw"]
    assert out["probe"]["nominal"]["max"] < 0.005 and out["probe"]["nominal"]["mean"] < 0.001
    assert out["probe"]["compensation"] == {"probe_radius_mm": 1.5, "coating_mm": 0.0, "offset_mm": 1.5,
                                            "normals": "section curve"}
    assert out["split"]["nominal"]["max"] == out["probe"]["nominal"]["max"]


def test_deviation_and_sections_with_probe_radius(balls):
    raw = json.loads(run("deviation", balls, "--nominal", SAMPLE / "nominal.step", "--json", "--quiet").stdout)
    r = run("deviation", balls, "--nominal", SAMPLE / "nominal.step", "--json", "--quiet", "--probe-radius", "1.5")
    assert r.returncode == 0, r.stderr
    comp = json.loads(r.stdout)
    assert raw["mean"] > 1.4 and comp["max_abs"] < 0.002 and comp["compensation"]["normals"] == "section curve"
    r = run("sections", balls, "--json", "--quiet", "--flow", "1,0,0", "--probe-radius", "1.5")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    laws = BLADE.section_laws(section_heights(6))
    le = np.array([o["le_radius"] for o in rows])
    te = np.array([o["te_radius"] for o in rows])
    assert np.abs(le - laws.le_radius).max() < 0.005 and np.abs(te - laws.te_radius).max() < 0.005, (le, te)
    assert rows[0]["compensation"]["offset_mm"] == 1.5


def test_a_cloud_is_compensated_along_the_nominal_normals(tmp_path):
    """No sections: each point moves along the nominal's normal at its foot (a coating on a scan)."""
    P = []
    for h in np.linspace(0.0, 1.0, 21):
        t = t_at_length_fraction(BLADE, h, np.arange(200) / 200)
        P.append(BLADE.point(h, t) + 0.05 * BLADE.normal(h, t))       # a 0.05 mm coating over the blade
    P = np.concatenate(P)
    f = tmp_path / "coated.xyz"
    f.write_text("".join(f"{float(x)!r} {float(y)!r} {float(z)!r}\n" for x, y, z in P))
    r = run("deviation", f, "--nominal", SAMPLE / "nominal.step", "--json", "--quiet", "--coating", "0.05")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["compensation"]["normals"] == "nominal" and out["max_abs"] < 0.001


def test_bad_values_and_non_planar_sections_are_one_line(balls):
    for opts in (["--probe-radius", "-1"], ["--coating", "nan"], ["--probe-radius", "3"]):
        r = run("deviation", balls, "--nominal", SAMPLE / "nominal.step", "--quiet", *opts)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr, r.stderr
    r = run("reconstruct", ROOT / "tests" / "data" / "parablade_r67_cloud" / "NASA_R67_MoveSurface.txt",
            "--cloud-scale", "1000", "--slice-radii", "150.8,179.6,208.6", "--slab", "12", "--slab-keep", "--quiet",
            "--probe-radius", "0.5")
    assert r.returncode == 2 and "not planar" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_compensation_with_a_crop(balls):
    """--span-range with --probe-radius: each section is compensated whole, then cropped."""
    r = run("deviation", balls, "--nominal", SAMPLE / "nominal.step", "--json", "--quiet", "--probe-radius", "1.5",
            "--span-range", "10:90")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["max_abs"] < 0.002 and out["cropped"]["points_kept"] == 4 * 200
