# SPDX-License-Identifier: LGPL-2.1-or-later
"""Documents saved before the layout move keep opening: FCStd files store the proxies' module
and class paths (``bladerecon.fc.objects.MeasuredPoints``, ...), which are permanent."""
from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from fc_fixtures import require_freecad

FreeCAD, Part = require_freecad()

from bladerecon.fc import objects as bro  # noqa: E402

OLD = Path(__file__).resolve().parent / "data" / "documents" / "saved_before_the_layout_move.FCStd"


def test_the_old_document_names_the_permanent_proxy_paths():
    xml = zipfile.ZipFile(OLD).read("Document.xml").decode()
    for cls in ("MeasuredPoints", "BladeSections", "BladeSurface", "DeviationAnalysis"):
        assert f'module="bladerecon.fc.objects" class="{cls}"' in xml, cls


def test_a_document_saved_before_the_move_opens_and_recomputes(tmp_path):
    path = tmp_path / OLD.name
    shutil.copy(OLD, path)                     # never write the test data itself
    doc = FreeCAD.openDocument(str(path))
    try:
        kinds = {k: [o for o in doc.Objects if bro.is_type(o, k)]
                 for k in ("MeasuredPoints", "BladeSections", "BladeSurface", "DeviationAnalysis")}
        assert all(len(v) == 1 for v in kinds.values()), {k: len(v) for k, v in kinds.items()}
        points, sections, surface, analysis = (kinds[k][0] for k in kinds)
        saved_max, saved_poles = analysis.Max, (surface.UPoles, surface.VPoles)
        for obj in (points, sections, surface, analysis):
            obj.touch()
        doc.recompute()
        for obj in (points, sections, surface, analysis):
            assert obj.Status == "ok" and "Invalid" not in obj.State, (obj.Name, obj.Status, obj.State)
        assert points.PointCount == 390 and points.SectionCount == 6 and len(sections.ChordLengths) == 6
        assert (surface.UPoles, surface.VPoles) == saved_poles
        assert analysis.Max == pytest.approx(saved_max, abs=1e-6)      # mm: the same deviation again
        assert np.isfinite(analysis.Max) and 0 < analysis.Max < 0.03
    finally:
        FreeCAD.closeDocument(doc.Name)
