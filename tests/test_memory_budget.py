# SPDX-License-Identifier: LGPL-2.1-or-later
"""Issue 23 §4: bounded memory. ``deviation`` measured as the machine sees it (total PSS of the
command and its forked workers, :mod:`memory_probe`, not the command's own accounting):
31 000 points against a 1500 x 16-pole nominal within the issue's 300 MB, a larger job within
the budget estimate the command refuses by (so the estimate is an upper bound), and a job over
``--memory-limit`` refused in one line before the nominal is read, with nothing written."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from memory_probe import peak_memory

from bladerecon.core.io.memory import deviation_need
from bladerecon.samples.blade import SampleBlade, sample_sections

ROOT = Path(__file__).resolve().parents[1]
ENV = dict(os.environ, PYTHONPATH=str(ROOT))


def _cloud(path: Path, n_sections: int, per_section: int, seed: int) -> int:
    P = np.vstack(sample_sections(SampleBlade(), n_sections, per_section, "uniform", noise=0.01, seed=seed))
    np.savetxt(path, P, delimiter=",", fmt="%.6f", header="x,y,z", comments="")
    return len(P)


@pytest.fixture(scope="module")
def big_nominal(tmp_path_factory):
    """A 1500 x 16-pole B-spline face through the sample blade (the issue's dense nominal),
    made by the product's own reconstruct from 16 exact sections of 6000 points."""
    d = tmp_path_factory.mktemp("nominal")
    secs = sample_sections(SampleBlade(), 16, 6000, "uniform", noise=0.0, seed=2)
    src = d / "s16.csv"
    src.write_text("section,x,y,z\n" + "".join(f"{k},{x:.6f},{y:.6f},{z:.6f}\n"
                                               for k, p in enumerate(secs) for x, y, z in p))
    out = d / "nominal1500.step"
    r = subprocess.run([sys.executable, "-m", "bladerecon", "reconstruct", str(src), "--method", "approximate",
                        "--poles", "1500x16", "-o", str(out), "--quiet"], capture_output=True, text=True, env=ENV,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.timeout(240)
def test_deviation_memory_stays_within_its_bounds(big_nominal, tmp_path):
    for n_sections, per, limit in ((31, 1000, 300e6), (50, 3000, None)):
        f = tmp_path / f"c{n_sections}.csv"
        n = _cloud(f, n_sections, per, seed=n_sections)
        rc, peak, err = peak_memory([sys.executable, "-m", "bladerecon", "deviation", str(f), "--nominal",
                                     str(big_nominal), "--quiet"], env=ENV)
        assert rc == 0, err
        assert peak <= deviation_need(n), (n, peak / 1e6, deviation_need(n) / 1e6)
        if limit is not None:          # the figure for 31 000 points on this nominal
            assert peak <= limit, (n, peak / 1e6)


def test_a_job_over_the_budget_is_refused_before_it_starts(tmp_path):
    measured = ROOT / "resources" / "sample" / "measured.csv"
    csv = tmp_path / "dev.csv"
    before = measured.read_bytes()
    r = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", str(measured), "--nominal",
                        str(ROOT / "resources" / "sample" / "nominal.step"), "--memory-limit", "0.2", "--csv", str(csv)],
                       capture_output=True, text=True, env=ENV, timeout=120)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    errors = [line for line in r.stderr.splitlines() if line.startswith("bladerecon: error:")]
    assert len(errors) == 1 and "up to 12001 points" in errors[0] and "--memory-limit" in errors[0], r.stderr
    assert "reading nominal" not in r.stderr           # refused before the nominal is read
    assert not csv.exists() and list(tmp_path.iterdir()) == [] and measured.read_bytes() == before
    for bad in ("0", "-1", "nan", "inf", "lots"):
        r = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", str(measured), "--nominal",
                            str(ROOT / "resources" / "sample" / "nominal.step"), f"--memory-limit={bad}"],
                           capture_output=True, text=True, env=ENV, timeout=60)
        assert r.returncode == 2 and "--memory-limit" in r.stderr and "Traceback" not in r.stderr, (bad, r.stderr)


# --------------------------------------------------------------------------- every command's bound
def _write(path: Path, P: np.ndarray, section: np.ndarray | None = None) -> int:
    with open(path, "w") as f:
        if section is None:
            f.write("x,y,z\n" + "".join(f"{x!r},{y!r},{z!r}\n" for x, y, z in P.tolist()))
        else:
            f.write("section,x,y,z\n" + "".join(f"{s},{x!r},{y!r},{z!r}\n"
                                                 for s, (x, y, z) in zip(section.tolist(), P.tolist())))
    return len(P)


def _blade_sections(path, n_sections, per_section, seed):
    secs = sample_sections(SampleBlade(), n_sections, per_section, "uniform", noise=0.002, seed=seed)
    return _write(path, np.vstack(secs), np.repeat(np.arange(n_sections), per_section))


def _blade_cloud(path, n, seed):
    """Random (h, t) over the whole analytic blade, 2 µm noise in 3-D: a scan to slice."""
    blade, rng = SampleBlade(), np.random.default_rng(seed)
    h, t = rng.random(n), rng.random(n)
    P = np.vstack([blade.point(h[i:i + 100_000], t[i:i + 100_000]) for i in range(0, n, 100_000)])
    return _write(path, P + 0.002 * rng.standard_normal(P.shape))


def _zmap(path, n, seed):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(-8, 8, (n, 2))
    r = np.hypot(xy[:, 0], xy[:, 1])
    return _write(path, np.column_stack([xy, np.sin(r) / r + 0.002 * rng.standard_normal(n)]))


