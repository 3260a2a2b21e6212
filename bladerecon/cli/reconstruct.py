# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon reconstruct MEASURED -o blade.step ...``: measured sections -> surface.

Points -> sections -> curves -> surface (-> STEP, -> deviation from a nominal, -> report folder).
Lengths in mm. The options for real measurement data (slicing clouds, fairing, non-grid rows,
local bicubic patches) are added by :mod:`bladerecon.cli.realdata`.
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from bladerecon.core.errors import BladeReconError

__all__ = ["add_parser", "run_reconstruct"]


class _Progress:
    def __init__(self, quiet: bool) -> None:
        self.quiet = quiet

    def __call__(self, msg: str) -> None:
        if not self.quiet:      # names from the command line: never raw control bytes
            from bladerecon.core.io.outputs import escaped
            print(f"bladerecon: {escaped(msg)}", file=sys.stderr, flush=True)


def _fairing_runs(sections, table) -> list[dict]:
    """Where each run of replaced points is (issue 16 item 6): section, first and last line,
    chord fraction, largest displacement; from the rows of ``faired_points.csv``."""
    from bladerecon.core.sections.fairing import describe_runs

    runs = []
    for k, sec in enumerate(sections.sections):
        rows = table[table[:, 0] == k]
        for r in describe_runs(sec.points, rows[:, 10] > 0, rows[:, 9], sec.lines):
            runs.append({"section": sec.name, **r})
    return runs


def add_parser(sub) -> None:
    r = sub.add_parser("reconstruct", help="measured sections -> native B-spline surface (+ STEP)",
                       description="Fit one periodic x clamped cubic B-spline surface through measured "
                                   "blade sections. All lengths in mm.")
    r.add_argument("input", help="point file: CSV with x,y,z[,section] header, 'x y z' blocks, or a section table")
    r.add_argument("-o", "--output", help="STEP file to write (mm); written atomically")
    r.add_argument("--nominal", help="nominal blade (STEP/IGES/BREP/FCStd) to compute the shape error against")
    r.add_argument("--report", metavar="DIR", help="folder for summary.json, points.csv, plots")
    r.add_argument("--force", action="store_true", help="write --report into a folder that already holds files")
    r.add_argument("--json", action="store_true", help="print one JSON summary object to stdout")
    r.add_argument("--method", choices=("auto", "interpolate", "approximate"), default="auto",
                   help="auto (default): interpolate or smooth, chosen from point spacing against noise")
    r.add_argument("--tolerance", type=float, metavar="MM",
                   help="with --method approximate: largest allowed distance of a measured point (mm); "
                        "a whole-blade cloud: it sets the sections' fit, and is judged on the cloud's nodes")
    r.add_argument("--pairing", choices=("anchored", "angle"), default="anchored",
                   help="corresponding points between sections: LE/TE-anchored common parameter "
                        "(default) or the angle pairing of seed 000 Fig. 5 (interpolates the paired points)")
    r.add_argument("--segmented", action="store_true",
                   help="rebuild every section from LE/TE/suction/pressure segments with curvature-continuous "
                        "joints (seed 000 §2.2) and build the surface through the rebuilt sections")
    r.add_argument("--continuity", type=int, choices=(2, 3), default=2,
                   help="with --segmented: C2 (default) or C3 at the LE/TE joints")
    r.add_argument("--solid", action="store_true", help="close hub and tip with planar caps; write a solid")
    from bladerecon.cli.sections import add_compensation_options, flow_direction
    r.add_argument("--flow", type=flow_direction, metavar="X,Y,Z",
                   help="direction the fluid travels: the leading edge is the upstream end of every section")
    add_compensation_options(r)
    r.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    from bladerecon.core.io.memory import add_memory_option
    add_memory_option(r)
    from bladerecon.cli.realdata import add_options as add_realdata_options

    add_realdata_options(r)
    from bladerecon.cli.autocloud import add_options as add_autocloud_options

    add_autocloud_options(r)
    r.set_defaults(run=run_reconstruct)


