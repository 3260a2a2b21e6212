# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon deviation MEASURED --nominal NOMINAL ...``: signed deviation from the nominal.

Issue 4 §5. Parser and runner of the subcommand (``cli.py`` only wires them in). Lengths in
mm, angles in degrees. Errors a user can cause raise :class:`BladeReconError` (one line,
exit status 2). Outputs are all or nothing (:class:`bladerecon.core.io.outputs.Outputs`):
checked before any work, written beside their targets and put in place only when the whole
command succeeded.
"""
from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import (Outputs, check_coordinates, check_input, escaped, one_line_errors, positive)

__all__ = ["add_parser", "run_deviation"]


def add_parser(sub) -> None:
    d = sub.add_parser("deviation", help="signed deviation of measured points from the nominal (+ best fit, report)",
                       description="Signed distance (mm, + where material is outside the nominal) of every "
                                   "measured point to the nominal shape, optionally after a best-fit alignment.")
    d.add_argument("measured", help="point file (any format 'reconstruct' reads; section labels optional), "
                                    "or a reconstructed surface (STEP/IGES/BREP/FCStd, one B-spline face: sampled)")
    d.add_argument("--nominal", required=True, help="nominal blade: STEP/IGES/BREP/FCStd")
    d.add_argument("--align", choices=("none", "rigid", "translate", "rotate-z"), default="none",
                   help="best fit before comparing: none (default), rigid, translate, or rotate-z (about the z axis)")
    d.add_argument("--robust", action="store_true",
                   help="with --align: a robust best fit (Tukey biweight) that a worn or damaged zone does not "
                        "pull; the points it weighted out are counted in the summary")
    d.add_argument("--tolerance", type=positive(), default=0.03, metavar="MM",
                   help="profile tolerance ±MM for within_tolerance_pct (default 0.03)")
    d.add_argument("--plan", metavar="PLAN.toml",
                   help="inspection plan (TOML: profile zones per LE/TE/flanks, parameter limits, fit mode "
                        "incl. the minimax 'zone' fit): adds the pass/fail verdicts; see docs/verdicts.md")
    d.add_argument("--csv", metavar="FILE", help="write x,y,z,deviation,nx,ny,nz,face per point (a FILE ending in "
                                                 ".ply: a binary PLY with those properties)")
    d.add_argument("--report", metavar="DIR", help="write report.html with plots and deviations.csv into DIR")
    d.add_argument("--aligned", metavar="FILE",
                   help="with --align: write the measured input moved by the best fit: a STEP of the moved "
                        "surface when MEASURED is a surface, else a section,x,y,z points CSV (a FILE ending in .ply: "
                        "a binary PLY with a section property)")
    d.add_argument("--force", action="store_true",
                   help="write the report into an existing folder that holds files (files of the report's names "
                        "are replaced, others kept); without it such a folder is refused")
    from bladerecon.cli.sections import add_compensation_options, flow_direction
    d.add_argument("--flow", type=flow_direction, metavar="X,Y,Z",
                   help="direction the fluid travels: the section table's LE is the upstream end of every section")
    add_compensation_options(d)
    d.add_argument("--span-range", metavar="A:B",
                   help="leave out points outside A..B mm along --span-axis (a scan's fillet and tip cap); "
                        "they are counted in the summary")
    d.add_argument("--span-axis", choices=("x", "y", "z"), default="z", help="axis of --span-range (default z)")
    d.add_argument("--crop-to-nominal", action="store_true",
                   help="leave out points outside the nominal's bounding box grown by 1 mm (counted)")
    from bladerecon.core.io.memory import add_memory_option
    add_memory_option(d)
    d.add_argument("--json", action="store_true", help="print one JSON summary object to stdout")
    d.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    one_line_errors(d)
    d.set_defaults(run=run_deviation)


def _say(args, msg: str) -> None:
    if not args.quiet:
        print(f"bladerecon: {escaped(msg)}", file=sys.stderr, flush=True)


def _check_outputs(args) -> None:
    args.inspection_plan = None
    if getattr(args, "plan", None):
        from bladerecon.core.inspection.plan import read_inspection_plan

        check_input(args.plan, "--plan")
        if os.path.splitext(args.measured)[1].lower() in (".step", ".stp", ".iges", ".igs", ".brep", ".brp", ".fcstd"):
            raise BladeReconError(f"--plan judges measured sections: give the point file, not the surface "
                                  f"{args.measured}")
        args.inspection_plan = read_inspection_plan(args.plan)
        if args.align != "none" and args.align != args.inspection_plan.fit_mode:
            raise BladeReconError(f"--align {args.align} and the plan's fit.mode = "
                                  f"\"{args.inspection_plan.fit_mode}\" differ: with --plan the plan's [fit] decides")
    fitted = args.align != "none" or (args.inspection_plan is not None and args.inspection_plan.fit_mode != "none")
    if args.aligned and not fitted:
        raise BladeReconError("--aligned writes the best-fitted input: add --align rigid|translate|rotate-z")
    if args.robust and not fitted:
        raise BladeReconError("--robust is a kind of best fit: add --align rigid|translate|rotate-z")
    if not args.tolerance > 0:
        raise BladeReconError(f"--tolerance {args.tolerance}: give a positive tolerance in mm")
    check_input(args.measured, "MEASURED")
    check_input(args.nominal, "--nominal")


def run_deviation(args: argparse.Namespace) -> dict:
    """Run the subcommand; returns the JSON summary. Nothing is written unless all of it succeeds."""
    _check_outputs(args)
    with Outputs(inputs=(args.measured, args.nominal)) as outs:
        temps = {"csv": outs.file(args.csv, "--csv"), "aligned": outs.file(args.aligned, "--aligned"),
                 "report": outs.folder(args.report, "--report", force=args.force)}
        summary = _run(args, temps)
        outs.commit()
    for what in ("csv", "aligned"):
        if getattr(args, what):
            _say(args, f"wrote {getattr(args, what)}")
    if args.report:
        _say(args, f"report in {args.report}")
    return summary


def _read_measured(path: str):
    """Points, section index per point (None for a cloud) and names; coordinates checked."""
    return _read_measured_lines(path)[:3]


def _read_measured_lines(path: str, memory_limit: float | None = None):
    """As :func:`_read_measured`, and each point's file line (or a scan's vertex number) and the
    file's normals (N, 3) or None."""
    from bladerecon.core.io.readers import read_points

    ps = read_points(path, require_sections=False, memory_limit=memory_limit)
    check_coordinates(ps.points, ps.line, path)
    if not ps.structured:
        return np.asarray(ps.points, float), None, (), np.asarray(ps.line), ps.normals
    return np.asarray(ps.points, float), np.asarray(ps.section), ps.section_names, np.asarray(ps.line), ps.normals


