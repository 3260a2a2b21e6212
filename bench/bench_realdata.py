# SPDX-License-Identifier: LGPL-2.1-or-later
"""Real measurement data (issue 6): non-grid rows (seed 003), bad points (seed 001), unordered clouds.

Run from the repository root: ``/usr/bin/python3 bench/bench_realdata.py``. Prints three
Markdown tables and writes ``bench/results/realdata.md`` and ``.json``. Units: mm, seconds.

1. Seed 003's experiment rebuilt on the analytic SampleBlade: 21 rows of 97-118 points
   (2255), cubic 24 x 9 poles — time and the mean/max distance of the measured points to
   the surface (seed 003's "fitting error"), beside seed 003's 8 s / 1.27e-6 / 2.29e-6 and
   beside our interpolation path; also the distance of exact points *between* the rows.
   Two layouts: one blade side (open rows, as in-situ machines measure a section in parts)
   and whole closed profiles.
2. Bad points: sections with runs of 1-5 points displaced by 10-30 µm along the normal and
   one by 0.2 mm: runs found, clean points flagged, inflections, surface error to the truth.
3. The unordered NASA Rotor 67 cloud (ParaBlade, CFD surface nodes) sliced by cylinders and
   reconstructed; distance of the NASA Rotor 67 section table's points to our surface after
   the two frames are matched (axial shift + rotation about the axis, fitted).
"""
from __future__ import annotations

import datetime as dt
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
DATA = ROOT / "tests" / "data"
RESULTS = BENCH / "results"

from bladerecon.core.sections.fairing import fair_section  # noqa: E402
from bladerecon.core.analysis.fairness import count_inflections  # noqa: E402
from bladerecon.core.geometry.fitting import interpolate_closed_curve  # noqa: E402
from bladerecon.core.surface.nongrid import fit_nongrid  # noqa: E402
from bladerecon.core.geometry.projection import project_points_to_surface  # noqa: E402
from bladerecon.core.reconstruct import reconstruct  # noqa: E402
from bladerecon.samples.blade import t_at_length_fraction  # noqa: E402
from bladerecon.core.sections.ordering import build_sections  # noqa: E402
from bladerecon.core.sections.slicing import read_cloud, slice_cylinders, slices_to_pointset  # noqa: E402
from realdata_fixtures import BLADE, RUNS, clean_section, nongrid_counts, nongrid_rows, with_bad_runs  # noqa: E402

Z = np.array([0.0, 0.0, 1.0])
SEED003 = {"time_s": 8.0, "mean": 1.27e-6, "max": 2.29e-6}


def timed(fn, repeats=3):
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return out, best


def between_rows(heights, closed, n=200):
    """Exact points at the heights half-way between the rows (flank only for open rows)."""
    pts = []
    for h in (heights[:-1] + heights[1:]) / 2:
        if closed:
            pts.append(BLADE.point(h, t_at_length_fraction(BLADE, h, np.arange(n) / n)))
        else:
            b = BLADE.segment_bounds(h)
            m = 0.02 * (b[4] - b[3])
            pts.append(BLADE.point(h, np.linspace(b[3] + m, b[4] - m, n)))
    return np.concatenate(pts)


def seed003_table() -> list[dict]:
    counts = nongrid_counts()
    rows_out = []
    for closed in (False, True):
        rows, heights = nongrid_rows(counts, closed=closed)
        measured = np.concatenate(rows)
        mid = between_rows(heights, closed)
        layout = "whole closed profiles" if closed else "one side (suction flank), open rows"
        methods = [("seed 003 non-grid, 24x9", lambda: fit_nongrid(rows, Z, (24, 9), closed=closed).surface)]
        if closed:
            methods.append(("seed 003 non-grid, 96x12", lambda: fit_nongrid(rows, Z, (96, 12), closed=True).surface))
            methods.append(("ours: interpolation path (reconstruct, interpolate)",
                            lambda: reconstruct(rows, Z, method="interpolate").surface))
        for name, fn in methods:
            surf, sec = timed(fn)
            d = project_points_to_surface(surf, measured).distance
            dm = project_points_to_surface(surf, mid).distance
            rows_out.append({"layout": layout, "method": name, "poles": list(surf.shape), "time_s": sec,
                             "mean": float(d.mean()), "max": float(d.max()),
                             "between_mean": float(dm.mean()), "between_max": float(dm.max())})
            print(f"  {layout} / {name}: {sec:.3f} s, mean {d.mean():.3g} max {d.max():.3g}", file=sys.stderr)
    return rows_out


