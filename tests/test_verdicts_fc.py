# SPDX-License-Identifier: LGPL-2.1-or-later
"""The inspection plan in a FreeCAD document (issue 19 §5): a DeviationAnalysis with a Plan
holds the verdicts ``deviation --plan`` prints for the same points, nominal and plan; a bad
plan fails the recompute with its one-line message; the Plan survives save and reopen."""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from fc_fixtures import require_freecad

FreeCAD, Part = require_freecad()

from bladerecon.fc import objects as bro  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
POINTS = REPO / "resources" / "sample" / "measured_plan.csv"
NOMINAL = REPO / "resources" / "sample" / "nominal.step"
PROFILE_PLAN = """
[profile]
leading_edge  = 0.004
trailing_edge = 0.05
flanks        = 0.008
[fit]
mode = "zone"
"""


@pytest.fixture(scope="module")
def analysis(tmp_path_factory):
    plan = tmp_path_factory.mktemp("plan") / "plan.toml"
    plan.write_text(PROFILE_PLAN, encoding="utf-8")
    doc = FreeCAD.newDocument("VerdictTest")
    points = bro.make_measured_points(doc, str(POINTS))
    nominal = doc.addObject("Part::Feature", "Nominal")
    nominal.Shape = Part.read(str(NOMINAL))
    obj = bro.make_deviation_analysis(doc, points, nominal, None, plan=str(plan))
    doc.recompute()
    yield doc, obj, plan
    FreeCAD.closeDocument(doc.Name)


@pytest.mark.timeout(600)
def test_the_analysis_holds_the_cli_verdicts(analysis):
    doc, obj, plan = analysis
    assert obj.Status in ("", "ok"), obj.Status
    env = dict(os.environ, PYTHONPATH=str(REPO))
    r = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", str(POINTS), "--nominal", str(NOMINAL),
                        "--plan", str(plan), "--json", "--quiet"], capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    cli = json.loads(r.stdout)
    assert obj.Verdict == cli["verdict"]
    assert obj.MaxNormalised == pytest.approx(cli["fit"]["max_normalised"], rel=1e-6)
    assert [line.split(":")[1].strip() for line in obj.SectionVerdicts] == [s["verdict"] for s in cli["sections"]]
    assert obj.Max == pytest.approx(cli["max"], abs=1e-9) and obj.PointCount == cli["points"]


@pytest.mark.timeout(600)
def test_bad_plan_fails_the_recompute_and_reopen_keeps_the_plan(analysis, tmp_path):
    doc, obj, plan = analysis
    bad = tmp_path / "bad.toml"
    bad.write_text(PROFILE_PLAN.replace("0.008", "-0.008"), encoding="utf-8")
    verdict = obj.Verdict
    obj.Plan = str(bad)
    doc.recompute()
    assert "profile.flanks" in obj.Status and "\n" not in obj.Status
    assert obj.Verdict == verdict                           # the previous result is kept
    obj.Plan = str(plan)
    doc.recompute()
    path = tmp_path / "verdict.FCStd"
    doc.saveCopy(str(path))
    again = FreeCAD.openDocument(str(path))
    try:
        restored = again.getObject(obj.Name)
        assert restored.Plan == str(plan) and restored.Verdict == obj.Verdict
        assert list(restored.SectionVerdicts) == list(obj.SectionVerdicts)
    finally:
        FreeCAD.closeDocument(again.Name)


@pytest.mark.timeout(600)
def test_workbench_report_has_the_verdicts(analysis, tmp_path):
    from bladerecon.report.deviation import write_analysis_report

    doc, obj, plan = analysis
    summary = write_analysis_report(obj, str(tmp_path / "report"))
    assert summary["verdict"] == obj.Verdict
    assert [s["verdict"] for s in summary["sections"]] == [ln.split(": ")[1] for ln in obj.SectionVerdicts]
    page = (tmp_path / "report" / "report.html").read_text(encoding="utf-8")
    assert page.index("Verdict:") < page.index("Statistics")


@pytest.mark.timeout(600)
def test_flow_direction_gives_the_cli_verdicts_of_the_same_flow(analysis):
    """Issue 24: FlowDirection on the analysis puts the Plan's LE zone upstream, as ``--flow``
    does in the CLI; reversed, the verdicts are those of ``--flow=-1,0,0``."""
    doc, obj, plan = analysis
    before, before_max = list(obj.SectionVerdicts), obj.MaxNormalised
    try:
        obj.FlowDirection = FreeCAD.Vector(-1, 0, 0)
        doc.recompute()
        assert obj.Status in ("", "ok"), obj.Status
        env = dict(os.environ, PYTHONPATH=str(REPO))
        r = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", str(POINTS), "--nominal", str(NOMINAL),
                            "--plan", str(plan), "--flow=-1,0,0", "--json", "--quiet"], capture_output=True, text=True,
                           env=env, timeout=600)
        assert r.returncode == 0, r.stderr[-2000:]
        cli = json.loads(r.stdout)
        assert [line.split(":")[1].strip() for line in obj.SectionVerdicts] == [s["verdict"] for s in cli["sections"]]
        assert obj.MaxNormalised == pytest.approx(cli["fit"]["max_normalised"], rel=1e-6)
        assert abs(obj.MaxNormalised - before_max) > 1e-3 * before_max   # the tight LE zone now sits on the TE
    finally:
        obj.FlowDirection = FreeCAD.Vector(0, 0, 0)
        doc.recompute()
    assert list(obj.SectionVerdicts) == before and obj.MaxNormalised == pytest.approx(before_max, rel=1e-9)
