# SPDX-License-Identifier: LGPL-2.1-or-later
"""bladerecon.core never imports FreeCAD: every module under it imports in a clean interpreter
without pulling in FreeCAD, FreeCADGui or Part."""
from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

SCRIPT = r"""
import importlib, json, pkgutil, sys
import bladerecon.core as core
names = [m.name for m in pkgutil.walk_packages(core.__path__, "bladerecon.core.")]
for name in names:
    importlib.import_module(name)
print(json.dumps({"modules": names, "freecad": sorted(m for m in ("FreeCAD", "FreeCADGui", "Part") if m in sys.modules)}))
"""


def test_core_modules_import_without_freecad():
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT], cwd=REPO, capture_output=True, text=True, timeout=120,
        env={"PATH": "/usr/bin:/bin", "PYTHONPATH": str(REPO)},
    )
    assert proc.returncode == 0, proc.stderr
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    assert "bladerecon.core.geometry.spline" in result["modules"] and "bladerecon.core.geometry.bspline" in result["modules"]
    assert result["freecad"] == []


def test_no_freecad_import_statement_in_core():
    offenders = []
    for path in (REPO / "bladerecon" / "core").rglob("*.py"):
        for number, line in enumerate(path.read_text().splitlines(), 1):
            words = line.split()
            if words[:1] in (["import"], ["from"]) and len(words) > 1 and words[1].split(".")[0] in ("FreeCAD", "FreeCADGui", "Part"):
                offenders.append(f"{path.relative_to(REPO)}:{number}: {line.strip()}")
    assert offenders == []
