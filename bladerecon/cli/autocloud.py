# SPDX-License-Identifier: LGPL-2.1-or-later
"""``reconstruct CLOUD --cloud-scale 1000 -o blade.step`` with no slicing options (issue 25).

A point file with no section structure (one block of ``x y z`` lines) and no ``--slice*``
option is a whole-blade cloud: :func:`bladerecon.core.sections.cloud.auto_sections` finds the
span direction, the airfoil span (fillet and tip cap left out), the number of sections and the
slab width, and orders every slab by geometry. The JSON's ``slicing`` says what was chosen and
why; ``--span-range A:B``, ``--span-axis`` and ``--sections`` override the choices.

Also here: the note on the pole cap of the compatible section curves (issue 25 §4), for any
input. Units: mm.
"""
from __future__ import annotations

import argparse
import sys

from bladerecon.core.errors import BladeReconError
# one path with the workbench's: the size check and its limit live in core
from bladerecon.core.sections.whole_cloud import MIN_CLOUD_POINTS, check_cloud_size  # noqa: F401

__all__ = ["add_options", "read_input", "is_auto", "build", "pole_cap_note", "cloud_options", "check_cloud_size"]


def add_options(r: argparse.ArgumentParser) -> None:
    g = r.add_argument_group("whole-blade clouds (no slicing options: everything found from the cloud)")
    g.add_argument("--span-range", metavar="A:B",
                   help="airfoil span to slice, mm along the span axis (default: found from the cloud, "
                        "leaving out the hub fillet and the tip cap)")
    g.add_argument("--span-axis", choices=("x", "y", "z", "-x", "-y", "-z"),
                   help="span direction hub -> tip (default: found from the cloud)")
    g.add_argument("--sections", type=int, metavar="N",
                   help="number of sections cut from the cloud (default: from its density, 6 to 21)")
    g.add_argument("--blade-kind", choices=("auto", "axial", "radial"), default="auto",
                   help="axial: planes across the span; radial: stream surfaces between hub and shroud "
                        "(radial and mixed-flow rotors); auto (default): radial when planes cut the blade "
                        "into open curves")
    g.add_argument("--rotor-axis", choices=("x", "y", "z"), default="z",
                   help="with radial blades: the rotor axis through the origin (default z)")


def is_auto(args: argparse.Namespace) -> bool:
    """True once :func:`read_input` has taken the whole-cloud path."""
    return getattr(args, "_auto_cloud", None) is not None


def build(args: argparse.Namespace, pointset, build_sections):
    """The ordered sections: stream-surface sections as cut (their projection on one plane may
    cross itself), anything else through ``build_sections``."""
    if getattr(args, "_auto_cloud", None) is not None:
        return args._cloud_sections
    return build_sections(pointset)


def read_input(args: argparse.Namespace):
    """The input as ``(PointSet, slicing summary or None)``: a structured file as before, the
    ``--slice*`` options as before, a cloud with neither through the automatic slicing."""
    from bladerecon.cli import realdata
    from bladerecon.core.io.outputs import check_input
    from bladerecon.core.io.readers import read_points

    own = [o for o in ("span_range", "span_axis", "sections") if getattr(args, o, None) is not None]
    if getattr(args, "blade_kind", "auto") != "auto":
        own.append("blade_kind")
    if realdata.slicing_requested(args):
        if own:
            raise BladeReconError(f"--{own[0].replace('_', '-')} applies to a cloud sliced automatically: "
                                  "leave out --slice / --slice-at / --slice-radii")
        return realdata.read_input(args)
    check_input(args.input, "INPUT")
    ps = read_points(args.input, require_sections=False, memory_limit=getattr(args, "memory_limit", None))
    if ps.structured:           # labelled sections (even one: the section path names what is missing)
        if getattr(args, "cloud_scale", 1.0) != 1.0:    # the sections are read as they are: say so
            own.append("cloud_scale")
        if own:
            raise BladeReconError(f"--{own[0].replace('_', '-')} applies to an unordered cloud; "
                                  f"{args.input} holds {len(ps.section_names)} sections")
        return realdata.read_input(args)
    from bladerecon.core.sections.whole_cloud import cut_cloud, read_cloud_mm

    axis, rng, rotor = cloud_options(args)
    P, lines = read_cloud_mm(args.input, args.cloud_scale)
    check_cloud_size(args.input, len(P), " or cut them with --slice / --slice-at / --slice-radii")
    cut = cut_cloud(P, lines, args.input, args.blade_kind, rng, args.sections, axis, rotor, args.method,
                    args.cloud_scale)
    args._auto_cloud = cut
    args._cloud_sections = cut.sections
    args.method = cut.method
    return cut.pointset(), cut.info


def cloud_options(args: argparse.Namespace) -> tuple:
    """The cloud options as ``cut_sections`` takes them: (span axis or None, span range or None,
    rotor axis); a ``--sections`` count outside 2..200 or a bad ``--span-range`` is one line
    (:func:`bladerecon.core.sections.whole_cloud.cloud_options`, which the workbench uses too)."""
    from bladerecon.core.sections.whole_cloud import cloud_options as options

    return options(args.sections, args.span_axis, args.span_range, args.rotor_axis)


def pole_cap_note(surface, refit_error: float, tolerance: float | None) -> dict | None:
    """When the common section knots reached the pole cap and the compatible curves miss the
    section curves by more than their tolerance: a JSON note and a warning (never silent)."""
    from bladerecon.core.reconstruct import DEFAULT_REFIT_TOL

    tol = DEFAULT_REFIT_TOL if tolerance is None else max(DEFAULT_REFIT_TOL, 0.25 * tolerance)
    cap = 1500
    if surface.shape[0] < cap or not refit_error > tol:
        return None
    print(f"bladerecon: warning: the section curves reached the cap of {cap} poles around: the common curves "
          f"miss them by {refit_error * 1000:.1f} µm, over the {tol * 1000:.1f} µm asked "
          "(fewer points per section, or --method approximate, stay under it)", file=sys.stderr, flush=True)
    return {"reached": True, "poles": int(surface.shape[0]), "refit_error_mm": float(refit_error),
            "refit_tolerance_mm": float(tol), "missed_by_mm": float(refit_error - tol)}