def _check_units(measured: np.ndarray, on_points: np.ndarray, args: argparse.Namespace) -> None:
    """Measured points far from the nominal (median over 1 % of its size): the unit or frame
    check of ``deviation`` says which (metres, inches, micrometres, another frame) and stops
    the run; nearer, the shape error is reported as measured."""
    from bladerecon.fc.deviation import Nominal, check_units
    from bladerecon.fc.export import read_shape

    median = float(np.median(np.abs(on_points))) if on_points.size else 0.0
    extent = float(np.linalg.norm(np.ptp(measured, axis=0))) if len(measured) else 0.0
    if median <= 0.01 * extent:        # the usual case, decided without reading the nominal again
        return
    shape = read_shape(args.nominal)
    box = shape.BoundBox
    size = float(np.sqrt(box.XLength ** 2 + box.YLength ** 2 + box.ZLength ** 2))
    if median > 0.01 * size:
        check_units(measured, Nominal(shape), source=args.input)


def _stats(d: np.ndarray, signed: bool | None = None) -> dict:
    from bladerecon.core.geometry.projection import distance_stats
    return distance_stats(d, signed=signed)


def run_reconstruct(args: argparse.Namespace) -> dict:
    """Every output checked before any work, written beside its target and put in place only
    when the whole command succeeded (nothing new left, nothing old lost, on any failure)."""
    from bladerecon.core.io.outputs import Outputs

    say = _Progress(args.quiet or False)
    with Outputs(inputs=(args.input, args.nominal)) as outs:
        step = outs.file(args.output, "--output")
        report = outs.folder(args.report, "--report", force=args.force)
        summary = _reconstruct(args, say, step, report)
        outs.commit()
    if args.output:
        say(f"wrote {args.output}")
    if args.report:
        say(f"report in {args.report}")
    return summary


