# SPDX-License-Identifier: LGPL-2.1-or-later
"""Issue 24 figures: section parameters against the analytic truth, beside engeom 0.5 (run from the repo root).

    /usr/bin/python3 bench/bench_sections.py [--quick]
    /usr/bin/python3 bench/bench_sections.py --times [RUNS]   # only the times table (default 5 runs)

Truth: the analytic sample blade (:mod:`bladerecon.samples.blade`, exact in closed form), with
the issue's proportions (6 sections, chord 40 -> 32 mm, LE radius 0.55 -> 0.30 mm, TE radius
0.40 -> 0.25 mm). Cases: 2000 / 400 / 120 points a section, 0 and 2 µm noise (each
coordinate), even (equal arc length, random start) and random spacing (uniform random arc
length positions). Errors are the largest over the 6 sections. Times: both tools as processes
on the same files (6 x 2000 points, 21 x 240 points), runs alternating between the tools, min and
median. ``--times`` measures only these and rewrites only the times table (and ``times`` in the JSON).

The peer, engeom 0.5's ``airfoil2`` (full-round edges, flow direction given), is installed from
PyPI into a bench-only venv ``.cache/bench-venv`` by this script (``python3 -m venv
--system-site-packages``; pip): a peer to measure against, never a dependency. Without network
the table has our columns only. Writes bench/results/sections.md and .json.
"""
from __future__ import annotations

import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bladerecon.core.sections.parameters import measure_section, segment_blade  # noqa: E402
from bladerecon.samples.blade import SampleBlade, section_heights, t_at_length_fraction  # noqa: E402

BLADE = SampleBlade(chord_hub=40.0, chord_tip=32.0, le_radius_hub=0.55, le_radius_tip=0.3, te_radius_hub=0.4,
                    te_radius_tip=0.25, thickness_hub=0.06, thickness_tip=0.05)
FLOW = np.array([1.0, 0.0, 0.0])          # the sample's axial direction: LE upstream
AXIS = np.array([0.0, 0.0, 1.0])
VENV = ROOT / ".cache" / "bench-venv"
PEER = ROOT / "bench" / "peer_engeom_sections.py"
OUT = ROOT / "bench" / "results"
KEYS = ("le_radius", "te_radius", "chord", "max_thickness", "le")


def sections(n_sections: int, n: int, spacing: str, noise: float, seed: int) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out = []
    for h in section_heights(n_sections):
        if spacing == "even":
            f = (rng.random() + np.arange(n)) / n
        else:
            f = np.sort(rng.random(n))
        p = BLADE.point(h, t_at_length_fraction(BLADE, h, f))
        out.append(p + noise * rng.standard_normal(p.shape))
    return out


def truth(n_sections: int) -> list[dict]:
    out = []
    for h in section_heights(n_sections):
        laws = BLADE.section_laws(h)
        le, te = BLADE.le_te(h)
        # the camber-line definition (engeom's): the camber line extended through the edge circle
        ends = []
        for x0, r in ((0.0, laws.le_radius), (1.0, laws.te_radius)):
            c0 = BLADE.camber_point(h, x0)
            c1 = BLADE.camber_point(h, x0 + (1e-6 if x0 == 0 else -1e-6))
            ends.append((c0 - r * (c1 - c0) / np.linalg.norm(c1 - c0))[:2])
        out.append({"le_radius": float(laws.le_radius), "te_radius": float(laws.te_radius),
                    "chord": float(laws.chord), "max_thickness": float(laws.max_thickness), "le": le[:2],
                    "camber": {"le": ends[0], "chord": float(np.linalg.norm(ends[1] - ends[0]))}})
    return out


def errors(rows: list[dict], tr: list[dict], camber_ends: bool = False) -> dict:
    """Largest error over the sections: radii in % of the radius, chord and thickness in µm,
    LE point in µm; 'null' counts radii not given, 'failed' sections that gave nothing."""
    e = {k: 0.0 for k in KEYS}
    nulls = failed = 0
    for r, t in zip(rows, tr):
        if r is None or "error" in r:
            failed += 1
            continue
        for k in ("le_radius", "te_radius"):
            if r[k] is None:
                nulls += 1
            else:
                e[k] = max(e[k], 100 * abs(r[k] / t[k] - 1))
        ends = t["camber"] if camber_ends else t
        e["chord"] = max(e["chord"], 1000 * abs(r["chord"] - ends["chord"]))
        e["max_thickness"] = max(e["max_thickness"], 1000 * abs(r["max_thickness"] - t["max_thickness"]))
        e["le"] = max(e["le"], 1000 * float(np.linalg.norm(np.asarray(r["le"])[:2] - ends["le"])))
    e["null"], e["failed"] = nulls, failed
    return e


