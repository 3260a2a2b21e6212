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
    assert len(errors) == 1 and "12000 points" in errors[0] and "--memory-limit" in errors[0], r.stderr
    assert "reading nominal" not in r.stderr           # refused before the nominal is read
    assert not csv.exists() and list(tmp_path.iterdir()) == [] and measured.read_bytes() == before
    for bad in ("0", "-1", "nan", "inf", "lots"):
        r = subprocess.run([sys.executable, "-m", "bladerecon", "deviation", str(measured), "--nominal",
                            str(ROOT / "resources" / "sample" / "nominal.step"), f"--memory-limit={bad}"],
                           capture_output=True, text=True, env=ENV, timeout=60)
        assert r.returncode == 2 and "--memory-limit" in r.stderr and "Traceback" not in r.stderr, (bad, r.stderr)
