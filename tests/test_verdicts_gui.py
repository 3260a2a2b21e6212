# SPDX-License-Identifier: LGPL-2.1-or-later
"""The verdict in the workbench (issue 19 §5), in the real GUI under Xvfb: a DeviationAnalysis
with a Plan whose tip section fails shows, in its ``Verdict`` display mode, the failing section
red and the others green (pixels counted in the saved 3D view)."""
from __future__ import annotations

import numpy as np
import pytest

from test_workbench_gui import SAMPLE, copy_screenshots, image, run_gui, pytestmark  # noqa: F401

PLAN = """
[profile]
leading_edge  = 0.05
trailing_edge = 0.05
flanks        = 0.05
[fit]
mode = "rigid"
[sections]
"5" = { flanks = 0.0005 }
"""

FLOW = r'''
with part("verdict"):
    FreeCADGui.activateWorkbench("BladeReconWorkbench")
    import Part
    from bladerecon.fc import objects as bro
    doc = FreeCAD.newDocument("Verdicts")
    points = bro.make_measured_points(doc, CONFIG["points"])
    nominal = doc.addObject("Part::Feature", "Nominal")
    nominal.Shape = Part.read(CONFIG["nominal"])
    analysis = bro.make_deviation_analysis(doc, points, nominal, None, plan=CONFIG["plan"])
    doc.recompute()
    pump(0.5)
    for o in doc.Objects:
        o.ViewObject.Visibility = False
    analysis.ViewObject.DisplayMode = "Verdict"
    analysis.ViewObject.PointSize = 6.0
    analysis.ViewObject.Visibility = True
    redraw()
    shot("verdict.png", direction=(0.0, 1.0, 0.0))
    shot("verdict_sections.png")
    result["verdict"] = {"status": analysis.Status, "verdict": analysis.Verdict,
                         "sections": list(analysis.SectionVerdicts), "modes": analysis.ViewObject.listDisplayModes()}

result["report_view"] = report_view()
with open(os.path.join(OUT, "result.json"), "w") as f:
    json.dump(result, f, indent=1, default=str)
os._exit(0)
'''


def test_failing_section_is_red_the_others_green(tmp_path):
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN, encoding="utf-8")
    result, out = run_gui(tmp_path, FLOW, {"points": str(SAMPLE / "measured_plan.csv"),
                                           "nominal": str(SAMPLE / "nominal.step"), "plan": str(plan)})
    assert not result["errors"], result["errors"]
    v = result["verdict"]
    assert "Verdict" in v["modes"] and v["verdict"] == "fail"
    assert [line.split(": ")[1] for line in v["sections"]] == ["pass"] * 5 + ["fail"]
    assert "Traceback" not in result["report_view"]
    copy_screenshots(out, ["verdict_sections.png"])
    rgb = image(out / "verdict.png")
    red = (rgb[..., 0] > 0.6) & (rgb[..., 1] < 0.3) & (rgb[..., 2] < 0.3)
    green = (rgb[..., 1] > 0.45) & (rgb[..., 0] < 0.3) & (rgb[..., 2] < 0.3)
    assert red.sum() > 50 and green.sum() > 5 * 50
    # seen from the side (the span vertical in the image): the red section, the tip, lies
    # beyond every green one
    rows_red, rows_green = np.nonzero(red)[0], np.nonzero(green)[0]
    assert rows_red.mean() < rows_green.min() or rows_red.mean() > rows_green.max()
