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
import os
import re
import sys
import time

import numpy as np

from .core.errors import BladeReconError

__all__ = ["add_parser", "run_tspline", "read_zmap_points", "fit_point_file"]


def add_parser(sub) -> None:
    p = sub.add_parser("tspline", help="adaptive analysis-suitable T-spline fit (seed 002) -> Bézier patches (+ STEP)",
                       description="Fit an analysis-suitable T-spline to measured points with local refinement "
                                   "until every point is within --tolerance (mm), seed 002. Blade files (with "
                                   "sections) use the section reconstruction's (u,v); plain x y z files are "
                                   "z-maps over (x,y).")
    p.add_argument("input", help="point file: sections (blade) or plain 'x y z' lines / x,y,z CSV (z-map)")
    p.add_argument("--tolerance", type=float, required=True, metavar="MM",
                   help="largest allowed error at a point (mm): vertical for a z-map, |S(u,v)-P| for a blade")
    p.add_argument("-o", "--output", help="STEP file to write (mm): the Bézier patches sewn into one shell")
    p.add_argument("--zmap", action="store_true", help="treat the points as a z-map over (x, y) even if they have sections")
    p.add_argument("--max-iterations", type=int, default=40, help="refinement limit (default 40)")
    p.add_argument("--max-control-points", type=int, default=6000, help="control point limit (default 6000)")
    p.add_argument("--nd", type=int, help="N_d: split initial cells holding more points (default points/16)")
    p.add_argument("--nf", type=int, help="N_f: split initial cells holding more feature points (default points/80)")
    p.add_argument("--cut-order", choices=("longer-side", "switch-side"), default="longer-side",
                   help="where a cell that the midpoint would starve of data is cut: on its longer side between "
                        "the middle data lines (default) or on its other side")
    p.add_argument("--seam", choices=("closed-c1", "closed", "open"), default="closed-c1",
                   help="blades only (u goes around the profile, period 1): close the surface at the seam "
                        "u = 0 = 1 with C1 (default), with C0 only, or leave it open (the fit before the "
                        "seam constraint). Ignored for z-maps")
    p.add_argument("--json", action="store_true", help="print one JSON summary object to stdout")
    p.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    p.set_defaults(run=run_tspline)


def _say(args, msg: str) -> None:
    if not args.quiet:
        print(f"bladerecon: {msg}", file=sys.stderr, flush=True)


def read_zmap_points(path: str) -> np.ndarray:
    """(m, 3) points from plain ``x y z`` lines or a CSV with an x, y, z header (mm)."""
    try:
        with open(path, "r", encoding="utf-8-sig") as f:
            lines = f.read().splitlines()
    except OSError as err:
        raise BladeReconError(f"cannot read {path}: {err.strerror}") from None
    rows = [(k, ln.strip()) for k, ln in enumerate(lines, 1) if ln.strip() and not ln.lstrip().startswith("#")]
    if not rows:
        raise BladeReconError(f"{path}: no points in the file: give one 'x y z' point per line")
    cols = (0, 1, 2)
    first = re.split(r"[,;\s]+", rows[0][1])
    try:
        [float(c) for c in first]
    except ValueError:
        names = [c.strip().strip("\"'").lower() for c in first]
        if not all(c in names for c in "xyz"):
            raise BladeReconError(f"{path}, line {rows[0][0]}: header without x, y, z columns: name them x, y, z") from None
        cols = tuple(names.index(c) for c in "xyz")
        rows = rows[1:]
    out = np.empty((len(rows), 3))
    for n, (k, ln) in enumerate(rows):
        cells = re.split(r"[,;\s]+", ln)
        try:
            out[n] = [float(cells[c]) for c in cols]
        except (ValueError, IndexError):
            raise BladeReconError(f"{path}, line {k}: '{ln[:60]}' is not an 'x y z' point") from None
    if not np.all(np.isfinite(out)):
        raise BladeReconError(f"{path}: NaN or infinite coordinates: remove them")
    return out


def _blade_parameters(path: str, say) -> tuple[np.ndarray, np.ndarray, str] | None:
    """(uv, xyz, description, B-spline surface) from the section reconstruction, or None
    for a z-map file."""
    from .core.readers import read_points
    from .core.sections import build_sections
    from .core.reconstruct import reconstruct

    try:
        ps = read_points(path)
    except BladeReconError as err:
        if "no section structure" in str(err):
            return None
        raise
    if ps.n_sections < 2:
        return None
    sections = build_sections(ps)
    pts = [s.points for s in sections.sections]
    say(f"{len(ps.points)} points in {len(pts)} sections: blade parameterisation from the reconstruction")
    rec = reconstruct(pts, sections.span_axis, first_point_is_measured=not sections.sections[0].reordered)
    uv = np.column_stack([rec.point_u, rec.point_v])
    return uv, np.concatenate(pts), f"blade (u, v) of the section reconstruction, {len(pts)} sections", rec.surface


