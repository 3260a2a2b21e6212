# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon sections INPUT [--nominal NOMINAL] [--plots DIR] --json``: section parameters.

Issue 3 §4. For every section of INPUT: LE/TE points, chord, stagger, max thickness and its
position, LE/TE radius, inlet/outlet metal angles, thickness at given offsets
(:mod:`bladerecon.core.sections.parameters`). With ``--nominal`` (STEP/IGES/BREP/FCStd cut in
the plane of every measured section, or a dense section file) the nominal's values and the
differences measured − nominal. ``--plots DIR`` writes one PNG per section with the
segmentation coloured. A non-planar section on a surface of revolution about the machine axis
(``--axis``, ``--axis-point``; default z through the origin) is also measured in m′–θ (the
``meridional`` block). Lengths mm, angles degrees.
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import (Outputs, check_coordinates, check_input, check_samples, escaped,
                                        finite, one_line_errors, positive, shown)

__all__ = ["add_parser", "run_sections", "flow_direction", "machine_axis", "axis_point"]

SHAPE_SUFFIXES = (".step", ".stp", ".iges", ".igs", ".brep", ".brp", ".fcstd")


def _floats(text: str, what: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise BladeReconError(f"{what} '{shown(text)}': give numbers separated by commas, e.g. 1,2,5") from None
    if not all(np.isfinite(v) and v > 0 for v in values):
        raise BladeReconError(f"{what} '{shown(text)}': give positive distances in mm, e.g. 1,2,5")
    return values


def flow_direction(text: str) -> np.ndarray:
    """argparse ``type`` of ``--flow X,Y,Z``: the direction the fluid travels (unit vector)."""
    try:
        v = np.array([float(x) for x in text.split(",")], float)
    except ValueError:
        v = np.zeros(0)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.linalg.norm(v) < 1e-12:
        raise argparse.ArgumentTypeError(f"'{shown(text)}': give the flow direction as three numbers X,Y,Z "
                                         "(not all zero), e.g. 1,0,0")
    return v / np.linalg.norm(v)


def axis_point(text: str) -> np.ndarray:
    """argparse ``type`` of ``--axis-point X,Y,Z``: a point (mm) on the machine axis."""
    try:
        v = np.array([float(x) for x in text.split(",")], float)
    except ValueError:
        v = np.zeros(0)
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise argparse.ArgumentTypeError(f"'{shown(text)}': give a point on the machine axis as three numbers "
                                         "X,Y,Z (mm), e.g. 0,0,0")
    return v


def machine_axis(text: str) -> np.ndarray:
    """argparse ``type`` of ``--axis X,Y,Z``: the machine (rotor) axis direction (unit vector)."""
    try:
        return flow_direction(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"'{shown(text)}': give the machine axis as three numbers X,Y,Z "
                                         "(not all zero), e.g. 0,0,1") from None


def add_compensation_options(p) -> None:
    """``--probe-radius`` and ``--coating`` (mm): the points are moved that far toward the material
    (:mod:`bladerecon.core.surface.compensation`; ``deviation`` on a cloud: along the file's own
    normals when it gives them, else the nominal's)."""
    p.add_argument("--probe-radius", type=finite(0.0, 50.0, "mm"), default=0.0, metavar="MM",
                   help="the points are touch-probe ball centres of this radius: move each by it toward the "
                        "material, along the normal of its section (a cloud in deviation: the file's normals, "
                        "x y z i j k or nx,ny,nz columns, else the nominal's) (default 0)")
    p.add_argument("--coating", type=finite(0.0, 50.0, "mm"), default=0.0, metavar="MM",
                   help="the points lie on a coating this thick over the part: move each by it toward the "
                        "material (default 0)")


def compensation_of(args) -> dict | None:
    """The JSON record of the compensation asked for, or None."""
    r, t = getattr(args, "probe_radius", 0.0) or 0.0, getattr(args, "coating", 0.0) or 0.0
    return None if r == 0.0 and t == 0.0 else {"probe_radius_mm": r, "coating_mm": t, "offset_mm": r + t}


def compensate(args, ss):
    """The section set moved by ``--probe-radius`` + ``--coating`` toward the material."""
    if compensation_of(args) is None:
        return ss
    from bladerecon.core.surface.compensation import compensate_sections
    return compensate_sections(ss, args.probe_radius, args.coating)


def add_parser(sub) -> None:
    p = sub.add_parser("sections", help="section parameters (chord, stagger, thickness, LE/TE radius, angles)",
                       description="Segment every section (LE, TE, suction, pressure) and measure its "
                                   "parameters; lengths in mm, angles in degrees.")
    p.add_argument("input", help="point file with sections (any format 'reconstruct' reads), or a whole-blade "
                                 "cloud: cut into sections as reconstruct cuts it")
    p.add_argument("--nominal", help="nominal: STEP/IGES/BREP/FCStd (cut in each section's plane) or a section file")
    p.add_argument("--plots", metavar="DIR", help="write section_NN.png per section (segmentation coloured)")
    p.add_argument("--flow", type=flow_direction, metavar="X,Y,Z",
                   help="direction the fluid travels: the leading edge is the upstream end of every section "
                        "(without it the LE is guessed: the blunter end on most sections, with a warning)")
    p.add_argument("--axis", type=machine_axis, metavar="X,Y,Z",
                   help="machine (rotor) axis direction, default 0,0,1: a non-planar section on a surface of "
                        "revolution about it is also measured in m'-theta (the \"meridional\" block)")
    p.add_argument("--axis-point", type=axis_point, metavar="X,Y,Z",
                   help="a point on the machine axis (mm, default 0,0,0)")
    add_compensation_options(p)
    from bladerecon.cli.autocloud import add_options as add_cloud_options
    add_cloud_options(p)
    p.add_argument("--cloud-scale", type=positive(1e9, ""), default=1.0, metavar="F",
                   help="a cloud's coordinates times F (1000 for a file in metres)")
    p.add_argument("--offsets", default="", metavar="MM,...", help="thickness at these distances from LE and TE")
    p.add_argument("--fractions", default="", metavar="F,...",
                   help="thickness at these chord fractions (0 < F < 1), camber-normal and chord-normal")
    p.add_argument("--beta1", type=finite(-89.9, 89.9, "degrees"),
                   help="inlet flow angle (deg from axial) for the throat point (eq. 5)")
    p.add_argument("--beta2", type=finite(-89.9, 89.9, "degrees"),
                   help="outlet flow angle (deg from axial) for the throat point (eq. 5)")
    p.add_argument("--lift", type=positive(unit=""), default=1.0,
                   help="tangential lift coefficient C_L of eq. 5 (default 1.0)")
    p.add_argument("--max-gap", type=positive(), metavar="MM",
                   help="largest gap between points (default 15 %% of the section)")
    p.add_argument("--step", type=positive(), default=0.05, metavar="MM",
                   help="point spacing of the nominal cut (mm, default 0.05)")
    p.add_argument("--lenient", action="store_true",
                   help="report a radius as null (with a warning) instead of stopping when an edge has too few points")
    p.add_argument("--force", action="store_true",
                   help="write the plots into an existing folder that holds files (files of the same names are "
                        "replaced, others kept); without it such a folder is refused")
    p.add_argument("--plan", metavar="PLAN.toml",
                   help="with --nominal: judge every section's parameters against the inspection plan's "
                        "[parameters] limits (pass/fail per parameter and section; docs/verdicts.md)")
    p.add_argument("--json", action="store_true", help="print the list of sections as JSON on stdout")
    p.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    from bladerecon.core.io.memory import add_memory_option
    add_memory_option(p)
    one_line_errors(p)
    p.set_defaults(run=run_sections)


def _say(args, msg: str) -> None:
    if not args.quiet:
        print(f"bladerecon: {escaped(msg)}", file=sys.stderr, flush=True)


_CLOUD_OPTIONS = ("cloud_scale", "span_range", "span_axis", "sections", "blade_kind")


def _read_sections(path: str, args=None):
    """Ordered sections of a point file; with ``args``, compensated as its options say. With
    ``args``, a file with no section structure is a whole-blade cloud: cut into sections as
    ``reconstruct`` cuts it (:func:`_cloud_sections`)."""
    from bladerecon.core.io.readers import read_points
    from bladerecon.core.sections.ordering import build_sections
    ps = read_points(path, require_sections=args is None, memory_limit=getattr(args, "memory_limit", None))
    check_coordinates(ps.points, ps.line, path)
    own = [o for o in _CLOUD_OPTIONS if args is not None and getattr(args, o, None) not in (None, 1.0, "auto")]
    if args is not None and not ps.structured:
        return _cloud_sections(args, ps)
    if own:
        raise BladeReconError(f"--{own[0].replace('_', '-')} applies to an unordered cloud; "
                              f"{path} holds {len(ps.section_names)} sections")
    ss = build_sections(ps)
    if args is not None:
        ss = compensate(args, ss)
    return [s.points for s in ss.sections], ss.span_axis, not ss.sections[0].reordered


def _throat(args):
    if args.beta1 is None and args.beta2 is None:
        return None
    if args.beta1 is None or args.beta2 is None:
        raise BladeReconError("the throat point needs both --beta1 and --beta2 (flow angles in degrees)")
    from bladerecon.core.sections.segmentation import ThroatSpec
    return ThroatSpec(args.beta1, args.beta2, args.lift)


def _nominal_sections(args, section_points, span_axis) -> list[np.ndarray]:
    """The nominal in every measured section's plane (each section's best-fit plane, as its
    segmentation uses): a shape cut there, or a section file's nearest section."""
    from bladerecon.core.sections.segmentation import section_frame

    frames = [section_frame(np.asarray(p, float), span_axis) for p in section_points]
    if os.path.splitext(args.nominal)[1].lower() in SHAPE_SUFFIXES:
        from bladerecon.fc.slicing import cut_sections
        # the nominal's sections are about as long as the measured ones: bound the cut before OCC allocates it
        loops = [f.to_plane(np.asarray(p, float)) for f, p in zip(frames, section_points)]
        length = 1.5 * sum(float(np.linalg.norm(np.diff(np.vstack([q, q[:1]]), axis=0), axis=1).sum()) for q in loops)
        check_samples("--step", args.step, length, what="cutting the nominal")
        origins = np.array([f.origin for f in frames])
        normals = np.array([f.normal for f in frames])
        return cut_sections(args.nominal, origins, normals, args.step)
    pts, _, _ = _read_sections(args.nominal)
    if len(pts) == len(frames):
        return pts
    # nearest nominal section along the span axis
    h_nom = np.array([p.mean(axis=0) @ span_axis for p in pts])
    return [pts[int(np.argmin(np.abs(h_nom - f.origin @ span_axis)))] for f in frames]


def run_sections(args: argparse.Namespace) -> list:
    """Run the subcommand; the plots are put in place only when every section succeeded."""
    offsets = _floats(args.offsets, "--offsets")
    fractions = _floats(getattr(args, "fractions", ""), "--fractions")
    if any(f >= 1 for f in fractions):
        raise BladeReconError(f"--fractions '{shown(args.fractions)}': give chord fractions between 0 and 1, e.g. 0.1,0.5")
    throat = _throat(args)
    check_input(args.input, "INPUT")
    check_input(args.nominal, "--nominal")
    from bladerecon.core.io.memory import SECTIONS_NOMINAL, SECTIONS_PLOTS
    from bladerecon.core.io.readers import check_file
    check_file("sections", args.input, getattr(args, "memory_limit", None),
               extra=SECTIONS_NOMINAL * bool(args.nominal) + SECTIONS_PLOTS * bool(args.plots))
    plan = _inspection_plan(args)
    with Outputs(inputs=(args.input, args.nominal)) as outs:
        plots = outs.folder(args.plots, "--plots", force=args.force)
        out = _run(args, offsets, throat, plots, fractions)
        outs.commit()
    comp = compensation_of(args)
    if comp is not None:
        for o in out:
            o["compensation"] = comp
    if plan is not None:
        _judge(args, plan, out)
    if args.plots:
        _say(args, f"plots in {args.plots}")
    blade_warning = getattr(args, "_blade_warning", None)
    for o in out:
        _say(args, f"section {o['index']}: chord {o['chord']:.3f} stagger {o['stagger_deg']:.2f}° "
                   f"t_max {o['max_thickness']:.3f} {_edge(o, 'le')} {_edge(o, 'te')}")
        # the section's own warnings (an edge not round, few points on an arc, ...), not only in
        # the JSON: the blade's one was said above
        for w in o["warnings"]:
            if w != blade_warning:
                _say(args, f"warning: {w}")
    return out


def _run(args, offsets, throat, plots, fractions=()) -> list:
    from bladerecon.core.sections.parameters import (canonical_loop, compare_with_nominal, measure_section,
                                                     segment_blade, stacking)

    _say(args, f"reading {args.input}")
    pts, axis, _ = _read_sections(args.input, args)
    flow = getattr(args, "flow", None)
    nom_pts = nominal_blade = le_points = None
    if args.nominal:
        _say(args, f"nominal {args.nominal}")
        nom_pts = _nominal_sections(args, pts, axis)      # cut in the measured sections' planes
        _nominal_warning(args)
        if flow is None:
            # no flow given: the nominal decides, each measured LE the end nearest the nominal's
            # LE, and the nominal's LE is its blunter end on most sections, judged on exact
            # geometry that wear, damage and noise cannot swap (issue 24 §1)
            try:
                nominal_blade = segment_blade(nom_pts, axis, throat=throat)
            except BladeReconError as err:
                raise BladeReconError(f"{args.nominal} (the nominal, cut in the measured planes): {err}") from None
            le_points = [s.lift(s.le)[0] for s in nominal_blade.sections]
            _say(args, "leading edge from the nominal (its blunter end on most sections); "
                       "give --flow X,Y,Z to be sure")
    blade = segment_blade(pts, axis, throat=throat, max_gap=args.max_gap, flow=flow, le_points=le_points)
    if blade.warning:
        _say(args, f"warning: {blade.warning}")
    args._blade_warning = blade.warning
    segs = blade.sections
    rotor = {"axis": getattr(args, "axis", None), "axis_point": getattr(args, "axis_point", None)}
    params = [measure_section(s, offsets, strict_radius=not args.lenient, fractions=fractions, **rotor) for s in segs]
    out = [{**p.as_dict(), "le_rule": blade.le_rule, "stacking": st}
           for p, st in zip(params, stacking(params, axis, flow))]
    for o, cut in zip(out, getattr(args, "_cuts", None) or ()):
        o["cut"] = cut
    if blade.warning:
        for o in out:
            o["warnings"] = [blade.warning, *o["warnings"]]
    if args.nominal:
        if nominal_blade is not None:
            nsegs = nominal_blade.sections
        else:                       # --flow: the nominal's LE is its upstream end too
            from bladerecon.core.sections.segmentation import segment_section
            nsegs = [segment_section(canonical_loop(q, axis), k, axis, le_hint=s.lift(s.le)[0], throat=throat,
                                     flow=flow) for k, (s, q) in enumerate(zip(segs, nom_pts))]
        nparams = [measure_section(s, offsets, strict_radius=not args.lenient, fractions=fractions, **rotor)
                   for s in nsegs]
        out = [compare_with_nominal(o, n.as_dict()) for o, n in zip(out, nparams)]
    else:
        nsegs = [None] * len(segs)
    if plots:
        from bladerecon.report.section_plots import plot_section
        for s, p, ns in zip(segs, params, nsegs):
            plot_section(os.path.join(plots, f"section_{s.index:02d}.png"), s, p, ns)
    return out


def _cloud_sections(args, ps):
    """A whole-blade cloud cut into sections with no slicing options (issue 25), as
    ``reconstruct CLOUD`` cuts it (:func:`bladerecon.core.sections.blade_cloud.cut_sections`):
    span direction, airfoil span (fillet and cap left out), planes or, for a radial rotor,
    stream surfaces; each section's ``cut`` in the JSON says where. A radial rotor's sections are
    measured in m'-theta about ``--rotor-axis`` unless ``--axis`` is given."""
    from bladerecon.cli.autocloud import check_cloud_size, cloud_options
    from bladerecon.core.sections.whole_cloud import cut_cloud

    P = np.asarray(ps.points, float) * args.cloud_scale
    check_cloud_size(args.input, len(P))
    axis, rng, rotor = cloud_options(args)
    cut = cut_cloud(P, np.asarray(ps.line), args.input, args.blade_kind, rng, args.sections, axis, rotor, method=None,
                    scale=args.cloud_scale)     # the workbench's BladeSections cuts a cloud by the same call
    cs = cut.cloud
    ss = compensate(args, cut.sections)
    radial = cs.info.get("kind") == "stream-surfaces"
    if radial and args.axis is None:
        args.axis = rotor
    kind = "stream surfaces" if radial else "planes"
    span = cs.info.get("airfoil_span_mm")
    _say(args, f"a cloud of {len(P)} points: {len(ss.sections)} sections on {kind}"
               + (f", airfoil span {span[0]:.1f}–{span[1]:.1f} mm along the span axis" if span else "")
               + f" ({cs.info.get('kind_reason', cs.info.get('kind'))})")
    args._cuts = [{"kind": "stream surface" if radial else "plane", "position": float(p),
                   "position_unit": "span fraction hub 0 .. shroud 1" if radial else "mm along the span axis",
                   "axis": np.asarray(cs.axis, float).tolist(),     # planes: the span axis; stream surfaces: the rotor's
                   "points": int(len(sec.points))}
                  for p, sec in zip(cs.positions, ss.sections)]
    return [sec.points for sec in ss.sections], ss.span_axis, False


def _nominal_warning(args) -> None:
    """A shape nominal that does not look like a blade (a box, a cylinder given by mistake): a
    warning line on stderr, even with --quiet (the deviation command's check)."""
    if os.path.splitext(args.nominal)[1].lower() not in SHAPE_SUFFIXES:
        return
    from bladerecon.fc.deviation import blade_like_warning, load_nominal

    nominal = load_nominal(args.nominal)
    warning = blade_like_warning(nominal)
    if warning:
        print(f"bladerecon: warning: {escaped(warning)}", file=sys.stderr, flush=True)


def _inspection_plan(args):
    """``--plan``: the inspection plan, read before any work; it needs --nominal and [parameters]."""
    if not getattr(args, "plan", None):
        return None
    from bladerecon.core.inspection.plan import read_inspection_plan

    check_input(args.plan, "--plan")
    plan = read_inspection_plan(args.plan)
    if not args.nominal:
        raise BladeReconError("--plan judges measured − nominal: add --nominal NOMINAL")
    if not plan.limits:
        raise BladeReconError(f"--plan {args.plan}: no [parameters] limits to judge sections by (profile zones "
                              "need the deviation: use 'deviation --plan')")
    return plan


def _judge(args, plan, out: list) -> None:
    """Add "parameters" (each limited parameter: value, nominal, difference, limits, pass) and
    "verdict" to every section row."""
    from bladerecon.core.inspection.verdicts import parameter_verdicts

    for row in out:
        row["parameters"] = parameter_verdicts(plan, row)
        row["verdict"] = "pass" if all(v["pass"] for v in row["parameters"].values()) else "fail"
    blade = "pass" if all(row["verdict"] == "pass" for row in out) else "fail"
    failed = [f"{row['index']}: {k}" for row in out for k, v in row["parameters"].items() if not v["pass"]]
    _say(args, f"verdict: {blade}" + (f" ({', '.join(failed)})" if failed else ""))


def _fmt(v) -> str:
    return "n/a" if v is None else f"{v:.3f}"


def _edge(o: dict, end: str) -> str:
    """An edge in the summary line: its radius, or its ellipse's semi-axes or its flat's width (mm)."""
    fit, name = o.get(f"{end}_fit") or {}, end.upper()
    if fit.get("shape") == "ellipse":
        e = fit["ellipse"]
        return f"{name} ellipse {e['a_mm']:.3f}×{e['b_mm']:.3f}"
    if fit.get("shape") == "flat":
        return f"{name} flat {_fmt(fit['flat']['width_mm'])}"
    return f"r_{name} {_fmt(o[f'{end}_radius'])}"
