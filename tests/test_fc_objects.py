# SPDX-License-Identifier: LGPL-2.1-or-later
"""The document objects without a GUI: recompute chain, results against independent referees,
failure marking, saving and reopening, STEP export and the report glue.

Uses the sparse sample plan (6 sections x 65 points) so the whole chain recomputes in seconds.
Referees: the sample blade's chord lengths (resources/sample/README.md), OpenCASCADE's own
distances (``occ_distances``), and the ``deviation`` subcommand run on the same files.
"""
from __future__ import annotations

import json
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from fc_fixtures import require_freecad

FreeCAD, Part = require_freecad()

from bladerecon.core.errors import BladeReconError  # noqa: E402
from bladerecon.fc import objects as bro  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
PLAN = REPO / "resources" / "sample" / "measured_plan.csv"
NOMINAL = REPO / "resources" / "sample" / "nominal.step"


def make_chain(doc, path):
    """Points from ``path``, their sections and surface, the sample nominal and the deviation
    analysis of the points against it, recomputed."""
    points = bro.make_measured_points(doc, str(path))
    sections = bro.make_blade_sections(doc, points)
    surface = bro.make_blade_surface(doc, points)
    nominal = doc.addObject("Part::Feature", "Nominal")
    nominal.Shape = Part.read(str(NOMINAL))
    analysis = bro.make_deviation_analysis(doc, points, nominal, surface, tolerance=0.03)
    doc.recompute()
    return points, sections, surface, nominal, analysis


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    doc = FreeCAD.newDocument("ObjectsTest")
    yield (doc, *make_chain(doc, PLAN))
    FreeCAD.closeDocument(doc.Name)


def test_chain_recomputes(chain):
    doc, points, sections, surface, nominal, analysis = chain
    for obj in (points, sections, surface, analysis):
        assert obj.Status == "ok" and "Invalid" not in obj.State, (obj.Name, obj.Status)
    assert points.PointCount == 390 and points.SectionCount == 6 and points.Units == "mm"
    assert len(points.Shape.Vertexes) == 390
    assert surface.Shape.Faces[0].Surface.__class__.__name__ == "BSplineSurface"
    assert surface.VPoles == 6 and surface.UDegree == 3


def test_sections_against_the_sample_blade(chain):
    _, _, sections, _, _, _ = chain
    # chord runs linearly 56 -> 52 mm hub to tip (resources/sample/README.md)
    expected = 56.0 - 4.0 * np.arange(6) / 5
    np.testing.assert_allclose(sections.ChordLengths, expected, atol=0.05)
    le = np.array([tuple(v) for v in sections.LeadingEdges])
    np.testing.assert_allclose(le[:, 2], 20.0 * np.arange(6), atol=0.01)     # in the section planes
    assert len(sections.Shape.Edges) == 6 and len(sections.Shape.Vertexes) >= 12
    # the issue 3 parameters, against the analytic blade's own section laws (65 points a
    # section with 2 µm noise: an edge with < 5 points gives NaN and a warning, not a radius)
    from bladerecon.samples.blade import SampleBlade

    blade = SampleBlade()
    laws = [blade.section_laws(h) for h in np.arange(6) / 5]
    np.testing.assert_allclose(sections.StaggerDeg, [float(L.stagger) for L in laws], atol=0.05)
    np.testing.assert_allclose(sections.MaxThickness, [float(L.max_thickness) for L in laws], atol=0.008)
    for prop, key, edge in (("LERadius", "le_radius", "leading"), ("TERadius", "te_radius", "trailing")):
        measured, true = np.array(getattr(sections, prop)), np.array([float(getattr(L, key)) for L in laws])
        ok = np.isfinite(measured)
        np.testing.assert_allclose(measured[ok], true[ok], rtol=0.1)
        assert sum(edge in w for w in sections.Warnings[1:]) == int((~ok).sum())
    # no flow direction given: the LE is a guess, named and warned about first
    assert sections.LERule == "first_point" and sections.Warnings[0].startswith("leading edge guessed")


