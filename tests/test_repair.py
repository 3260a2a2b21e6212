# SPDX-License-Identifier: LGPL-2.1-or-later
"""Repair target (issue 18) against the known truth of the damaged sample blade.

The truth is closed form (:mod:`bladerecon.samples.damaged`): the deformed undamaged blade
at every (h, t), the twist law, and the missing volume from polygon areas of dense true
sections - none of it computed by the repair code. Distances to the target are the core's
exact projection onto the target B-spline surface.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.repair import repair_target
from bladerecon.samples.blade import SampleBlade, nominal_surface
from bladerecon.samples.damaged import (ServiceDamage, damaged_cloud, damaged_sections,
                                        true_missing_volume, truth_errors)

ROOT = Path(__file__).resolve().parents[1]
NOISE = 0.002


@pytest.fixture(scope="module")
def case():
    sd = ServiceDamage()
    return sd, nominal_surface(sd.blade)


@pytest.fixture(scope="module")
def cloud_result(case):
    sd, nom = case
    return repair_target(damaged_cloud(sd, n_rows=150, n_around=300, noise=NOISE), nom, 1.0)


@pytest.fixture(scope="module")
def sections_result(case):
    sd, nom = case
    secs = damaged_sections(sd, n_sections=25, n_points=600, noise=NOISE)
    labels = np.repeat(np.arange(len(secs)), [len(s) for s in secs])
    return repair_target(np.concatenate(secs), nom, 1.0, section=labels)


@pytest.mark.timeout(240)
def test_cloud_target_matches_the_true_deformed_blade(case, cloud_result):
    sd, _ = case
    d, damaged = truth_errors(sd, cloud_result.target)
    assert damaged.sum() > 100
    assert d[damaged].max() < 0.02            # over the damaged regions (issue: within 0.02 mm)
    assert d[~damaged].max() < 3 * NOISE      # elsewhere within the noise
    blend = cloud_result.blend
    assert blend["band_mm"] >= 2.0 and blend["max_curvature_jump"] < 0.05     # 1/mm; the TE circle is ~2 1/mm
    naive, _ = truth_errors(sd, cloud_result.naive)
    assert naive[damaged].max() > 5 * d[damaged].max()   # the naive target misses by far more


@pytest.mark.timeout(240)
def test_cloud_twist_and_missing_volume(case, cloud_result):
    sd, _ = case
    d = cloud_result.deformation
    assert abs(d["twist_deg_at_tip"] - sd.twist_tip_deg) < 0.02
    c = np.array(d["centre_mm"])
    for row in d["per_section"]:            # the twist axis point's move, against the generator's law
        h = sd.blade.h_of_z(row["z_mm"])
        a = np.radians(sd.twist_deg(h))
        move = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]]) @ c - c + sd.shift_mm(h)
        assert np.hypot(*(np.array(row["shift_mm"]) - move)) < 0.005
        assert abs(row["twist_deg"] - sd.twist_deg(h)) < 0.02
    truth = true_missing_volume(sd)["total_mm3"]
    assert abs(cloud_result.volume_mm3 - truth) < 0.03 * truth
    kinds = {r["kind"] for r in cloud_result.regions}
    assert {"tip", "leading_edge", "trailing_edge"} <= kinds
    tip = [r for r in cloud_result.regions if r["kind"] == "tip"][0]
    assert abs(tip["span_range_mm"][0] - sd.cut_z) < 0.1
    le = [r for r in cloud_result.regions if r["kind"] == "leading_edge"]
    assert abs(max(r["max_depth_mm"] for r in le) - sd.le_erosion_depth_mm) < 0.02


@pytest.mark.timeout(240)
def test_sections_twist_and_target(case, sections_result):
    sd, _ = case
    assert sections_result.mode == "sections"
    assert abs(sections_result.deformation["twist_deg_at_tip"] - sd.twist_tip_deg) < 0.02
    d, damaged = truth_errors(sd, sections_result.target)
    assert d[damaged].max() < 0.02
    assert sections_result.target_vs_measured["rms"] < 2 * NOISE


@pytest.fixture(scope="module")
def sections_cut_result(case):
    """The same sections with --cut-height at the break: where a repair cell knows the blade's
    material to end (it cuts the tip flat there before building up)."""
    sd, nom = case
    secs = damaged_sections(sd, n_sections=25, n_points=600, noise=NOISE)
    labels = np.repeat(np.arange(len(secs)), [len(s) for s in secs])
    return repair_target(np.concatenate(secs), nom, 1.0, section=labels, cut_height=sd.cut_z)


@pytest.mark.timeout(240)
def test_sections_missing_volume_with_the_cut_at_the_break(case, sections_result, sections_cut_result):
    """Sections end 0.5 mm under the break (damaged_sections), so without a cut the tip is
    counted from the highest section: an upper bound, over the truth by about that slab's
    volume (0.5 mm x the ~126 mm² section), and the JSON warns. With --cut-height at the
    break the slab is taken as intact (reported as unmeasured) and the volume is within the
    issue's 3 % of the closed-form truth; the target stays within 0.02 mm of the true blade."""
    sd, _ = case
    truth = true_missing_volume(sd)["total_mm3"]
    top = sections_result.depth_map["tip"]
    assert top["from"] == "highest section" and "upper bound" in top["warning"]
    slab = sections_result.volume_mm3 - truth
    assert 0.5 * 100.0 < slab < 0.5 * 150.0            # the unmeasured 0.5 mm slab, area 100-150 mm²
    tip = sections_cut_result.depth_map["tip"]
    assert tip["from"] == "cut_height" and "warning" not in tip
    assert tip["z_mm"] == pytest.approx(sd.cut_z)
    assert tip["unmeasured_mm"] == [pytest.approx(top["measured_top_mm"]), pytest.approx(sd.cut_z)]
    assert abs(sections_cut_result.volume_mm3 - truth) < 0.03 * truth
    d, damaged = truth_errors(sd, sections_cut_result.target)
    assert d[damaged].max() < 0.02


