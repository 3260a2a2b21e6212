# SPDX-License-Identifier: LGPL-2.1-or-later
"""BladeRecon against FreeCAD's own ways: accuracy, fit time and core speed, as Markdown tables.

Run from the repository root: ``/usr/bin/python3 bench/run_all.py``. Prints the tables and
writes ``bench/results/latest.md`` and ``bench/results/latest.json``. What each column
means: ``bench/README.md``. Units: mm and seconds.

1. Accuracy: every method fits the same sections; its shape is scored by OpenCASCADE's
   point-to-face distance (``referee.pruned_occ_distances``) from the same true points.
2. Speed: ``reconstruct`` alone on the 12 000 points of data set (a), median of 5 runs.
"""
from __future__ import annotations

import datetime as dt  # not 'datetime': FreeCAD's start-up rebinds that name in __main__
import json
import multiprocessing
import os
import platform
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH.parent))
DATA = Path(__file__).resolve().parents[1] / "tests" / "data"
RESULTS = BENCH / "results"

from bladerecon.core.surface.pairing import reconstruct_paired  # noqa: E402
from bladerecon.core.io.readers import PointSet, read_points  # noqa: E402
from bladerecon.core.reconstruct import reconstruct  # noqa: E402
from bladerecon.samples.blade import SampleBlade, dense_truth, sample_sections, section_heights  # noqa: E402
from bladerecon.core.sections.ordering import build_sections  # noqa: E402
from bladerecon.fc.convert import make_face  # noqa: E402
from bladerecon.fc.freecad_env import import_freecad  # noqa: E402

FreeCAD, Part = import_freecad()

import freecad_ways as fcw  # noqa: E402
from referee import agreement, pruned_occ_distances  # noqa: E402

NOISE_MM = 0.002
TRUTH_SPAN, TRUTH_PROFILE = 21, 300   # dense_truth grid of the sample blade: 6300 points
FIT_REPEATS = 3                       # fit time = median of this many runs
SPEED_REPEATS = 5
SPEED_TARGET_S = 0.5
CHECK_POINTS = 8                      # per row: points re-measured by occ_distances itself


@dataclass
class Case:
    """One data set: the fitted sections and the true points that score the fit (mm)."""

    key: str
    label: str
    sections: list[np.ndarray]        # counter-clockwise about span_axis, hub first
    span_axis: np.ndarray
    leading_edges: list[np.ndarray]   # one LE point per section (for FreeCAD's seams)
    truth: np.ndarray                 # (N, 3)
    truth_text: str
    on_section: np.ndarray | None     # (N,) True where a true point lies on a fitted section

    @property
    def n_points(self) -> int:
        return int(sum(len(s) for s in self.sections))


# --- data sets ---------------------------------------------------------------------------

def blade_case(key: str, label: str, layout: str) -> Case:
    blade = SampleBlade()
    sections = sample_sections(blade, n_sections=6, layout=layout, noise=NOISE_MM, seed=0)
    les = [np.asarray(blade.le_te(h)[0], dtype=float) for h in section_heights(6)]
    truth = dense_truth(blade, TRUTH_SPAN, TRUTH_PROFILE)
    step = (TRUTH_SPAN - 1) // 5      # truth rows that are the 6 sections' heights
    on = np.repeat(np.arange(TRUTH_SPAN) % step == 0, TRUTH_PROFILE)
    text = f"dense_truth({TRUTH_SPAN}, {TRUTH_PROFILE}): {len(truth)} true points on and between the sections"
    return Case(key, label, sections, np.array([0.0, 0.0, 1.0]), les, truth, text, on)


def _subset(ps: PointSet, keep: list[int]) -> PointSet:
    mask = np.isin(ps.section, keep)
    return PointSet(points=ps.points[mask].copy(), section=np.searchsorted(keep, ps.section[mask]),
                    line=ps.line[mask].copy(), section_names=tuple(ps.section_names[k] for k in keep),
                    source=ps.source, format=ps.format)