def test_flow_direction_puts_every_leading_edge_upstream(tmp_path):
    """Issue 24 §1 in the workbench: a file whose sections all start at the TE (as a design tool
    writes them). FlowDirection (1,0,0), the sample's axial direction: every LE within 0.02 mm
    of the analytic LE and LERule "flow" with no guess warning; (-1,0,0): every LE at the
    analytic TE, so the property, not the data, decides; and the surface takes it too."""
    from section_files import write_sections_csv
    from test_section_invariance import BLADES, _te_first, _truth_le

    blade = BLADES["small"]
    secs = _te_first(blade, 6, 240)
    f = tmp_path / "te_first.csv"
    write_sections_csv(f, secs)
    from bladerecon.samples.blade import section_heights
    truth_le = np.array(_truth_le(blade, 6))
    truth_te = np.array([blade.le_te(h)[1] for h in section_heights(6)])
    doc = FreeCAD.newDocument("FlowTest")
    try:
        points = bro.make_measured_points(doc, str(f))
        sections = bro.make_blade_sections(doc, points)
        surface = bro.make_blade_surface(doc, points)
        for flow, truth in (((1.0, 0.0, 0.0), truth_le), ((-2.0, 0.0, 0.0), truth_te)):
            sections.FlowDirection = FreeCAD.Vector(*flow)
            surface.FlowDirection = FreeCAD.Vector(*flow)
            doc.recompute()
            assert sections.Status == "ok" and surface.Status == "ok", (sections.Status, surface.Status)
            le = np.array([tuple(v) for v in sections.LeadingEdges])
            assert np.linalg.norm(le - truth, axis=1).max() < 0.02, (flow, le - truth)
            assert sections.LERule == "flow" and not any("guessed" in w for w in sections.Warnings)
            # the surface's u = 0 seam starts at the section's upstream end
            face = surface.Shape.Faces[0].Surface
            u0, u1, v0, v1 = face.bounds()
            seam = np.array(tuple(face.value(u0, v0)))
            assert np.linalg.norm(seam - truth[0]) < 0.5, (flow, seam, truth[0])
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_edge_shapes_in_the_workbench(tmp_path):
    """Issue 24 §3 in the document: Blade sections lists each edge's shape (an elliptic LE's
    semi-axes, a flat TE's width and direction) and puts the LE/TE points on them."""
    from section_files import write_sections_csv
    from test_edge_shape import edge_profile

    f = write_sections_csv(tmp_path / "shapes.csv", [edge_profile(z, 10.0, 600, 0.002, k)
                                                     for k, z in enumerate((0.0, 5.0, 10.0))])
    doc = FreeCAD.newDocument("ShapesTest")
    try:
        sections = bro.make_blade_sections(doc, bro.make_measured_points(doc, str(f)))
        sections.FlowDirection = FreeCAD.Vector(1.0, 0.0, 0.0)
        doc.recompute()
        assert sections.Status == "ok", sections.Status
        assert len(sections.LEShape) == len(sections.TEShape) == 3
        for le, te in zip(sections.LEShape, sections.TEShape):
            a, b = (float(v) for v in re.fullmatch(r"ellipse (\d\.\d{4}) × (\d\.\d{4}) mm \(tip radius \d\.\d{4} mm\)",
                                                   le).groups())
            assert abs(a / 1.2 - 1) < 0.025 and abs(b / 0.5 - 1) < 0.006, le
            w, ang = (float(v) for v in re.fullmatch(r"flat (\d\.\d{4}) mm wide, normal (-?\d+\.\d\d)° from the chord",
                                                     te).groups())
            assert abs(w * np.cos(np.radians(10.0)) - 1.0) < 0.015 and abs(ang - 10.0) < 1.0, te
        le, te = (np.array([tuple(v) for v in vs]) for vs in (sections.LeadingEdges, sections.TrailingEdges))
        assert np.abs(le[:, :2]).max() < 0.006 and np.abs(te[:, :2] - [30.0, 0.0]).max() < 0.006, (le, te)
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_blade_sections_figures_do_not_depend_on_where_a_loop_starts(tmp_path):
    """Issue 24 §5 in the workbench: Blade sections' figures from the same sections rolled and
    reversed agree to 1e-9 relative (the LE from the flow: the first-point rule depends on the
    start by design). Before, the workbench measured loops in file order: 5e-9 on an ellipse's
    axis, 3e-6 on its direction."""
    from section_files import write_sections_csv

    from bladerecon.core.io.readers import read_points
    from bladerecon.core.sections.ordering import build_sections
    from bladerecon.samples.blade import SampleBlade, sample_sections

    secs = sample_sections(SampleBlade(), 4, 300, "uniform", noise=0.002, seed=3)
    moved = [np.roll(p, 37 * k + 11, axis=0)[::1 if k % 2 else -1] for k, p in enumerate(secs)]
    flow = np.array([1.0, 0.0, 0.0])
    res = [bro.section_parameters(build_sections(read_points(write_sections_csv(tmp_path / f"{n}.csv", ss))), flow)
           for n, ss in (("a", secs), ("b", moved))]
    for key in ("leading_edge", "trailing_edge", "chord", "stagger_deg", "max_thickness", "max_thickness_pos",
                "le_radius", "te_radius", "inlet_angle_deg", "outlet_angle_deg"):
        a, b = np.asarray(getattr(res[0], key), float), np.asarray(getattr(res[1], key), float)
        assert np.all(np.abs(a - b) <= 1e-9 * np.maximum(np.abs(a), 1.0)), (key, a - b)
    assert res[0].le_shape == res[1].le_shape and res[0].te_shape == res[1].te_shape


