# SPDX-License-Identifier: LGPL-2.1-or-later
"""Reading point files: ``read_points`` on CSV, XYZ, PLY (binary, ASCII) and PCD (binary) at
10k / 100k / 1M points, beside ``numpy.loadtxt`` on the same text file and FreeCAD's own
``Points`` reader on the same scan file (the peers).

Run from the repository root: ``/usr/bin/python3 bench/bench_readers.py [--runs 5]``.
Writes ``bench/results/readers.md`` and ``.json``. Times are in-process (the read call alone:
file bytes to arrays), min / median / max over ``--runs``; a page-cached file, as after the
first read of a measurement.
"""
from __future__ import annotations

import argparse
import datetime as dt
import json
import os
import platform
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
RESULTS = BENCH / "results"
SIZES = (10_000, 100_000, 1_000_000)

from bladerecon.core.io.readers import read_points  # noqa: E402
from scan_files import write_pcd, write_ply  # noqa: E402


def _times(fn, runs: int) -> list[float]:
    out = []
    for _ in range(runs):
        t = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t)
    return out


def _fmt(ts: list[float] | None) -> str:
    if not ts:
        return "—"
    return f"{min(ts):.3f} / {statistics.median(ts):.3f} / {max(ts):.3f}"


def _freecad_points():
    try:
        from bladerecon.fc.freecad_env import import_freecad

        FreeCAD, _ = import_freecad()
        import Points

        doc = FreeCAD.newDocument("bench_readers")

        def read(path: str):
            Points.insert(path, doc.Name)
            obj = doc.Objects[-1]
            n = obj.Points.CountPoints
            doc.removeObject(obj.Name)
            return n
        return read
    except Exception:           # noqa: BLE001  (a bench without FreeCAD still measures ours)
        return None


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--sizes", type=int, nargs="+", default=list(SIZES))
    a = ap.parse_args(argv)
    rng = np.random.default_rng(16)
    freecad = _freecad_points()
    rows = []
    with tempfile.TemporaryDirectory(prefix="bench_readers_") as tmp:
        tmp = Path(tmp)
        for m in a.sizes:
            P = rng.normal(size=(m, 3)) * [30.0, 8.0, 40.0]
            N = rng.normal(size=(m, 3))
            N /= np.linalg.norm(N, axis=1)[:, None]
            files = {
                "CSV x,y,z": tmp / f"c{m}.csv",
                "XYZ x y z": tmp / f"c{m}.xyz",
                "XYZ x y z i j k (normals)": tmp / f"n{m}.xyz",
                "PLY binary, float, normals": tmp / f"c{m}.ply",
                "PLY ASCII, normals": tmp / f"a{m}.ply",
                "PCD binary, float, normals": tmp / f"c{m}.pcd",
            }
            np.savetxt(files["CSV x,y,z"], P, fmt="%.6f", delimiter=",", header="x,y,z", comments="")
            np.savetxt(files["XYZ x y z"], P, fmt="%.6f")
            np.savetxt(files["XYZ x y z i j k (normals)"], np.column_stack([P, N]), fmt="%.6f")
            write_ply(files["PLY binary, float, normals"], P, N, kind="float")
            write_ply(files["PLY ASCII, normals"], np.round(P, 6), np.round(N, 6), fmt="ascii", kind="float")
            write_pcd(files["PCD binary, float, normals"], P, N)
            for label, path in files.items():
                ours = _times(lambda: read_points(path, require_sections=False), a.runs)
                peer_name, peer = "", None
                if label.startswith(("CSV", "XYZ")):
                    delim = "," if label.startswith("CSV") else None
                    skip = 1 if label.startswith("CSV") else 0
                    peer_name = "numpy.loadtxt"
                    peer = _times(lambda: np.loadtxt(path, delimiter=delim, skiprows=skip), a.runs)
                elif freecad is not None and "ASCII" not in label:
                    peer_name = "FreeCAD Points.insert"
                    peer = _times(lambda: freecad(str(path)), a.runs)
                rows.append({"file": label, "points": m, "bytes": os.path.getsize(path), "ours_s": ours,
                             "peer": peer_name, "peer_s": peer})
                print(f"{label:28s} {m:>9,d}  ours {_fmt(ours)}  {peer_name} {_fmt(peer)}", flush=True)
    RESULTS.mkdir(exist_ok=True)
    stamp = dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    head = (f"Reading point files, in process ({stamp}, {os.cpu_count()} CPUs, {platform.machine()}, "
            f"{a.runs} runs a case, load average {os.getloadavg()[0]:.1f}; page-cached files).\n\n"
            "| file | points | size (MB) | read_points min / median / max (s) | peer | peer min / median / max (s) |\n"
            "|---|---|---|---|---|---|\n")
    body = "".join(f"| {r['file']} | {r['points']:,} | {r['bytes'] / 1e6:.1f} | {_fmt(r['ours_s'])} | "
                   f"{r['peer'] or '—'} | {_fmt(r['peer_s'])} |\n" for r in rows)
    (RESULTS / "readers.md").write_text(head + body)
    (RESULTS / "readers.json").write_text(json.dumps({"when": stamp, "rows": rows}, indent=1))
    print(f"wrote {RESULTS / 'readers.md'}")


if __name__ == "__main__":
    main()