def rotor_case(key: str, label: str, path: Path, fit: list[int], held_out: list[int]) -> Case:
    """Fit the sections ``fit`` (0-based); the truth is the held-out sections' points."""
    ps = read_points(path)
    ss = build_sections(_subset(ps, fit))
    sections = [s.points for s in ss.sections]
    les = [ps.section_points(k)[0] for k in fit]   # the files start each section at the LE (J=1)
    truth = np.concatenate([ps.section_points(k) for k in held_out])
    names = ",".join(str(k + 1) for k in held_out)
    text = f"{len(truth)} points of the held-out sections {names} (1-based)"
    return Case(key, label, sections, ss.span_axis, les, truth, text, None)


def all_cases() -> tuple[list[Case], list[str]]:
    cases = [blade_case("a", "(a) blade 6×2000 uniform", "uniform"),
             blade_case("b", "(b) blade 6×65 plan", "plan")]
    skipped = []
    r37 = DATA / "nasa_rotor37" / "rotor37_sections_xyz_mm.txt"
    r67 = DATA / "nasa_rotor67" / "rotor67_sections_xyz_mm.txt"
    if r37.is_file():
        cases.append(rotor_case("r37", "(c) Rotor 37, 7 of 13", r37, list(range(0, 13, 2)), list(range(1, 12, 2))))
    else:
        skipped.append(f"(c) Rotor 37 skipped: {r37} not found")
    if r67.is_file():
        # section 14 (index 13, the casing) lies beyond the last fitted one: not scored
        cases.append(rotor_case("r67", "(c) Rotor 67, 7 of 14", r67, list(range(0, 13, 2)), list(range(1, 12, 2))))
    else:
        skipped.append(f"(c) Rotor 67 skipped: {r67} not found")
    return cases, skipped


# --- methods -------------------------------------------------------------------------------

def fit_ours(case: Case) -> tuple[Any, str, str]:
    r = reconstruct(case.sections, case.span_axis)
    nu, nv = r.surface.poles.shape[:2]
    return make_face(r.surface), f"{nu}×{nv}", f"auto chose {r.choice.method}"


def fit_paired(case: Case) -> tuple[Any, str, str]:
    r = reconstruct_paired(case.sections, case.span_axis)
    nu, nv = r.surface.poles.shape[:2]
    return make_face(r.surface), f"{nu}×{nv}", f"{r.added_points} points added by pairing"


def _le_first(case: Case) -> list[np.ndarray]:
    return [fcw.start_at_leading_edge(s, le) for s, le in zip(case.sections, case.leading_edges)]


def fit_loft_periodic(case: Case) -> tuple[Any, str, str]:
    shape = fcw.loft_periodic(_le_first(case))
    return shape, fcw.poles_text(shape), f"{shape.ShapeType}, {len(shape.Faces)} face(s)"


def fit_loft_closed(case: Case) -> tuple[Any, str, str]:
    shape = fcw.loft_closed(_le_first(case))
    return shape, fcw.poles_text(shape), f"{shape.ShapeType}, {len(shape.Faces)} face(s); C0 seam at LE"


def fit_grid(case: Case) -> tuple[Any, str, str]:
    shape = fcw.grid_interpolate(_le_first(case))
    return shape, fcw.poles_text(shape, around_is_u=False), "not periodic: C0 seam at LE"


METHODS: list[tuple[str, Callable[[Case], tuple[Any, str, str]]]] = [
    ("ours: reconstruct (auto)", fit_ours),
    ("ours: reconstruct_paired", fit_paired),
    ("FreeCAD makeLoft, periodic sections", fit_loft_periodic),
    ("FreeCAD makeLoft, closed C0 sections", fit_loft_closed),
    (f"FreeCAD BSplineSurface.interpolate, {fcw.GRID_POINTS}/section", fit_grid),
]


# --- measuring -----------------------------------------------------------------------------

def _timed_fit(fit: Callable[[Case], tuple[Any, str, str]], case: Case) -> tuple[Any, str, str, float]:
    times, result = [], None
    for _ in range(FIT_REPEATS):
        start = time.perf_counter()
        result = fit(case)
        times.append(time.perf_counter() - start)
    shape, poles, note = result
    return shape, poles, note, float(np.median(times))


def _check_indices(d: np.ndarray) -> np.ndarray:
    spread = np.linspace(0, len(d) - 1, CHECK_POINTS - 1).round().astype(int)
    return np.unique(np.concatenate([[int(np.argmax(d))], spread]))