def test_stats_equal_the_cli(chain):
    *_, analysis = chain
    proc = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", str(PLAN), "--nominal", str(NOMINAL),
                           "--json", "--quiet"], cwd=str(REPO), capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    cli = json.loads(proc.stdout)
    ours = bro.DeviationAnalysis.stats(analysis)
    for key, value in ours.items():
        assert value == pytest.approx(cli[key], rel=1e-9, abs=1e-12), key
    assert len(analysis.Deviations) == cli["points"]


def test_robust_fit_equals_the_cli(chain):
    """RobustFit on a rigid best fit: the same transform and statistics as
    ``deviation --align rigid --robust``; PointsWeightedOut as its JSON says."""
    doc, points, _, _, nominal, _ = chain
    robust = bro.make_deviation_analysis(doc, points, nominal, None, alignment="rigid", name="RobustAnalysis",
                                         robust=True)
    try:
        doc.recompute()
        assert robust.Status == "ok", robust.Status
        proc = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", str(PLAN), "--nominal", str(NOMINAL),
                               "--align", "rigid", "--robust", "--json", "--quiet"], cwd=str(REPO), capture_output=True,
                              text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr
        cli = json.loads(proc.stdout)
        for key, value in bro.DeviationAnalysis.stats(robust).items():
            assert value == pytest.approx(cli[key], rel=1e-9, abs=1e-12), key
        assert robust.PointsWeightedOut == cli["alignment"]["points_weighted_out"]
        M = np.array(robust.AlignmentMatrix.A).reshape(4, 4)
        np.testing.assert_allclose(M, cli["alignment"]["matrix"], atol=1e-9)
    finally:                     # the module's shared document as it was, whatever failed
        doc.removeObject(robust.Name)
        doc.recompute()


def test_surface_map_against_occ(chain):
    """The colour map's per-vertex deviations equal OpenCASCADE's signed distances to the nominal."""
    from bladerecon.fc.occ_measure import occ_distances

    *_, nominal, analysis = chain
    nu, nv = analysis.SurfaceGridSize
    grid = np.array([tuple(v) for v in analysis.SurfaceGrid])
    dev = np.array(analysis.SurfaceDeviations)
    assert grid.shape == (nu * nv, 3) and dev.shape == (nu * nv,)
    rows = np.random.default_rng(0).choice(len(grid), 150, replace=False)
    occ = occ_distances(grid[rows], nominal.Shape, signed=True)
    np.testing.assert_allclose(dev[rows], occ, atol=2e-5)
    assert dev.std() > 1e-4          # the map has something to show


