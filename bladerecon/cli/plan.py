# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon plan NOMINAL --heights z1,z2,... --tolerance 0.05 -o plan.csv --json``.

Issue 3 §3: a measurement plan with the fewest points (seed 000 §2.1,
:mod:`bladerecon.core.sections.plan`). NOMINAL is a STEP/IGES/BREP/FCStd blade, cut by the planes
``axis·x = z`` at the given heights and discretised every ``--step`` mm (0.1 mm, the paper's
measurement step), or a dense section file (then ``--heights`` picks the nearest sections,
all sections without it). Writes ``section,x,y,z`` (mm); prints points kept, compression
rate and the achieved Hausdorff distance. ``--check`` also reconstructs the surface from the
plan and measures it against a shape nominal.
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import (Outputs, check_coordinates, check_input, check_samples, escaped,
                                        one_line_errors, positive, shown)

__all__ = ["add_parser", "run_plan"]

SHAPE_SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep", ".brp", ".fcstd")


def add_parser(sub) -> None:
    p = sub.add_parser("plan", help="measurement plan: fewest section points for a tolerance (seed 000 §2.1)",
                       description="Reduce dense nominal sections to a measurement plan: 8 equal points + the 2 "
                                   "curvature extrema, then the farthest point until the cubic through the plan "
                                   "is within the tolerance. Lengths in mm.")
    p.add_argument("nominal", help="nominal blade (STEP/IGES/BREP/FCStd) or a dense section file")
    p.add_argument("--heights", default="", metavar="Z1,Z2,...", help="section heights along --axis (mm)")
    p.add_argument("--axis", default="0,0,1", metavar="X,Y,Z", help="span axis (default 0,0,1)")
    p.add_argument("--tolerance", type=positive(), default=0.05, metavar="MM",
                   help="compression tolerance (default 0.05)")
    p.add_argument("--step", type=positive(), default=0.1, metavar="MM",
                   help="point spacing of the dense nominal cut (default 0.1, the paper's measurement step)")
    p.add_argument("-o", "--output", help="plan CSV to write (section,x,y,z; mm), only when the whole command succeeds")
    p.add_argument("--check", action="store_true",
                   help="reconstruct the surface from the plan and measure it against the (shape) nominal")
    p.add_argument("--surface-within", action="store_true",
                   help="plan again at tighter section tolerances until the surface reconstructed from the plan "
                        "is within --tolerance of the (shape) nominal between the sections too (implies --check)")
    from bladerecon.cli.sections import flow_direction
    p.add_argument("--flow", type=flow_direction, metavar="X,Y,Z",
                   help="direction the fluid travels: every section's plan starts at its upstream (leading) edge")
    p.add_argument("--json", action="store_true", help="print the JSON summary on stdout")
    p.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    from bladerecon.core.io.memory import add_memory_option
    add_memory_option(p)
    one_line_errors(p)
    p.set_defaults(run=run_plan)


def _say(args, msg: str) -> None:
    if not args.quiet:
        print(f"bladerecon: {escaped(msg)}", file=sys.stderr, flush=True)


def _numbers(text: str, what: str) -> np.ndarray:
    try:
        values = np.array([float(v) for v in text.split(",") if v.strip()], float)
    except ValueError:
        raise BladeReconError(f"{what} '{shown(text)}': give numbers separated by commas") from None
    if not np.isfinite(values).all():
        raise BladeReconError(f"{what} '{shown(text)}': give finite numbers separated by commas")
    return values


def _dense_sections(args, axis: np.ndarray, heights: np.ndarray) -> tuple[list[np.ndarray], np.ndarray]:
    if os.path.splitext(args.nominal)[1].lower() in SHAPE_SUFFIXES:
        if not heights.size:
            raise BladeReconError("a shape nominal needs --heights z1,z2,... (mm along --axis) to cut sections")
        from bladerecon.fc.export import read_shape
        from bladerecon.fc.slicing import cut_sections
        shape = read_shape(args.nominal)
        bb = shape.BoundBox
        centre = np.array([bb.Center.x, bb.Center.y, bb.Center.z])
        size = np.array([bb.XLength, bb.YLength, bb.ZLength])
        # a section lies in the box across the axis: its length is about the box's perimeter there
        across = np.sqrt(np.maximum(size ** 2 - (size * axis) ** 2, 0.0))
        length = 2.0 * float(across.sum()) * len(heights)
        check_samples("--step", args.step, length, what="cutting the nominal")
        from bladerecon.core.io.memory import check_command
        check_command("plan", int(length / args.step) + 1, getattr(args, "memory_limit", None), args.nominal,
                      what="samples of the cut")
        origins = np.array([centre + (z - centre @ axis) * axis for z in heights])
        return cut_sections(args.nominal, origins, np.tile(axis, (len(origins), 1)), args.step, shape=shape), heights
    from bladerecon.core.io.readers import read_points
    from bladerecon.core.sections.ordering import build_sections
    ps = read_points(args.nominal, memory_limit=getattr(args, "memory_limit", None))
    check_coordinates(ps.points, ps.line, args.nominal)
    ss = build_sections(ps)
    pts = _denoised([s.points for s in ss.sections], args)
    h = np.array([p.mean(axis=0) @ axis for p in pts])
    if heights.size:
        pick = [int(np.argmin(np.abs(h - z))) for z in heights]
        return [pts[i] for i in pick], h[pick]
    return pts, h