def ours(secs: list[np.ndarray]) -> list[dict]:
    blade = segment_blade(secs, AXIS, flow=FLOW)
    out = []
    for s in blade.sections:
        try:
            out.append(measure_section(s, strict_radius=False).as_dict())
        except Exception as err:      # noqa: BLE001  a refused section is a result here
            out.append({"error": str(err)})
    return out


def peer_python() -> Path | None:
    """The bench venv's python with engeom 0.5, made on first use; None when it cannot be."""
    py = VENV / "bin" / "python"
    try:
        if not py.exists():
            subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(VENV)], check=True,
                           capture_output=True, timeout=300)
        ok = subprocess.run([str(py), "-c", "import engeom.airfoil2"], capture_output=True, timeout=60)
        if ok.returncode != 0:
            subprocess.run([str(py), "-m", "pip", "install", "-q", "engeom==0.5.0"], check=True,
                           capture_output=True, timeout=600)
        return py
    except (subprocess.SubprocessError, OSError) as err:
        print(f"bench_sections: engeom not available ({err}): truth-only table", file=sys.stderr)
        return None


def peer(py: Path | None, secs: list[np.ndarray], tmp: Path, mode: str = "raw"
         ) -> tuple[list[dict] | None, float | None]:
    if py is None:
        return None, None
    npz, js = tmp / "s.npz", tmp / "e.json"
    np.savez(npz, **{f"s{k}": p for k, p in enumerate(secs)})
    subprocess.run([str(py), str(PEER), str(npz), str(js), f"{FLOW[0]},{FLOW[1]}", "1e-4", mode], check=True,
                   timeout=600)
    res = json.loads(js.read_text())
    return res["sections"], res["seconds"]


def process_times(py: Path | None, tmp: Path, runs: int = 3) -> list[dict]:
    """Both tools as processes on the same files, ``runs`` times each, the tools alternating so that
    both see the same load: wall clock and CPU (user + system), min (``bladerecon``, ``bladerecon_cpu``)
    and median (``..._median``)."""
    rows = []
    for n_sec, n in ((6, 2000), (21, 240)):
        secs = sections(n_sec, n, "even", 0.002, seed=5)
        csv = tmp / f"t{n_sec}.csv"
        csv.write_text("section,x,y,z\n" + "".join(f"{k},{x!r},{y!r},{z!r}\n" for k, p in enumerate(secs)
                                                    for x, y, z in p))
        np.savez(tmp / f"t{n_sec}.npz", **{f"s{k}": p for k, p in enumerate(secs)})
        env = dict(os.environ, PYTHONPATH=str(ROOT))
        cmds = {"bladerecon": [sys.executable, "-m", "bladerecon", "sections", str(csv), "--flow", "1,0,0",
                               "--lenient", "--json", "--quiet"]}
        if py is not None:
            cmds["engeom"] = [str(py), str(PEER), str(tmp / f"t{n_sec}.npz"), str(tmp / "x.json"), "1,0"]
        row = {"case": f"{n_sec} x {n}", "runs": runs}
        wall: dict = {name: [] for name in cmds}
        cpu: dict = {name: [] for name in cmds}
        for _ in range(runs):
            for name, cmd in cmds.items():
                r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
                t0 = time.perf_counter()
                subprocess.run(cmd, check=True, capture_output=True, env=env, timeout=600)
                wall[name].append(time.perf_counter() - t0)
                r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
                cpu[name].append((r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime))
        for name in cmds:
            row[name], row[name + "_cpu"] = min(wall[name]), min(cpu[name])
            row[name + "_median"], row[name + "_cpu_median"] = statistics.median(wall[name]), statistics.median(cpu[name])
        rows.append(row)
    return rows


def _load() -> str:
    return "load average " + " ".join(f"{v:.2f}" for v in os.getloadavg()) + f" on {os.cpu_count()} CPUs"


def times_only(runs: int) -> None:
    """``--times``: measure the process times again and replace only the times table (and ``times``
    in the JSON); the error tables stay as they were."""
    py = peer_python()
    before = _load()
    with tempfile.TemporaryDirectory() as d:
        times = process_times(py, Path(d), runs)
    load = f"{before} before, {_load()} after"
    md = OUT / "sections.md"
    text = md.read_text()
    start = text.find(TIMES_HEAD)
    text = (text[:start] if start >= 0 else text + "\n").rstrip("\n") + "\n\n" + "\n".join(_times_table(times, load)) + "\n"
    print(text[text.find(TIMES_HEAD):])
    md.write_text(text)
    js = OUT / "sections.json"
    data = json.loads(js.read_text()) if js.exists() else {"cases": []}
    data["times"], data["times_load"] = times, load
    js.write_text(json.dumps(data, indent=1))


