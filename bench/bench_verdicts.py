# SPDX-License-Identifier: LGPL-2.1-or-later
"""Issue 19 figure: the zone best fit's time on the sample blade's 12 000 measured points.

    /usr/bin/python3 bench/bench_verdicts.py

Reads resources/sample/measured.csv (6 sections x 2000 points, 2 µm noise) and nominal.step,
takes the zones from the segmentation and the half-widths from bladerecon/samples/inspection_plan.toml,
fits least squares, then the zone fit from it; the median of 3 runs of each. Prints a Markdown
table and writes bench/results/verdicts.md and .json. Seconds and mm.
"""
from __future__ import annotations

import json
import os
import platform
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bladerecon.core.analysis.alignment import best_fit  # noqa: E402
from bladerecon.core.inspection.plan import read_inspection_plan  # noqa: E402
from bladerecon.core.inspection.verdicts import halfwidths  # noqa: E402
from bladerecon.core.inspection.zone_fit import zone_fit  # noqa: E402
from bladerecon.core.io.readers import read_points  # noqa: E402
from bladerecon.core.sections.ordering import build_sections  # noqa: E402
from bladerecon.fc.deviation import load_nominal  # noqa: E402
from bladerecon.fc.inspection import _point_zones  # noqa: E402

REPEATS = 3
OUT = ROOT / "bench" / "results"


def main() -> None:
    ps = read_points(ROOT / "resources" / "sample" / "measured.csv")
    nominal = load_nominal(str(ROOT / "resources" / "sample" / "nominal.step"))
    plan = read_inspection_plan(ROOT / "bladerecon" / "samples" / "inspection_plan.toml")
    t0 = time.perf_counter()
    zone = _point_zones(ps, build_sections(ps))
    t_zones = time.perf_counter() - t0
    hw = halfwidths(plan, np.asarray(ps.section), zone, list(ps.section_names))
    P = np.asarray(ps.points, float)
    ls_times, zf_times, zf = [], [], None
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        ls = best_fit(P, nominal.projector(), "rigid")
        ls_times.append(time.perf_counter() - t0)
        zf = zone_fit(P, nominal.projector(), hw, start=ls.matrix)
        zf_times.append(zf.seconds)
    t_proj = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        nominal.measure(P)
        t_proj.append(time.perf_counter() - t0)
    row = {"points": len(P), "zones_s": t_zones, "least_squares_s": float(np.median(ls_times)),
           "zone_fit_s": float(np.median(zf_times)), "zone_fit_lp_s": zf.lp_seconds,
           "projections": zf.projections, "lp_steps": zf.iterations, "one_projection_s": float(np.median(t_proj)),
           "max_normalised_least_squares": zf.max_normalised_start, "max_normalised_zone": zf.max_normalised,
           "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
           "machine": f"{platform.machine()}, {os.cpu_count()} cores (shared), Python {platform.python_version()}"}
    table = ("| points | zones (segmentation) | least squares | zone fit | of which LP | LP steps | projections "
             "| one projection | max dev/zone LS → zone |\n|---|---|---|---|---|---|---|---|---|\n"
             f"| {row['points']} | {t_zones:.2f} s | {row['least_squares_s']:.2f} s | {row['zone_fit_s']:.2f} s "
             f"| {row['zone_fit_lp_s']:.2f} s | {row['lp_steps']} | {row['projections']} "
             f"| {row['one_projection_s']:.3f} s | {row['max_normalised_least_squares']:.4f} → "
             f"{row['max_normalised_zone']:.4f} |\n\n{row['date']}, {row['machine']}\n")
    print(table)
    OUT.mkdir(exist_ok=True)
    (OUT / "verdicts.md").write_text(table, encoding="utf-8")
    (OUT / "verdicts.json").write_text(json.dumps(row, indent=2), encoding="utf-8")


if __name__ == "__main__":
    main()
