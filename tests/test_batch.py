# SPDX-License-Identifier: LGPL-2.1-or-later
"""``bladerecon batch``: a lot of sample blades with known normal offsets through the local
pool and through a Dask cluster (scheduler + 2 workers on 127.0.0.1, started and stopped
here): the same lot.json bytes; lot statistics checked against Python's ``statistics``;
a bad blade fails alone (exit 2); --resume skips what is done."""
from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bladerecon.core.io.readers import write_points_csv
from bladerecon.core.lot.stats import capability, lot_statistics
from bladerecon.samples.blade import SampleBlade, section_heights, t_at_length_fraction

ROOT = Path(__file__).resolve().parents[1]
NOMINAL = ROOT / "resources" / "sample" / "nominal.step"
N_BLADES = 12


def run(*args, timeout=300):
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "bladerecon", *map(str, args)], capture_output=True,
                          text=True, env=env, timeout=timeout)


def blade_points(offset: float, seed: int, n_sections: int = 4, n_points: int = 120) -> tuple[np.ndarray, np.ndarray]:
    """Sections of the sample blade moved ``offset`` mm along its outward normal, 2 µm noise."""
    blade, rng = SampleBlade(), np.random.default_rng(seed)
    pts = []
    for h in section_heights(n_sections):
        t = t_at_length_fraction(blade, h, (rng.random() + np.arange(n_points)) / n_points)
        pts.append(blade.point(h, t) + offset * blade.normal(h, t) + 0.002 * rng.standard_normal((n_points, 3)))
    return np.vstack(pts), np.repeat(np.arange(n_sections), n_points)


@pytest.fixture(scope="module")
def lot(tmp_path_factory):
    """12 blades with offsets -11..+11 µm; a manifest with serials in reverse and dates."""
    folder = tmp_path_factory.mktemp("lot")
    offsets = np.linspace(-0.011, 0.011, N_BLADES)
    rows = ["blade,file,serial,date"]
    for k, off in enumerate(offsets):
        P, s = blade_points(off, seed=k)
        write_points_csv(folder / f"b{k:02d}.csv", P, s)
        rows.append(f"B{k:02d},b{k:02d}.csv,SN{100 - k},2026-11-{k + 1:02d}")
    (folder / "manifest.csv").write_text("\n".join(rows) + "\n")
    return folder, offsets




# --------------------------------------------------------------------------- core (numpy only)
def test_capability_matches_the_textbook_formula():
    rng = np.random.default_rng(1)
    x = list(rng.normal(0.01, 0.004, 40))
    s, m = statistics.stdev(x), statistics.fmean(x)
    cap = capability(x, -0.03, 0.03)
    assert cap["cp"] == pytest.approx(0.06 / (6 * s), rel=1e-12)
    assert cap["cpk"] == pytest.approx(min(0.03 - m, m + 0.03) / (3 * s), rel=1e-12)
    one = capability(x, None, 0.03)
    assert one["cp"] is None and one["cpk"] == pytest.approx((0.03 - m) / (3 * s), rel=1e-12)
    assert capability([0.1], -1, 1)["cpk"] is None


def test_lot_statistics_of_records():
    recs = [{"blade": f"b{k}", "status": "ok", "stats": {"max_abs": v, "mean": -v},
             "sections": [{"index": 0, "difference": {"chord": 2 * v}}]} for k, v in enumerate([0.01, 0.03, 0.02])]
    recs.append({"blade": "bad", "status": "error", "error": "x"})
    st = lot_statistics(recs, {"deviation.max_abs": (None, 0.025), "section.*.chord": (-0.1, 0.1)})
    assert list(st) == ["deviation.mean", "deviation.max_abs", "section.0.chord"]
    assert st["deviation.max_abs"]["n"] == 3
    assert st["deviation.max_abs"]["std"] == pytest.approx(statistics.stdev([0.01, 0.03, 0.02]))
    assert [w["blade"] for w in st["deviation.max_abs"]["worst"]] == ["b1", "b2", "b0"]
    assert st["section.0.chord"]["cp"] == pytest.approx(0.2 / (6 * statistics.stdev([0.02, 0.06, 0.04])))