def score(name: str, fit: Callable, case: Case) -> dict:
    row = {"method": name, "data": case.label, "data_key": case.key, "points": case.n_points}
    try:
        shape, poles, note, seconds = _timed_fit(fit, case)
    except Exception as err:  # a FreeCAD way that fails is reported, not hidden
        row.update(failed=f"{type(err).__name__}: {err}".strip())
        return row
    start = time.perf_counter()
    d = pruned_occ_distances(case.truth, shape)
    occ_seconds = time.perf_counter() - start
    check = _check_indices(d)
    row.update(poles=poles, note=note, fit_s=seconds, max_mm=float(d.max()), mean_mm=float(d.mean()),
               max_on_sections_mm=None if case.on_section is None else float(d[case.on_section].max()),
               max_between_mm=None if case.on_section is None else float(d[~case.on_section].max()),
               worst_point=[float(x) for x in case.truth[int(np.argmax(d))]],
               truth_points=len(d), occ_s=occ_seconds,
               referee_check_mm=agreement(case.truth[check], shape, d[check]))
    return row


def _score_to_pipe(send: Any, name: str, fit: Callable, case: Case) -> None:
    send.send(score(name, fit, case))
    send.close()


def score_isolated(name: str, fit: Callable, case: Case) -> dict:
    """:func:`score` in a forked process, so a FreeCAD call that kills the process fails one row.

    (``Part.makeLoft`` through periodic Rotor 37 sections dereferences a null pointer in
    OCC: sometimes OCC turns the SIGSEGV into an ``OCCError``, sometimes the process exits.)
    """
    if "fork" not in multiprocessing.get_all_start_methods():
        return score(name, fit, case)
    ctx = multiprocessing.get_context("fork")
    receive, send = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_score_to_pipe, args=(send, name, fit, case))
    child.start()
    send.close()
    try:
        row = receive.recv()
    except EOFError:
        row = None
    child.join()
    if row is None:
        row = {"method": name, "data": case.label, "data_key": case.key, "points": case.n_points,
               "failed": f"the process died inside FreeCAD/OCC (exit code {child.exitcode})"}
    return row


def speed(case: Case) -> list[dict]:
    rows = []
    for name, run in (("reconstruct (auto)", lambda: reconstruct(case.sections, case.span_axis)),
                      ("reconstruct_paired", lambda: reconstruct_paired(case.sections, case.span_axis))):
        times, stages = [], []
        for _ in range(SPEED_REPEATS):
            start = time.perf_counter()
            r = run()
            times.append(time.perf_counter() - start)
            stages.append(r.seconds)
        median_stages = {k: float(np.median([s[k] for s in stages])) for k in stages[0] if k != "total"}
        rows.append({"call": name, "points": case.n_points, "runs": SPEED_REPEATS,
                     "median_s": float(np.median(times)), "min_s": float(np.min(times)),
                     "max_s": float(np.max(times)), "stages_median_s": median_stages})
    return rows


# --- machine and Markdown ------------------------------------------------------------------