def test_failed_recompute_keeps_the_previous_result():
    doc = FreeCAD.newDocument("Fail")
    try:
        points = bro.make_measured_points(doc, str(PLAN))
        surface = bro.make_blade_surface(doc, points)
        doc.recompute()
        area, poles = surface.Shape.Area, surface.UPoles
        surface.Tolerance = -1.0
        doc.recompute()
        assert surface.Status.startswith("failed: ") and "Tolerance" in surface.Status
        assert "Invalid" in surface.State
        assert surface.Shape.Area == pytest.approx(area) and surface.UPoles == poles
        surface.Tolerance = 0.0
        doc.recompute()
        assert surface.Status == "ok" and "Invalid" not in surface.State
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_bad_file_raises_before_adding(tmp_path):
    doc = FreeCAD.newDocument("BadFile")
    try:
        with pytest.raises(BladeReconError, match="missing.csv"):
            bro.make_measured_points(doc, str(tmp_path / "missing.csv"))
        assert len(doc.Objects) == 0
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_save_and_reopen_keeps_results(chain, tmp_path):
    doc, points, _, surface, _, analysis = chain
    before = bro.DeviationAnalysis.stats(analysis)
    dev = list(analysis.Deviations)
    path = tmp_path / "blade.FCStd"
    doc.saveCopy(str(path))
    # the proxies' pickled state is tiny: the results live in properties
    with zipfile.ZipFile(path) as z:
        xml = z.read("Document.xml").decode()
    assert "bladerecon.fc.objects" in xml
    for chunk in xml.split('<Python value="')[1:]:
        assert len(chunk.split('"', 1)[0]) < 200
    other = FreeCAD.openDocument(str(path))
    try:
        a = other.getObject(analysis.Name)
        # FCStd keeps 16 significant digits of a float property
        assert bro.DeviationAnalysis.stats(a) == pytest.approx(before, rel=1e-14)
        np.testing.assert_allclose(a.Deviations, dev, rtol=1e-14)
        assert bro.is_type(a, "DeviationAnalysis") and bro.is_type(other.getObject(points.Name), "MeasuredPoints")
        s = other.getObject(surface.Name)
        assert s.Shape.Area == pytest.approx(surface.Shape.Area) and s.UPoles == surface.UPoles
        for obj in other.Objects:
            obj.touch()
        other.recompute()
        assert bro.DeviationAnalysis.stats(a) == pytest.approx(before, rel=1e-12)
    finally:
        FreeCAD.closeDocument(other.Name)


def test_export_step_round_trip(chain, tmp_path):
    from bladerecon.fc.convert import from_part_surface

    surface = chain[3]
    path = tmp_path / "surface.step"
    bro.export_step(surface, str(path))
    back = Part.read(str(path))
    a, b = from_part_surface(surface.Shape.Faces[0].Surface), from_part_surface(back.Faces[0].Surface)
    np.testing.assert_allclose(b.poles, a.poles, atol=1e-9)


def test_report_summary_matches_the_analysis(chain, tmp_path, monkeypatch):
    """write_analysis_report hands the deviation report what the CLI would (the plots are tested there)."""
    import bladerecon.report.deviation as dr

    *_, analysis = chain
    seen = {}
    monkeypatch.setattr(dr, "write_deviation_report",
                        lambda folder, summary, result, nominal, section, names, surface=None:
                        seen.update(summary=summary, n=len(result.points), surface=surface, names=names))
    summary = dr.write_analysis_report(analysis, str(tmp_path / "report"))
    assert summary is seen["summary"] and seen["n"] == analysis.PointCount and seen["surface"] is not None
    for key, value in bro.DeviationAnalysis.stats(analysis).items():
        assert summary[key] == pytest.approx(value, rel=1e-12), key
    assert summary["alignment"]["mode"] == "none" and summary["units"] == "mm"
    with pytest.raises(BladeReconError, match="does not exist"):
        dr.write_analysis_report(analysis, str(tmp_path / "no" / "such" / "report"))