def occ_check(surface, points) -> float | None:
    """Largest |ours - OpenCASCADE| point-to-surface distance on a sample (None without FreeCAD)."""
    try:
        from bladerecon.fc.convert import make_face
        from bladerecon.fc.freecad_env import import_freecad
        from bladerecon.fc.occ_measure import occ_distances
        import_freecad()
    except Exception:  # noqa: BLE001 - the referee is optional
        return None
    d_occ = occ_distances(points, make_face(surface))
    d_ours = project_points_to_surface(surface, points).distance
    return float(np.abs(d_occ - d_ours).max())


def badpoint_table() -> list[dict]:
    out = []
    for h, n, noise in ((0.2, 300, 0.0), (0.5, 360, 0.0), (0.8, 500, 0.0), (0.5, 360, 0.0005), (0.8, 500, 0.0007)):
        clean, nrm, _ = clean_section(h, n, noise=noise, seed=11)
        bad, inj = with_bad_runs(clean, nrm)
        f, sec = timed(lambda: fair_section(bad), repeats=3)
        expected = sorted((int(fr * n), k) for fr, k, _ in RUNS)
        found = sum(1 for r in expected if r in f.runs)
        curve_kind = "interp." if noise == 0 else "fair LS"
        if noise == 0:
            inf = [count_inflections(interpolate_closed_curve(p), Z) for p in (clean, bad, f.faired)]
        else:
            from bladerecon.core.sections.fairing import fair_fit
            inf = [count_inflections(fair_fit(p)[0], Z) for p in (clean, bad, f.faired)]
        out.append({"h": h, "points": n, "noise_mm": noise, "runs_injected": len(expected), "runs_found": found,
                    "points_injected": int(inj.sum()), "points_flagged": int(f.bad.sum()),
                    "clean_flagged": int((f.bad & ~inj).sum()), "missed": int((inj & ~f.bad).sum()),
                    "inflections_clean_bad_faired": inf, "inflections_on": curve_kind, "time_s": sec})
    return out


def badpoint_surface() -> dict:
    heights = np.linspace(0.0, 1.0, 6)
    clean, bad = [], []
    for k, h in enumerate(heights):
        c, nrm, _ = clean_section(h, 300, start=0.011 + 0.01 * k)
        clean.append(c)
        bad.append(with_bad_runs(c, nrm)[0] if k in (1, 3, 4) else c)
    truth = np.concatenate(clean)
    res = {}
    for name, secs in (("clean", clean), ("bad, not faired", bad), ("bad, faired", [fair_section(p).faired for p in bad])):
        surf = reconstruct(secs, Z, method="interpolate").surface
        d = project_points_to_surface(surf, truth).distance
        res[name] = {"mean": float(d.mean()), "max": float(d.max())}
    return res


def _r67_frames(surf, a, R, th, P):
    """Match the NASA table's frame to the cloud's: rotation about z and axial shift (least
    squares of the point-to-surface distances; Newton restarts from the previous feet)."""
    from scipy.optimize import least_squares

    phi_c = np.arctan2(P[:, 1], P[:, 0])
    state = {}

    def dist(p, s):
        phi = s * th + p[0]
        Q = np.c_[R * np.cos(phi), R * np.sin(phi), a + p[1]]
        if s in state:
            pr = project_points_to_surface(surf, Q, state[s][0], state[s][1])
        else:
            pr = project_points_to_surface(surf, Q)
        state[s] = (pr.u, pr.v)
        return pr.distance

    # starts: the frames as they are, and one lined up by mean angle and median axial
    # position; both turning senses. The closest start is refined.
    starts = []
    for s in (1.0, -1.0):
        for p0 in (np.zeros(2), np.array([np.angle(np.exp(1j * phi_c).mean()) - s * np.angle(np.exp(1j * th).mean()),
                                          float(np.median(P[:, 2]) - np.median(a))])):
            state.pop(s, None)
            starts.append((float(np.mean(dist(p0, s))), s, p0))
    _, s, p0 = min(starts, key=lambda c: c[0])
    state.pop(s, None)
    dist(p0, s)
    fit = least_squares(lambda p: dist(p, s), p0, diff_step=1e-6, x_scale=[0.001, 0.1], max_nfev=25)
    state.pop(s, None)
    d = dist(fit.x, s)          # a global search at the end: the feet are the true closest
    best = (float(d.mean()), s, fit.x, d)
    return best[1], best[2], best[3]


