# SPDX-License-Identifier: LGPL-2.1-or-later
"""Options of ``reconstruct`` for real measurement data (issue 6): slicing, fairing, non-grid.

Kept out of cli.py so that ``build_parser`` / ``run_reconstruct`` change by a few lines:

* ``--slice N`` / ``--slice-at z1,z2,..`` / ``--slice-radii r1,r2,..`` with ``--slab MM``:
  the input is an unordered cloud, cut into sections (:mod:`bladerecon.core.sections.slicing`);
* ``--fair [--fair-threshold MM] [--fair-limit MM]``: bad points of every section replaced
  (:mod:`bladerecon.core.sections.fairing`), reported in the summary and in ``faired_points.csv``;
* ``--method approximate --poles NUxNV``: seed 003's non-grid hierarchical fit
  (:mod:`bladerecon.core.surface.nongrid`).

Units: mm.
"""
from __future__ import annotations

import argparse
import os

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import check_coordinates, check_input, count, one_line_errors, positive, shown

__all__ = ["add_options", "read_input", "apply_fairing", "write_fairing_csv", "fairness_summary"]


def add_options(r: argparse.ArgumentParser) -> None:
    """The real-data options, checked as the command line is parsed (finite, sign, range); the
    parser then reports a bad command line in one ``bladerecon: error:`` line."""
    one_line_errors(r)
    g = r.add_argument_group("real data (unordered clouds, bad points, non-grid rows)")
    g.add_argument("--poles", metavar="NUxNV",
                   help="with --method approximate: seed 003 non-grid fit with this many poles around x along "
                        "the span, e.g. 24x9")
    g.add_argument("--surface", choices=("bspline", "local-bicubic"), default="bspline",
                   help="bspline (default): one C2 cubic B-spline face; local-bicubic: seed 004's local bicubic "
                        "interpolation, C1 Bézier patches, exported as a sewn shell")
    g.add_argument("--patches-around", type=count(8, 100_000), default=160, metavar="N",
                   help="with --surface local-bicubic: grid points (patches) around each section (default 160)")
    g.add_argument("--fair-surface", action="store_true",
                   help="with --surface local-bicubic: alternate fairing of the u and v mesh curves of the grid "
                        "until both are fair, then rebuild regions farther than 0.02 mm from the points (seed 004)")
    g.add_argument("--fair", action="store_true",
                   help="replace bad points (farther than --fair-threshold from a fair fit) of every section by "
                        "points on an auxiliary cubic (seed 001 §1.1); all are reported")
    g.add_argument("--fair-threshold", type=positive(), metavar="MM", default=None,
                   help="with --fair or --fair-surface: distance from the fair fit that makes a point bad "
                        "(default 0.003)")
    g.add_argument("--fair-limit", type=positive(), metavar="MM", default=None,
                   help="with --fair: refuse when a replacement would move a point farther (default 0.5)")
    g.add_argument("--slice", type=count(2, 100_000), metavar="N", help="input is an unordered cloud: N planes along --slice-axis")
    g.add_argument("--slice-at", metavar="Z1,Z2,..", help="unordered cloud: planes at these heights (mm)")
    g.add_argument("--slice-radii", metavar="R1,R2,..",
                   help="unordered cloud: cylinders of these radii (mm) about --slice-axis through the origin")
    g.add_argument("--slice-axis", choices=("x", "y", "z"), default="z", help="plane normal / rotor axis (default z)")
    g.add_argument("--slab", type=positive(), metavar="MM",
                   help="width of each slice's slab (default a quarter of the smallest gap between slices)")
    g.add_argument("--slab-keep", action="store_true",
                   help="keep slab points where they are instead of moving them onto the cutting plane/cylinder "
                        "(for surface-mesh clouds whose nodes lie in rows: no slide along a twisted surface)")
    g.add_argument("--cloud-scale", type=positive(1e9, ""), default=1.0, metavar="F",
                   help="multiply the cloud's coordinates by F (1000 for a file in metres)")


def _floats(text: str, what: str, positive_only: bool = False) -> np.ndarray:
    try:
        vals = np.array([float(x) for x in text.split(",") if x.strip()])
    except ValueError:
        raise BladeReconError(f"{what} '{shown(text)}': give comma-separated numbers in mm, e.g. 10,20,30") from None
    if not np.isfinite(vals).all() or (positive_only and not (vals > 0).all()):
        kind = "positive" if positive_only else "finite"
        raise BladeReconError(f"{what} '{shown(text)}': give {kind} numbers in mm, e.g. 10,20,30")
    if vals.size < 2:
        raise BladeReconError(f"{what} '{shown(text)}': need at least 2 slices for a surface")
    return vals


