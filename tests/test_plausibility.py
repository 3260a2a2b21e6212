# SPDX-License-Identifier: LGPL-2.1-or-later
"""Issue 23 §6: a nominal that is not blade-like (a box, a cylinder, a sphere given by mistake)
gets one warning line, and blades (single-face, multi-face, a dense 1500 x 16-pole face, a thin
plate, which is blade-like by shape) get none. Referee: the shapes' own known geometry (the
wall distances of a box and a cylinder are known in closed form: the checked ratios are the
box's 30 mm and the cylinder's 40 mm over their diagonals), plus the warning through the
command a user runs."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fc_fixtures import require_freecad

FreeCAD, Part = require_freecad()

from bladerecon.core.analysis.plausibility import BLADE_WALL_RATIO, wall_ratio  # noqa: E402
from bladerecon.fc.deviation import blade_like_warning, load_nominal  # noqa: E402
from bladerecon.fc.nominal_faces import write_multiface_nominal  # noqa: E402
from bladerecon.samples.multiface import multiface_spec  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "resources" / "sample" / "nominal.step"


def _grid_ratio(shape) -> float:
    """wall_ratio on OCC's own mesh (an independent triangulation of the same shape)."""
    V, T = shape.tessellate(0.5)
    return wall_ratio(np.array([tuple(v) for v in V]), np.array(T))


def test_known_walls_give_known_ratios():
    box = Part.makeBox(60, 30, 100)          # most area faces ±y (60 x 100 walls 30 mm apart)
    np.testing.assert_allclose(_grid_ratio(box), 30 / np.sqrt(60 ** 2 + 30 ** 2 + 100 ** 2), rtol=0.02)
    cyl = Part.makeCylinder(20, 100)         # the mantle faces every way in xy: opposite walls 40 mm apart
    assert 0.5 * 40 / np.sqrt(40 ** 2 + 40 ** 2 + 100 ** 2) < _grid_ratio(cyl) < 40 / np.sqrt(40 ** 2 + 40 ** 2 + 100 ** 2)
    assert _grid_ratio(Part.makeBox(60, 3, 100)) == pytest.approx(3 / np.sqrt(60 ** 2 + 3 ** 2 + 100 ** 2), rel=0.02)


def test_blades_pass_and_other_shapes_are_warned_about(tmp_path):
    multi = write_multiface_nominal(tmp_path, multiface_spec())["step"]
    for shape in (str(SAMPLE), multi, Part.makeBox(60, 3, 100)):
        assert blade_like_warning(load_nominal(shape)) is None, shape
    for shape in (Part.makeBox(60, 30, 100), Part.makeCylinder(20, 100), Part.makeSphere(20)):
        w = blade_like_warning(load_nominal(shape))
        assert w is not None and "does not look like a blade" in w and "--nominal" in w


def test_the_command_warns_and_still_measures(tmp_path):
    box = Part.makeBox(60, 30, 100)
    box.translate(FreeCAD.Vector(-30, -15, 0))
    step = tmp_path / "box.step"
    box.exportStep(str(step))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    plan = str(ROOT / "resources" / "sample" / "measured_plan.csv")
    for nominal, warned in ((step, True), (SAMPLE, False)):
        r = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", plan, "--nominal", str(nominal), "--json"],
                           capture_output=True, text=True, env=env, timeout=120)
        assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
        lines = [ln for ln in r.stderr.splitlines() if "does not look like a blade" in ln]
        assert len(lines) == int(warned) and all(ln.startswith("bladerecon: warning:") for ln in lines), r.stderr
        assert ("warning" in json.loads(r.stdout)["nominal"]) == warned


def test_sections_warns_about_a_box_and_names_the_nominal_when_it_has_no_edges(tmp_path):
    """sections --nominal: a box nominal gets the same warning line (even with --quiet) and is
    measured; a cylinder, whose cuts have no LE/TE, is refused in one line naming the nominal."""
    box = Part.makeBox(60, 30, 100)
    box.translate(FreeCAD.Vector(-30, -15, 0))
    box.exportStep(str(tmp_path / "box.step"))
    Part.makeCylinder(30, 100).exportStep(str(tmp_path / "cyl.step"))
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    measured = str(ROOT / "resources" / "sample" / "measured.csv")

    def sections(nominal):
        return subprocess.run([sys.executable, "-m", "bladerecon", "sections", measured, "--nominal", str(nominal),
                               "--json", "--quiet"], capture_output=True, text=True, env=env, timeout=300)
    for nominal, warned in ((tmp_path / "box.step", True), (SAMPLE, False)):
        r = sections(nominal)
        assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
        assert ("bladerecon: warning: the nominal does not look like a blade" in r.stderr) == warned, r.stderr
        assert len(json.loads(r.stdout)) == 6
    r = sections(tmp_path / "cyl.step")
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2 and lines[-1].startswith(f"bladerecon: error: {tmp_path / 'cyl.step'} (the nominal")
    assert "Traceback" not in r.stderr and len(lines) == 2                 # the warning, then the error
