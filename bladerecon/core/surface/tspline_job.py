# SPDX-License-Identifier: LGPL-2.1-or-later
"""The T-spline job of ``tspline`` and the workbench: a point file in, an ASTS fit (seed 002),
its Bézier patches (3D control points, mm) and a summary out.

A file with sections gets the blade parameterisation of the section reconstruction; a plain
``x y z`` file is fitted as a z-map over (x, y).
"""
from __future__ import annotations

import re

import numpy as np

from bladerecon.core.errors import BladeReconError

__all__ = ["fit_point_file", "read_zmap_points"]


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
    from bladerecon.core.io.readers import read_points
    from bladerecon.core.sections.ordering import build_sections
    from bladerecon.core.reconstruct import reconstruct

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
    from bladerecon.core.surface import tspline as ts
    if not tolerance > 0:
        raise BladeReconError(f"--tolerance must be a positive distance in mm, got {tolerance}")
    blade = None if zmap else _blade_parameters(path, say)
    if blade is None:
        if zmap:
            from bladerecon.core.io.readers import read_points
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
        from bladerecon.core.geometry.bspline import evaluate_surface

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
