# SPDX-License-Identifier: LGPL-2.1-or-later
"""Deviation end to end, as the user waits: ``python3 -m bladerecon deviation FILE --nominal N``.

Run from the repository root: ``/usr/bin/python3 bench/bench_deviation_e2e.py [--runs 5]``.
Writes ``bench/results/deviation_e2e.md`` and ``.json``.

For the single B-spline face of the sample nominal (``resources/sample/nominal.step``) and the
multi-face nominal of :mod:`bladerecon.samples.multiface` (trimmed B-spline airfoil faces, caps
on a surface of revolution and a cone; written to STEP here), point files of 10k, 100k and 1M
points (``x,y,z`` CSV, spread over the nominal's area and pushed off it by N(0, 0.05 mm)) are
measured by the command as a separate process, ``--runs`` times each. Reported per case:

* wall time from process start to exit (the figure a user waits for: interpreter start,
  imports, file reading, the nominal, the measurement), min / median / max;
* the command's own ``seconds`` (read, align, measure, total) of the median run;
* peak resident memory of the process (``ru_maxrss`` from ``os.wait4``), max over the runs;
* OpenCASCADE's ``Vertex.distToShape`` per point on 1000 of the points (the faces' compound),
  scaled to N: the peer the issue names, and the largest |ours - OCC| on those points.
"""
from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
sys.path.insert(0, str(ROOT))
RESULTS = BENCH / "results"
PYTHON = "/usr/bin/python3"
SIZES = (10_000, 100_000, 1_000_000)
OCC_SAMPLE = 1000

from bladerecon.fc.freecad_env import import_freecad  # noqa: E402

sys.path.insert(0, str(ROOT / "tests"))
from memory_probe import peak_memory  # noqa: E402

sys.path.insert(0, str(BENCH))
from bench_deviation import area_points  # noqa: E402  (points spread over a shape's area)

FreeCAD, Part = import_freecad()


# A small launcher runs the command as its child and reports the children's peak RSS: measured
# on a child of this (large) bench process directly, the pages shared at fork would count.
_LAUNCHER = ("import resource, subprocess, sys; r = subprocess.run(sys.argv[1:]); "
             "print('RSS_KB=%d' % resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); "
             "sys.exit(r.returncode)")