def _denoised(pts: list, args) -> list:
    """Measured points as the nominal: where their noise is larger than their spacing allows
    (the reconstruction's own test, :func:`choose_method`), each section is replaced by its
    noise-consistent smoothing curve at the points' feet, in order along it; a plan needs the
    curvature of the shape, not of the noise."""
    from bladerecon.core.geometry.bspline import evaluate_curve
    from bladerecon.core.reconstruct import _fit_sections
    from bladerecon.core.surface.section_curves import choose_method

    choice = choose_method(pts)
    if choice.method != "approximate":
        return pts
    _say(args, f"the nominal's points carry {choice.noise_mm * 1000:.1f} µm of noise: planning on their smoothed "
               "section curves")
    args._smoothed_noise_mm = choice.noise_mm
    return [evaluate_curve(c.curve, np.unique(np.mod(c.t_points, 1.0))) for c in _fit_sections(pts, choice, None)]


def run_plan(args: argparse.Namespace) -> dict:
    """Run the subcommand; the plan CSV is put in place only when all of it succeeded."""
    axis = _numbers(args.axis, "--axis")
    if axis.size != 3 or not np.linalg.norm(axis) > 0 or not np.isfinite(np.linalg.norm(axis)):
        raise BladeReconError(f"--axis {shown(args.axis)}: give a direction x,y,z")
    axis = axis / np.linalg.norm(axis)
    heights = _numbers(args.heights, "--heights")
    check_input(args.nominal, "NOMINAL")
    with Outputs(inputs=(args.nominal,)) as outs:
        temp = outs.file(args.output, "--output")
        summary = _run(args, axis, heights, temp)
        outs.commit()
    if args.output:
        _say(args, f"wrote {args.output}")
    return summary


def _run(args, axis: np.ndarray, heights: np.ndarray, temp: str | None) -> dict:
    from bladerecon.core.sections.plan import plan_sections

    _say(args, f"cutting {args.nominal}")
    dense, h = _dense_sections(args, axis, heights)
    _say(args, f"{len(dense)} sections, {sum(len(p) for p in dense)} dense points; planning at ±{args.tolerance} mm")
    surface_plan = None
    if args.surface_within:
        from bladerecon.core.sections.plan import plan_for_surface
        _check_possible(args, dense)

        def surface_error(plans):
            err = _check(args, plans, axis)["surface_to_nominal_max"]
            _say(args, f"surface from the plan: max {err:.4f} mm from the nominal")
            return err

        surface_plan = plan_for_surface(dense, args.tolerance, surface_error, axis, flow=getattr(args, "flow", None))
        plans = surface_plan.plans
        if not surface_plan.within:
            _say(args, f"the surface stays {surface_plan.surface_error:.4f} mm from the nominal after "
                       f"{surface_plan.rounds} rounds (section tolerance {surface_plan.section_tolerance:.4f} mm)")
    else:
        plans = plan_sections(dense, args.tolerance, axis, getattr(args, "flow", None))
    kept = sum(len(p.indices) for p in plans)
    total = sum(p.dense_points for p in plans)
    summary = {
        "nominal": args.nominal, "tolerance": args.tolerance, "step": args.step, "units": "mm",
        "points_kept": int(kept), "dense_points": int(total), "compression_rate": 1.0 - kept / total,
        "hausdorff_max": max(p.hausdorff for p in plans),
        "sections": [{"index": p.index, "height": float(z), "dense_points": p.dense_points,
                      "points_kept": int(len(p.indices)), "compression_rate": p.compression,
                      "hausdorff": p.hausdorff, "iterations": p.iterations,
                      "le": dense[k][p.extrema[0]].tolist()} for k, (p, z) in enumerate(zip(plans, h))],
        "le_rule": "flow" if getattr(args, "flow", None) is not None else "blunter_edge",
    }
    if surface_plan is not None:
        summary["surface_within"] = {"within": surface_plan.within, "section_tolerance": surface_plan.section_tolerance,
                                     "surface_to_nominal_max": surface_plan.surface_error,
                                     "rounds": surface_plan.rounds}
    if args.output:
        from bladerecon.core.io.readers import write_points_csv
        pts = np.concatenate([p.points for p in plans])
        sec = np.concatenate([np.full(len(p.indices), p.index) for p in plans])
        write_points_csv(temp, pts, sec)
        summary["output"] = args.output
    if getattr(args, "_smoothed_noise_mm", None) is not None:
        summary["nominal_smoothed"] = {"noise_mm": args._smoothed_noise_mm}
    if args.check or args.surface_within:
        summary["check"] = _check(args, plans, axis)
    _say(args, f"kept {kept} of {total} points ({100 * summary['compression_rate']:.1f} % fewer), "
               f"max Hausdorff {summary['hausdorff_max']:.4f} mm")
    return summary


def _check_possible(args, sections) -> None:
    what = "--surface-within" if args.surface_within else "--check"
    if os.path.splitext(args.nominal)[1].lower() not in SHAPE_SUFFIXES:
        raise BladeReconError(f"{what} needs a shape nominal (STEP/IGES/BREP/FCStd) to measure against")
    if len(sections) < 2:
        raise BladeReconError(f"{what} needs at least 2 heights to build a surface")


def _check(args, plans, axis) -> dict:
    """Reconstruct from the plan (interpolation) and measure the surface against the nominal."""
    _check_possible(args, plans)
    from bladerecon.core.reconstruct import reconstruct
    from bladerecon.fc.compare import deviation_to_nominal, surface_samples
    rec = reconstruct([p.points for p in plans], axis, method="interpolate")
    _, samples = surface_samples(rec.surface)
    dev = np.abs(deviation_to_nominal(samples, args.nominal).signed)
    return {"surface_to_nominal_max": float(dev.max()), "surface_to_nominal_mean": float(dev.mean()),
            "samples": int(len(samples))}