def fit_point_file(path: str, tolerance: float, zmap: bool = False, nd: int | None = None, nf: int | None = None,
                   max_iterations: int = 40, max_control_points: int = 6000, say=lambda msg: None,
                   cut_order: str = "longer-side", seam: str = "closed-c1"):
    """Read ``path``, choose the parameterisation from the data, fit (seed 002) and extract
    the Bézier patches (3D control points, mm). Returns (fit, patches, summary dict)."""
    from .core import tspline as ts

    if not tolerance > 0:
        raise BladeReconError(f"--tolerance must be a positive distance in mm, got {tolerance}")
    blade = None if zmap else _blade_parameters(path, say)
    if blade is None:
        if zmap:
            from .core.readers import read_points
            try:
                xyz = read_points(path).points
            except BladeReconError:
                xyz = read_zmap_points(path)
        else:
            xyz = read_zmap_points(path)
        uv, origin, scale = ts.normalise_parameters(xyz[:, :2])
        values, kind = xyz[:, 2:3], "z-map over (x, y)"
        say(f"{len(xyz)} points: z-map over (x, y)")
    else:
        uv_raw, xyz, kind, surface = blade
        uv, origin, scale = ts.normalise_parameters(uv_raw)
        if seam != "open":
            # u is periodic with period 1 in the reconstruction: keep it, so u = 0 and u = 1
            # are the same profile point and the seam can be closed there
            uv[:, 0], origin[0], scale[0] = np.clip(uv_raw[:, 0], 0.0, 1.0), 0.0, 1.0
        values = xyz
        from .core.bspline import evaluate_surface

        def prior(g):
            # between sections the T-spline follows the section reconstruction (see fit_tspline)
            return evaluate_surface(surface, origin[0] + scale[0] * g[:, 0], origin[1] + scale[1] * g[:, 1])
    limits = ts.FitLimits(max_iterations=max_iterations, max_control_points=max_control_points)
    fit = ts.fit_tspline(uv, values, tolerance, n_data=nd, n_feature=nf, xyz=xyz, limits=limits,
                         prior=None if blade is None else prior, cut_order=cut_order,
                         seam="open" if blade is None else seam)
    dup = fit.duplicates
    if dup.get("points_sharing_parameters"):
        say(f"warning: degenerate parameterisation: {dup['points_sharing_parameters']} points share a "
            f"(u, v) with another point ({dup['conflicting_groups']} groups with different positions; "
            "the fit takes their mean)")
    say(f"{fit.n_control_points} control points after {fit.refinements} refinements; "
        f"max {fit.max_error:.4g} mm; {fit.stop_reason}")
    if not fit.converged:
        say(f"warning: tolerance not reached: {fit.stop_reason}")
    patches = ts.bezier_patches(fit)
    summary = {
        "control_points": fit.n_control_points, "refinements": fit.refinements,
        "max": fit.max_error, "mean": fit.mean_error, "seconds": None, "faces": len(patches),
        "tolerance": tolerance, "converged": fit.converged, "stop_reason": fit.stop_reason,
        "parameterisation": kind, "points": int(len(uv)), "tmesh_faces": int(len(fit.mesh.reduced_faces())),
        "bezier_patches": len(patches), "ast_extension_steps": fit.ast_steps, "duplicates": dup,
        "history": fit.history, "fit_seconds": fit.seconds, "seam": fit.seam,
        "error_measure": "vertical |z - S(x,y)| (mm)" if blade is None else "|S(u_j,v_j) - P_j| (mm), parametric",
    }
    if blade is None:
        patches = ts.zmap_patches(patches, origin, scale)
    else:
        # the blade is closed around the profile: how far the T-spline's two u-ends (the
        # seam at u = 0 and u = 1) lie apart (~1e-13 mm when the seam is closed)
        v = np.linspace(0.0, 1.0, 201)
        ends = ts.evaluate(fit, np.column_stack([np.r_[np.zeros_like(v), np.ones_like(v)], np.r_[v, v]]))
        summary["seam_gap_max"] = float(np.linalg.norm(ends[:201] - ends[201:], axis=1).max())
    return fit, patches, summary


def run_tspline(args: argparse.Namespace) -> dict:
    t0 = time.perf_counter()
    if args.output:
        parent = os.path.dirname(os.path.abspath(args.output)) or "."
        if not os.path.isdir(parent):
            raise BladeReconError(f"--output {args.output}: folder {parent} does not exist; create it first")
        if os.path.abspath(args.output) == os.path.abspath(args.input):
            raise BladeReconError(f"--output {args.output} is the input file: choose another name")
    _, patches, summary = fit_point_file(args.input, args.tolerance, args.zmap, args.nd, args.nf,
                                         args.max_iterations, args.max_control_points, lambda m: _say(args, m),
                                         args.cut_order, args.seam)
    t_fit = time.perf_counter()
    if args.output:
        from .fc.tspline_export import write_tspline_step
        _say(args, "sewing patches and writing STEP")
        info = write_tspline_step(patches, args.output, seam="seam_gap_max" in summary)
        summary["faces"] = info["faces"]
        summary["output"] = {"step": args.output, **info}
        _say(args, f"wrote {args.output}")
    summary["seconds"] = time.perf_counter() - t0
    summary["seconds_fit"] = t_fit - t0
    return summary
