# SPDX-License-Identifier: LGPL-2.1-or-later
"""The headless command as a user runs it: JSON summary, bad input, no half-written outputs."""
from __future__ import annotations

import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "resources" / "sample"
DATA = ROOT / "tests" / "data"


def run(*args, cwd=None):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "bladerecon", *map(str, args)], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=600)


def digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    before = digest(SAMPLE / "measured.csv")
    r = run("reconstruct", SAMPLE / "measured.csv", "-o", out / "blade.step", "--nominal",
            SAMPLE / "nominal.step", "--report", out / "report", "--json")
    assert digest(SAMPLE / "measured.csv") == before, "the input file was modified"
    return r, out


def test_demo_json_has_the_documented_keys(demo):
    r, out = demo
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["input"]["points"] == 12000 and s["input"]["sections"] == 6
    surf = s["surface"]
    for key in ("u_poles", "v_poles", "u_degree", "v_degree", "u_periodic", "method"):
        assert key in surf
    assert surf["u_degree"] == 3 and surf["v_degree"] == 3 and surf["u_periodic"] is True
    assert surf["method"] == "approximate"          # dense noisy data -> smoothing, chosen automatically
    assert 0 < s["fit"]["max"] < 0.012 and s["fit"]["mean"] < 0.003
    for key in ("max", "mean", "std", "rms", "min_signed", "max_signed"):
        assert key in s["nominal"]
    assert s["nominal"]["max"] < 0.010               # surface within 10 µm of the nominal CAD
    assert set(s["seconds"]) >= {"read", "fit", "export", "total"}


def test_demo_writes_a_step_with_one_bspline_face_and_a_report(demo):
    _, out = demo
    from bladerecon.fc.freecad_env import import_freecad
    import_freecad()
    from bladerecon.fc.export import read_shape
    shape = read_shape(str(out / "blade.step"))
    assert len(shape.Faces) == 1 and type(shape.Faces[0].Surface).__name__ == "BSplineSurface"
    assert shape.Faces[0].Surface.isUPeriodic()
    for name in ("summary.json", "points.csv", "fit.png", "nominal.png", "surface_vs_nominal.csv", "README.txt"):
        assert (out / "report" / name).is_file(), name
    rows = (out / "report" / "points.csv").read_text().splitlines()
    assert len(rows) == 12001 and rows[0].startswith("section,line,x,y,z")
    assert not [p for p in out.iterdir() if p.name.startswith(".")], "temporary files left behind"


def test_solid_on_planar_sections_and_clear_error_on_stream_surfaces(tmp_path):
    r = run("reconstruct", SAMPLE / "measured_plan.csv", "-o", tmp_path / "solid.step", "--solid", "--json")
    assert r.returncode == 0, r.stderr
    from bladerecon.fc.freecad_env import import_freecad
    import_freecad()
    from bladerecon.fc.export import read_shape
    shape = read_shape(str(tmp_path / "solid.step"))
    assert shape.Solids and shape.Solids[0].isValid() and shape.Solids[0].Volume > 0
    # Referee: the true blade's volume, Simpson over 41 exact section areas (shoelace on 20 000
    # points each, z = 0..100 mm). The solid's volume by OCC with its B-spline face split at every
    # knot (solid.Volume integrates the whole face with a few Gauss points: 13 % off here).
    from scipy.integrate import simpson
    from test_fc_export import split_volume
    from bladerecon.samples.blade import SampleBlade as _Blade, t_at_length_fraction

    blade, heights, areas = _Blade(), np.linspace(0.0, 1.0, 41), []
    for h in heights:
        q = blade.point(np.full(20000, h), t_at_length_fraction(blade, h, np.arange(20000) / 20000))
        areas.append(0.5 * abs(q[:, 0] @ np.roll(q[:, 1], -1) - q[:, 1] @ np.roll(q[:, 0], -1)))
    true_volume = simpson(np.array(areas), x=100.0 * heights)
    # 65 points a section and 2 µm noise: the surface is within ~0.02 mm of the blade over
    # ~90 mm of perimeter: ±0.02 x 90 x 100 mm³ = ±0.15 % of ~17 000 mm³ at most
    assert split_volume(shape.Solids[0]) == pytest.approx(true_volume, rel=0.004)
    r37 = DATA / "nasa_rotor37" / "rotor37_sections_xyz_mm.txt"
    if r37.is_file():
        r = run("reconstruct", r37, "-o", tmp_path / "r37.step", "--solid")
        assert r.returncode == 2
        assert "not planar" in r.stderr and "Traceback" not in r.stderr
        assert not (tmp_path / "r37.step").exists()


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _section_csv(n_sections=3, n=12, extra="") -> str:
    rows = ["section,x,y,z"]
    for k in range(n_sections):
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
        for a in t:
            rows.append(f"{k},{20 * np.cos(a):.6f},{2 * np.sin(a):.6f},{10.0 * k:.1f}")
    return "\n".join(rows) + "\n" + extra


