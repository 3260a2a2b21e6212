# SPDX-License-Identifier: LGPL-2.1-or-later
"""Repair target of a damaged blade: register, service deformation, damage, target, volume.

Units: mm, mm², mm³ and degrees. The span axis is z (the nominal's sections lie in planes
z = const, as the sample nominal's and most blade CAD's); the nominal is one B-spline
surface, u around the section (periodic), v along the span.

1. **Register**: the robust best fit (:func:`bladerecon.core.analysis.alignment.best_fit`,
   Tukey biweight) on a subsample: damage does not pull it.
2. **Service deformation**: :func:`bladerecon.core.repair.deformation.fit_span_field`.
3. **Damage**: every point's in-plane depth under the adapted nominal (signed distance over
   the in-plane share of the normal); cells of a (height row x u) grid on the nominal's
   (u, v) domain whose mean depth exceeds the tolerance are damaged; connected regions
   (periodic in u) are classified by their chord position; the rows above the highest
   measured point (or above ``cut_height``) are the ``tip`` region.
4. **Target**: the adapted nominal, made by moving the nominal's poles with the field (a
   smooth field moves a B-spline's poles as its points to ~0.1 µm here), plus the measured
   correction blended in outside the damage (:mod:`bladerecon.core.repair.blend`).
5. **Missing volume**: per region, sum over its cells (dilated by one cell, so the shallow
   rim counts) of ``(delta - kappa delta²/2) ds dz``, the exact area between a profile and a
   curve at normal depth ``delta`` (``kappa`` the profile's curvature), and for the tip the
   target's section areas integrated from the cut to the nominal tip.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage
from scipy.integrate import trapezoid

from bladerecon.core.analysis.alignment import Alignment, SurfaceProjector, apply_transform, best_fit, transform_surface
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.bspline import evaluate_surface
from bladerecon.core.geometry.projection import project_points_to_surface
from bladerecon.core.geometry.spline import BSplineSurface
from bladerecon.core.repair.deformation import SpanField, fit_span_field

__all__ = ["RepairResult", "repair_target", "adapt_surface"]

_REGISTER_POINTS = 1200
_U_BINS = 256
_MIN_UNDAMAGED = 0.2         # share of the points within tolerance needed to fit the field
_MAX_DAMAGE_SHARE = 0.4      # damaged share of the nominal's area beyond which we refuse


@dataclass
class RepairResult:
    """Everything the command reports; surfaces in the measured frame (mm)."""

    target: BSplineSurface
    naive: BSplineSurface
    adapted: BSplineSurface          # the adapted nominal alone (the nominal's parameters)
    alignment: Alignment
    field: SpanField
    regions: list
    volume_mm3: float
    deformation: dict
    target_vs_measured: dict
    naive_vs_target: dict
    blend: dict
    depth_map: dict
    seconds: dict = field(default_factory=dict)
    mode: str = "cloud"
    sign: float = 1.0                # turns the nominal's (and target's) normal out of the material

    def summary(self) -> dict:
        return {"regions": self.regions, "volume_mm3": self.volume_mm3, "deformation": self.deformation,
                "target_vs_measured": self.target_vs_measured, "naive_vs_target": self.naive_vs_target,
                "blend": self.blend, "measured_as": self.mode, "alignment": self.alignment.as_dict(),
                "tip": self.depth_map["tip"], "seconds": self.seconds}


def adapt_surface(surface: BSplineSurface, fld: SpanField) -> BSplineSurface:
    """The nominal moved by the service deformation: its poles moved by the field."""
    from dataclasses import replace

    poles = np.asarray(surface.poles, float)
    moved = fld.apply(poles.reshape(-1, 3)).reshape(poles.shape)
    return replace(surface, poles=moved)


def _nominal_z(surface: BSplineSurface, n_u: int = 64, n_v: int = 201):
    """z range of the nominal and v(z): the mean height of each v iso-curve, inverted."""
    u = np.linspace(*surface.u_domain, n_u, endpoint=False)
    v = np.linspace(*surface.v_domain, n_v)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    z = evaluate_surface(surface, uu.ravel(), vv.ravel())[:, 2].reshape(n_u, n_v).mean(axis=0)
    if not np.all(np.diff(z) > 0) and not np.all(np.diff(z) < 0):
        raise BladeReconError("the nominal's v direction is not along z: repair needs a blade "
                              "surface with u around the section and v along the span (z)")
    order = np.argsort(z)
    return float(z.min()), float(z.max()), (z[order], v[order])


def _check_span(points: np.ndarray, z_lo: float, z_hi: float) -> None:
    lo, hi = float(points[:, 2].min()), float(points[:, 2].max())
    slack = 0.02 * (z_hi - z_lo) + 0.5
    if lo < z_lo - slack or hi > z_hi + slack:
        raise BladeReconError(
            f"the nominal does not cover the measured span: points from z = {lo:.2f} to {hi:.2f} mm, "
            f"nominal from z = {z_lo:.2f} to {z_hi:.2f} mm: check the nominal file and the points' frame")


def _register(points: np.ndarray, surface: BSplineSurface, sign: float) -> Alignment:
    rng = np.random.default_rng(0)
    sub = points if len(points) <= _REGISTER_POINTS else points[rng.choice(len(points), _REGISTER_POINTS, replace=False)]
    try:
        return best_fit(sub, SurfaceProjector(surface, sign), "rigid", robust=True)
    except BladeReconError as err:
        if "did not converge" not in str(err):
            raise
    # The robust fit can cycle when the service deformation is of the size of the noise
    # scale it sets; the registration only has to bring the blade near: the field fit that
    # follows holds every small rigid motion (in-plane per height, and the out-of-plane part).
    return best_fit(sub, SurfaceProjector(surface, sign), "rigid", robust=False)


def _naive_fit(points: np.ndarray, surface: BSplineSurface, sign: float, undamaged: np.ndarray) -> Alignment:
    """The naive target's best fit: the nominal itself, rigidly fitted to the points the
    deformation fit found undamaged (damage cannot pull it)."""
    idx = np.nonzero(undamaged)[0]
    rng = np.random.default_rng(1)
    if len(idx) > _REGISTER_POINTS:
        idx = rng.choice(idx, _REGISTER_POINTS, replace=False)
    return best_fit(points[idx], SurfaceProjector(surface, sign), "rigid")


def _projector(surface: BSplineSurface, sign: float):
    def project(Q, state):
        if state is None:
            pr = project_points_to_surface(surface, Q)
        else:
            pr = project_points_to_surface(surface, Q, state[0], state[1])
        return pr.foot, sign * pr.normal, sign * pr.signed, (pr.u, pr.v)
    return project


def repair_target(points: np.ndarray, nominal: BSplineSurface, sign: float = 1.0, *,
                  tolerance: float = 0.03, cut_height: float | None = None, blend: float | None = None,
                  section: np.ndarray | None = None, max_damage_share: float = _MAX_DAMAGE_SHARE,
                  flow: np.ndarray | None = None) -> RepairResult:
    """The repair target of a damaged blade measured as ``points`` (m, 3) mm.

    ``nominal``: the design blade surface; ``sign`` makes its normal point out of the
    material. ``section``: section index per point when the points are planar sections
    (then the damage rows are the sections), None for a cloud. Raises
    :class:`BladeReconError` for no undamaged area, a nominal that does not cover the
    measured span, or damage over ``max_damage_share`` of the blade. ``flow``: the direction the
    fluid travels (nominal frame): a region's ``leading_edge`` / ``trailing_edge`` kind is then
    named from the upstream end, not from the blunter one.
    """
    t0 = time.perf_counter()
    P0 = np.asarray(points, float)
    if P0.ndim != 2 or P0.shape[1] != 3 or len(P0) < 50:
        raise BladeReconError(f"repair needs at least 50 measured points, got {len(P0)}")
    z_lo, z_hi, z_to_v = _nominal_z(nominal)
    _check_span(P0, z_lo, z_hi)
    alignment = _register(P0, nominal, sign)
    P = apply_transform(P0, alignment.matrix)
    t1 = time.perf_counter()
    box = nominal.poles.reshape(-1, 3)
    centre = 0.5 * (box.min(axis=0) + box.max(axis=0))
    fld, fit = fit_span_field(P, _projector(nominal, sign), centre[:2], (z_lo, z_hi))
    t2 = time.perf_counter()
    signed, w = fit["signed"], fit["weights"]
    ok = np.abs(signed) <= tolerance
    if ok.mean() < _MIN_UNDAMAGED:
        raise BladeReconError(
            f"no undamaged area left to fit the deformation: only {100 * ok.mean():.1f} % of the "
            f"{len(P)} points ({int(ok.sum())}) lie within ±{tolerance} mm of the adapted nominal "
            f"(at least {100 * _MIN_UNDAMAGED:.0f} % needed): check the nominal, or raise --tolerance")
    adapted = adapt_surface(nominal, fld)
    inv = np.linalg.inv(alignment.matrix)
    naive = transform_surface(nominal, np.linalg.inv(_naive_fit(P0, nominal, sign, w > 0).matrix))

    mode = "sections" if section is not None and _planar_sections(P, section) else "cloud"
    grid = _damage_grid(P, fit, nominal, fld, z_to_v, (z_lo, z_hi), tolerance, cut_height, section, mode, flow)
    share = grid["damaged_area"] / grid["total_area"]
    if share > max_damage_share:
        raise BladeReconError(
            f"damage over {100 * share:.0f} % of the blade's area ({grid['damaged_area']:.0f} of "
            f"{grid['total_area']:.0f} mm²), more than the {100 * max_damage_share:g} % a repair target "
            f"can be built for: check the nominal and the tolerance")
    band = blend if blend is not None else _default_band(grid["regions"])
    target_reg, blend_info = _blend_target(adapted, nominal, sign, fit, grid, band, tolerance)
    target = transform_surface(target_reg, inv)
    t3 = time.perf_counter()
    und = (w > 0) & ok
    resid = signed[und]
    # naive target (the nominal, best-fitted) against the adapted nominal, over the damage
    naive_gap = _naive_gap(grid, nominal, fld)
    zs = np.linspace(z_lo, z_hi, 11)
    vals = fld.values(zs)
    rel = vals - fld.values([z_lo])
    # the bend in the measured frame: how the twist axis point of each height moves under
    # the whole map (field, then the registration undone), relative to the hub's move; the
    # registration's tilt and the field's linear bend cancel here (they do not in d(z))
    axis_pts = np.column_stack([np.full_like(zs, fld.centre[0]), np.full_like(zs, fld.centre[1]), zs])
    moved = apply_transform(fld.apply(axis_pts), inv) - axis_pts
    rel[:, :2] = moved[:, :2] - moved[:1, :2]
    deformation = {
        "twist_deg_at_tip": float(np.degrees(rel[-1, 2])),
        "max_bend_mm": float(np.max(np.hypot(rel[:, 0], rel[:, 1]))),
        "bend_frame": "measured frame, the twist axis point of each height relative to the hub's",
        "per_section": [{"z_mm": float(z), "shift_mm": [float(a), float(b)], "twist_deg": float(np.degrees(t))}
                        for z, (a, b, t) in zip(zs, rel)],
        "stiffness_edf": fld.edf, "noise_mm": fit["noise_mm"],
        "centre_mm": [float(c) for c in fld.centre],
    }
    seconds = {"register": t1 - t0, "deformation": t2 - t1, "damage_and_blend": t3 - t2}
    seconds["total"] = time.perf_counter() - t0
    return RepairResult(
        target=target, naive=naive, adapted=transform_surface(adapted, inv), alignment=alignment, field=fld, regions=grid["regions"],
        volume_mm3=float(sum(r["volume_mm3"] for r in grid["regions"])), deformation=deformation,
        target_vs_measured={"max": float(np.max(np.abs(resid))) if resid.size else 0.0,
                            "rms": float(np.sqrt(np.mean(resid ** 2))) if resid.size else 0.0,
                            "points": int(resid.size)},
        naive_vs_target=naive_gap,
        blend=blend_info,
        depth_map=grid, seconds=seconds, mode=mode, sign=float(sign))


def _default_band(regions: list) -> float:
    """Band width (mm) from the damage size: 10x the deepest non-tip damage, 2 to 8 mm."""
    depths = [r["max_depth_mm"] for r in regions if r["kind"] != "tip"]
    return float(np.clip(10.0 * max(depths, default=0.3), 2.0, 8.0))


def _blend_target(adapted, nominal, sign, fit, grid, band, tol, n_u: int = 600, n_v: int = 81):
    """Target = adapted + b e n on a dense grid, interpolated (module doc of blend.py);
    and the blend's numbers: the largest curvature jump across the band boundaries."""
    from bladerecon.core.geometry.projection import surface_derivatives_fast
    from bladerecon.core.repair.blend import blend_weight, fit_correction, grid_points
    from bladerecon.core.surface.skinning import interpolate_grid

    u_f, v_f = fit["state"]
    clean = (fit["weights"] > 0) & (np.abs(fit["signed"]) <= tol)
    corr = fit_correction(u_f, v_f, fit["signed"], clean.astype(float), nominal.u_domain, nominal.v_domain)
    uu, vv, nom_pts = grid_points(nominal, n_u, n_v)
    S, Su, Sv = surface_derivatives_fast(adapted, uu.ravel(), vv.ravel())[:3]
    n = np.cross(Su, Sv)
    n = sign * n / np.linalg.norm(n, axis=1, keepdims=True)
    b = blend_weight(grid, band, uu.ravel(), nom_pts[..., 2].ravel())
    e = corr(uu.ravel(), vv.ravel())
    pts = (S + (b * e)[:, None] * n).reshape(n_v, n_u, 3)
    target = interpolate_grid(pts, "chord")
    k_t = _row_curvature(pts)
    k_a = _row_curvature(S.reshape(n_v, n_u, 3))
    bb = b.reshape(n_v, n_u)
    inside = (bb > 0) & (bb < 1)
    edge = inside ^ np.roll(inside, 1, axis=1)        # a node pair across a band boundary
    jump = np.abs(np.diff(np.concatenate([k_t, k_t[:, :1]], axis=1), axis=1)
                  - np.diff(np.concatenate([k_a, k_a[:, :1]], axis=1), axis=1))
    jump = np.roll(jump, 1, axis=1)
    info = {"continuity": "G2: a C2 blend weight (quintic smootherstep) of a smooth measured correction",
            "band_mm": band, "max_curvature_jump": float(jump[edge].max()) if edge.any() else 0.0,
            "max_correction_mm": float(np.max(np.abs(e))), "curvature_units": "1/mm"}
    return target, info