def run_once(args: list[str]) -> tuple[float, int, dict]:
    """(wall s, peak RSS MiB, the --json summary) of one command run as its own process; the
    wall time includes the launcher's start (about 20 ms)."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t = time.perf_counter()
    proc = subprocess.run([PYTHON, "-c", _LAUNCHER, PYTHON, "-m", "bladerecon", *args], capture_output=True,
                          env=env, cwd=ROOT)
    wall = time.perf_counter() - t
    err = proc.stderr.decode()
    if proc.returncode != 0:
        raise SystemExit(f"bench: {' '.join(args)} failed: {err[-2000:]}")
    rss_kb = int(err.strip().splitlines()[-1].split("=")[1])
    return wall, rss_kb // 1024, json.loads(proc.stdout)


def occ_per_point(shape, P: np.ndarray) -> tuple[float, np.ndarray]:
    faces = Part.Compound(shape.Faces)
    t = time.perf_counter()
    d = np.array([Part.Vertex(FreeCAD.Vector(*p)).distToShape(faces)[0] for p in P])
    return (time.perf_counter() - t) / len(P), d


def bench_case(label: str, nominal: str, shape, sizes, runs: int, rng, tmp: Path) -> list[dict]:
    P_all = area_points(shape, max(sizes), rng)
    rows = []
    for m in sizes:
        path = tmp / f"{label}_{m}.csv"
        np.savetxt(path, P_all[:m], fmt="%.6f", delimiter=",", header="x,y,z", comments="")
        csv_out = tmp / f"{label}_{m}_dev.csv"
        results = []
        for _ in range(runs):
            results.append(run_once(["deviation", str(path), "--nominal", nominal, "--csv", str(csv_out),
                                     "--json", "--quiet"]))
        # one more run for the memory the machine sees: total PSS of the command and its forked
        # worker (ru_maxrss is the largest single process), sampled every 20 ms
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        _, pss, _ = peak_memory([PYTHON, "-m", "bladerecon", "deviation", str(path), "--nominal", nominal, "--quiet"],
                                env=env)
        walls = [w for w, _, _ in results]
        median_run = sorted(results, key=lambda r: r[0])[len(results) // 2]
        ours = np.abs(np.loadtxt(csv_out, delimiter=",", skiprows=1, usecols=(3,), max_rows=OCC_SAMPLE))
        per_point, occ = occ_per_point(shape, P_all[:OCC_SAMPLE])
        row = {"nominal": label, "points": m, "load_avg": os.getloadavg()[0],
               "wall_s": {"min": min(walls), "median": statistics.median(walls), "max": max(walls)},
               "runs_wall_s": walls, "seconds_median_run": median_run[2]["seconds"],
               "peak_rss_mib": max(r for _, r, _ in results), "peak_total_pss_mib": int(pss / 2 ** 20), "method": median_run[2].get("nominal", {}).get("method"),
               "occ_ms_per_point": per_point * 1e3, "occ_scaled_s": per_point * m,
               "max_abs_diff_vs_occ_mm": float(np.abs(ours[:len(occ)] - occ).max())}
        rows.append(row)
        print(f"{label} {m:>9,} points: wall {row['wall_s']['median']:.2f} s (min {row['wall_s']['min']:.2f}, "
              f"max {row['wall_s']['max']:.2f}), peak {row['peak_rss_mib']} MiB (total {row['peak_total_pss_mib']} MiB), OCC ~{row['occ_scaled_s']:.0f} s, "
              f"|ours-OCC| {row['max_abs_diff_vs_occ_mm']:.1e} mm", file=sys.stderr, flush=True)
    return rows


def markdown(meta: dict, rows: list[dict]) -> str:
    lines = [f"Deviation end to end as a process ({meta['date']}, {meta['cpus']} CPUs, {meta['machine']}, "
             f"FreeCAD {meta['freecad']}, {meta['runs']} runs a case; load average printed: a shared machine).",
             "",
             "| nominal | points | wall min / median / max (s) | read / measure / total of the median run (s) "
             "| peak RSS (MiB) | total PSS with the worker (MiB) | OCC distToShape, scaled (s) "
             "| max \\|ours − OCC\\| (mm) | load |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        w, s = r["wall_s"], r["seconds_median_run"]
        lines.append(f"| {r['nominal']} | {r['points']:,} | {w['min']:.2f} / {w['median']:.2f} / {w['max']:.2f} | "
                     f"{s['read']:.2f} / {s['measure']:.2f} / {s['total']:.2f} | {r['peak_rss_mib']} | {r['peak_total_pss_mib']} | "
                     f"{r['occ_scaled_s']:.0f} | {r['max_abs_diff_vs_occ_mm']:.1e} | {r['load_avg']:.1f} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    ap.add_argument("--out", type=Path, default=RESULTS)
    a = ap.parse_args(argv)
    from bladerecon.fc.nominal_faces import write_multiface_nominal
    from bladerecon.samples.multiface import multiface_spec

    rng = np.random.default_rng(17)
    meta = {"date": dt.date.today().isoformat(), "cpus": os.cpu_count(), "machine": platform.machine(),
            "freecad": ".".join(FreeCAD.Version()[:3]), "runs": a.runs}
    rows = []
    with tempfile.TemporaryDirectory(prefix="bladerecon-bench-") as tmp:
        tmp = Path(tmp)
        single = str(ROOT / "resources" / "sample" / "nominal.step")
        rows += bench_case("single face (sample)", single, Part.read(single), a.sizes, a.runs, rng, tmp)
        multi = write_multiface_nominal(tmp, multiface_spec())["step"]
        rows += bench_case("multi-face", multi, Part.read(multi), a.sizes, a.runs, rng, tmp)
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "deviation_e2e.json").write_text(json.dumps({"meta": meta, "rows": rows}, indent=1) + "\n")
    text = markdown(meta, rows)
    (a.out / "deviation_e2e.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