def machine() -> dict:
    import scipy
    cpu = "unknown"
    try:
        cpu = next(line.split(":", 1)[1].strip() for line in open("/proc/cpuinfo") if line.startswith("model name"))
    except (OSError, StopIteration):
        pass
    version = FreeCAD.Version()
    return {"date_utc": dt.datetime.now(dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
            "nproc": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count(),
            "cpu": cpu, "freecad": ".".join(version[:3]),
            "occt": getattr(Part, "OCC_VERSION", "?"), "python": platform.python_version(),
            "numpy": np.__version__, "scipy": scipy.__version__, "platform": platform.platform()}


def _mm(x: float | None) -> str:
    return "—" if x is None else f"{x:.4f}"


def accuracy_table(rows: list[dict]) -> list[str]:
    out = ["| method | data | points | poles (around×span) | fit s | max error mm | mean error mm "
           "| max on fitted sections mm | note |",
           "|---|---|---:|---:|---:|---:|---:|---:|---|"]
    for r in rows:
        if "failed" in r:
            out.append(f"| {r['method']} | {r['data']} | {r['points']} | — | — | failed | failed | — | {r['failed']} |")
            continue
        out.append(f"| {r['method']} | {r['data']} | {r['points']} | {r['poles']} | {r['fit_s']:.3f} "
                   f"| {_mm(r['max_mm'])} | {_mm(r['mean_mm'])} | {_mm(r['max_on_sections_mm'])} | {r['note']} |")
    return out


def speed_table(rows: list[dict]) -> list[str]:
    out = ["| call | points | runs | median s | min s | max s | stages (median s) | target |",
           "|---|---:|---:|---:|---:|---:|---|---|"]
    for r in rows:
        stages = ", ".join(f"{k} {v:.3f}" for k, v in r["stages_median_s"].items()) or "—"
        target = ""
        if r["call"].startswith("reconstruct (auto)"):
            target = f"< {SPEED_TARGET_S} s: {'met' if r['median_s'] < SPEED_TARGET_S else 'NOT met'}"
        out.append(f"| {r['call']} | {r['points']} | {r['runs']} | {r['median_s']:.3f} | {r['min_s']:.3f} "
                   f"| {r['max_s']:.3f} | {stages} | {target} |")
    return out


def markdown(m: dict, cases: list[Case], skipped: list[str], rows: list[dict], speeds: list[dict],
             total_s: float) -> str:
    scored = [r for r in rows if "failed" not in r]
    worst_check = max((r["referee_check_mm"] for r in scored), default=0.0)
    occ_total = sum(r["occ_s"] for r in scored)
    lines = [
        "# BladeRecon benchmark", "",
        f"{m['date_utc']} · {m['nproc']} CPU ({m['cpu']}) · FreeCAD {m['freecad']} · OCCT {m['occt']} · "
        f"Python {m['python']} · numpy {m['numpy']} · scipy {m['scipy']}", "",
        "## 1. Accuracy and fit time", "",
        *accuracy_table(rows), "",
        "Truth per data set:", "",
        *[f"- {c.label}: {c.truth_text}" for c in cases],
        *[f"- {s}" for s in skipped], "",
        f"Fit s: wall time, median of {FIT_REPEATS} runs, from the section arrays in memory to a Part "
        "shape (ours: `reconstruct` + `make_face`; FreeCAD: Vectors + curve interpolation + loft or "
        "surface interpolation + Face). Excluded: FreeCAD start-up, file reading, scoring. "
        f"Noise: σ = {NOISE_MM * 1000:.0f} µm per coordinate on (a) and (b). "
        "Errors: OCC `distToShape` from each true point to the shape (bench/referee.py), "
        f"{occ_total:.0f} s in all; re-measured with `occ_distances` on {CHECK_POINTS} points per row "
        f"including each row's worst: largest difference {worst_check:.1e} mm.", "",
        "## 2. Core speed on data set (a)", "",
        *speed_table(speeds), "",
        f"Total run time: {total_s:.0f} s.", "",
    ]
    return "\n".join(lines)


def main() -> int:
    start = time.perf_counter()
    m = machine()
    cases, skipped = all_cases()
    rows = []
    for case in cases:
        for name, fit in METHODS:
            row = score_isolated(name, fit, case)
            rows.append(row)
            print(f"  {case.key:4s} {name:50s} "
                  + (row["failed"] if "failed" in row else f"max {row['max_mm']:.4f} mm, fit {row['fit_s']:.3f} s, "
                     f"occ {row['occ_s']:.1f} s"), file=sys.stderr, flush=True)
    speeds = speed(cases[0])
    total = time.perf_counter() - start
    text = markdown(m, cases, skipped, rows, speeds, total)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "latest.md").write_text(text)
    payload = {"machine": m, "total_s": total, "settings": {
        "noise_mm": NOISE_MM, "truth_grid": [TRUTH_SPAN, TRUTH_PROFILE], "fit_repeats": FIT_REPEATS,
        "speed_repeats": SPEED_REPEATS, "speed_target_s": SPEED_TARGET_S, "grid_points": fcw.GRID_POINTS},
        "truth": {c.key: c.truth_text for c in cases}, "skipped": skipped, "accuracy": rows, "speed": speeds}
    (RESULTS / "latest.json").write_text(json.dumps(payload, indent=1))
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