def slicing_requested(args: argparse.Namespace) -> bool:
    return any(getattr(args, k, None) is not None for k in ("slice", "slice_at", "slice_radii"))


def check_options(args: argparse.Namespace) -> None:
    if sum(getattr(args, k, None) is not None for k in ("slice", "slice_at", "slice_radii")) > 1:
        raise BladeReconError("give one of --slice, --slice-at, --slice-radii")
    if (args.slab is not None or args.slab_keep) and not slicing_requested(args):
        raise BladeReconError("--slab applies to slicing a cloud: add --slice, --slice-at or --slice-radii")
    if args.fair_threshold is not None and not (args.fair or args.fair_surface):
        raise BladeReconError("--fair-threshold applies with --fair or --fair-surface: add one of them")
    if args.fair_limit is not None and not args.fair:
        raise BladeReconError("--fair-limit applies with --fair: add --fair")
    if args.poles is not None and args.method != "approximate":
        raise BladeReconError("--poles applies to --method approximate (seed 003 non-grid fit): add --method approximate")
    if args.poles is not None and args.tolerance is not None:
        raise BladeReconError("--poles fixes the pole count; leave out --tolerance")
    if args.fair_surface and args.surface != "local-bicubic":
        raise BladeReconError("--fair-surface works on the grid of --surface local-bicubic: add it")
    if args.surface == "local-bicubic":
        if args.poles is not None or args.pairing == "angle":
            raise BladeReconError("--surface local-bicubic builds on the anchored sections: leave out --poles / --pairing angle")
        if args.solid:
            raise BladeReconError("--surface local-bicubic exports a sewn shell of patches; --solid needs the single "
                                  "B-spline face: drop one of them")
        if args.patches_around < 8:
            raise BladeReconError(f"--patches-around {args.patches_around}: need at least 8")
    for name in ("fair_threshold", "fair_limit", "slab"):
        v = getattr(args, name)
        if v is not None and not v > 0:
            raise BladeReconError(f"--{name.replace('_', '-')} must be a positive distance in mm, got {v}")


def read_input(args: argparse.Namespace):
    """The input as a PointSet: the file itself, or the sections sliced out of a cloud.

    Returns ``(pointset, slicing_summary or None)``.
    """
    from bladerecon.core.io.readers import read_points
    from bladerecon.core.sections import slicing
    check_input(args.input, "INPUT")
    if not slicing_requested(args):
        ps = read_points(args.input, memory_limit=getattr(args, "memory_limit", None))
        check_coordinates(ps.points, ps.line, args.input)
        return ps, None
    axis = np.eye(3)["xyz".index(args.slice_axis)]
    radii = _floats(args.slice_radii, "--slice-radii", positive_only=True) if args.slice_radii is not None else None
    at = _floats(args.slice_at, "--slice-at") if args.slice_at is not None else None
    P, lines = _read_cloud(args.input, args.cloud_scale, getattr(args, "memory_limit", None))
    if radii is not None:
        slices = slicing.slice_cylinders(P, radii, axis, slab=args.slab, project=not args.slab_keep)
        kind = "cylinders"
    else:
        pos = at if at is not None else slicing.plane_positions(P, axis, args.slice)
        slices = slicing.slice_planes(P, pos, axis, slab=args.slab, project=not args.slab_keep)
        kind = "planes"
    ps = slicing.slices_to_pointset(slices, lines, args.input)
    summary = {"kind": kind, "axis": args.slice_axis, "cloud_points": int(P.shape[0]),
               "positions_mm": [s.position for s in slices], "points": [int(len(s.points)) for s in slices],
               "outliers": [[k, int(lines[i])] for k, s in enumerate(slices) for i in s.outliers],
               "projected_onto_cut": not args.slab_keep,
               "slab_mm": float(slices[0].slab) if slices else args.slab}
    return ps, summary


def _read_cloud(path: str, scale: float, memory_limit: float | None = None):
    """The cloud (mm, after ``--cloud-scale``): :func:`bladerecon.core.sections.whole_cloud.read_cloud_mm`."""
    from bladerecon.core.sections.whole_cloud import read_cloud_mm

    return read_cloud_mm(path, scale, memory_limit)


def _file_index(lines: np.ndarray) -> np.ndarray:
    """0-based index of each point within its section in file order (from its line number)."""
    return np.argsort(np.argsort(lines, kind="stable"), kind="stable")