def _row_curvature(pts: np.ndarray) -> np.ndarray:
    """Discrete curvature (1/mm) along each closed row of a grid (n_v, n_u, 3)."""
    d1 = (np.roll(pts, -1, axis=1) - np.roll(pts, 1, axis=1)) / 2
    d2 = np.roll(pts, -1, axis=1) - 2 * pts + np.roll(pts, 1, axis=1)
    return np.linalg.norm(np.cross(d1, d2), axis=2) / np.maximum(np.linalg.norm(d1, axis=2) ** 3, 1e-300)


def _planar_sections(P: np.ndarray, section: np.ndarray) -> bool:
    labels = np.unique(section)
    if len(labels) < 2:
        return False
    for k in labels:                    # each section within 0.05 mm of its own plane
        Q = P[section == k]
        if len(Q) < 3:
            return False
        off = np.linalg.svd(Q - Q.mean(axis=0), compute_uv=False)[-1] / np.sqrt(len(Q))
        if off > 0.05:
            return False
    return True


def _profile_rows(nominal: BSplineSurface, v_rows: np.ndarray, n_u: int, flow: np.ndarray | None = None):
    """Per row: points at the u-bin edges, ds and in-plane curvature at the bin centres, and
    the chord fraction of each bin centre (0 LE, 1 TE; LE = the blunter end, or with ``flow``
    the upstream end)."""
    if flow is not None:
        f2 = np.asarray(flow, float)[:2]
        if np.linalg.norm(f2) < 0.1 * np.linalg.norm(flow):
            raise BladeReconError("--flow runs along the blade's span: give the direction the fluid crosses the "
                                  "sections in")
    u0, u1 = nominal.u_domain
    edges = np.linspace(u0, u1, n_u + 1)
    fine = 8
    uf = np.linspace(u0, u1, n_u * fine, endpoint=False)
    ds, kappa, chord = [], [], []
    for v in v_rows:
        pts = evaluate_surface(nominal, uf, np.full_like(uf, v))[:, :2]
        seg = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
        ds.append(seg.reshape(n_u, fine).sum(axis=1))
        d1 = (np.roll(pts, -1, axis=0) - np.roll(pts, 1, axis=0)) / 2
        d2 = np.roll(pts, -1, axis=0) - 2 * pts + np.roll(pts, 1, axis=0)
        k = (d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]) / np.maximum(np.linalg.norm(d1, axis=1) ** 3, 1e-300)
        area2 = np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - pts[:, 1] * np.roll(pts[:, 0], -1))
        k = k * np.sign(area2)                   # > 0 where convex
        kappa.append(k.reshape(n_u, fine).mean(axis=1))
        centre = pts.mean(axis=0)
        a = int(np.argmax(np.linalg.norm(pts - centre, axis=1)))
        b = int(np.argmax(np.linalg.norm(pts - pts[a], axis=1)))
        if flow is not None:                            # the LE is the upstream end
            le, te = (a, b) if pts[a] @ f2 < pts[b] @ f2 else (b, a)
        else:                                           # the LE is the rounder (larger radius) end
            le, te = (a, b) if k[a] < k[b] else (b, a)
        c = pts[te] - pts[le]
        x = ((pts - pts[le]) @ c) / (c @ c)
        chord.append(x.reshape(n_u, fine).mean(axis=1))
    return np.array(ds), np.array(kappa), np.array(chord), edges