@pytest.mark.timeout(240)
def test_the_tip_solid_starts_at_a_cut_above_the_highest_section(case, sections_cut_result):
    """With --cut-height above the highest section the tip is counted from the cut; its solid
    in missing.step must start there too, not at the highest section 0.5 mm lower."""
    from fc_fixtures import require_freecad
    require_freecad()
    from bladerecon.fc.repair import missing_shape

    sd, _ = case
    tip = missing_shape(sections_cut_result).Solids[0]
    assert abs(tip.BoundBox.ZMin - sd.cut_z) < 0.1      # the registration tilts the frame by µm over the chord


def test_cut_height_far_above_the_measurement_is_refused(case):
    """A cut more than a section spacing above the highest section would take an unmeasured
    band as intact: refused in one line, naming the option."""
    sd, nom = case
    secs = damaged_sections(sd, n_sections=6, n_points=300, noise=NOISE)
    labels = np.repeat(np.arange(len(secs)), [len(s) for s in secs])
    top = max(float(s[:, 2].mean()) for s in secs)
    spacing = float(np.diff(sorted(s[:, 2].mean() for s in secs)).max())
    with pytest.raises(BladeReconError, match="--cut-height .* above the highest section"):
        repair_target(np.concatenate(secs), nom, 1.0, section=labels, cut_height=top + 2.0 * spacing)


