"""Headless entry point: ``python3 -m bladerecon reconstruct measured.csv -o blade.step ...``.

Errors a user can cause print one line ``bladerecon: error: ...`` on stderr and exit with
status 2; input files are never written; outputs are written atomically (a failed run leaves
no half-written STEP or report behind). Progress goes to stderr, the ``--json`` summary to
stdout. Set ``BLADERECON_DEBUG=1`` to see a traceback for an internal error.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

from . import __version__
from .core.errors import BladeReconError

__all__ = ["main", "build_parser"]


class _Progress:
    def __init__(self, quiet: bool) -> None:
        self.quiet = quiet

    def __call__(self, msg: str) -> None:
        if not self.quiet:
            print(f"bladerecon: {msg}", file=sys.stderr, flush=True)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="python3 -m bladerecon",
                                     description="Blade surface reconstruction from measured sections (units: mm).")
    parser.add_argument("--version", action="version", version=f"bladerecon {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("reconstruct", help="measured sections -> native B-spline surface (+ STEP)",
                       description="Fit one periodic x clamped cubic B-spline surface through measured "
                                   "blade sections. All lengths in mm.")
    r.add_argument("input", help="point file: CSV with x,y,z[,section] header, 'x y z' blocks, or a section table")
    r.add_argument("-o", "--output", help="STEP file to write (mm); written atomically")
    r.add_argument("--nominal", help="nominal blade (STEP/IGES/BREP/FCStd) to compute the shape error against")
    r.add_argument("--report", metavar="DIR", help="folder for summary.json, points.csv, plots")
    r.add_argument("--json", action="store_true", help="print one JSON summary object to stdout")
    r.add_argument("--method", choices=("auto", "interpolate", "approximate"), default="auto",
                   help="auto (default): interpolate or smooth, chosen from point spacing against noise")
    r.add_argument("--tolerance", type=float, metavar="MM",
                   help="with --method approximate: largest allowed distance of a measured point (mm)")
    r.add_argument("--pairing", choices=("anchored", "angle"), default="anchored",
                   help="corresponding points between sections: LE/TE-anchored common parameter "
                        "(default) or the angle pairing of seed 000 Fig. 5 (interpolates the paired points)")
    r.add_argument("--segmented", action="store_true",
                   help="rebuild every section from LE/TE/suction/pressure segments with curvature-continuous "
                        "joints (seed 000 §2.2) and build the surface through the rebuilt sections")
    r.add_argument("--continuity", type=int, choices=(2, 3), default=2,
                   help="with --segmented: C2 (default) or C3 at the LE/TE joints")
    r.add_argument("--solid", action="store_true", help="close hub and tip with planar caps; write a solid")
    r.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    from .realdata_cli import add_options as add_realdata_options
    add_realdata_options(r)
    from .deviation_cli import add_parser as add_deviation_parser
    add_deviation_parser(sub)
    from .acquire.commands import add_parsers as add_acquire_parsers
    add_acquire_parsers(sub)
    import importlib
    for module in SUBCOMMAND_MODULES:
        importlib.import_module(module, __package__).add_parser(sub)
    return parser


# Further subcommands live in their own modules, each with ``add_parser(sub)`` that calls
# ``set_defaults(run=function_returning_summary_dict)``; main() prints the summary with --json.
SUBCOMMAND_MODULES: tuple[str, ...] = (".sections_cli", ".plan_cli", ".tspline_cli")


def _stats(d: np.ndarray, signed: bool | None = None) -> dict:
    from .core.projection import distance_stats
    return distance_stats(d, signed=signed)


def run_reconstruct(args: argparse.Namespace) -> dict:
    from . import realdata_cli as realdata
    from .core.sections import build_sections
    from .core.reconstruct import reconstruct
    from .core.pairing import reconstruct_paired
    from .core.projection import project_points_to_surface

    say = _Progress(args.quiet or False)
    realdata.check_options(args)
    if args.tolerance is not None and args.method != "approximate":
        raise BladeReconError("--tolerance applies to --method approximate; add --method approximate")
    if args.pairing == "angle" and args.method == "approximate":
        raise BladeReconError("--pairing angle interpolates the paired points; use it without --method approximate")
    for path, what in ((args.output, "--output"), (args.report, "--report")):
        if path:
            parent = os.path.dirname(os.path.abspath(path)) or "."
            if not os.path.isdir(parent):
                raise BladeReconError(f"{what} {path}: folder {parent} does not exist; create it first")
    if args.output and os.path.abspath(args.output) == os.path.abspath(args.input):
        raise BladeReconError(f"--output {args.output} is the input file: choose another name (inputs are never overwritten)")
    t_start = time.perf_counter()
    say(f"reading {args.input}")
    pointset, slicing = realdata.read_input(args)
    sections = build_sections(pointset)
    t_read = time.perf_counter()
    n_reordered = sum(s.reordered for s in sections.sections)
    say(f"{len(pointset.points)} points in {len(sections.sections)} sections"
        + (f" ({n_reordered} reordered along the profile)" if n_reordered else ""))

    pts = [s.points for s in sections.sections]
    fairing = None
    if args.fair:
        say("fairing: looking for bad points")
        pts, fairing, fairing_table = realdata.apply_fairing(sections, args)
        say(f"fairing: {len(fairing['replaced'])} points replaced")
    say("fitting section curves and surface")
    measured_start = not sections.sections[0].reordered
    seg_info = None
    if getattr(args, "segmented", False):
        if args.pairing == "angle" or args.method != "auto" or args.poles is not None:
            raise BladeReconError("--segmented builds its own section curves: use it without --pairing angle, "
                                  "--method and --poles")
        from .core.segment_fit import rebuild_sections
        rebuilt, seg_info = rebuild_sections(pts, sections.span_axis, measured_start, args.continuity)
        # the rebuilt sections are sampled densely without noise: the surface interpolates them
        rec = reconstruct(rebuilt, sections.span_axis, method="interpolate", first_point_is_measured=True)
    elif args.poles is not None:
        rec = realdata.reconstruct_nongrid(pts, sections.span_axis, args.poles)
    elif args.pairing == "angle":
        rec = reconstruct_paired(pts, sections.span_axis, first_point_is_measured=measured_start)
    else:
        rec = reconstruct(pts, sections.span_axis, method=args.method, tolerance=args.tolerance,
                          first_point_is_measured=measured_start)
    if args.surface == "local-bicubic":
        rec = realdata.local_bicubic(rec, args.patches_around, args.fair_surface, pts)
    measured = np.concatenate(pts)
    if seg_info is None:
        proj = project_points_to_surface(rec.surface, measured, rec.point_u, rec.point_v)
    else:  # the surface parameters belong to the rebuilt sections' samples: search globally
        proj = project_points_to_surface(rec.surface, measured)
    t_fit = time.perf_counter()
    surf = rec.surface
    say(f"surface {surf.shape[0]} x {surf.shape[1]} poles ({rec.choice.method}); "
        f"fit max {proj.distance.max() * 1000:.2f} µm")

    summary: dict = {
        "input": {"file": args.input, "format": pointset.format, "points": int(len(pointset.points)),
                  "sections": len(sections.sections), "reordered_sections": int(n_reordered), "units": "mm"},
        "surface": {"u_poles": surf.shape[0], "v_poles": surf.shape[1], "u_degree": surf.u_degree,
                    "v_degree": surf.v_degree, "u_periodic": bool(surf.u_periodic),
                    "method": rec.choice.method, "method_reason": rec.choice.reason,
                    "pairing": args.pairing, "noise_estimate_mm": rec.choice.noise_mm,
                    "tolerance_mm": rec.tolerance, "refit_error_mm": rec.refit_error},
        "fit": _stats(proj.distance),
    }
    if seg_info is not None:
        summary["segmented"] = {"continuity": args.continuity, "sections": seg_info,
                                "joint_curvature_rel_max": max(i["joint_curvature_rel_max"] for i in seg_info)}
    if getattr(rec, "added_points", None) is not None:
        summary["surface"]["pairing_added_points"] = int(rec.added_points)
    if slicing is not None:
        summary["slicing"] = slicing
    if fairing is not None:
        summary["fairing"] = fairing
    if getattr(rec, "surface_fairing", None) is not None:
        summary["surface_fairing"] = rec.surface_fairing
    summary["fairness"] = realdata.fairness_summary(surf, pts, sections.span_axis)

    t_exp0 = time.perf_counter()
    shape = None
    if args.output or args.nominal:
        from .fc.freecad_env import import_freecad
        say("loading FreeCAD")
        import_freecad()
    if args.output:
        from .fc.export import write_step
        shape = realdata.make_shape(surf, args)
        write_step(shape, args.output)
        summary["output"] = {"step": args.output, "solid": bool(args.solid)}
        say(f"wrote {args.output}")
    t_export = time.perf_counter()

    nominal_dev = None
    if args.nominal:
        from .fc.compare import deviation_to_nominal, surface_samples
        say(f"comparing with nominal {args.nominal}")
        uv, samples = surface_samples(surf)
        # one read of the nominal and one projection for both point sets: the start grid over
        # the nominal is the expensive part
        dev = deviation_to_nominal(np.concatenate([samples, measured]), args.nominal)
        on_surface, on_points = dev.signed[: len(samples)], dev.signed[len(samples):]
        summary["nominal"] = {**_stats(on_surface, signed=True), "file": args.nominal,
                              "samples": int(samples.shape[0]), "method": dev.method}
        summary["measured_to_nominal"] = _stats(on_points, signed=True)
        nominal_dev = (uv, samples, on_surface, on_points)
    t_compare = time.perf_counter()
    summary["seconds"] = {"read": t_read - t_start, "fit": t_fit - t_read, "export": t_export - t_exp0,
                          "compare": t_compare - t_export, "total": t_compare - t_start}
    if args.report:
        from .report import write_report
        write_report(args.report, summary, sections, measured, proj, nominal_dev)
        if fairing is not None:
            realdata.write_fairing_csv(args.report, fairing_table)
        say(f"report in {args.report}")
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        if args.command == "reconstruct":
            summary = run_reconstruct(args)
            if args.json:
                print(json.dumps(summary, indent=2))
        elif args.command == "deviation":
            from .deviation_cli import run_deviation
            summary = run_deviation(args)
            if args.json:
                print(json.dumps(summary, indent=2))
        elif getattr(args, "run", None) is not None:
            summary = args.run(args)
            if getattr(args, "json", False):
                print(json.dumps(summary, indent=2))
        elif args.command in ("acquire", "simulate-instrument"):
            from .acquire.commands import run_acquire, run_simulate
            summary = (run_acquire if args.command == "acquire" else run_simulate)(args)
            if args.command == "simulate-instrument" or args.json:
                print(json.dumps(summary), flush=True)
        return 0
    except BladeReconError as err:
        print(f"bladerecon: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bladerecon: interrupted; no output was completed", file=sys.stderr)
        return 130
    except Exception as err:  # an internal error: one line unless debugging
        if os.environ.get("BLADERECON_DEBUG"):
            raise
        print(f"bladerecon: internal error: {type(err).__name__}: {err} "
              "(please report it; set BLADERECON_DEBUG=1 for details)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
