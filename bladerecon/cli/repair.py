# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon repair MEASURED --nominal NOMINAL -o target.step``: repair target (issue 18).

From the measurement of a serviced, damaged blade: the robust best fit, the spanwise
service deformation, the damaged regions, the repair target (the nominal adapted to this
blade) as STEP, and the missing material (mm³). Lengths mm, angles degrees. Errors a user
can cause raise :class:`BladeReconError` (one line, exit 2); outputs are all or nothing.
"""
from __future__ import annotations

import argparse
import sys
import time

from bladerecon.core.io.outputs import Outputs, check_input, escaped, finite, one_line_errors, positive

__all__ = ["add_parser", "run_repair"]


def add_parser(sub) -> None:
    d = sub.add_parser("repair", help="repair target of a damaged blade: adapted nominal, damage, missing volume",
                       description="Repair target of a serviced, damaged blade: the nominal adapted to the blade's "
                                   "own service deformation (twist, bend), the damaged regions and the missing "
                                   "material (mm, mm³, degrees).")
    d.add_argument("measured", help="the damaged blade's points: any format 'deviation' reads (sections or a cloud)")
    d.add_argument("--nominal", required=True, help="the design blade: STEP/IGES/BREP/FCStd with the blade surface "
                                                    "as one B-spline face")
    d.add_argument("-o", "--output", metavar="FILE", help="write the target (a solid when the ends are planar) as STEP")
    d.add_argument("--tolerance", type=positive(), default=0.03, metavar="MM",
                   help="a point deeper than this under the adapted nominal is damaged (default 0.03 mm)")
    d.add_argument("--cut-height", type=finite(unit="mm"), metavar="Z",
                   help="everything above the span height Z (mm, nominal frame) is rebuilt (a tip repair)")
    d.add_argument("--blend", type=positive(), metavar="MM",
                   help="width (mm) of the band over which the target passes from the adapted nominal to the "
                        "measured surface (default: 10x the deepest damage, 2 to 8 mm)")
    d.add_argument("--max-damage", type=positive(100.0, "%"), default=40.0, metavar="PCT",
                   help="refuse when more than PCT %% of the blade's area is damaged (default 40)")
    d.add_argument("--report", metavar="DIR",
                   help="write missing.step, missing_map.png, regions.csv and report.html into DIR")
    d.add_argument("--force", action="store_true", help="write the report into an existing folder that holds files")
    from bladerecon.cli.sections import flow_direction
    d.add_argument("--flow", type=flow_direction, metavar="X,Y,Z",
                   help="direction the fluid travels (nominal frame): a damaged region at the upstream end is "
                        "the leading edge (without it: the blunter end)")
    d.add_argument("--json", action="store_true", help="print one JSON summary object to stdout")
    d.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    from bladerecon.core.io.memory import add_memory_option
    add_memory_option(d)
    one_line_errors(d)
    d.set_defaults(run=run_repair)


def _say(args, msg: str) -> None:
    if not args.quiet:
        print(f"bladerecon: {escaped(msg)}", file=sys.stderr, flush=True)


def run_repair(args: argparse.Namespace) -> dict:
    """Run the subcommand; returns the JSON summary. Nothing is written unless all of it succeeds."""
    check_input(args.measured, "MEASURED")
    check_input(args.nominal, "--nominal")
    from bladerecon.core.io.readers import check_file
    check_file("repair", args.measured, getattr(args, "memory_limit", None))
    with Outputs(inputs=(args.measured, args.nominal)) as outs:
        temps = {"output": outs.file(args.output, "--output"),
                 "report": outs.folder(args.report, "--report", force=args.force)}
        summary = _run(args, temps)
        outs.commit()
    if args.output:
        _say(args, f"wrote {args.output}")
    if args.report:
        _say(args, f"report in {args.report}")
    return summary


def _read(path: str, memory_limit: float | None = None):
    """Points and section index per point (None for a cloud or a single section), checked."""
    from bladerecon.cli.deviation import _read_measured_lines

    points, section, names = _read_measured_lines(path, memory_limit)[:3]
    return points, (section if len(names) > 1 else None)


def _run(args: argparse.Namespace, temps: dict) -> dict:
    t0 = time.perf_counter()
    from bladerecon.core.repair import repair_target
    from bladerecon.fc.repair import blade_surface, target_shape

    _say(args, f"reading {args.measured}")
    points, section = _read(args.measured, getattr(args, "memory_limit", None))
    _say(args, f"{len(points)} points; reading nominal {args.nominal}")
    surface, sign, _ = blade_surface(args.nominal)
    t_read = time.perf_counter()
    _say(args, "best fit, service deformation, damage")
    res = repair_target(points, surface, sign, tolerance=args.tolerance, cut_height=args.cut_height,
                        blend=args.blend, section=section, max_damage_share=args.max_damage / 100.0,
                        flow=getattr(args, "flow", None))
    d = res.deformation
    _say(args, f"twist at the tip {d['twist_deg_at_tip']:.3f}°, bend {d['max_bend_mm']:.3f} mm; "
               f"{len(res.regions)} damaged region(s), missing {res.volume_mm3:.2f} mm³")
    summary = res.summary()
    if summary["tip"].get("warning"):
        _say(args, f"warning: {summary['tip']['warning']}")
    summary.update({"units": "mm, mm², mm³, degrees", "measured": args.measured, "nominal": args.nominal,
                    "tolerance_mm": args.tolerance,
                    "le_rule": "flow" if getattr(args, "flow", None) is not None else "blunter_edge"})
    t_core = time.perf_counter()
    if args.output:
        from bladerecon.fc.export import write_step

        shape, kind = target_shape(res.target)
        write_step(shape, temps["output"])
        summary["target"] = {"file": args.output, "shape": kind}
    t_step = time.perf_counter()
    if args.report:
        from bladerecon.report.repair import write_repair_report

        write_repair_report(temps["report"], summary, res)
    summary["seconds"] = dict(res.seconds, read=t_read - t0, step=t_step - t_core,
                              report=time.perf_counter() - t_step, total=time.perf_counter() - t0)
    return summary