def apply_fairing(sections, args: argparse.Namespace):
    """Fair every section; returns ``(point lists, summary dict, table for faired_points.csv)``."""
    from bladerecon.core.sections.fairing import DEFAULT_MAX_MOVE, DEFAULT_THRESHOLD, fair_section
    from bladerecon.core.analysis.fairness import count_inflections
    from bladerecon.core.reconstruct import _fit_sections
    from bladerecon.core.surface.section_curves import MethodChoice, choose_method

    thr = args.fair_threshold if args.fair_threshold is not None else DEFAULT_THRESHOLD
    limit = args.fair_limit if args.fair_limit is not None else DEFAULT_MAX_MOVE
    axis = np.asarray(sections.span_axis)

    # inflections of the section curves the reconstruction itself fits (interpolation or the
    # noise-consistent smoothing of core.reconstruct), before and after the fairing
    original = [s.points for s in sections.sections]
    choice = choose_method(original)
    if args.method != "auto":
        choice = MethodChoice(args.method, "", choice.noise_mm, choice.min_spacing_mm, choice.tangent_noise)
    tol = args.tolerance

    def inflections(point_lists):
        return [count_inflections(c.curve, axis) for c in _fit_sections(point_lists, choice, tol)]

    pts, replaced, rows = [], [], []
    for k, sec in enumerate(sections.sections):
        f = fair_section(sec.points, thr, limit, name=sec.name)
        pts.append(f.faired)
        idx = _file_index(sec.lines)
        for i in np.flatnonzero(f.bad):
            replaced.append([k, int(idx[i]), float(f.displacement[i])])
        rows.append(np.column_stack([np.full(len(sec.points), k), sec.lines, idx, sec.points, f.faired,
                                     f.displacement, f.bad.astype(int), f.distance]))
    before = inflections(original)
    after = inflections(pts) if replaced else before
    method = choice.method
    replaced.sort(key=lambda r: (r[0], r[1]))
    summary = {"threshold_mm": thr, "limit_mm": limit, "replaced": replaced,
               "inflections_before": before, "inflections_after": after,
               "inflections_measured_on": f"the reconstruction's own section curves ({method})"}
    return pts, summary, np.concatenate(rows)


def write_fairing_csv(folder: str, table: np.ndarray) -> None:
    """Original beside faired points: nothing is silently dropped."""
    path = os.path.join(folder, "faired_points.csv")
    np.savetxt(path, table, delimiter=",",
               fmt=["%d", "%d", "%d"] + ["%.6f"] * 7 + ["%d", "%.6f"],
               header="section,line,index_in_section,x,y,z,x_faired,y_faired,z_faired,displacement,bad,"
                      "distance_to_fair_fit", comments="")


def fairness_summary(surface, sections_pts: list[np.ndarray], span_axis) -> dict:
    """Seed 004's fairness criteria as numbers for the summary: the section curves (as the
    reconstruction fits them, method chosen from the data) and the surface."""
    from bladerecon.core.analysis.fairness import curve_fairness, surface_fairness
    from bladerecon.core.reconstruct import _fit_sections
    from bladerecon.core.surface.section_curves import choose_method

    curves = _fit_sections(sections_pts, choose_method(sections_pts), None)
    secs = [curve_fairness(c.curve, span_axis) for c in curves]
    return {"sections": {"inflections": [s["inflections"] for s in secs],
                         "strain_energy_per_mm": [s["strain_energy"] for s in secs],
                         "max_curvature_jump_per_mm": [s["max_curvature_jump"] for s in secs]},
            "surface": surface_fairness(surface, span_axis)}


def reconstruct_nongrid(pts: list[np.ndarray], span_axis, poles_text: str):
    """Seed 003's non-grid fit for the CLI, shaped like a Reconstruction for the summary."""
    from types import SimpleNamespace

    from bladerecon.core.surface.nongrid import fit_nongrid, parse_poles
    from bladerecon.core.surface.section_curves import MethodChoice

    poles = parse_poles(poles_text)
    fit = fit_nongrid(pts, np.asarray(span_axis), poles, closed=True)
    counts = [len(p) for p in pts]
    why = (f"seed 003 non-grid fit: rows of {min(counts)}-{max(counts)} points, least-squares row curves "
           f"resampled at {fit.grid.shape[1]} common parameters, hierarchical least squares "
           f"{poles[0]}x{poles[1]} poles")
    choice = MethodChoice("approximate-nongrid", why, None, None, None)
    return SimpleNamespace(surface=fit.surface, choice=choice, tolerance=None,
                           refit_error=float(fit.row_residual.max()), point_u=None, point_v=None,
                           seconds=fit.seconds)