def _run(args: argparse.Namespace, temps: dict) -> dict:
    t0 = time.perf_counter()
    from bladerecon.fc.deviation import load_nominal, measure_deviation, write_deviation_csv

    _say(args, f"reading {args.measured}")
    surface = None
    if os.path.splitext(args.measured)[1].lower() in (".step", ".stp", ".iges", ".igs", ".brep", ".brp", ".fcstd"):
        points, surface = _surface_points(args.measured)
        check_coordinates(points, None, args.measured)
        from bladerecon.core.io.memory import check_command
        check_command("deviation", len(points), getattr(args, "memory_limit", None), args.measured)
        section, names, lines, normals = None, (), None, None
    else:
        from bladerecon.core.io.readers import check_file
        check_file("deviation", args.measured, getattr(args, "memory_limit", None))   # before it is read
        points, section, names, lines, normals = _read_measured_lines(args.measured, getattr(args, "memory_limit", None))
    _say(args, f"{len(points)} points; reading nominal {args.nominal}")
    nominal = load_nominal(args.nominal)
    from bladerecon.fc.deviation import blade_like_warning
    nominal_warning = blade_like_warning(nominal)
    if nominal_warning:         # a warning, not a refusal: a user may compare with any shape on purpose
        _say(args, f"warning: {nominal_warning}")
    from bladerecon.cli.sections import compensation_of
    compensation = compensation_of(args)
    if compensation is not None and args.inspection_plan is not None:
        raise BladeReconError("--probe-radius and --coating are not applied with --plan yet: compensate the "
                              "points first (sections or reconstruct), or leave the options out")
    offset = 0.0
    if compensation is not None:      # before any crop: a section is compensated whole
        if section is not None:       # measured sections: along each section curve's normal, in its plane
            points = _compensate_sections(args, points, section, names, lines)
            compensation["normals"] = "section curve"
        else:                         # a cloud: along its file's normals, else the nominal's (measure_deviation)
            offset = compensation["offset_mm"]
            compensation["normals"] = "nominal" if normals is None else "file"
        _say(args, f"moving the points {compensation['offset_mm']:g} mm toward the material along the "
                   f"{compensation['normals']} normals (probe radius + coating)")
    points, section, crop, normals = _crop(args, points, section, nominal, normals)
    t_read = time.perf_counter()
    if args.align != "none":
        _say(args, f"best fit ({args.align})")
    inspection = None
    if args.inspection_plan is not None:
        inspection = _inspect(args, nominal)
        res = inspection.result
    else:
        res = measure_deviation(points, nominal, args.align, args.tolerance, source=args.measured,
                                robust=args.robust, offset=offset, normals=normals if offset else None)
    s = res.stats
    _say(args, f"deviation max {s['max'] * 1000:.1f} µm, min {s['min'] * 1000:.1f} µm, "
               f"{s['within_tolerance_pct']:.1f} % within ±{args.tolerance} mm")
    summary = {
        "points": s["points"], "max": s["max"], "min": s["min"], "mean": s["mean"], "std": s["std"],
        "rms": s["rms"], "within_tolerance_pct": s["within_tolerance_pct"], "tolerance": args.tolerance,
        "max_abs": s["max_abs"], "mean_abs": s["mean_abs"],
        "alignment": _alignment_json(res.alignment),
        "nominal": {"file": args.nominal, "faces": nominal.n_faces, "size_mm": nominal.size,
                    "method": "+".join(res.deviation.methods)},
        "units": "mm", "measured": args.measured,
    }
    if crop is not None:
        summary["cropped"] = crop
    if compensation is not None:
        summary["compensation"] = compensation
    if nominal_warning:
        summary["nominal"]["warning"] = nominal_warning
    if args.csv and _is_ply(args.csv):
        from bladerecon.core.io.scanner import write_ply
        dev = res.deviation
        write_ply(temps["csv"], res.points, {"deviation": dev.signed, "nx": dev.normal[:, 0], "ny": dev.normal[:, 1],
                                             "nz": dev.normal[:, 2], "face": dev.face.astype(np.int32)},
                  comment=f"signed deviation from {os.path.basename(args.nominal)} (mm, + outside), outward normal, "
                          "face (0-based)")
    elif args.csv:
        write_deviation_csv(temps["csv"], res.points, res.deviation)
    if args.aligned:
        _write_aligned(temps["aligned"], res, surface, section, names, ply=_is_ply(args.aligned))
        summary["aligned"] = args.aligned
    t_done = time.perf_counter()
    summary["seconds"] = {"read": t_read - t0, "align": res.seconds["align"], "measure": res.seconds["measure"],
                          "total": t_done - t0}
    if inspection is not None:
        v = inspection.verdicts
        summary.update(verdict=v["verdict"], sections=v["sections"], fit=v["fit"], inspection_plan=v["plan"])
        _say(args, f"verdict: {v['verdict']}")
        if args.report:
            summary["section_parameters"] = inspection.table
    elif args.report and section is not None:
        summary["sections"] = _section_table(args, res, nominal)
    if args.report:
        from bladerecon.report.deviation import write_deviation_report
        write_deviation_report(temps["report"], summary, res, nominal, section, names, surface)
        summary["seconds"]["report"] = time.perf_counter() - t_done
        summary["seconds"]["total"] = time.perf_counter() - t0
    return summary