def test_surface_follows_its_points(tmp_path):
    """Moving the measured points moves the surface on the next recompute (the link is a dependency)."""
    doc = FreeCAD.newDocument("Follow")
    try:
        points = bro.make_measured_points(doc, str(PLAN))
        surface = bro.make_blade_surface(doc, points)
        doc.recompute()
        x0 = surface.Shape.BoundBox.XMin
        points.Points = [v + FreeCAD.Vector(0.5, 0.0, 0.0) for v in points.Points]
        doc.recompute()
        assert surface.Shape.BoundBox.XMin == pytest.approx(x0 + 0.5, abs=1e-6)
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_importer_module(tmp_path):
    """FreeCAD's importer API (File > Open / Import), registered in Init.py."""
    from bladerecon.fc import importer

    assert "bladerecon.fc.importer" in (REPO / "Init.py").read_text()
    doc = importer.open(str(PLAN))
    try:
        obj = doc.Objects[0]
        assert bro.is_type(obj, "MeasuredPoints") and obj.PointCount == 390 and obj.Status == "ok"
        importer.insert(str(PLAN), doc.Name)
        assert len(doc.Objects) == 2
        with pytest.raises(BladeReconError, match="missing.csv"):
            importer.insert(str(tmp_path / "missing.csv"), doc.Name)
        assert len(doc.Objects) == 2
    finally:
        FreeCAD.closeDocument(doc.Name)


def test_probe_radius_on_measured_points_reaches_every_later_step(tmp_path):
    """ProbeRadius on a MeasuredPoints of ball centres (R = 1.5 mm): its shape, the sections'
    edge radii, the surface and the deviation all use the contact points; back to 0, the raw ones."""
    sys.path.insert(0, str(REPO / "tests"))
    from section_files import write_sections_csv
    from test_compensation import BLADE, ball_centres

    from bladerecon.samples.blade import section_heights

    centres, _ = ball_centres(BLADE, 1.5, 200)
    f = write_sections_csv(tmp_path / "balls.csv", centres)
    doc = FreeCAD.newDocument("ProbeRadius")
    try:
        points, sections, surface, nominal, analysis = make_chain(doc, f)
        raw_max = analysis.MaxAbs
        raw_le = np.array(sections.LERadius)
        points.ProbeRadius = 1.5
        doc.recompute()
        for obj in (points, sections, surface, analysis):
            assert obj.Status == "ok", (obj.Name, obj.Status)
        laws = BLADE.section_laws(section_heights(6))
        assert np.abs(np.array(sections.LERadius) - laws.le_radius).max() < 0.005
        assert np.abs(raw_le - laws.le_radius).min() > 1.4                  # the raw centres: radius + 1.5
        shape_pts = np.array([(v.X, v.Y, v.Z) for v in points.Shape.Vertexes])
        d = np.array([nominal.Shape.distToShape(Part.Vertex(*p))[0] for p in shape_pts[::25]])
        assert d.max() < 0.002, d.max()                                      # OCC's distance to the nominal
        face = surface.Shape.Faces[0]
        on = np.array([nominal.Shape.distToShape(Part.Vertex(face.valueAt(u, v)))[0]
                       for u in np.linspace(*face.ParameterRange[:2], 7)[:-1]
                       for v in np.linspace(*face.ParameterRange[2:], 5)])
        assert on.max() < 0.01, on.max()
        assert analysis.MaxAbs < 0.002 and raw_max > 1.4
        points.ProbeRadius = 0.0
        doc.recompute()
        assert np.abs(np.array(sections.LERadius) - raw_le).max() < 1e-9
    finally:
        FreeCAD.closeDocument(doc.Name)
