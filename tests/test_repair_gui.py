# SPDX-License-Identifier: LGPL-2.1-or-later
"""The "Repair target" command in the real workbench (the harness of tests/test_workbench_gui.py):
select the damaged blade's points and the nominal, run the command, get a RepairAnalysis whose
twist is the generator's, one undo step; no traceback in the report view."""
from __future__ import annotations

import numpy as np

from test_workbench_gui import REPO, SAMPLE, run_gui, pytestmark  # noqa: F401

FLOW = r'''
with part("setup"):
    FreeCADGui.activateWorkbench("BladeReconWorkbench")
    doc = FreeCAD.newDocument("Repair")
    import bladerecon.fc.objects as bro
    from bladerecon.fc.export import read_shape
    points = bro.make_measured_points(doc, CONFIG["points"])
    nominal = doc.addObject("Part::Feature", "Nominal")
    nominal.Shape = read_shape(CONFIG["nominal"])
    doc.recompute()
with part("repair"):
    rep = Report()
    select(points, nominal)
    result["active"] = FreeCADGui.Command.get("BladeRecon_Repair").isActive()
    run("BladeRecon_Repair")
    pump(0.5)
    an = [o for o in doc.Objects if getattr(getattr(o, "Proxy", None), "Type", "") == "RepairAnalysis"]
    result["repair"] = {"count": len(an), "status": an[0].Status if an else None,
                        "twist": an[0].TwistDegAtTip if an else None, "solids": len(an[0].Shape.Solids) if an else 0,
                        "regions": an[0].RegionCount if an else 0,
                        "undo": list(doc.UndoNames), "nominal_visible": nominal.ViewObject.Visibility,
                        "report": rep.new(),
                        "coloured_points": an[0].ViewObject.Proxy.colours() if an else 0,
                        "children": sorted(c.Label for c in an[0].ViewObject.claimChildren()) if an else [],
                        "children_visible": [c.ViewObject.Visibility for c in an[0].ViewObject.claimChildren()] if an else [],
                        "measured_points": len(points.Points)}

result["report_view"] = report_view()
with open(os.path.join(OUT, "result.json"), "w") as f:
    json.dump(result, f, indent=1, default=str)
os._exit(0)
'''


def test_repair_command_in_the_workbench(tmp_path):
    from bladerecon.core.io.readers import write_points_csv
    from bladerecon.samples.damaged import ServiceDamage, damaged_sections

    sd = ServiceDamage()
    secs = damaged_sections(sd, n_sections=15, n_points=400)
    path = tmp_path / "damaged.csv"
    write_points_csv(path, np.concatenate(secs), np.repeat(np.arange(15), [len(s) for s in secs]))
    result, _ = run_gui(tmp_path, FLOW, {"points": str(path), "nominal": str(SAMPLE / "nominal.step")})
    assert not result["errors"], result["errors"]
    assert result["active"]
    r = result["repair"]
    assert r["count"] == 1, r
    # the 15 sections stop 0.5 mm under the break: the status says the volume is an upper bound
    assert "upper bound" in r["status"], r
    assert abs(r["twist"] - sd.twist_tip_deg) < 0.02
    assert r["solids"] == 1 + r["regions"]        # the target and a missing-material solid per region
    assert r["children"] == ["Missing material", "Repair target"]       # in the tree, under the analysis
    assert r["children_visible"] == [False, False]
    assert r["undo"][:1] == ["Repair target"]
    assert not r["nominal_visible"]
    assert r["coloured_points"] == r["measured_points"]      # the points coloured by missing depth
    assert "Traceback" not in result["report_view"]