def r67_table() -> dict | None:
    cloud_file = DATA / "parablade_r67_cloud" / "NASA_R67_MoveSurface.txt"
    table_file = DATA / "nasa_rotor67" / "rotor67_sections_xyz_mm.txt"
    if not cloud_file.exists() or not table_file.exists():
        print("  (Rotor 67 data not found beside the repository: skipped)", file=sys.stderr)
        return None
    from bladerecon.core.io.readers import read_points

    P, lines = read_cloud(str(cloud_file), 1000.0)
    # the cloud's mesh rows 4..11 sit in radius bands (145.2-156.4, 161.2-169.1, ... 247.9-255.2):
    # one cylinder at the middle of each band with a 12 mm slab catches one whole row. Rows
    # 1-3 cross each other's radii near the hub (95.9-143.7 mm) and are left out.
    radii = np.array([150.8, 165.2, 179.6, 194.1, 208.6, 222.7, 237.0, 251.6])
    table = read_points(str(table_file))
    T = table.points
    a, R, th = T[:, 0], np.hypot(T[:, 1], T[:, 2]), np.arctan2(T[:, 1], T[:, 2])
    keep = (R > radii.min() + 2.0) & (R < radii.max() - 2.0)
    a, R, th, sec = a[keep], R[keep], th[keep], table.section[keep]
    out = {"cloud_points": int(P.shape[0]), "slice_radii_mm": radii.tolist(), "slab_mm": 12.0,
           "table_points_compared": int(keep.sum()), "variants": []}
    for project in (False, True):
        t0 = time.perf_counter()
        slices = slice_cylinders(P, radii, Z, slab=12.0, project=project)
        secs = build_sections(slices_to_pointset(slices, lines, str(cloud_file)))
        rec = reconstruct([s.points for s in secs.sections], secs.span_axis)
        t_rec = time.perf_counter() - t0
        s, x, d = _r67_frames(rec.surface, a, R, th, P)
        per = [{"table_section": int(k) + 1, "r_mm": float(R[sec == k].mean()), "n": int((sec == k).sum()),
                "mean": float(d[sec == k].mean()), "max": float(d[sec == k].max())} for k in np.unique(sec)]
        out["variants"].append({
            "slab_points": "moved onto the cylinder" if project else "kept where they are (--slab-keep)",
            "slice_points": [int(len(sl.points)) for sl in slices],
            "outliers": int(sum(len(sl.outliers) for sl in slices)), "reconstruct_s": t_rec,
            "surface_poles": list(rec.surface.shape), "method": rec.choice.method,
            "frame": {"theta_sign": s, "rotation_deg": float(np.degrees(x[0])), "axial_shift_mm": float(x[1])},
            "distance_mean": float(d.mean()), "distance_rms": float(np.sqrt(np.mean(d ** 2))),
            "distance_p95": float(np.percentile(d, 95)), "distance_max": float(d.max()), "by_section": per})
        print(f"  R67 project={project}: mean {d.mean():.4f} max {d.max():.4f}", file=sys.stderr)
    return out


