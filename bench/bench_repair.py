# SPDX-License-Identifier: LGPL-2.1-or-later
"""Repair target vs the naive target (the nominal, best-fitted) on damaged sample blades.

Run from the repository root: ``/usr/bin/python3 bench/bench_repair.py [--quick]``.
Prints a Markdown table and writes ``bench/results/repair.md`` and ``.json``.

Each case is the sample blade with a known service deformation (twist and bend growing as
h², zero at the hub) and known damage (tip loss, LE erosion, a nick, TE burn-off),
:mod:`bladerecon.samples.damaged`, measured as a cloud (jittered grid, 150 x 300 points)
and as 25 planar sections, with 2 µm noise. The truth (closed form, not the repair code):
the deformed undamaged blade on an 81 x 300 (h, t) grid, the twist law, the missing volume
from polygon areas of dense true sections. Columns (mm, degrees, %, 1/mm, s):

* target / naive, damaged: largest distance of the true deformed blade from the repair
  target / from the naive target over the damaged places (damage > 1 µm, or above the cut);
* target, elsewhere: the same over the undamaged places;
* twist error: recovered tip twist minus the true one;
* volume error: missing volume (cloud: all regions; sections: a nick between sections is
  not seen, and the tip is counted from the highest section, 0.5 mm under the break: an
  upper bound; "sections, --cut-height at the break": the tip counted from the break, as a
  repair cell that cuts the tip flat there gives it) minus the true one, in %;
* curvature jump: the largest curvature jump across the blend band's boundaries.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
sys.path.insert(0, str(BENCH.parent))

from bladerecon.core.repair import repair_target  # noqa: E402
from bladerecon.samples.blade import nominal_surface  # noqa: E402
from bladerecon.samples.damaged import (ServiceDamage, damaged_cloud, damaged_sections,  # noqa: E402
                                        true_missing_volume, truth_errors)

CASES = {
    "A: twist 0.3°, bend 0.18 mm, tip 2.5 mm": ServiceDamage(),
    "B: twist 0.1°, bend 0.05 mm, tip 1 mm, LE nick": ServiceDamage(
        twist_tip_deg=0.1, bend_tip_mm=(0.05, 0.0), tip_loss_mm=1.0, nick_edge="le", nick_h=0.2,
        le_erosion_depth_mm=0.1, le_erosion_span=(0.5, 0.7)),
    "C: twist 0.5°, bend 0.3 mm, tip 4 mm, deep erosion": ServiceDamage(
        twist_tip_deg=0.5, bend_tip_mm=(0.0, 0.3), tip_loss_mm=4.0, le_erosion_depth_mm=0.3,
        le_erosion_span=(0.3, 0.7), nick_depth_mm=0.4),
}


def run_case(name: str, sd: ServiceDamage, how: str) -> dict:
    nom = nominal_surface(sd.blade)
    cut = sd.cut_z if how.endswith("--cut-height at the break") else None
    if how == "cloud":
        P, labels = damaged_cloud(sd, n_rows=150, n_around=300), None
    else:
        secs = damaged_sections(sd, n_sections=25, n_points=600)
        P, labels = np.concatenate(secs), np.repeat(np.arange(len(secs)), [len(s) for s in secs])
    t0 = time.perf_counter()
    res = repair_target(P, nom, 1.0, section=labels, cut_height=cut)
    seconds = time.perf_counter() - t0
    d, damaged = truth_errors(sd, res.target)
    dn, _ = truth_errors(sd, res.naive)
    truth = true_missing_volume(sd)["total_mm3"]
    return {"case": name, "measured": how, "points": int(len(P)),
            "target_damaged_max_mm": float(d[damaged].max()), "naive_damaged_max_mm": float(dn[damaged].max()),
            "target_elsewhere_max_mm": float(d[~damaged].max()),
            "twist_error_deg": res.deformation["twist_deg_at_tip"] - sd.twist_tip_deg,
            "volume_mm3": res.volume_mm3, "true_volume_mm3": truth,
            "volume_error_pct": 100.0 * (res.volume_mm3 - truth) / truth,
            "curvature_jump_per_mm": res.blend["max_curvature_jump"], "seconds": seconds}


def table(rows: list[dict]) -> str:
    head = ("| case | measured | target, damaged (mm) | naive, damaged (mm) | target, elsewhere (mm) | "
            "twist error (°) | volume (mm³) / true | volume error (%) | curvature jump (1/mm) | time (s) |\n"
            "|---|---|---|---|---|---|---|---|---|---|\n")
    return head + "".join(
        f"| {r['case']} | {r['measured']} | {r['target_damaged_max_mm']:.4f} | {r['naive_damaged_max_mm']:.3f} | "
        f"{r['target_elsewhere_max_mm']:.4f} | {r['twist_error_deg']:+.4f} | {r['volume_mm3']:.1f} / "
        f"{r['true_volume_mm3']:.1f} | {r['volume_error_pct']:+.2f} | {r['curvature_jump_per_mm']:.4f} | "
        f"{r['seconds']:.1f} |\n" for r in rows)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="case A only")
    parser.add_argument("--out", default=str(BENCH / "results"))
    args = parser.parse_args()
    rows = []
    for name, sd in list(CASES.items())[:1 if args.quick else None]:
        for how in ("cloud", "sections", "sections, --cut-height at the break"):
            rows.append(run_case(name, sd, how))
            print(table(rows[-1:]).splitlines()[-1], flush=True)
    md = table(rows)
    print(md)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "repair.md").write_text("# Repair target vs naive target\n\n" + md, encoding="utf-8")
    (out / "repair.json").write_text(json.dumps(rows, indent=2), encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
