# SPDX-License-Identifier: LGPL-2.1-or-later
"""Every blade a user brings (issue 25): one command, no slicing options, on the project's own
test blades — a propeller (span along x, hub fillet, tip cap), a fan (span along -y, 60° twist,
fillet), a radial turbine rotor (stream surfaces) — written as unordered clouds in metres.

The accuracy is judged against the blades' true surfaces (closed form in
``bladerecon.samples``), never against the product's own numbers; the command's path is the
one ``reconstruct`` runs (``cut_sections`` -> sections -> ``reconstruct`` with the cloud's
default method).
"""
from __future__ import annotations

import io
import json
from contextlib import redirect_stdout

import numpy as np
import pytest

from bladerecon.cli.main import main
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.projection import project_points_to_surface
from bladerecon.core.reconstruct import reconstruct
from bladerecon.core.sections.blade_cloud import choose_method, cut_sections, fit_to_cloud, section_set
from bladerecon.core.sections.cloud import order_slab
from bladerecon.core.sections.ordering import build_sections
from bladerecon.samples.propeller import AIRFOIL, blade_cloud, fan_blade, propeller_blade, write_cloud
from bladerecon.samples.radial import radial_cloud, radial_rotor

# Issue 25 asks the one command to reconstruct every test blade within 0.1 mm of the true
# surface over the airfoil span, as a CFD export and as a scan with 5 µm noise: the largest
# distance of dense true points (closed form) from the surface must stay under MAX_MM. The
# true points lie exactly on the true surface and their distance is the exact foot-point
# distance, so the only slack in the figure is the sampling of the true surface (15 x 300
# points here, 21 x 400 in bench/bench_blades.py: the denser set finds at most 3 µm more on
# today's surfaces, up to 23 µm more on the old ones, whose errors peaked sharply at the
# edges); no margin is taken off the 0.1 mm. The mean is held to a tenth of it
# (MEAN_MM): a surface that is off by a few hundredths everywhere fails too.
# Measured here: max 0.013 / 0.030 / 0.037 mm (propeller, fan, radial as CFD), 0.026 / 0.023 /
# 0.057 mm (scans), mean 0.0003-0.0024 mm. Before the fit to the whole cloud (the sections'
# surface alone, 0.09-0.19 mm off at its round edges) fan 0.160 / 0.144 and radial 0.182 /
# 0.182 mm (CFD / scan) fail MAX_MM; the propeller's 0.09 passed.
MAX_MM = 0.1
MEAN_MM = 0.01
BLADES = [("propeller", 0.0), ("fan", 0.0), ("radial", 0.0),
          ("propeller", 0.005), ("fan", 0.005), ("radial", 0.005)]
_CACHE: dict = {}


def _blade(name: str, noise: float = 0.0):
    key = (name, noise)
    if key not in _CACHE:
        if name == "radial":
            rotor = radial_rotor()
            _CACHE[key] = (rotor, radial_cloud(rotor, 15000, noise=noise), None)
        else:
            cb = propeller_blade() if name == "propeller" else fan_blade()
            P, lab = blade_cloud(cb, 30000, noise=noise)
            _CACHE[key] = (cb, P, lab)
    return _CACHE[key]


def _reconstructed(name: str, noise: float = 0.0):
    """The one command's surface, by the functions it runs: sections, method, fit to the cloud."""
    key = (name, noise, "rec")
    if key not in _CACHE:
        blade, P, _ = _blade(name, noise)
        cs = cut_sections(P)
        lines = np.arange(len(P)) + 1
        ss = section_set(cs, lines, name)
        method, _, _ = choose_method(cs, P, ss)
        rec = reconstruct([s.points for s in ss.sections], ss.span_axis, method=method)
        fitted, info, _ = fit_to_cloud(rec, cs)
        _CACHE[key] = (cs, fitted, info, rec)
    return _CACHE[key][:2]


def _truth(name: str, blade, cs) -> np.ndarray:
    """True points over the reconstructed airfoil span (15 x 300, dense on the round edges)."""
    if name == "radial":
        # found stream surfaces lie within a few % of span of the true ones: keep 4 % inside
        s0, s1 = cs.positions[0] + 0.04, cs.positions[-1] - 0.04
        return blade.truth(s0, s1, n_span=15, n_profile=300)
    sign = float(np.dot(blade.span_axis, cs.axis))
    a0, a1 = blade.airfoil_range()
    h = np.sort((cs.positions[[0, -1]] * sign - a0) / (a1 - a0))
    return blade.truth(max(h[0], 0.0), min(h[1], 1.0), n_span=15, n_profile=300)