# --------------------------------------------------------------------------- the command
@pytest.fixture(scope="module")
def pool_run(lot, tmp_path_factory):
    folder, _ = lot
    out = tmp_path_factory.mktemp("pool") / "out"
    r = run("batch", folder / "manifest.csv", "--nominal", NOMINAL, "-o", out, "--workers", "2", "--json")
    assert r.returncode == 0, r.stderr
    return out, json.loads(r.stdout), r.stderr


@pytest.mark.timeout(240)
def test_lot_statistics_recover_the_offsets(lot, pool_run):
    _, offsets = lot
    out, summary, stderr = pool_run
    assert summary["blades"] == N_BLADES and summary["failed"] == 0
    assert f"{N_BLADES}/{N_BLADES} blades done" in stderr
    data = json.loads((out / "lot" / "lot.json").read_text())
    means = [r["stats"]["mean"] for r in data["blades"]]
    assert np.allclose(means, offsets, atol=0.0015)          # a blade's mean deviation is its offset
    for r in data["blades"]:                                  # per blade: the deviation --json object
        blade = json.loads((out / r["blade"] / "summary.json").read_text())
        assert blade["mean"] == r["stats"]["mean"] and blade["points"] == 480
        assert (out / r["blade"] / "deviations.csv").exists()
    st = data["statistics"]["deviation.mean"]
    assert st["mean"] == pytest.approx(statistics.fmean(means), abs=1e-15)
    assert st["std"] == pytest.approx(statistics.stdev(means), rel=1e-12)
    assert st["cpk"] == pytest.approx(min(0.03 - st["mean"], st["mean"] + 0.03) / (3 * st["std"]), rel=1e-12)
    assert data["order"][0] == "B00"                          # date order
    text = (out / "lot" / "lot.json").read_text()
    assert str(out) not in text and "seconds" not in text     # results only
    assert (out / "lot" / "lot.html").exists() and (out / "lot" / "trend.png").exists()


@pytest.mark.timeout(300)
def test_dask_cluster_gives_the_same_lot_json(lot, pool_run, tmp_path):
    pytest.importorskip("distributed", reason="Dask distributed is not installed (apt-get install python3-distributed)")
    from distributed import LocalCluster

    folder, _ = lot
    out = tmp_path / "dask"
    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                           dashboard_address=None)
    try:
        r = run("batch", folder / "manifest.csv", "--nominal", NOMINAL, "-o", out,
                "--scheduler", cluster.scheduler_address, timeout=240)
    finally:
        cluster.close(timeout=30)
    assert r.returncode == 0, r.stderr
    assert (out / "lot" / "lot.json").read_bytes() == (pool_run[0] / "lot" / "lot.json").read_bytes()


