# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon tspline INPUT --tolerance EPS -o OUT.step --json``: adaptive ASTS fit.

Seed 002: analysis-suitable T-spline fitting with local refinement, exported as bicubic
Bézier patches sewn into one shell. The parameterisation is decided from the data: a file
with sections (blank-line blocks, a ``section`` column, a NASA section table) is a blade —
parameters are the (u, v) of the section reconstruction and x, y, z are fitted as one
vector-valued T-spline; a file of plain ``x y z`` lines without sections is a z-map — the
parameters are (x, y) and z is fitted. ``--zmap`` forces the z-map reading. Units: mm.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

from bladerecon.core.errors import BladeReconError
from bladerecon.core.surface.tspline_job import fit_point_file

__all__ = ["add_parser", "run_tspline"]


def add_parser(sub) -> None:
    p = sub.add_parser("tspline", help="adaptive analysis-suitable T-spline fit (seed 002) -> Bézier patches (+ STEP)",
                       description="Fit an analysis-suitable T-spline to measured points with local refinement "
                                   "until every point is within --tolerance (mm), seed 002. Blade files (with "
                                   "sections) use the section reconstruction's (u,v); plain x y z files are "
                                   "z-maps over (x,y).")
    p.add_argument("input", help="point file: sections (blade) or plain 'x y z' lines / x,y,z CSV (z-map)")
    p.add_argument("--tolerance", type=float, required=True, metavar="MM",
                   help="largest allowed error at a point (mm): vertical for a z-map, |S(u,v)-P| for a blade")
    p.add_argument("-o", "--output", help="STEP file to write (mm): the Bézier patches sewn into one shell")
    p.add_argument("--zmap", action="store_true", help="treat the points as a z-map over (x, y) even if they have sections")
    p.add_argument("--max-iterations", type=int, default=40, help="refinement limit (default 40)")
    p.add_argument("--max-control-points", type=int, default=6000, help="control point limit (default 6000)")
    p.add_argument("--nd", type=int, help="N_d: split initial cells holding more points (default points/16)")
    p.add_argument("--nf", type=int, help="N_f: split initial cells holding more feature points (default points/80)")
    p.add_argument("--cut-order", choices=("longer-side", "switch-side"), default="longer-side",
                   help="where a cell that the midpoint would starve of data is cut: on its longer side between "
                        "the middle data lines (default) or on its other side")
    p.add_argument("--seam", choices=("closed-c1", "closed", "open"), default="closed-c1",
                   help="blades only (u goes around the profile, period 1): close the surface at the seam "
                        "u = 0 = 1 with C1 (default), with C0 only, or leave it open (the fit before the "
                        "seam constraint). Ignored for z-maps")
    p.add_argument("--json", action="store_true", help="print one JSON summary object to stdout")
    p.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    p.set_defaults(run=run_tspline)


def _say(args, msg: str) -> None:
    if not args.quiet:
        print(f"bladerecon: {msg}", file=sys.stderr, flush=True)


def run_tspline(args: argparse.Namespace) -> dict:
    t0 = time.perf_counter()
    if args.output:
        parent = os.path.dirname(os.path.abspath(args.output)) or "."
        if not os.path.isdir(parent):
            raise BladeReconError(f"--output {args.output}: folder {parent} does not exist; create it first")
        if os.path.abspath(args.output) == os.path.abspath(args.input):
            raise BladeReconError(f"--output {args.output} is the input file: choose another name")
    _, patches, summary = fit_point_file(args.input, args.tolerance, args.zmap, args.nd, args.nf,
                                         args.max_iterations, args.max_control_points, lambda m: _say(args, m),
                                         args.cut_order, args.seam)
    t_fit = time.perf_counter()
    if args.output:
        from bladerecon.fc.tspline_export import write_tspline_step
        _say(args, "sewing patches and writing STEP")
        info = write_tspline_step(patches, args.output, seam="seam_gap_max" in summary)
        summary["faces"] = info["faces"]
        summary["output"] = {"step": args.output, **info}
        _say(args, f"wrote {args.output}")
    summary["seconds"] = time.perf_counter() - t0
    summary["seconds_fit"] = t_fit - t0
    return summary