def _inspect(args, nominal):
    """``--plan``: the plan's fit, the deviations and the verdicts (bladerecon.fc.inspection)."""
    from bladerecon.core.io.readers import read_points
    from bladerecon.fc.inspection import inspect_measured

    return inspect_measured(read_points(args.measured, require_sections=False), nominal, args.inspection_plan,
                            tolerance=args.tolerance, robust=args.robust, nominal_name=args.nominal,
                            say=lambda msg: _say(args, msg), flow=getattr(args, "flow", None))


def _crop(args, points, section, nominal, normals=None):
    """Points (and their normals) left out by --span-range / --crop-to-nominal, counted (issue 25)."""
    if args.span_range is None and not args.crop_to_nominal:
        return points, section, None, normals
    from bladerecon.core.analysis.crop import crop_points

    rng = None
    if args.span_range is not None:
        try:
            rng = tuple(float(v) for v in args.span_range.split(":"))
            if len(rng) != 2 or not all(np.isfinite(rng)):
                raise ValueError
        except ValueError:
            raise BladeReconError(f"--span-range '{args.span_range[:40]}': give A:B in mm, e.g. 45:195") from None
    box = None
    if args.crop_to_nominal:
        b = nominal.shape.BoundBox
        box = ((b.XMin, b.YMin, b.ZMin), (b.XMax, b.YMax, b.ZMax))
    keep, info = crop_points(points, np.eye(3)["xyz".index(args.span_axis)], rng, box)
    _say(args, f"{info['points_in'] - info['points_kept']} points left out by the crop, {info['points_kept']} kept")
    return points[keep], (None if section is None else section[keep]), info, (None if normals is None else normals[keep])