@pytest.mark.timeout(240)
@pytest.mark.parametrize("name", ["propeller", "fan", "radial"])
def test_one_command_no_options_exit_0(name, tmp_path):
    blade, P, _ = _blade(name)
    path = tmp_path / f"{name}.xyz"
    write_cloud(str(path), P)                                # metres, unordered
    out = io.StringIO()
    with redirect_stdout(out):
        rc = main(["reconstruct", str(path), "--cloud-scale", "1000", "--json", "--quiet"])
    assert rc == 0
    summary = json.loads(out.getvalue())
    sl = summary["slicing"]
    assert sl["kind"] == ("stream-surfaces" if name == "radial" else "auto-planes")
    assert sl["kind_reason"] and sl["method_reason"]
    assert summary["surface"]["method"] in sl["method_reason"]
    fit = summary["surface"]["cloud_fit"]           # the surface fitted to the whole cloud, said so
    assert fit["fitted"] and fit["nodes"] > 0.8 * len(P) and fit["rms_mm"] < fit["rms_before_mm"], fit
    assert summary["fit"]["n"] == fit["nodes"] and summary["fit"]["max"] == pytest.approx(fit["max_mm"])
    if name != "radial":
        # the span axis found is the blade's, and the airfoil span lies inside the true one
        assert np.allclose(sl["axis"], blade.span_axis, atol=1e-9)
        a0, a1 = sorted(np.array(blade.airfoil_range()) * float(np.dot(blade.span_axis, sl["axis"])))
        lo, hi = sl["airfoil_span_mm"]
        assert a0 - 0.2 <= lo < hi <= a1 + 0.2
        assert hi - lo >= 0.9 * (a1 - a0)
        left_out = sl["points_left_out"]["below"] + sl["points_left_out"]["above"]
        assert left_out > 0


@pytest.mark.timeout(240)
@pytest.mark.parametrize("name, noise", BLADES, ids=[f"{n}-{'scan' if z else 'cfd'}" for n, z in BLADES])
def test_true_surface_within_0_1_mm(name, noise):
    """Issue 25's figure: the one command's surface within 0.1 mm of the true surface over
    the airfoil span, on every test blade, as a CFD export and as a 5 µm scan."""
    blade, P, lab = _blade(name, noise)
    cs, rec = _reconstructed(name, noise)
    d = project_points_to_surface(rec.surface, _truth(name, blade, cs)).distance
    assert d.max() <= MAX_MM and d.mean() <= MEAN_MM, (d.max(), d.mean())


@pytest.mark.timeout(240)
def test_cloud_fit_keeps_planar_ends_and_leaves_stray_nodes_out():
    """The fit to the cloud moves a planar end section in its plane only (--solid caps it), and
    nodes far off the blade (stray points of a scan) are left out, not fitted."""
    import dataclasses

    cs, rec = _reconstructed("propeller")
    before = _CACHE[("propeller", 0.0, "rec")][3].surface
    for col in (0, -1):
        row = rec.surface.poles[:, col]
        n = np.linalg.svd(before.poles[:, col] - before.poles[:, col].mean(axis=0))[2][2]
        assert np.ptp((row - row.mean(axis=0)) @ n) < 1e-9
    # 40 nodes between the sections (in none of them: the slabs leave out what is not
    # connected to the section) pushed 2 mm off the blade along the surface normal, out of it
    P = cs.cloud.copy()
    moved = np.random.default_rng(4).choice(np.setdiff1d(cs.between, np.concatenate(cs.rows)), 40, replace=False)
    n = project_points_to_surface(before, P[moved]).normal
    out = [P[moved] + k * 2.0 * n for k in (1.0, -1.0)]
    far = [project_points_to_surface(before, q).distance for q in out]
    P[moved] = np.where((far[0] > far[1])[:, None], out[0], out[1])
    assert np.minimum(*far).min() > 0.5 or np.maximum(*far).min() > 1.5
    stray = dataclasses.replace(cs, cloud=P)
    fitted, info, _ = fit_to_cloud(_CACHE[("propeller", 0.0, "rec")][3], stray)
    assert info["fitted"] and info["left_out_stray"] >= 38, info
    blade = _blade("propeller")[0]
    d = project_points_to_surface(fitted.surface, _truth("propeller", blade, cs)).distance
    assert d.max() <= MAX_MM, d.max()