@pytest.mark.timeout(300)
def test_bad_blade_fails_alone_and_resume_skips_the_rest(tmp_path):
    manifest = tmp_path / "m.csv"
    lines = ["blade,file,serial,date"]
    for k, off in enumerate((-0.004, 0.006)):       # small blades: --report cuts the nominal per section
        P, sec = blade_points(off, seed=50 + k, n_sections=2, n_points=80)
        write_points_csv(tmp_path / f"r{k}.csv", P, sec)
        lines.append(f"B0{k},r{k}.csv,SN{k},2026-11-0{k + 1}")
    (tmp_path / "bad.csv").write_text("section,x,y,z\n0,1,2\n")
    lines.append("BAD,bad.csv,SN1,2026-12-01")
    manifest.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    plan = tmp_path / "plan.toml"
    plan.write_text("[profile]\nflanks = 0.08\n[parameters]\nchord = [-0.10, 0.10]\nle_radius = [-0.03, 0.03]\n"
                    "position = 0.10\n[fit]\nmode = \"none\"\n")     # as measured: the offsets stay to be seen
    r = run("batch", manifest, "--nominal", NOMINAL, "-o", out, "--workers", "2", "--report", "--plan", plan)
    assert r.returncode == 2 and "1 of 3 blades failed" in r.stderr and "Traceback" not in r.stderr
    data = json.loads((out / "lot" / "lot.json").read_text())
    bad = data["blades"][-1]
    assert bad["status"] == "error" and "bad.csv" in bad["error"] and "\n" not in bad["error"]
    assert not (out / "BAD").exists() and data["lot"]["ok"] == 2
    first = json.loads((out / "B00" / "summary.json").read_text())
    assert first["points"] == 160 and first["mean"] == pytest.approx(-0.004, abs=0.0015)
    assert (out / "B00" / "report" / "report.html").exists()
    # --plan: every blade judged by the inspection plan (deviation --plan's verdicts), lot.json
    # carries each blade's verdict and failed checks and the count, as its summary.json says
    for rec in data["blades"][:2]:
        own = json.loads((out / rec["blade"] / "summary.json").read_text())
        assert rec["verdict"] == own["verdict"] in ("pass", "fail")
        failed = [f"section {sec['label']}: {name}" for sec in own["sections"] for group in ("profile", "parameters")
                  for name, c in sec[group].items() if not c["pass"]]
        assert rec["failed"] == failed and (own["verdict"] == "pass") == (not failed)
    verdicts = [rec["verdict"] for rec in data["blades"][:2]]
    assert data["lot"]["verdicts"] == {"pass": verdicts.count("pass"), "fail": verdicts.count("fail")}
    # --report: section parameters (measured - nominal) per blade, their lot statistics, the plan's limits
    rows = first["section_parameters"]["rows"]
    chords = [json.loads((out / b / "summary.json").read_text())["section_parameters"]["rows"][1]["difference"]["chord"]
              for b in ("B00", "B01")]
    st = data["statistics"]["section.1.chord"]
    assert len(rows) == 2 and st["n"] == 2 and st["mean"] == pytest.approx(statistics.fmean(chords), abs=1e-15)
    assert (st["lsl"], st["usl"]) == (-0.1, 0.1)
    assert st["cp"] == pytest.approx(0.2 / (6 * statistics.stdev(chords)), rel=1e-12)
    assert data["lot"]["limits"]["section.*.le_radius"] == [-0.03, 0.03]
    stamp = (out / "B00" / "summary.json").stat().st_mtime_ns
    r2 = run("batch", manifest, "--nominal", NOMINAL, "-o", out, "--workers", "2", "--report", "--plan", plan,
             "--resume")
    assert r2.returncode == 2 and r2.stderr.count("resumed") == 2
    assert (out / "B00" / "summary.json").stat().st_mtime_ns == stamp
    assert (out / "lot" / "lot.json").read_text() == json.dumps(data, indent=1) + "\n"
    r3 = run("batch", manifest, "--nominal", NOMINAL, "-o", out)
    assert r3.returncode == 2 and "--resume" in r3.stderr       # an OUTDIR that holds files


def test_missing_dask_is_one_line(lot, tmp_path):
    folder, _ = lot
    code = ("import sys; sys.modules['distributed'] = None; from bladerecon.cli.main import main; "
            f"sys.exit(main(['batch', {str(folder / 'manifest.csv')!r}, '--nominal', {str(NOMINAL)!r}, "
            f"'-o', {str(tmp_path / 'o')!r}, '--scheduler', 'tcp://127.0.0.1:1']))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=60)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "no distributed" in r.stderr
    assert not (tmp_path / "o").exists()


def test_plan_limits_and_bad_plans(tmp_path):
    from bladerecon.cli.batch import read_plan_limits
    from bladerecon.core.errors import BladeReconError

    plan = tmp_path / "p.toml"
    plan.write_text("[parameters]\nchord = [-0.1, 0.1]\nposition = 0.1\n")
    assert read_plan_limits(str(plan)) == {"section.*.chord": (-0.1, 0.1)}
    plan.write_text("[parameters]\nchord = [0.1, -0.1]\n")
    with pytest.raises(BladeReconError, match="parameters.chord"):
        read_plan_limits(str(plan))
    plan.write_text("[parameters\n")
    with pytest.raises(BladeReconError, match="cannot read the plan"):
        read_plan_limits(str(plan))