def main() -> int:
    started = dt.datetime.now(dt.timezone.utc)
    env = (f"{started:%Y-%m-%d %H:%M} UTC, {os.cpu_count()} CPUs, {platform.processor() or platform.machine()}, "
           f"Python {platform.python_version()}, numpy {np.__version__}")
    print("seed 003 ...", file=sys.stderr)
    s3 = seed003_table()
    print("bad points ...", file=sys.stderr)
    bp = badpoint_table()
    bps = badpoint_surface()
    print("Rotor 67 cloud ...", file=sys.stderr)
    r67 = r67_table()
    occ = None
    try:
        counts = nongrid_counts()
        rows, _ = nongrid_rows(counts, closed=False)
        surf = fit_nongrid(rows, Z, (24, 9), closed=False).surface
        occ = occ_check(surf, np.concatenate(rows)[::10])
    except Exception as exc:  # noqa: BLE001
        print(f"  OCC check skipped: {exc}", file=sys.stderr)

    md = [f"# Real measurement data (issue 6) — {env}", ""]
    md += ["## 1. Seed 003's experiment: 21 rows, 97–118 points (2255), cubic surface", "",
           "Fitting error = distance of the 2255 measured points to the surface (mm); 'between' = "
           "exact points half-way between the rows (200 per gap). Time = best of 3 (s).", "",
           "| layout | method | poles | time s | mean | max | between mean | between max |",
           "|---|---|---|---|---|---|---|---|",
           f"| seed 003 (their blade, VC++) | seed 003 | 24x9 | {SEED003['time_s']} | {SEED003['mean']:.3g} | "
           f"{SEED003['max']:.3g} | – | – |"]
    for r in s3:
        md.append(f"| {r['layout']} | {r['method']} | {r['poles'][0]}x{r['poles'][1]} | {r['time_s']:.3f} | "
                  f"{r['mean']:.3g} | {r['max']:.3g} | {r['between_mean']:.3g} | {r['between_max']:.3g} |")
    md += ["", "Seed 003 gives no units. On one smooth side of a blade (their in-situ machine measures a "
           "section in parts) a cubic 24x9 surface comes within micrometres; our one-side figures read "
           "in mm are of the order of theirs read in mm. Whole closed profiles cannot be held by 24 poles "
           "around (0.7-0.9 mm edge radii): there the error is set by the pole count, not the method. "
           "Our interpolation path (periodic sections, LE/TE anchored) needs closed sections, so it "
           "appears for the closed layout only.",
           f"OpenCASCADE cross-check of the one-side 24x9 distances (226 points): largest |ours - OCC| = "
           f"{occ:.2e} mm" if occ is not None else "OpenCASCADE cross-check: not run (FreeCAD not available)", ""]
    md += ["## 2. Bad points: runs of 1, 2, 3, 4, 5, 3 points displaced 10–30 µm and 1 point 0.2 mm", "",
           "| h | points | noise σ mm | runs found | points flagged / injected | clean flagged | missed | "
           "inflections clean / bad / faired | time s |", "|---|---|---|---|---|---|---|---|---|"]
    for r in bp:
        i = r["inflections_clean_bad_faired"]
        md.append(f"| {r['h']} | {r['points']} | {r['noise_mm']} | {r['runs_found']}/{r['runs_injected']} | "
                  f"{r['points_flagged']}/{r['points_injected']} | {r['clean_flagged']} | {r['missed']} | "
                  f"{i[0]} / {i[1]} / {i[2]} ({r['inflections_on']}) | {r['time_s']:.3f} |")
    md += ["", "Surface from 6 sections of 300 points, 3 of them with the bad runs (interpolation path); "
           "distance of the clean true section points to the surface (mm):", "",
           "| sections | mean | max |", "|---|---|---|"]
    for k, v in bps.items():
        md.append(f"| {k} | {v['mean']:.3g} | {v['max']:.3g} |")
    md.append("")
    if r67 is not None:
        md += ["## 3. NASA Rotor 67: unordered ParaBlade cloud sliced by cylinders", "",
               f"{r67['cloud_points']} points (file in m, ×1000), cylinders r = {r67['slice_radii_mm']} mm, "
               f"slab {r67['slab_mm']} mm. Scored: the {r67['table_points_compared']} points of the NASA section "
               "table (1-based sections 5-14; 14 is NASA's casing stream surface) between the first and last cylinder, distance to our surface after the "
               "table's frame is matched to the cloud's (rotation about z + axial shift, least squares).", "",
               "| slab points | per slice | outliers | surface | fit s | rotation ° | axial shift mm | "
               "mean mm | RMS mm | 95 % mm | max mm |", "|---|---|---|---|---|---|---|---|---|---|---|"]
        for v in r67["variants"]:
            md.append(f"| {v['slab_points']} | {min(v['slice_points'])}–{max(v['slice_points'])} | "
                      f"{v['outliers']} | {v['method']} {v['surface_poles'][0]}x{v['surface_poles'][1]} | "
                      f"{v['reconstruct_s']:.2f} | {v['frame']['rotation_deg']:.4f} | "
                      f"{v['frame']['axial_shift_mm']:.4f} | {v['distance_mean']:.4f} | {v['distance_rms']:.4f} | "
                      f"{v['distance_p95']:.4f} | {v['distance_max']:.4f} |")
        md += ["", "Per NASA section (points kept where they are):", "",
               "| table section | mean r mm | points | mean mm | max mm |", "|---|---|---|---|---|"]
        for b in r67["variants"][0]["by_section"]:
            md.append(f"| {b['table_section']} | {b['r_mm']:.1f} | {b['n']} | {b['mean']:.4f} | {b['max']:.4f} |")
        md.append("")
    text = "\n".join(md)
    print(text)
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "realdata.md").write_text(text + "\n")
    (RESULTS / "realdata.json").write_text(json.dumps(
        {"environment": env, "seed003": s3, "seed003_paper": SEED003, "occ_check_max_abs_diff": occ,
         "bad_points": bp, "bad_points_surface": bps, "rotor67": r67}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