def _reconstruct(args: argparse.Namespace, say, step: str | None, report: str | None) -> dict:
    """The work of ``reconstruct``; the STEP goes to ``step`` and the report into ``report``
    (temporaries of :class:`~bladerecon.core.io.outputs.Outputs`)."""
    from bladerecon.cli import realdata
    from bladerecon.core.sections.ordering import build_sections
    from bladerecon.core.reconstruct import reconstruct
    from bladerecon.core.surface.pairing import reconstruct_paired
    from bladerecon.core.geometry.projection import project_points_to_surface

    realdata.check_options(args)
    if args.tolerance is not None and args.method != "approximate":
        raise BladeReconError("--tolerance applies to --method approximate; add --method approximate")
    if args.pairing == "angle" and args.method == "approximate":
        raise BladeReconError("--pairing angle interpolates the paired points; use it without --method approximate")
    t_start = time.perf_counter()
    from bladerecon.core.io.readers import check_file
    from bladerecon.core.io.outputs import check_input
    check_input(args.input, "INPUT")
    check_file("reconstruct", args.input, args.memory_limit)
    say(f"reading {args.input}")
    from bladerecon.cli import autocloud
    pointset, slicing = autocloud.read_input(args)
    sections = autocloud.build(args, pointset, build_sections)
    from bladerecon.cli.sections import compensate, compensation_of
    compensation = compensation_of(args)
    if compensation is not None:
        from bladerecon.core.sections.ordering import SectionSet
        if not isinstance(sections, SectionSet):
            raise BladeReconError("--probe-radius and --coating apply to measured sections in planes; these "
                                  "sections were cut on stream surfaces: leave the options out")
        say(f"moving the points {compensation['offset_mm']:g} mm toward the material (probe radius + coating)")
        sections = compensate(args, sections)
    t_read = time.perf_counter()
    n_reordered = sum(s.reordered for s in sections.sections)
    say(f"{len(pointset.points)} points in {len(sections.sections)} sections"
        + (f" ({n_reordered} reordered along the profile)" if n_reordered else ""))

    pts = [s.points for s in sections.sections]
    fairing = None
    if args.fair:
        say("fairing: looking for bad points")
        pts, fairing, fairing_table = realdata.apply_fairing(sections, args)
        fairing["runs"] = _fairing_runs(sections, fairing_table)
        say(f"fairing: {len(fairing['replaced'])} points replaced")
    say("fitting section curves and surface")
    measured_start = not sections.sections[0].reordered
    flow = getattr(args, "flow", None)
    if flow is not None:    # each loop starts at its most upstream point: that end is the LE (issue 24)
        from bladerecon.core.reconstruct import start_upstream
        pts = start_upstream(pts, flow)
        measured_start = True
    seg_info = cloud_fit = cloud_dist = None
    if getattr(args, "segmented", False):
        if args.pairing == "angle" or args.method != "auto" or args.poles is not None:
            raise BladeReconError("--segmented builds its own section curves: use it without --pairing angle, "
                                  "--method and --poles")
        from bladerecon.core.sections.edge_fits import rebuild_sections
        rebuilt, seg_info = rebuild_sections(pts, sections.span_axis, measured_start, args.continuity)
        # the rebuilt sections are sampled densely without noise: the surface interpolates them
        rec = reconstruct(rebuilt, sections.span_axis, method="interpolate", first_point_is_measured=True)
    elif args.poles is not None:
        rec = realdata.reconstruct_nongrid(pts, sections.span_axis, args.poles)
    elif args.pairing == "angle":
        rec = reconstruct_paired(pts, sections.span_axis, first_point_is_measured=measured_start)
    elif autocloud.is_auto(args):
        # a whole-blade cloud: the surface through its sections fitted to every node (issue 25),
        # the nodes moved by the probe compensation as the section points were; --tolerance is
        # then judged on the nodes. The workbench's BladeSurface takes the same path.
        from bladerecon.core.sections.whole_cloud import cloud_surface
        rec, cloud_fit, cloud_dist = cloud_surface(
            args._auto_cloud, pts, sections.span_axis, tolerance=args.tolerance, first_point_is_measured=measured_start,
            offset=0.0 if compensation is None else compensation["offset_mm"], say=say)
    else:
        rec = reconstruct(pts, sections.span_axis, method=args.method, tolerance=args.tolerance,
                          first_point_is_measured=measured_start)
    if args.surface == "local-bicubic":
        cloud_dist = None           # the patches are another surface: judged by the section points
        rec = realdata.local_bicubic(rec, args.patches_around, args.fair_surface, pts, args.fair_threshold)
    measured = np.concatenate(pts)
    if seg_info is None:
        proj = project_points_to_surface(rec.surface, measured, rec.point_u, rec.point_v)
    else:  # the surface parameters belong to the rebuilt sections' samples: search globally
        proj = project_points_to_surface(rec.surface, measured)
    t_fit = time.perf_counter()
    surf = rec.surface
    # a surface fitted to the whole cloud is judged by the cloud's nodes, not by the section
    # points slid onto their planes (those are off the blade by up to 0.2 mm at the edges)
    fit_dist = proj.distance if cloud_dist is None else cloud_dist
    say(f"surface {surf.shape[0]} x {surf.shape[1]} poles ({rec.choice.method}); "
        f"fit max {fit_dist.max() * 1000:.2f} µm"
        + ("" if cloud_dist is None else f" ({len(cloud_dist)} cloud nodes)"))
    # --tolerance asked for a largest distance: say when the fit does not reach it (even with --quiet)
    tolerance_met = None if args.tolerance is None else bool(fit_dist.max() <= args.tolerance)
    if tolerance_met is False:
        print(f"bladerecon: warning: tolerance not met: the largest distance of a measured point is "
              f"{fit_dist.max() * 1000:.1f} µm, over the {args.tolerance * 1000:.1f} µm asked "
              f"({surf.shape[0]} x {surf.shape[1]} poles)", file=sys.stderr, flush=True)

    summary: dict = {
        "input": {"file": args.input, "format": pointset.format, "points": int(len(pointset.points)),
                  "sections": len(sections.sections), "reordered_sections": int(n_reordered), "units": "mm"},
        "surface": {"u_poles": surf.shape[0], "v_poles": surf.shape[1], "u_degree": surf.u_degree,
                    "v_degree": surf.v_degree, "u_periodic": bool(surf.u_periodic),
                    "method": rec.choice.method, "method_reason": rec.choice.reason,
                    "pairing": args.pairing, "noise_estimate_mm": rec.choice.noise_mm,
                    "tolerance_mm": rec.tolerance, "tolerance_met": tolerance_met,
                    "refit_error_mm": rec.refit_error},
        "fit": _stats(fit_dist),
    }
    if cloud_dist is not None:
        summary["fit"]["points"] = ("cloud nodes between the end sections"
                                    + ("" if compensation is None else ", moved by the compensation"))
        summary["fit_section_points"] = _stats(proj.distance)
    if seg_info is not None:
        summary["segmented"] = {"continuity": args.continuity, "sections": seg_info,
                                "joint_curvature_rel_max": max(i["joint_curvature_rel_max"] for i in seg_info)}
    if getattr(rec, "added_points", None) is not None:
        summary["surface"]["pairing_added_points"] = int(rec.added_points)
    if slicing is not None:
        summary["slicing"] = slicing
    if cloud_fit is not None:
        summary["surface"]["cloud_fit"] = cloud_fit
    cap_note = autocloud.pole_cap_note(surf, rec.refit_error, rec.tolerance)
    if cap_note is not None:
        summary["surface"]["pole_cap"] = cap_note
    if fairing is not None:
        summary["fairing"] = fairing
    if getattr(rec, "surface_fairing", None) is not None:
        summary["surface_fairing"] = rec.surface_fairing
    summary["fairness"] = realdata.fairness_summary(surf, pts, sections.span_axis)
    summary["le_rule"] = "flow" if flow is not None else ("first_point" if measured_start else "blunter_edge")
    if compensation is not None:
        summary["compensation"] = dict(compensation, normals="section curve")

    t_exp0 = time.perf_counter()
    shape = None
    if args.output or args.nominal:
        from bladerecon.fc.freecad_env import import_freecad
        say("loading FreeCAD")
        import_freecad()
    if args.output:
        from bladerecon.fc.export import write_step
        shape = realdata.make_shape(surf, args)
        write_step(shape, step)
        summary["output"] = {"step": args.output, "solid": bool(args.solid)}
    t_export = time.perf_counter()

    nominal_dev = None
    if args.nominal:
        from bladerecon.fc.compare import deviation_to_nominal, surface_samples
        say(f"comparing with nominal {args.nominal}")
        uv, samples = surface_samples(surf)
        # one read of the nominal and one projection for both point sets: the start grid over
        # the nominal is the expensive part
        dev = deviation_to_nominal(np.concatenate([samples, measured]), args.nominal)
        on_surface, on_points = dev.signed[: len(samples)], dev.signed[len(samples):]
        _check_units(measured, on_points, args)
        summary["nominal"] = {**_stats(on_surface, signed=True), "file": args.nominal,
                              "samples": int(samples.shape[0]), "method": dev.method}
        summary["measured_to_nominal"] = _stats(on_points, signed=True)
        nominal_dev = (uv, samples, on_surface, on_points)
    t_compare = time.perf_counter()
    summary["seconds"] = {"read": t_read - t_start, "fit": t_fit - t_read, "export": t_export - t_exp0,
                          "compare": t_compare - t_export, "total": t_compare - t_start}
    if args.report:
        from bladerecon.report.reconstruct import write_report
        write_report(report, summary, sections, measured, proj, nominal_dev)
        if fairing is not None:
            realdata.write_fairing_csv(report, fairing_table)
    return summary