BAD = {
    "empty.csv": ("", ["empty"]),
    "noxyz.csv": ("a,b,c\n1,2,3\n", ["x", "y", "z"]),
    "text.csv": ("section,x,y,z\n0,1,2,abc\n", ["line 2", "abc"]),
    "nan.csv": ("section,x,y,z\n0,1,2,nan\n", ["line 2"]),
    "few.csv": ("section,x,y,z\n0,0,0,0\n0,1,0,0\n0,1,1,0\n1,0,0,5\n1,1,0,5\n1,1,1,5\n", ["points", "at least"]),
    "one.csv": (_section_csv(1), ["only 1 section", "at least 2"]),
    "cloud.txt": ("\n".join(f"{i} {np.cos(i)} {np.sin(i)} {i * 0.1}" for i in range(50)) + "\n", ["section"]),
}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_input_one_line_error_exit_2_input_untouched(tmp_path, name):
    text, words = BAD[name]
    src = _write(tmp_path / name, text)
    before = digest(src)
    r = run("reconstruct", src, "-o", tmp_path / "out.step")
    assert r.returncode == 2, r.stderr
    err = r.stderr.strip().splitlines()[-1]
    assert err.startswith("bladerecon: error:") and name in err
    said = err.replace(str(src), "").lower()          # the words, not the temporary path, must say it
    for w in words:
        assert w.lower() in said, (w, err)
    assert "Traceback" not in r.stderr
    assert digest(src) == before
    assert not (tmp_path / "out.step").exists()


def test_duplicate_point_and_wrong_section_order(tmp_path):
    text = _section_csv(3)
    lines = text.splitlines()
    lines.insert(3, lines[2])                       # repeat a point of section 0
    r = run("reconstruct", _write(tmp_path / "dup.csv", "\n".join(lines) + "\n"))
    assert r.returncode == 2 and ("duplicate" in r.stderr.lower() or "repeat" in r.stderr.lower()), r.stderr
    rows = _section_csv(3).splitlines()
    header, body = rows[0], rows[1:]
    shuffled = body[12:24] + body[:12] + body[24:]   # sections 1, 0, 2: not monotonic along the span
    swapped = [header] + [r_.replace("1,", "X,", 1) if i < 12 else r_ for i, r_ in enumerate(shuffled)]
    r = run("reconstruct", _write(tmp_path / "order.csv", "\n".join(swapped) + "\n"))
    assert r.returncode == 2 and "order" in r.stderr.lower(), r.stderr


def test_output_folder_missing_and_tolerance_misuse(tmp_path):
    r = run("reconstruct", SAMPLE / "measured_plan.csv", "-o", tmp_path / "nope" / "b.step")
    assert r.returncode == 2 and "does not exist" in r.stderr
    r = run("reconstruct", SAMPLE / "measured_plan.csv", "--tolerance", "0.01")
    assert r.returncode == 2 and "--method approximate" in r.stderr


def test_approximate_tolerance_and_angle_pairing(tmp_path):
    r = run("reconstruct", SAMPLE / "measured.csv", "--method", "approximate", "--tolerance", "0.02", "--json",
            "--quiet")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["fit"]["max"] <= 0.02 and s["surface"]["method"] == "approximate"
    assert r.stderr == ""                            # --quiet: no progress lines
    r = run("reconstruct", SAMPLE / "measured_plan.csv", "--pairing", "angle", "--json")
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert s["surface"]["pairing_added_points"] > 0 and s["fit"]["max"] < 1e-3