def main() -> None:
    if "--times" in sys.argv:
        rest = sys.argv[sys.argv.index("--times") + 1:]
        times_only(int(rest[0]) if rest and rest[0].isdigit() else 5)
        return
    quick = "--quick" in sys.argv
    py = peer_python()
    tr = truth(6)
    results = []
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for n in (2000, 400, 120):
            for noise in (0.0, 0.002):
                for spacing in ("even", "random"):
                    secs = sections(6, n, spacing, noise, seed=n + int(noise * 1e4) + (spacing == "random"))
                    t0 = time.perf_counter()
                    mine = ours(secs)
                    t_ours = time.perf_counter() - t0
                    row = {"points": n, "noise_um": noise * 1000, "spacing": spacing,
                           "ours": errors(mine, tr), "ours_s": t_ours}
                    for mode, key in (("raw", "engeom"), ("spline", "engeom_spline")):
                        theirs, t_peer = peer(py, secs, tmp, mode)
                        if theirs is not None:
                            row[key], row[key + "_s"] = errors(theirs, tr, camber_ends=True), t_peer
                    results.append(row)
                    print(json.dumps(row), file=sys.stderr)
            if quick:
                break
        before = _load()
        times = process_times(py, tmp, 5)
        load = f"{before} before, {_load()} after"
    write(results, times, py is not None, load)


def _cell(e: dict | None, k: str) -> str:
    if e is None:
        return "–"
    return f"{e[k]:.3g}"


TIMES_HEAD = "Times as processes"


def _times_table(times: list[dict], load: str) -> list[str]:
    """The times table: min and median of the runs, wall clock and CPU (user + system)."""
    runs = times[0].get("runs", 3) if times else 3
    lines = [f"{TIMES_HEAD} (s, {runs} runs each, the tools alternating; 2 µm noise, even spacing; "
             f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {load}; wall clock and CPU, user + system, "
             "min / median: the machine may be shared, CPU is the steadier figure):", "",
             "| case | bladerecon CPU s | bladerecon wall s | engeom CPU s | engeom wall s |", "|---|---|---|---|---|"]
    nan = float("nan")

    def cell(t: dict, key: str) -> str:
        return f"{t.get(key, nan):.2f} / {t.get(key + '_median', t.get(key, nan)):.2f}"
    for t in times:
        lines.append(f"| {t['case']} | {cell(t, 'bladerecon_cpu')} | {cell(t, 'bladerecon')} | "
                     f"{cell(t, 'engeom_cpu')} | {cell(t, 'engeom')} |")
    return lines


def write(results: list[dict], times: list[dict], have_peer: bool, load: str = "") -> None:
    lines = ["# Section parameters against the analytic truth (issue 24)", "",
             f"{datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {platform.machine()}, Python "
             f"{platform.python_version()}, numpy {np.__version__}. Largest error over 6 sections; radii in % "
             "of the true radius, chord / max thickness / LE point in µm; `null`: radii not given (of 12); "
             "`fail`: sections refused. Our LE point is the end along the chord (tangent ⟂ chord, the "
             "generator's definition); engeom's is where its camber line meets the edge, so its chord and LE "
             "point are judged against the truth of that definition (the generator's camber line extended "
             "by the edge radius). `s`: seconds in process for the 6 sections (engeom: its own loop).", ""]
    tools = [("ours", "bladerecon")] + ([("engeom", "engeom (raw points)"), ("engeom_spline", "engeom (spline-densified)")]
                                        if have_peer else [])
    for key, title in tools:
        lines += ["", f"**{title}**", "",
                  "| points | noise µm | spacing | r_LE % | r_TE % | chord µm | t_max µm | LE µm | null | fail | s |",
                  "|" + "---|" * 11]
        for r in results:
            e = r.get(key)
            cells = [str(r["points"]), f"{r['noise_um']:g}", r["spacing"]]
            cells += [_cell(e, k) for k in KEYS] + [str(e["null"]), str(e["failed"]), f"{r[key + '_s']:.2f}"]
            lines.append("| " + " | ".join(cells) + " |")
    lines += [""] + _times_table(times, load)
    text = "\n".join(lines) + "\n"
    print(text)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "sections.md").write_text(text)
    (OUT / "sections.json").write_text(json.dumps({"cases": results, "times": times, "times_load": load}, indent=1))


if __name__ == "__main__":
    main()