@pytest.mark.timeout(240)
def test_shallow_regions_missing_material_as_solids(case, cloud_result):
    """Each shallow region's material to add (between the target and the damaged floor) is a
    valid closed solid. Referee: the closed-form damage volume (polygon areas of dense true
    sections, samples.damaged), which the solids' OCC volumes must sum to within the issue's
    3 %; each solid also holds its own region's core volume within 5 % (the solid interpolates
    the depth between cell centres where the core sums cells) and stays in its span range."""
    from fc_fixtures import require_freecad
    require_freecad()
    from bladerecon.fc.repair import region_missing_shapes

    sd, _ = case
    solids = region_missing_shapes(cloud_result)
    shallow = [r for r in cloud_result.regions if r["kind"] != "tip"]
    assert len(solids) == len(shallow) >= 2
    for solid, reg in zip(solids, shallow):
        assert solid.isValid() and solid.isClosed()
        assert abs(solid.Volume - reg["volume_mm3"]) < 0.05 * reg["volume_mm3"] + 0.02, reg
        lo, hi = reg["span_range_mm"]
        assert lo - 1.5 < solid.BoundBox.ZMin and solid.BoundBox.ZMax < hi + 1.5   # rows of 1 mm, a tilted frame
    truth = true_missing_volume(sd)["damage_mm3"]
    assert abs(sum(s.Volume for s in solids) - truth) < 0.03 * truth


def test_no_undamaged_area_is_refused(case):
    sd, nom = case
    H, T = np.meshgrid(np.linspace(0.0, 1.0, 40), np.linspace(0.0, 1.0, 120, endpoint=False), indexing="ij")
    n = sd.blade.normal(H, T)[..., :2]
    P = sd.blade.point(H, T)
    P[..., :2] -= 0.1 * n / np.linalg.norm(n, axis=-1, keepdims=True)   # everything worn 0.1 mm
    P = P.reshape(-1, 3)
    with pytest.raises(BladeReconError, match="no undamaged area left"):
        repair_target(P, nom, 1.0)


def test_nominal_not_covering_the_span_is_refused(case):
    _, nom = case
    long = ServiceDamage(blade=SampleBlade(span=130.0), tip_loss_mm=0.5)
    P = damaged_cloud(long, n_rows=40, n_around=120, noise=NOISE)
    with pytest.raises(BladeReconError, match="does not cover the measured span"):
        repair_target(P, nom, 1.0)


@pytest.mark.timeout(240)
def test_too_much_damage_is_refused(case):
    sd, nom = case
    P = damaged_cloud(sd, n_rows=40, n_around=120, noise=NOISE)
    with pytest.raises(BladeReconError, match="damage over"):
        repair_target(P, nom, 1.0, max_damage_share=0.01)


def test_nominal_without_a_closed_blade_face_is_refused():
    from fc_fixtures import require_freecad
    _, Part = require_freecad()
    from bladerecon.fc.deviation import Nominal
    from bladerecon.fc.repair import _blade_face

    with pytest.raises(BladeReconError, match="no untrimmed B-spline face"):
        _blade_face(Nominal(Part.makeBox(50, 5, 100)), "box")


def _cli(*args, cwd):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "bladerecon", "repair", *map(str, args)], capture_output=True,
                          text=True, env=env, cwd=cwd, timeout=600)