def _damaged(path, rows, around):
    from bladerecon.samples.damaged import ServiceDamage, damaged_cloud
    return _write(path, damaged_cloud(ServiceDamage(), n_rows=rows, n_around=around))


def _blisk(path, per_section):
    from bladerecon.samples.blisk import blisk_scan
    scan = blisk_scan(12, n_sections=10, n_points=per_section, seed=3)
    return _write(path, scan.points, scan.section)


NOMINAL = str(ROOT / "resources" / "sample" / "nominal.step")
#: command -> (make the input, the arguments after the input). Sizes: between the smallest and
#: the largest the constants were measured on; --slice 6 on 400 000 points is the case whose
#: neighbour pairs grew with the square of the slab's points (1.44 GB; the bound is 0.53 GB)
JOBS = {
    "reconstruct": (lambda p: _blade_sections(p, 6, 8000, 1), lambda out: ["-o", str(out / "r.step")]),
    "reconstruct --slice": (lambda p: _blade_cloud(p, 400_000, 2), lambda out: ["--slice", "6", "-o", str(out / "s.step")]),
    "sections": (lambda p: _blade_sections(p, 6, 8000, 3), lambda out: ["--json"]),
    "sections --nominal --plots": (lambda p: _blade_sections(p, 6, 8000, 3),
                                   lambda out: ["--nominal", NOMINAL, "--plots", str(out / "plots")]),
    "tspline": (lambda p: _zmap(p, 100_000, 4), lambda out: ["--zmap", "--tolerance", "0.05", "-o", str(out / "t.step")]),
    "repair": (lambda p: _damaged(p, 150, 300), lambda out: ["--nominal", NOMINAL, "-o", str(out / "x.step")]),
    "blisk": (lambda p: _blisk(p, 500), lambda out: ["--nominal", str(ROOT / "resources" / "blisk" / "blade0.step"),
                                                      "--blades", "12", "-o", str(out / "lot")]),
}


def _need(argv: list[str]) -> float:
    """The need (bytes) the command itself states when refusing the job under a tiny budget."""
    import re
    r = subprocess.run(argv + ["--memory-limit", "0.001"], capture_output=True, text=True, env=ENV, timeout=120)
    found = re.search(r"needs about ([\d.]+) (GB|MB) of memory", r.stderr)
    assert r.returncode == 2 and found, r.stderr
    return float(found.group(1)) * (1e9 if found.group(2) == "GB" else 1e6)


@pytest.mark.timeout(300)
@pytest.mark.parametrize("job", sorted(JOBS))
def test_every_commands_estimate_is_an_upper_bound_of_its_peak(tmp_path, job):
    """The need a command refuses a job by (stated in its message, from the points in the file
    and the options) is at least the peak the machine sees, and within 4 x of it (8 x for
    reconstruct, whose base is the cloud path's; an estimate that refuses jobs that would fit is a
    defect too)."""
    make, argv = JOBS[job]
    src = tmp_path / "in.csv"
    n = make(src)
    out = tmp_path / "out"
    out.mkdir()
    cmd = [sys.executable, "-m", "bladerecon", job.split()[0], str(src)] + argv(out) + ["--quiet"]
    need = _need(cmd)
    assert list(out.iterdir()) == []
    rc, peak, err = peak_memory(cmd, env=ENV, timeout=280)
    assert rc == 0, err[-600:]
    # reconstruct's base is the whole-blade cloud's (0.29-0.38 GB from 50k points: the kind of
    # input is known only once it is read); a sections file, or a cloud cut by --slice (its
    # slabs hold ~3000 points), stays near 0.1 GB
    # and a run of 1-2 s can finish between two 20 ms samples of its peak: the upper side is a
    # guard against absurd estimates, the lower side (peak <= need) is the claim
    loose = 8 if job.startswith("reconstruct") else 4
    assert peak <= need <= loose * peak, (job, n, peak / 1e6, need / 1e6)


def test_plans_estimate_is_an_upper_bound_of_its_peak(tmp_path):
    cmd = [sys.executable, "-m", "bladerecon", "plan", NOMINAL, "--heights", "5,23,41,59,77,95", "--step", "0.02",
           "-o", str(tmp_path / "plan.csv"), "--quiet"]
    need = _need(cmd)
    rc, peak, err = peak_memory(cmd, env=ENV, timeout=280)
    assert rc == 0, err[-600:]
    assert peak <= need <= 4 * peak, (peak / 1e6, need / 1e6)


def test_a_lots_budget_is_shared_by_its_workers(tmp_path):
    """``batch --memory-limit`` is the lot's: each of two workers' blades gets half. At 0.6 GB
    a blade's share (0.3 GB) is under ``deviation``'s need (0.40 GB + 500 B a point): every
    blade fails in its own one line, the lot goes on to its end (exit 2), and the message says
    the share, not the lot's figure."""
    import json

    out = tmp_path / "lot"
    r = subprocess.run([sys.executable, "-m", "bladerecon", "batch", str(ROOT / "resources" / "sample"), "--nominal",
                        NOMINAL, "-o", str(out), "--workers", "2", "--memory-limit", "0.6", "--json"],
                       capture_output=True, text=True, env=ENV, timeout=300)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    # every blade failed: no lot summary is written (nothing there would be a result); the
    # --json summary and the one line say why, per blade
    assert "all 2 blades failed, nothing was written" in r.stderr and not out.exists()
    errors = json.loads(r.stdout)["errors"]
    assert len(errors) == 2, errors
    for e in errors.values():
        assert "needs about 0.4" in e and "budget of 0.30 GB" in e, e
