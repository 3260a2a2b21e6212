# SPDX-License-Identifier: LGPL-2.1-or-later
"""Lot throughput: ``bladerecon batch`` on 48 blades x 200 000 points, local pool and Dask.

Run from the repository root: ``/usr/bin/python3 bench/bench_batch.py [--blades 48]
[--points 200000] [--no-dask]``. Prints a Markdown table and writes
``bench/results/batch.md`` and ``.json``.

The blades are the sample blade (20 sections, equally spaced in arc length, 2 µm noise,
a different seed for each of 4 distinct blades, copied round-robin to ``--blades`` files)
written once into ``.cache/bench_batch/`` (ignored by git). The nominal is
``resources/sample/nominal.step``. Each row is one whole command,
``python3 -m bladerecon batch manifest.csv --nominal ... -o OUT`` in a fresh OUT, wall time
measured around the process (start-up, workers' FreeCAD import and the lot summary
included):

* ``--workers 1`` and ``--workers 2``: blades per minute; scaling efficiency =
  speed-up / 2;
* ``--scheduler``: a Dask ``LocalCluster`` (2 worker processes x 1 thread on 127.0.0.1,
  started before the clock and stopped after); its overhead is its time over the
  ``--workers 2`` run on the same machine. The lot.json of the Dask run is compared byte for
  byte with the pool's.

The machine is shared (the load average is printed beside each row): the figures are
indicative; the bytes comparison is not.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
CACHE = ROOT / ".cache" / "bench_batch"
RESULTS = ROOT / "bench" / "results"
NOMINAL = ROOT / "resources" / "sample" / "nominal.step"
SECTIONS = 20
DISTINCT = 4


def make_lot(n_blades: int, n_points: int) -> Path:
    """The manifest of ``n_blades`` point files of ``n_points`` each (made once, cached)."""
    from bladerecon.core.io.readers import write_points_csv
    from bladerecon.samples.blade import SampleBlade, sample_sections

    folder = CACHE / f"{n_points}"
    folder.mkdir(parents=True, exist_ok=True)
    per = n_points // SECTIONS
    for k in range(DISTINCT):
        path = folder / f"distinct{k}.csv"
        if not path.exists():
            secs = sample_sections(SampleBlade(), SECTIONS, per, noise=0.002, seed=100 + k)
            write_points_csv(path, np.vstack(secs), np.repeat(np.arange(SECTIONS), per))
    rows = ["blade,file,serial"]
    for b in range(n_blades):
        rows.append(f"B{b:03d},distinct{b % DISTINCT}.csv,SN{b:05d}")
    manifest = folder / f"manifest{n_blades}.csv"
    manifest.write_text("\n".join(rows) + "\n")
    return manifest


def timed_batch(manifest: Path, out: Path, extra: list[str]) -> float:
    shutil.rmtree(out, ignore_errors=True)
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "bladerecon", "batch", str(manifest), "--nominal", str(NOMINAL),
                        "-o", str(out), "--quiet", *extra], capture_output=True, text=True, env=env)
    seconds = time.perf_counter() - t0
    if r.returncode != 0:
        raise SystemExit(f"batch {' '.join(extra)} failed: {r.stderr.strip()}")
    return seconds


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blades", type=int, default=48)
    parser.add_argument("--points", type=int, default=200_000, help="points per blade")
    parser.add_argument("--no-dask", action="store_true", help="skip the Dask row")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    manifest = make_lot(args.blades, args.points)
    work = CACHE / "runs"
    work.mkdir(parents=True, exist_ok=True)
    rows = []

    def row(label: str, seconds: float) -> dict:
        r = {"run": label, "seconds": seconds, "blades_per_min": args.blades / seconds * 60.0,
             "load": os.getloadavg()[0]}
        rows.append(r)
        print(f"{label}: {seconds:.1f} s, {r['blades_per_min']:.1f} blades/min (load {r['load']:.2f})", flush=True)
        return r

    one = row("--workers 1", timed_batch(manifest, work / "w1", ["--workers", "1"]))
    two = row("--workers 2", timed_batch(manifest, work / "w2", ["--workers", "2"]))
    efficiency = one["seconds"] / two["seconds"] / 2.0
    same = None
    dask = None
    if not args.no_dask:
        try:
            from distributed import LocalCluster
        except ImportError:
            print("no Dask distributed: the Dask row is skipped (apt-get install python3-distributed)")
        else:
            cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=None, silence_logs=50)
            try:
                dask = row("--scheduler (LocalCluster 2x1)",
                           timed_batch(manifest, work / "dask", ["--scheduler", cluster.scheduler_address]))
            finally:
                cluster.close()
            same = (work / "dask" / "lot" / "lot.json").read_bytes() == (work / "w2" / "lot" / "lot.json").read_bytes()
    lines = [f"# Lot throughput: {args.blades} blades x {args.points} points (`bench/bench_batch.py`)", "",
             f"{platform.node()}: {os.cpu_count()} cores, Python {platform.python_version()}, "
             f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}", "",
             "| run | wall time (s) | blades/min | load avg |", "|---|---|---|---|"]
    lines += [f"| `{r['run']}` | {r['seconds']:.1f} | {r['blades_per_min']:.1f} | {r['load']:.2f} |" for r in rows]
    lines += ["", f"Scaling efficiency, 1 -> 2 workers: {efficiency * 100:.0f} % "
                  f"(speed-up {one['seconds'] / two['seconds']:.2f} on 2 cores)."]
    if dask:
        lines.append(f"Dask overhead on one machine: {dask['seconds'] - two['seconds']:+.1f} s "
                     f"({(dask['seconds'] / two['seconds'] - 1) * 100:+.0f} %) over `--workers 2`; "
                     f"lot.json identical to the pool's: {'yes' if same else 'NO'}.")
    text = "\n".join(lines) + "\n"
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "batch.md").write_text(text)
    (args.out / "batch.json").write_text(json.dumps({"blades": args.blades, "points": args.points, "rows": rows,
                                                     "efficiency": efficiency, "dask_same_bytes": same}, indent=2))
    return 0 if same in (None, True) else 1


if __name__ == "__main__":
    sys.exit(main())