@pytest.mark.timeout(300)
def test_cli_json_step_and_bad_input(tmp_path):
    from fc_fixtures import require_freecad
    require_freecad()
    from bladerecon.core.io.readers import write_points_csv

    sd = ServiceDamage()
    secs = damaged_sections(sd, n_sections=15, n_points=400, noise=NOISE)
    write_points_csv(tmp_path / "m.csv", np.concatenate(secs), np.repeat(np.arange(15), [len(s) for s in secs]))
    nominal = ROOT / "resources" / "sample" / "nominal.step"
    r = _cli("m.csv", "--nominal", nominal, "-o", "t.step", "--report", "rep", "--json", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    s = json.loads(r.stdout)
    assert abs(s["deformation"]["twist_deg_at_tip"] - sd.twist_tip_deg) < 0.02
    for key in ("regions", "volume_mm3", "target_vs_measured", "blend", "seconds"):
        assert key in s
    assert s["tip"]["from"] == "highest section" and "upper bound" in s["tip"]["warning"]
    assert {"kind", "area_mm2", "max_depth_mm", "volume_mm3", "span_range_mm", "chord_range"} <= set(s["regions"][0])
    assert (tmp_path / "t.step").stat().st_size > 1000
    for name in ("missing_map.png", "regions.csv", "missing.step", "report.html", "summary.json"):
        assert (tmp_path / "rep" / name).stat().st_size > 100, name
    rows = (tmp_path / "rep" / "regions.csv").read_text().splitlines()[1:]
    assert [row.split(",")[0] for row in rows] == [reg["kind"] for reg in s["regions"]]
    assert abs(sum(float(row.split(",")[3]) for row in rows) - s["volume_mm3"]) < 1e-3 * s["volume_mm3"]
    # bad input: one line, exit 2, nothing written
    long = ServiceDamage(blade=SampleBlade(span=130.0), tip_loss_mm=0.5)
    write_points_csv(tmp_path / "long.csv", damaged_cloud(long, n_rows=20, n_around=60), np.zeros(1200, int))
    r = _cli("long.csv", "--nominal", nominal, "-o", "bad.step", "--report", "badrep", "--quiet", cwd=tmp_path)
    assert r.returncode == 2
    assert r.stderr.strip().count("\n") == 0 and "does not cover the measured span" in r.stderr
    assert not (tmp_path / "bad.step").exists() and not (tmp_path / "badrep").exists()


@pytest.mark.timeout(300)
def test_repair_analysis_document_object(tmp_path):
    from fc_fixtures import require_freecad
    FreeCAD, _ = require_freecad()
    from bladerecon.core.io.readers import write_points_csv
    from bladerecon.fc.export import read_shape
    from bladerecon.fc.objects import make_measured_points
    from bladerecon.fc.repair import export_target_step, make_repair_analysis

    sd = ServiceDamage()
    secs = damaged_sections(sd, n_sections=15, n_points=400, noise=NOISE)
    write_points_csv(tmp_path / "m.csv", np.concatenate(secs), np.repeat(np.arange(15), [len(s) for s in secs]))
    doc = FreeCAD.newDocument("RepairTest")
    try:
        measured = make_measured_points(doc, str(tmp_path / "m.csv"))
        nominal = doc.addObject("Part::Feature", "Nominal")
        nominal.Shape = read_shape(str(ROOT / "resources" / "sample" / "nominal.step"))
        obj = make_repair_analysis(doc, measured, nominal)
        doc.recompute()
        # 15 sections that stop under the break and no CutHeight: the volume is an upper bound,
        # and the status says so (the GUI shows it) instead of "ok"
        assert "upper bound" in obj.Status and "--cut-height" in obj.Status, obj.Status
        assert abs(obj.TwistDegAtTip - sd.twist_tip_deg) < 0.02
        assert obj.TargetShape.isValid() and obj.TargetShape.Solids
        # a missing solid per region, the tip's first: it holds the tip region's volume,
        # measured on its mesh (OCC's GProp volume of these capped B-spline solids is off by %
        # here, see docs/repair.md); the shallow regions' flat-faced solids by OCC, within 5 %
        # (they interpolate the depth between the 15 sections' rows, the core sums row by row)
        import MeshPart
        regions = [json.loads(r) for r in obj.Regions]
        solids = obj.MissingShape.Solids
        assert obj.MissingShape.isValid() and len(solids) == len(regions)
        tip = [r for r in regions if r["kind"] == "tip"][0]
        mesh = MeshPart.meshFromShape(Shape=solids[0], LinearDeflection=0.005, AngularDeflection=0.05)
        assert abs(mesh.Volume - tip["volume_mm3"]) < 0.01 * tip["volume_mm3"]
        shallow = sum(r["volume_mm3"] for r in regions if r["kind"] != "tip")
        assert abs(sum(s.Volume for s in solids[1:]) - shallow) < 0.05 * shallow
        # the target and the missing material as child objects, each a copy of its shape
        from bladerecon.fc.repair import repair_pieces
        pieces = {p.Piece: p for p in repair_pieces(obj)}
        assert set(pieces) == {"target", "missing"}
        assert pieces["target"].Shape.Volume == pytest.approx(obj.TargetShape.Volume, rel=1e-12)
        assert len(pieces["target"].Shape.Faces) == len(obj.TargetShape.Faces)
        assert len(pieces["missing"].Shape.Solids) == len(regions)
        assert pieces["missing"].Shape.Volume == pytest.approx(obj.MissingShape.Volume, rel=1e-12)
        assert len(obj.PointDepth) == len(measured.Points)
        export_target_step(obj, str(tmp_path / "target.step"))
        assert (tmp_path / "target.step").stat().st_size > 1000
        volume, n_regions = obj.VolumeMm3, len(obj.Regions)
        doc.saveAs(str(tmp_path / "repair.FCStd"))
    finally:
        FreeCAD.closeDocument(doc.Name)
    doc = FreeCAD.openDocument(str(tmp_path / "repair.FCStd"))      # saved files keep it all
    try:
        again = [o for o in doc.Objects if getattr(getattr(o, "Proxy", None), "Type", "") == "RepairAnalysis"][0]
        assert again.VolumeMm3 == volume and len(again.Regions) == n_regions
        assert not again.TargetShape.isNull() and again.Measured is not None
        from bladerecon.fc.repair import repair_pieces
        assert sorted(p.Piece for p in repair_pieces(again)) == ["missing", "target"]
    finally:
        FreeCAD.closeDocument(doc.Name)


@pytest.mark.timeout(400)
def test_cli_cut_height_blend_and_max_damage(tmp_path):
    """--cut-height Z: everything above Z is rebuilt (a tip region reaching down to Z, more
    volume than without the cut); --blend sets the band width the JSON reports; --max-damage
    below the damaged share refuses in one line with nothing written."""
    from fc_fixtures import require_freecad
    require_freecad()
    from bladerecon.core.io.readers import write_points_csv

    sd = ServiceDamage()
    cloud = damaged_cloud(sd, n_rows=60, n_around=160, noise=NOISE)
    write_points_csv(tmp_path / "c.csv", cloud, np.zeros(len(cloud), int))
    nominal = ROOT / "resources" / "sample" / "nominal.step"
    plain = _cli("c.csv", "--nominal", nominal, "--json", "--quiet", cwd=tmp_path)
    assert plain.returncode == 0, plain.stderr
    top = float(cloud[:, 2].max())
    cut = top - 6.0
    r = _cli("c.csv", "--nominal", nominal, "--cut-height", cut, "--blend", 3.5, "--json", "--quiet", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    s, p = json.loads(r.stdout), json.loads(plain.stdout)
    assert s["blend"]["band_mm"] == 3.5 and p["blend"]["band_mm"] != 3.5
    tips = [reg for reg in s["regions"] if reg["kind"] == "tip"]
    assert tips and min(reg["span_range_mm"][0] for reg in tips) <= cut + 0.5
    assert s["volume_mm3"] > p["volume_mm3"]
    assert p["tip"]["from"] == "highest measured point" and "warning" not in p["tip"]
    assert s["tip"]["from"] == "cut_height" and s["tip"]["z_mm"] == pytest.approx(cut)
    r = _cli("c.csv", "--nominal", nominal, "--cut-height", top + 5.0, "-o", "x.step", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.strip().splitlines()[-1].startswith("bladerecon: error: --cut-height")
    assert "above the highest measured point" in r.stderr and not (tmp_path / "x.step").exists()
    r = _cli("c.csv", "--nominal", nominal, "--max-damage", 0.5, "-o", "x.step", "--quiet", cwd=tmp_path)
    assert r.returncode == 2 and "damage over" in r.stderr and r.stderr.strip().count("\n") == 0
    assert not (tmp_path / "x.step").exists()


def test_flow_names_the_edges(case):
    """Issue 24: with the flow given, a region's LE/TE kind comes from the upstream end. The
    sample blade's LE is upstream for +x: the same chord as the blunter-end rule; reversed, the
    chord runs the other way."""
    from bladerecon.core.repair.target import _profile_rows

    _, nom = case
    v = np.linspace(0.1, 0.9, 5)
    plain = _profile_rows(nom, v, 64)[2]
    ahead = _profile_rows(nom, v, 64, np.array([1.0, 0.0, 0.0]))[2]
    back = _profile_rows(nom, v, 64, np.array([-2.0, 0.0, 0.0]))[2]
    assert np.allclose(ahead, plain) and np.allclose(back, 1.0 - plain, atol=0.02)
    with pytest.raises(BladeReconError, match="along the blade's span"):
        _profile_rows(nom, v, 64, np.array([0.0, 0.0, 1.0]))


@pytest.mark.timeout(240)
def test_reversed_flow_calls_the_eroded_edge_the_trailing_edge(case, cloud_result):
    sd, nom = case
    res = repair_target(damaged_cloud(sd, n_rows=150, n_around=300, noise=NOISE), nom, 1.0,
                        flow=np.array([-1.0, 0.0, 0.0]))
    le = max(r["max_depth_mm"] for r in cloud_result.regions if r["kind"] == "leading_edge")
    te = max(r["max_depth_mm"] for r in res.regions if r["kind"] == "trailing_edge")
    assert abs(te - le) < 1e-9 and abs(res.volume_mm3 - cloud_result.volume_mm3) < 1e-9


def _gcv_direct(N, rhs, K, x0, signed, A, w):
    """Referee for the GCV lambda search: every trial lambda solved directly (numpy)."""
    scale, m, best = np.trace(N) / np.trace(K), float(w.sum()), None
    for lam in scale * np.logspace(-8, 2, 21):
        M = N + lam * K
        dx = np.linalg.solve(M, rhs - lam * K @ x0)
        res = signed - A @ dx
        edf = float(np.trace(np.linalg.solve(M, N)))
        g = m * float((w * res * res).sum()) / max(m - edf, 1.0) ** 2
        if best is None or g < best[0]:
            best = (g, x0 + dx, lam, edf)
    return best[1:]


@pytest.mark.parametrize("seed", range(4))
def test_gcv_lambda_search_equals_solving_every_lambda(seed):
    """The shared-factorisation lambda search of the deformation fit picks the lambda, the
    coefficients and the degrees of freedom that solving each trial directly gives (round-off),
    on weighted random least squares with a second-difference penalty; a rank-deficient normal
    matrix (no Cholesky factor) takes the direct path."""
    from bladerecon.core.repair.deformation import _gcv_solve

    rng = np.random.default_rng(seed)
    n, k = 40, 300
    A = rng.normal(size=(k, n))
    w = rng.uniform(0.0, 1.0, k)
    signed = A @ rng.normal(size=n) + rng.normal(scale=0.3, size=k)
    N = A.T @ (w[:, None] * A) + 1e-9 * np.eye(n)
    D2 = np.diff(np.eye(n), 2, axis=0)
    K = D2.T @ D2
    x0 = 0.1 * rng.normal(size=n)
    rhs = A.T @ (w * signed)
    x, lam, edf = _gcv_solve(N, rhs, K, x0, signed, A, w)
    xr, lamr, edfr = _gcv_direct(N, rhs, K, x0, signed, A, w)
    assert lam == lamr
    np.testing.assert_allclose(x, xr, rtol=0, atol=1e-9 * np.abs(xr).max())
    assert edf == pytest.approx(edfr, rel=1e-12)
    # rank-deficient: the last column never seen by the data, K keeps the system solvable
    A[:, -1] = 0.0
    N = A.T @ (w[:, None] * A)
    rhs = A.T @ (w * signed)
    x, lam, edf = _gcv_solve(N, rhs, K, x0, signed, A, w)
    xr, lamr, edfr = _gcv_direct(N, rhs, K, x0, signed, A, w)
    assert lam == lamr and np.allclose(x, xr, atol=1e-9 * np.abs(xr).max()) and edf == pytest.approx(edfr, rel=1e-9)