def local_bicubic(rec, n_around: int, fair: bool = False, measured: list[np.ndarray] | None = None,
                  threshold: float | None = None):
    """Seed 004's local bicubic surface through a grid sampled on the anchored section curves.

    The grid: every section curve at ``n_around`` common parameters (LE/TE anchored, as for
    the B-spline surface); u parameters centripetal averaged over the sections, v those of
    the reconstruction. Returns a Reconstruction-like object for the summary.
    """
    from types import SimpleNamespace

    from bladerecon.core.geometry.bspline import evaluate_curve
    from bladerecon.core.surface.local_bicubic import local_bicubic_surface
    from bladerecon.core.surface.section_curves import MethodChoice
    from bladerecon.core.surface.skinning import closed_grid_parameters, s_to_t

    s = np.arange(n_around) / n_around
    grid = np.stack([evaluate_curve(a.curve, s_to_t(a, s, rec.s_te)) for a in rec.anchored])
    report = None
    if fair:
        from bladerecon.core.surface.fairing import DEFAULT_THRESHOLD, fair_grid_alternating
        g = fair_grid_alternating(grid, DEFAULT_THRESHOLD if threshold is None else threshold)
        if not g.converged:
            raise BladeReconError(
                f"surface fairing did not settle in {g.passes} passes ({g.replaced_u} section points replaced): "
                f"a grid of {n_around} points around is too coarse for the fairing threshold; raise --patches-around")
        grid = g.grid
        report = {"passes": g.passes, "converged": g.converged, "v_mesh_curves_faired": g.v_faired, "replaced_v_mesh_points": g.replaced_v,
                  "replaced_u_mesh_points": g.replaced_u, "max_move_mm": float(g.moved.max())}
    u = closed_grid_parameters(grid)
    v = np.asarray(rec.v_params)
    surf = local_bicubic_surface(grid, u, v)
    if fair and measured is not None:
        surf, repaired = _repair(surf, grid, u, v, np.concatenate(measured))
        report["repaired_grid_points"] = repaired
    why = (f"seed 004 local bicubic interpolation of {grid.shape[0]} x {n_around} points on the "
           f"{rec.choice.method} section curves: C1 Bézier patches")
    choice = MethodChoice("local-bicubic", why, rec.choice.noise_mm, rec.choice.min_spacing_mm, rec.choice.tangent_noise)
    return SimpleNamespace(surface=surf, choice=choice, tolerance=rec.tolerance, refit_error=rec.refit_error,
                           point_u=None, point_v=None, seconds=rec.seconds, surface_fairing=report)


def _repair(surf, grid, u, v, measured):
    """Seed 004's auxiliary-surface step: cells with a measured point > 0.02 mm off are rebuilt."""
    from bladerecon.core.surface.local_bicubic import local_bicubic_surface
    from bladerecon.core.geometry.projection import project_points_to_surface
    from bladerecon.core.surface.fairing import REPAIR_THRESHOLD, repair_regions

    pr = project_points_to_surface(surf, measured)
    S, N, _ = grid.shape
    k = np.clip(np.searchsorted(np.concatenate([u, [1.0]]), pr.u, side="right") - 1, 0, N - 1)
    j = np.clip(np.searchsorted(v, pr.v, side="right") - 1, 0, S - 2)
    err = np.zeros((S - 1, N))
    np.maximum.at(err, (j, k), pr.distance)
    if not (err > REPAIR_THRESHOLD).any():
        return surf, 0
    new, replaced = repair_regions(grid, err)
    rebuilt = local_bicubic_surface(new, u, v)
    if project_points_to_surface(rebuilt, measured).distance.max() > pr.distance.max():
        raise BladeReconError(f"the region repair (seed 004) made the fit worse ({int(replaced.sum())} grid points "
                              "rebuilt): leave out --fair-surface, or fair the sections first with --fair")
    return rebuilt, int(replaced.sum())


def make_shape(surface, args):
    """The exported shape: the B-spline face (or solid), or the sewn shell of Bézier patches."""
    if args.surface == "local-bicubic":
        from bladerecon.fc.patches import make_patch_shell
        return make_patch_shell(surface)
    from bladerecon.fc.convert import make_face
    from bladerecon.fc.export import make_solid
    return make_solid(surface) if args.solid else make_face(surface)