def _compensate_sections(args, points, section, names, lines) -> np.ndarray:
    """The points (file order) moved by ``--probe-radius`` + ``--coating`` along their section
    curves' normals (:mod:`bladerecon.core.surface.compensation`)."""
    from bladerecon.core.io.readers import PointSet
    from bladerecon.core.surface.compensation import compensate_points

    return compensate_points(PointSet(np.array(points), np.asarray(section), np.array(lines), tuple(names),
                                      args.measured, "csv"), args.probe_radius, args.coating)


def _section_table(args, res, nominal) -> dict:
    """Section parameters measured (after the best fit) vs the nominal cut in each section's
    plane, for the report. A section that cannot be measured does not stop the report: the
    message is kept instead of the table."""
    from bladerecon.core.analysis.alignment import apply_transform
    from bladerecon.core.io.readers import read_points
    from bladerecon.core.sections.ordering import build_sections
    from bladerecon.fc.section_compare import compare_section_parameters

    _say(args, "section parameters, measured vs nominal")
    try:
        from bladerecon.cli.sections import compensate
        ss = compensate(args, build_sections(read_points(args.measured)))
        M = res.alignment.matrix if res.alignment is not None else np.eye(4)
        pts = [apply_transform(s.points, M) for s in ss.sections]
        flow = getattr(args, "flow", None)
        rows = compare_section_parameters(pts, ss.span_axis, not ss.sections[0].reordered, nominal.shape,
                                          name=args.nominal, flow=flow)
        return {"rows": rows, "names": [s.name for s in ss.sections]}
    except BladeReconError as err:
        _say(args, f"no section-parameter table: {err}")
        return {"error": str(err)}


def _write_aligned(path: str, res, surface, section, names, ply: bool = False) -> str:
    """The measured input moved by the alignment: the surface exactly (its poles moved), or
    the points with their section labels, written to ``path`` (the command's temporary)."""
    if surface is not None:
        from bladerecon.core.analysis.alignment import transform_surface
        from bladerecon.fc.convert import make_face
        from bladerecon.fc.export import write_step

        write_step(make_face(transform_surface(surface, res.alignment.matrix)), path)
        return path
    from bladerecon.core.io.readers import write_points_csv

    labels = section if section is not None else np.zeros(len(res.points), dtype=int)
    if ply:
        from bladerecon.core.io.scanner import write_ply
        write_ply(path, res.points, section=labels, section_names=names or None, comment="aligned by the best fit (mm)")
    else:
        write_points_csv(path, res.points, labels, names or None)
    return path


def _is_ply(path: str) -> bool:
    return str(path).lower().endswith(".ply")


def _surface_points(path: str):
    """A reconstructed surface given as MEASURED: its B-spline face sampled densely (the
    ``reconstruct --nominal`` samples: 8 per knot span around, 41 along the span)."""
    from bladerecon.fc.compare import surface_samples
    from bladerecon.fc.convert import from_part_surface
    from bladerecon.fc.export import read_shape

    shape = read_shape(path)
    faces = [f for f in shape.Faces if type(f.Surface).__name__ == "BSplineSurface"]
    if len(faces) != 1:
        raise BladeReconError(f"{path}: expected one B-spline face (a reconstructed blade surface), "
                              f"found {len(faces)} among {len(shape.Faces)} faces: give the point file instead")
    surface = from_part_surface(faces[0].Surface)
    return surface_samples(surface)[1], surface


def _alignment_json(al) -> dict:
    if al is None:
        return {"mode": "none", "matrix": np.eye(4).tolist(), "rotation_deg": 0.0,
                "translation_mm": [0.0, 0.0, 0.0]}
    return al.as_dict()
