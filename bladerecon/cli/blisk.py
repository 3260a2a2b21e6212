# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon blisk SCAN --nominal BLADE_NOMINAL --blades N -o OUTDIR``: a blisk.

Issue 21. The scan of the whole blisk (sections or a cloud) is split into N blades by
angular sector about the axis (:func:`bladerecon.core.lot.blisk.split_sectors`), the sector
of blade 0 centred on the nominal's bounding-box centre. Blade ``k``'s points are turned
back by ``-k * 360/N`` into blade 0's place and written to ``OUTDIR/scan/blade_KK.csv``;
then every blade runs as in ``batch`` (:mod:`bladerecon.cli.batch`) against the nominal -
the same as comparing blade k with the nominal turned by ``k * 360/N`` - and gets its
position errors (pitch, stagger, radial, axial) from a rigid best fit, which the lot
summary gathers.
"""
from __future__ import annotations

import argparse
import os

import numpy as np

from bladerecon.cli.batch import _say, add_lot_options, finish, make_jobs, output_folder, read_plan_limits, run_lot
from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import Outputs, check_coordinates, check_input, count, one_line_errors

__all__ = ["add_parser", "run_blisk"]


def add_parser(sub) -> None:
    b = sub.add_parser("blisk", help="a blisk: one scan split into N blades, each compared, pitch/stagger/radial errors",
                       description="Split the scan of a whole blisk into N blades by angular sector about the axis, "
                                   "compare blade k with the nominal turned by k*360/N, and gather the blade-to-blade "
                                   "position errors (pitch, stagger, radial) in the lot summary OUTDIR/lot/.")
    b.add_argument("scan", help="point file of the whole blisk (sections or a cloud; any format deviation reads)")
    b.add_argument("--nominal", required=True, help="blade 0's nominal in the blisk's frame: STEP/IGES/BREP/FCStd")
    b.add_argument("--blades", type=count(1, 1000), required=True, metavar="N", help="number of blades")
    b.add_argument("--axis", choices=("x", "y", "z"), default="z", help="the blisk's axis through the origin (default z)")
    add_lot_options(b)
    one_line_errors(b)
    b.set_defaults(run=run_blisk)


def _blade0_angle(nominal: str, axis: np.ndarray) -> float:
    """Angle (°) of the nominal blade's bounding-box centre about the axis."""
    from bladerecon.core.lot.blisk import point_angles
    from bladerecon.fc.export import read_shape

    box = read_shape(nominal).BoundBox
    return float(point_angles(np.array([[box.Center.x, box.Center.y, box.Center.z]]), axis)[0])


def _split(args, out: str, axis: np.ndarray):
    """Write each blade's points (turned back into blade 0's place) into OUTDIR/scan/; the
    list of (name, file) of the blades that have points, and the names of empty sectors."""
    from bladerecon.core.io.readers import read_points, write_points_csv
    from bladerecon.core.lot.blisk import split_sectors, turn
    from bladerecon.core.lot.manifest import LotBlade

    _say(args, f"reading {args.scan}")
    ps = read_points(args.scan, require_sections=False, memory_limit=getattr(args, "memory_limit", None))
    points = np.asarray(ps.points, float)
    check_coordinates(points, ps.line, args.scan)
    section = np.asarray(ps.section) if ps.structured else np.zeros(len(points), int)
    names = list(ps.section_names) if ps.structured else ["1"]
    theta0 = _blade0_angle(args.nominal, axis)
    blade = split_sectors(points, axis, args.blades, theta0)
    pitch = 360.0 / args.blades
    width = len(str(args.blades - 1))
    blades, empty = [], []
    with Outputs(inputs=(args.scan, args.nominal)) as outs:
        tmp = outs.folder(os.path.join(out, "scan"), "scan", force=True)
        for k in range(args.blades):
            name = f"blade_{k:0{width}d}"
            mask = blade == k
            if not mask.any():
                empty.append(name)
                continue
            used, local = np.unique(section[mask], return_inverse=True)
            path = os.path.join(tmp, f"{name}.csv")
            write_points_csv(path, turn(points[mask], axis, -k * pitch), local, [names[i] for i in used])
            blades.append(LotBlade(name, os.path.join(out, "scan", f"{name}.csv"), f"scan/{name}.csv"))
        outs.commit()
    _say(args, f"blisk: {len(points)} points in {args.blades} sectors of {pitch:.6g}° (blade 0 at {theta0:.4g}°)")
    return blades, empty


def run_blisk(args: argparse.Namespace) -> dict:
    """Run the subcommand; returns the lot summary (``--json``). Exit status 2 if any blade failed."""
    from bladerecon.core.lot.blisk import axis_vector

    check_input(args.scan, "SCAN")
    check_input(args.nominal, "--nominal")
    from bladerecon.core.io.readers import check_file
    check_file("blisk", args.scan, getattr(args, "memory_limit", None),
               workers=1 if args.scheduler else args.workers)
    if not os.path.isfile(args.nominal):
        raise BladeReconError(f"--nominal {args.nominal}: no such file")
    limits = read_plan_limits(args.plan) if args.plan else None
    axis = axis_vector(args.axis)
    with output_folder(args) as out:
        blades, empty = _split(args, out, axis)
        jobs = make_jobs(blades, args, out, position={"axis": axis.tolist()})
        _say(args, f"blisk: {len(jobs)} blades on {args.scheduler or f'{args.workers} local worker(s)'}")
        extra = {"blisk": {"blades": args.blades, "axis": args.axis, "pitch_deg": 360.0 / args.blades,
                           "empty_sectors": empty}}
        lot = run_lot(jobs, args, out, extra=extra, limits=limits)
        if empty and lot["lot"]["ok"]:
            raise BladeReconError(f"{len(empty)} of {args.blades} sectors hold no points ({', '.join(empty[:5])}): "
                                  f"check --blades and --axis; results in {args.output}")
        return finish(lot, args)