def test_fillet_and_cap_left_out_of_the_sections():
    cb, P, lab = _blade("propeller")
    cs, _ = _reconstructed("propeller")
    used = np.concatenate(cs.rows)
    assert np.all(lab[used] == AIRFOIL)
    assert cs.info["span_reason"]["trimmed_at_start"] and cs.info["span_reason"]["trimmed_at_end"]


def test_radial_hub_and_shroud_lines_found():
    rotor, P, _ = _blade("radial")
    cs, _ = _reconstructed("radial")
    for key, s in (("hub_a_r_mm", 0.0), ("shroud_a_r_mm", 1.0)):
        line = np.array(cs.info["channel"][key])
        phi = np.linspace(0.0, 0.5 * np.pi, 2001)
        z, r = rotor.meridional(phi, s)
        true = np.column_stack([z, r])
        inner = line[(line[:, 0] > 1.0) & (line[:, 1] > 11.0) & (line[:, 0] < 38.0) & (line[:, 1] < 57.0)]
        gap = np.min(np.linalg.norm(inner[:, None, :] - true[None, :, :], axis=2), axis=1)
        # the outline of random nodes lies up to about one node spacing (~0.5 mm here) inside
        assert gap.max() < 1.0 and gap.mean() < 0.4, (key, gap.max(), gap.mean())


def test_sparse_thin_slab_is_one_section_not_two_blades():
    # one blade cut thin: its sides break into pieces closer than its thickness, merged
    cb, P, _ = _blade("propeller")
    h = P[:, 0]
    q = P[np.abs(h - 120.0) < 0.15][:, 1:]
    order, dropped, info = order_slab(q, "thin slab")
    assert len(order) + len(dropped) == len(q) and len(dropped) == 0, (len(q), len(dropped))
    assert info["pieces_merged"] > 0


def test_second_blade_farther_than_the_thickness_is_refused():
    cb, P, _ = _blade("propeller")
    q = P[np.abs(P[:, 0] - 120.0) < 1.0][:, 1:]
    with pytest.raises(BladeReconError, match="second blade"):
        order_slab(np.concatenate([q, q + np.array([0.0, 60.0])]), "two blades")


def test_span_range_overrides(tmp_path):
    cb, P, _ = _blade("propeller")
    cs = cut_sections(P, "axial", span_range=(60.0, 150.0), n_sections=6)
    assert cs.info["airfoil_span_mm"] == [60.0, 150.0]
    assert len(cs.sections) == 6
    with pytest.raises(BladeReconError, match="span-range"):
        cut_sections(P, "axial", span_range=(300.0, 400.0))