def _section_area(nominal: BSplineSurface, v: float, n: int = 4000) -> float:
    u = np.linspace(*nominal.u_domain, n, endpoint=False)
    p = evaluate_surface(nominal, u, np.full_like(u, v))
    return 0.5 * abs(float(np.dot(p[:, 0], np.roll(p[:, 1], -1)) - np.dot(p[:, 1], np.roll(p[:, 0], -1))))


def _damage_grid(P, fit, nominal, fld, z_to_v, z_range, tol, cut_height, section, mode, flow=None) -> dict:
    """Depth map on (row, u-bin) cells, the damaged regions, their volumes (module doc §3, §5)."""
    z_lo, z_hi = z_range
    signed, w, normal = fit["signed"], fit["weights"], fit["normal"]
    u_feet = fit["state"][0]
    inplane = np.maximum(np.linalg.norm(normal[:, :2], axis=1), 0.2)
    depth = -signed / inplane                       # > 0 under the target, in the section plane
    u0, u1 = nominal.u_domain
    col = np.clip(((u_feet - u0) / (u1 - u0) * _U_BINS).astype(int), 0, _U_BINS - 1)
    z = fit["nominal_frame"][:, 2]                 # heights on the nominal (out-of-plane motion undone)
    good = w > 0
    z_top = float(z.max()) if not good.any() else float(np.max(z[good | (depth > tol)]))
    if mode == "sections":
        labels = np.unique(section)
        z_rows = np.array([z[section == k].mean() for k in labels])
        order = np.argsort(z_rows)
        z_rows = z_rows[order]
        row = np.empty(len(P), int)
        for r, k in enumerate(labels[order]):
            row[section == k] = r
        z_top = float(z_rows[-1])
        dz = np.gradient(z_rows) if len(z_rows) > 1 else np.array([1.0])
    else:
        n_rows = max(2, int(np.ceil((z_top - z_lo) / 1.0)))
        row_edges = np.linspace(z_lo, z_top, n_rows + 1)
        z_rows = 0.5 * (row_edges[1:] + row_edges[:-1])
        dz = np.diff(row_edges)
        row = np.clip(np.searchsorted(row_edges, z, side="right") - 1, 0, n_rows - 1)
    cut, tip_basis = _tip_cut(z_top, cut_height, z_hi, mode, z_rows if mode == "sections" else None)
    n_rows = len(z_rows)
    total = np.zeros((n_rows, _U_BINS))
    count = np.zeros((n_rows, _U_BINS))
    np.add.at(total, (row, col), depth)
    np.add.at(count, (row, col), 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = total / count
    for r in range(n_rows):                          # empty cells: interpolate along u (periodic)
        have = count[r] > 0
        if have.any() and not have.all():
            idx = np.arange(_U_BINS)
            mean[r, ~have] = np.interp(idx[~have], idx[have], mean[r, have], period=_U_BINS)
        elif not have.any():
            mean[r] = 0.0
    v_rows = np.interp(z_rows, z_to_v[0], z_to_v[1])
    ds, kappa, chord, _ = _profile_rows(nominal, v_rows, _U_BINS, flow)
    below_cut = (z_rows <= cut)[:, None]
    damaged = (mean > tol) & below_cut
    grown = ndimage.binary_dilation(damaged, structure=np.ones((3, 3), bool)) & below_cut
    labels, n = ndimage.label(grown)
    labels = _merge_periodic(labels, n)
    cell_area = ds * dz[:, None]
    cell_volume = (mean - 0.5 * kappa * mean ** 2) * cell_area
    regions, region_labels = [], []
    for lab in np.unique(labels[labels > 0]):
        cells = labels == lab
        if not (damaged & cells).any():
            continue
        region_labels.append(int(lab))
        rows_in = np.nonzero(cells.any(axis=1))[0]
        x = chord[cells]
        kind = "flank"
        near_le, near_te = int(np.sum(x < 0.1)), int(np.sum(x > 0.9))
        if near_le or near_te:
            kind = "leading_edge" if near_le >= near_te else "trailing_edge"
        regions.append({"kind": kind, "area_mm2": float(cell_area[cells].sum()),
                        "max_depth_mm": float(mean[cells].max()),
                        "volume_mm3": float(cell_volume[cells].sum()),
                        "span_range_mm": [float(z_rows[rows_in[0]] - dz[rows_in[0]] / 2),
                                          float(z_rows[rows_in[-1]] + dz[rows_in[-1]] / 2)],
                        "chord_range": [float(x.min()), float(x.max())]})
    total_area = float(cell_area.sum())
    tip_span = z_hi - cut
    if tip_span > max(tol, 0.01):
        zt = np.linspace(cut, z_hi, 9)
        vt = np.interp(zt, z_to_v[0], z_to_v[1])
        areas = [_section_area(nominal, v) for v in vt]
        perim = float(ds.sum(axis=1).mean())
        regions.append({"kind": "tip", "area_mm2": perim * tip_span, "max_depth_mm": float(tip_span),
                        "volume_mm3": float(trapezoid(areas, zt)),
                        "span_range_mm": [float(cut), float(z_hi)], "chord_range": [0.0, 1.0]})
        total_area += perim * tip_span
    damaged_area = float(sum(r["area_mm2"] for r in regions))
    return {"regions": regions, "depth": mean, "ds": ds, "point_depth": depth, "damaged": damaged, "labels": labels, "z_rows": z_rows,
            "chord": chord, "u_edges": np.linspace(u0, u1, _U_BINS + 1), "cut_mm": cut, "tip": tip_basis,
            "region_labels": region_labels, "z_to_v": z_to_v,
            "total_area": total_area, "damaged_area": damaged_area, "v_rows": v_rows}


def _tip_cut(z_top: float, cut_height: float | None, z_hi: float, mode: str, z_rows) -> tuple[float, dict]:
    """Height (mm) from which the tip is rebuilt, and how it was decided (the JSON's ``tip``).

    Without ``cut_height`` the tip starts at the highest measured height: on a cloud the
    broken tip itself, on sections the highest section, which may lie below the real break
    (the material between is not measured and is counted as missing: an upper bound, said in
    ``warning``). A ``cut_height`` below that cuts the blade there; above it (at most one
    section spacing, or 1 mm on a cloud) it says where the blade's material really ends (the
    break or the cut made before the repair): the band between the highest measurement and
    the cut is taken as intact and reported as ``unmeasured_mm``."""
    what = "highest section" if mode == "sections" else "highest measured point"
    basis = {"from": what, "z_mm": float(z_top), "measured_top_mm": float(z_top), "unmeasured_mm": None}
    if cut_height is None:
        if mode == "sections" and z_hi - z_top > 0.01:
            basis["warning"] = (f"the tip is counted from the {what} (z = {z_top:.3f} mm): material between it and "
                                f"the real break is not measured and counts as missing (an upper bound); give "
                                f"--cut-height at the break or at the repair cut")
        return float(z_top), basis
    cut = float(cut_height)
    basis["from"] = "cut_height"
    if cut <= z_top:
        basis["z_mm"] = cut
        return cut, basis
    gap = (1.5 * float(np.max(np.diff(z_rows)))) if z_rows is not None and len(z_rows) > 1 else 1.0
    if cut - z_top > gap:
        raise BladeReconError(
            f"--cut-height {cut:g} mm lies {cut - z_top:.3g} mm above the {what} (z = {z_top:.4g} mm), more "
            f"than the {gap:.3g} mm that may be taken as intact without a measurement: measure the blade up to "
            f"the cut, or give a lower --cut-height")
    cut = min(cut, float(z_hi))
    basis.update(z_mm=cut, unmeasured_mm=[float(z_top), cut])
    return cut, basis


def _merge_periodic(labels: np.ndarray, n: int) -> np.ndarray:
    """Regions that touch across u = u0 / u1 are one region (u is periodic)."""
    first, last = labels[:, 0], labels[:, -1]
    for a, b in zip(first, last):
        if a and b and a != b:
            labels[labels == b] = a
            first = labels[:, 0]
    return labels


def _naive_gap(grid: dict, nominal: BSplineSurface, fld: SpanField) -> dict:
    """How far the naive target (nominal, best-fitted) lies from the adapted nominal over the
    damaged cells and the tip: max and RMS (mm) at the cell centres."""
    damaged = grid["damaged"]
    u_mid = 0.5 * (grid["u_edges"][1:] + grid["u_edges"][:-1])
    rr, cc = np.nonzero(damaged)
    u = list(u_mid[cc])
    v = list(grid["v_rows"][rr])
    if any(r["kind"] == "tip" for r in grid["regions"]):
        vt = nominal.v_domain[1]
        u += list(u_mid)
        v += [vt] * len(u_mid)
    if not u:
        return {"max": 0.0, "rms": 0.0}
    p = evaluate_surface(nominal, np.array(u), np.array(v))
    gap = np.linalg.norm(fld.apply(p) - p, axis=1)
    return {"max": float(gap.max()), "rms": float(np.sqrt(np.mean(gap ** 2)))}
