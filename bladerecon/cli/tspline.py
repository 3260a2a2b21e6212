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
import sys
import time

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import Outputs, check_coordinates, check_input, count, escaped, one_line_errors, positive
from bladerecon.core.surface.tspline_job import fit_point_file

__all__ = ["add_parser", "run_tspline"]


def add_parser(sub) -> None:
    p = sub.add_parser("tspline", help="adaptive analysis-suitable T-spline fit (seed 002) -> Bézier patches (+ STEP)",
                       description="Fit an analysis-suitable T-spline to measured points with local refinement "
                                   "until every point is within --tolerance (mm), seed 002. Blade files (with "
                                   "sections) use the section reconstruction's (u,v); plain x y z files are "
                                   "z-maps over (x,y).")
    p.add_argument("input", help="point file: sections (blade) or plain 'x y z' lines / x,y,z CSV (z-map)")
    p.add_argument("--tolerance", type=positive(), required=True, metavar="MM",
                   help="largest allowed error at a point (mm): vertical for a z-map, |S(u,v)-P| for a blade")
    p.add_argument("-o", "--output", help="STEP file to write (mm): the Bézier patches sewn into one shell; "
                                          "put in place only when the whole command succeeds")
    p.add_argument("--zmap", action="store_true", help="treat the points as a z-map over (x, y) even if they have sections")
    p.add_argument("--max-iterations", type=count(0, 10_000), default=40, metavar="N",
                   help="refinement limit (default 40)")
    p.add_argument("--max-control-points", type=count(16, 100_000), default=6000, metavar="N",
                   help="control point limit (default 6000)")
    p.add_argument("--nd", type=count(1), metavar="N",
                   help="N_d: split initial cells holding more points (default points/16)")
    p.add_argument("--nf", type=count(1), metavar="N",
                   help="N_f: split initial cells holding more feature points (default points/80)")
    p.add_argument("--cut-order", choices=("longer-side", "switch-side"), default="longer-side",
                   help="where a cell that the midpoint would starve of data is cut: on its longer side between "
                        "the middle data lines (default) or on its other side")
    p.add_argument("--seam", choices=("closed-c1", "closed", "open"), default="closed-c1",
                   help="blades only (u goes around the profile, period 1): close the surface at the seam "
                        "u = 0 = 1 with C1 (default), with C0 only, or leave it open (the fit before the "
                        "seam constraint). Ignored for z-maps")
    p.add_argument("--json", action="store_true", help="print one JSON summary object to stdout")
    p.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    from bladerecon.core.io.memory import add_memory_option
    add_memory_option(p)
    one_line_errors(p)
    p.set_defaults(run=run_tspline)


def _say(args, msg: str) -> None:
    if not args.quiet:
        print(f"bladerecon: {escaped(msg)}", file=sys.stderr, flush=True)


def _check_coordinates(path: str, memory_limit: float | None = None) -> None:
    """Coordinates beyond ±1 km (a corrupt line, wrong units) are refused before the fit; a file
    the point reader does not take is left to the fit's own reading (z-maps)."""
    from bladerecon.core.io.readers import read_points

    try:
        ps = read_points(path, require_sections=False, memory_limit=memory_limit)
    except BladeReconError:
        return
    check_coordinates(ps.points, ps.line, path)


def run_tspline(args: argparse.Namespace) -> dict:
    """Run the subcommand; the STEP is put in place only when all of it succeeded."""
    check_input(args.input, "INPUT")
    from bladerecon.core.io.readers import check_file
    check_file("tspline", args.input, getattr(args, "memory_limit", None))
    with Outputs(inputs=(args.input,)) as outs:
        temp = outs.file(args.output, "--output")
        summary = _run(args, temp)
        outs.commit()
    if args.output:
        _say(args, f"wrote {args.output}")
    return summary


def _run(args: argparse.Namespace, temp: str | None) -> dict:
    t0 = time.perf_counter()
    _check_coordinates(args.input, getattr(args, "memory_limit", None))
    _, patches, summary = fit_point_file(args.input, args.tolerance, args.zmap, args.nd, args.nf,
                                         args.max_iterations, args.max_control_points, lambda m: _say(args, m),
                                         args.cut_order, args.seam)
    t_fit = time.perf_counter()
    if args.output:
        from bladerecon.fc.tspline_export import write_tspline_step
        _say(args, "sewing patches and writing STEP")
        info = write_tspline_step(patches, temp, seam="seam_gap_max" in summary)
        summary["faces"] = info["faces"]
        summary["output"] = {"step": args.output, **info}
    summary["seconds"] = time.perf_counter() - t0
    summary["seconds_fit"] = t_fit - t0
    return summary