def _cli(*argv):
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    return subprocess.run([sys.executable, "-m", "bladerecon", *argv], cwd=root, capture_output=True, text=True,
                          env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin", "HOME": str(root)})


@pytest.mark.timeout(400)
def test_solid_and_cropped_deviation_of_the_whole_scan(tmp_path):
    """--solid closes the propeller (planar ends) and refuses the radial rotor in one line; the
    deviation of the whole cloud from the result leaves the fillet and cap out, counted."""
    cb, P, lab = _blade("propeller")
    cloud = tmp_path / "propeller.xyz"
    write_cloud(str(cloud), P)
    step = tmp_path / "propeller.step"
    run = _cli("reconstruct", str(cloud), "--cloud-scale", "1000", "-o", str(step), "--solid", "--quiet")
    assert run.returncode == 0, run.stderr      # FreeCAD is a dependency: no skip
    mm = tmp_path / "propeller_mm.xyz"
    sub = P[::10]                                   # still holds fillet and cap nodes
    write_cloud(str(mm), sub, metres=False)
    whole = _cli("deviation", str(mm), "--nominal", str(step), "--json", "--quiet")
    cropped = _cli("deviation", str(mm), "--nominal", str(step), "--crop-to-nominal", "--json", "--quiet")
    assert whole.returncode == 0 and cropped.returncode == 0, (whole.stderr, cropped.stderr)
    w, c = json.loads(whole.stdout), json.loads(cropped.stdout)
    left = c["cropped"]["left_out_outside_nominal"]
    assert left > 0 and c["points"] == len(sub) - left
    # the fillet and cap nodes beyond the surface's ends dominate the whole cloud's maximum
    assert c["max_abs"] < w["max_abs"]
    radial = tmp_path / "radial.xyz"
    write_cloud(str(radial), _blade("radial")[1])
    run = _cli("reconstruct", str(radial), "--cloud-scale", "1000", "-o", str(tmp_path / "r.step"), "--solid",
               "--quiet")
    assert run.returncode == 2
    errors = [ln for ln in run.stderr.splitlines() if "error" in ln]
    assert len(errors) == 1 and "Traceback" not in run.stderr


@pytest.mark.timeout(300)
def test_node_rows_are_the_sections():
    """Nodes on common planes (a CFD mesh's rows): the rows in the airfoil span are the sections,
    and every airfoil node is within 0.02 mm of the surface (the issue asks 0.01 mm)."""
    cb = propeller_blade()
    P, lab = blade_cloud(cb, 12000, rows=21)
    cs = cut_sections(P)
    assert cs.info["node_rows"] and cs.info["sections"] == 21
    lo, hi = cs.info["airfoil_span_mm"]
    assert abs(lo - 40.0) < 1e-6 and abs(hi - 200.0) < 1e-6
    ss = build_sections(cs.pointset(np.arange(len(P)) + 1, "rows"))
    rec = reconstruct([s.points for s in ss.sections], ss.span_axis, method="interpolate")
    d = project_points_to_surface(rec.surface, P[lab == AIRFOIL]).distance
    assert d.max() < 0.02, d.max()


@pytest.mark.timeout(400)
def test_whole_cloud_options_through_the_command(tmp_path):
    """The overrides a user gives when the automatic choice is not wanted: --span-axis,
    --span-range, --sections, --blade-kind, --rotor-axis (reconstruct), and --span-range /
    --span-axis (deviation). The counts are checked against the cloud itself."""
    _, P, _ = _blade("propeller")
    cloud = tmp_path / "propeller.xyz"
    write_cloud(str(cloud), P)
    step = tmp_path / "p.step"
    r = _cli("reconstruct", str(cloud), "--cloud-scale", "1000", "--span-axis", "x", "--span-range", "60:150",
             "--sections", "6", "--blade-kind", "axial", "-o", str(step), "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    sl = json.loads(r.stdout)["slicing"]
    assert sl["axis"] == [1.0, 0.0, 0.0] and sl["airfoil_span_mm"] == [60.0, 150.0] and sl["sections"] == 6
    assert sl["kind_reason"] == "axial requested" and sl["span_reason"]["method"] == "--span-range"
    mm = np.loadtxt(cloud) * 1000.0            # what was read: the file's (rounded) nodes, in mm
    x = mm[:, 0]
    assert sl["points_left_out"] == {"below": int((x < 60.0).sum()), "above": int((x > 150.0).sum())}
    assert all(60.0 <= p <= 150.0 for p in sl["positions_mm"])
    # deviation of the nodes, cropped to the same span along x: the left-out ones counted
    nodes = tmp_path / "nodes_mm.xyz"
    sub = mm[::10]
    np.savetxt(nodes, sub)
    d = _cli("deviation", str(nodes), "--nominal", str(step), "--span-range", "60:150", "--span-axis", "x",
             "--json", "--quiet")
    assert d.returncode == 0, d.stderr
    s = json.loads(d.stdout)
    inside = (sub[:, 0] >= 60.0) & (sub[:, 0] <= 150.0)
    # six sections over 90 mm of a twisted blade: up to ~0.8 mm off between them at the edges; the
    # bulk (mean) close
    assert s["points"] == int(inside.sum()) and s["mean_abs"] < 0.05, s
    # a radial rotor told what it is: stream surfaces about the given axis
    radial = tmp_path / "radial.xyz"
    write_cloud(str(radial), _blade("radial")[1])
    r = _cli("reconstruct", str(radial), "--cloud-scale", "1000", "--blade-kind", "radial", "--rotor-axis", "z",
             "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    sl = json.loads(r.stdout)["slicing"]
    assert sl["kind"] == "stream-surfaces" and sl["kind_reason"] == "radial requested" and sl["axis"] == [0.0, 0.0, 1.0]


def _smooth_area(rows: np.ndarray) -> np.ndarray:
    """A blade's section area along 60-180 mm whose log bends off a quadratic (the cubic term:
    ~4 % at the ends), as the fan's does."""
    x = (rows - 120.0) / 120.0
    return np.exp(5.5 + 0.9 * x - 0.5 * x * x + 0.35 * x ** 3)


def test_smooth_rows_are_kept_and_a_fillet_still_trimmed():
    """The airfoil span of node rows: a fan's tip row lies 4 % off the quadratic trend of the
    middle half's log(area) (its area bends away smoothly) and was trimmed with the row before it
    (732 airfoil nodes 3–6.5 mm off the surface, 2026-11-27). Rows judged against the continued
    trend keep every smooth row; rows in a fillet (area +8 %, +25 %, +60 % one after the other)
    or a cap are still trimmed, and the row before them too. Areas in closed form."""
    from bladerecon.core.sections.cloud import _trend_ends

    rows = np.linspace(60.0, 180.0, 41)
    smooth = _smooth_area(rows)
    k_lo, k_hi, _ = _trend_ends(rows, smooth, 60.0, 180.0)
    assert (k_lo, k_hi) != (0, 40)                                    # the old rule trims a smooth end
    assert _trend_ends(rows, smooth, 60.0, 180.0, local=True)[:2] == (0, 40)
    fillet = smooth.copy()
    fillet[:3] *= np.array([1.6, 1.25, 1.08])
    cap = smooth.copy()
    cap[-2:] *= np.array([0.7, 0.3])
    assert _trend_ends(rows, fillet, 60.0, 180.0, local=True)[:2] == (3, 40)
    assert _trend_ends(rows, cap, 60.0, 180.0, local=True)[:2] == (0, 38)
    # whatever the row spacing (a fine CFD mesh near the hub): a fillet growing the area as
    # 1 + 0.6 (s / 8 mm)² over its 8 mm is left where it has grown ~1 % (s ≈ 1 mm), a cap
    # shrinking it over 5 mm likewise; judged over a twentieth of the span, not one row
    for n in (41, 161, 321):
        rows = np.linspace(60.0, 180.0, n)
        smooth = _smooth_area(rows)
        s_in = np.clip(68.0 - rows, 0.0, None)
        fillet = smooth * (1.0 + 0.6 * (s_in / 8.0) ** 2)
        s_cap = np.clip(rows - 175.0, 0.0, None)
        cap = smooth * np.clip(1.0 - 0.9 * (s_cap / 5.0) ** 2, 0.05, None)
        k_lo = _trend_ends(rows, fillet, 60.0, 180.0, local=True)[0]
        k_hi = _trend_ends(rows, cap, 60.0, 180.0, local=True)[1]
        assert 0 < k_lo and s_in[k_lo + 1] < 1.5, (n, k_lo, s_in[k_lo + 1])        # the row kept first
        assert k_hi < n - 1 and s_cap[k_hi - 1] < 0.75, (n, k_hi, s_cap[k_hi - 1])
        assert _trend_ends(rows, smooth, 60.0, 180.0, local=True)[:2] == (0, n - 1)
    # area noise of 0.6 % (a coarse hull): the whole span kept on at least 95 % of 200 seeds
    rng = np.random.default_rng(0)
    rows = np.linspace(60.0, 180.0, 41)
    smooth = _smooth_area(rows)
    kept = sum(_trend_ends(rows, smooth * np.exp(0.006 * rng.standard_normal(41)), 60.0, 180.0, local=True)[:2]
               == (0, 40) for _ in range(200))
    assert kept >= 190, kept
    # a row without an area in mid-span is stepped over, not the span's end
    holed = smooth.copy()
    holed[25] = 0.0
    assert _trend_ends(rows, holed, 60.0, 180.0, local=True)[:2] == (0, 40)


@pytest.mark.timeout(400)
def test_fan_on_node_rows_by_one_command_keeps_every_row(tmp_path):
    """A fan's CFD nodes on 41 rows, by the one command a user runs: all 41 rows are the
    sections (span 60–180 mm), each row whole (thinned to 600 nodes it lost its clustered edge
    nodes: 0.020 mm), and every airfoil node is within the issue's 0.01 mm of the STEP (measured
    0.0062 mm on 2026-11-27), by ``deviation`` and, on the worst nodes, by OpenCASCADE's
    distToShape."""
    from fc_fixtures import require_freecad

    FreeCAD, Part = require_freecad()

    cloud = tmp_path / "fan_rows.xyz"
    P, lab = blade_cloud(fan_blade(), 30000, rows=41)
    write_cloud(str(cloud), P)
    step = tmp_path / "fan.step"
    r = _cli("reconstruct", str(cloud), "--cloud-scale", "1000", "-o", str(step), "--json", "--quiet")
    assert r.returncode == 0, r.stderr
    sl = json.loads(r.stdout)["slicing"]
    assert sl["node_rows"] and sl["sections"] == 41
    assert sorted(sl["airfoil_span_mm"]) == pytest.approx([-180.0, -60.0], abs=1e-6) or \
        sorted(sl["airfoil_span_mm"]) == pytest.approx([60.0, 180.0], abs=1e-6), sl["airfoil_span_mm"]
    nodes = tmp_path / "airfoil_mm.csv"
    A = np.loadtxt(cloud)[lab == AIRFOIL] * 1000.0          # what was read: the file's nodes, in mm
    np.savetxt(nodes, A, delimiter=",", fmt="%.6f", header="x,y,z", comments="")
    out = tmp_path / "dev.csv"
    d = _cli("deviation", str(nodes), "--nominal", str(step), "--csv", str(out), "--json", "--quiet")
    assert d.returncode == 0, d.stderr
    assert json.loads(d.stdout)["max_abs"] < 0.01
    dev = np.abs(np.loadtxt(out, delimiter=",", skiprows=1, usecols=(3,)))
    worst = np.argsort(dev)[-40:]
    shape = Part.read(str(step))
    occ = np.array([Part.Vertex(FreeCAD.Vector(*A[i])).distToShape(shape)[0] for i in worst])
    assert np.abs(occ - dev[worst]).max() < 1e-4 and occ.max() < 0.01


@pytest.mark.timeout(400)
def test_coated_scan_is_compensated_in_the_fit_to_the_cloud(tmp_path):
    """A scan of a coated propeller (nodes 0.05 mm out along the analytic blade's outward normal,
    3 µm noise, one half of the loop sampled 3x as densely as the other), ``--coating 0.05``: the nodes are moved by the compensation as the section
    points are, and the surface fitted to them. Before, the fit to the cloud was skipped with a
    compensation (and with ``--tolerance``): the true surface 0.050 mm max off, now 0.0067 mm
    (2026-11-27). ``--tolerance`` is judged on the cloud's nodes: met or not as their largest
    distance says. Distances of the true surface by the projection, the worst checked by OCC."""
    from fc_fixtures import require_freecad
    from bladerecon.fc.convert import from_part_surface
    from bladerecon.samples.propeller import _edge_weighted_t

    FreeCAD, Part = require_freecad()
    cb = propeller_blade()
    b = cb.blade
    rng = np.random.default_rng(3)
    h = rng.random(30000)
    t = _edge_weighted_t(b, h, rng, 0.1)
    t = np.where(rng.random(30000) < 0.5, 0.5 * t, t)     # one half of the loop 3x denser than the other
    X = cb.to_world(b.point(h, t)) + 0.05 * (b.normal(h, t) @ cb.rotation.T) + 0.003 * rng.standard_normal((30000, 3))
    cloud = tmp_path / "coated.xyz"
    write_cloud(str(cloud), X)
    ht, tt = rng.uniform(0.05, 0.95, 3000), rng.random(3000)
    truth = cb.to_world(b.point(ht, tt))

    def run(*extra):
        step = tmp_path / f"coated{len(extra)}.step"
        r = _cli("reconstruct", str(cloud), "--cloud-scale", "1000", "-o", str(step), "--json", "--quiet", *extra)
        assert r.returncode == 0, r.stderr
        face = Part.read(str(step)).Faces[0]
        d = project_points_to_surface(from_part_surface(face.Surface), truth).distance
        return json.loads(r.stdout), d, face, r.stderr

    js, d, face, _ = run("--coating", "0.05")
    assert js["surface"]["cloud_fit"]["fitted"] and "compensation" in js["fit"]["points"]
    assert d.max() < 0.02 and d.mean() < 0.002, (d.max(), d.mean())
    worst = np.argsort(d)[-20:]
    occ = np.array([face.distToShape(Part.Vertex(FreeCAD.Vector(*truth[i])))[0] for i in worst])
    assert np.abs(occ - d[worst]).max() < 1e-4
    js, d, _, err = run("--coating", "0.05", "--method", "approximate", "--tolerance", "0.005")
    assert js["surface"]["tolerance_met"] is False and js["fit"]["max"] > 0.005
    assert f"{js['fit']['max'] * 1000:.1f} µm, over the 5.0 µm asked" in err
    js, d, _, err = run("--coating", "0.05", "--method", "approximate", "--tolerance", "0.05")
    assert js["surface"]["tolerance_met"] is True and js["fit"]["max"] <= 0.05 and "warning" not in err
    assert d.max() < 0.02
