# SPDX-License-Identifier: LGPL-2.1-or-later
"""The report of ``repair --report DIR``: missing.step, missing_map.png, regions.csv, report.html.

``missing_map.png``: the depth of missing material (mm) on the nominal's (chord position x
span height) grid, damaged cells outlined, the tip region shaded. ``regions.csv``: one row
per region (kind, area mm², max depth mm, volume mm³, span range mm, chord range).
``missing.step``: the material to add, one solid per region (the tip; each shallow region
between the target and its damaged floor, :func:`bladerecon.fc.repair.region_missing_shapes`).
The folder given is the command's temporary
folder (all or nothing, :class:`bladerecon.core.io.outputs.Outputs`).
"""
from __future__ import annotations

import html
import json
import os

import numpy as np

__all__ = ["write_repair_report"]


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _missing_map(path: str, res) -> None:
    plt = _plt()
    g = res.depth_map
    depth = np.where(g["depth"] > 0, g["depth"], 0.0)
    u = 0.5 * (g["u_edges"][1:] + g["u_edges"][:-1])
    fig, ax = plt.subplots(figsize=(9, 5), dpi=110)
    mesh = ax.pcolormesh(u, g["z_rows"], depth * 1000.0, shading="nearest", cmap="magma_r")
    fig.colorbar(mesh, ax=ax, label="missing depth (µm)")
    if g["damaged"].any():
        ax.contour(u, g["z_rows"], g["damaged"].astype(float), levels=[0.5], colors="tab:cyan", linewidths=0.8)
    top = max(r["span_range_mm"][1] for r in res.regions) if res.regions else g["z_rows"][-1]
    ax.axhspan(g["cut_mm"], max(top, g["cut_mm"]), color="tab:red", alpha=0.25, label="tip to rebuild")
    ax.set_xlabel("u (around the section, nominal parameter)")
    ax.set_ylabel("span height z (mm, nominal frame)")
    ax.set_title("Missing material (outline: damaged, tolerance exceeded)")
    ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _regions_csv(path: str, regions: list) -> None:
    rows = ["kind,area_mm2,max_depth_mm,volume_mm3,z_from_mm,z_to_mm,chord_from,chord_to"]
    for r in regions:
        rows.append(f"{r['kind']},{r['area_mm2']:.4f},{r['max_depth_mm']:.5f},{r['volume_mm3']:.4f},"
                    f"{r['span_range_mm'][0]:.3f},{r['span_range_mm'][1]:.3f},"
                    f"{r['chord_range'][0]:.4f},{r['chord_range'][1]:.4f}")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(rows) + "\n")


def write_repair_report(folder: str, summary: dict, res) -> None:
    """Write the report files into ``folder`` (mm, mm², mm³, degrees)."""
    from bladerecon.fc.export import write_step
    from bladerecon.fc.repair import missing_shape

    _missing_map(os.path.join(folder, "missing_map.png"), res)
    _regions_csv(os.path.join(folder, "regions.csv"), res.regions)
    files = ["missing_map.png", "regions.csv"]
    missing = missing_shape(res)
    if missing is not None:
        write_step(missing, os.path.join(folder, "missing.step"))
        files.append("missing.step")
    with open(os.path.join(folder, "summary.json"), "w", encoding="utf-8") as f:
        json.dump(summary, f, indent=2)
    d = summary["deformation"]
    rows = "".join(f"<tr><td>{html.escape(r['kind'])}</td><td>{r['area_mm2']:.2f}</td><td>{r['max_depth_mm']:.3f}</td>"
                   f"<td>{r['volume_mm3']:.3f}</td><td>{r['span_range_mm'][0]:.2f} – {r['span_range_mm'][1]:.2f}</td>"
                   f"<td>{r['chord_range'][0]:.2f} – {r['chord_range'][1]:.2f}</td></tr>" for r in res.regions)
    page = f"""<!doctype html><html><head><meta charset="utf-8"><title>Repair target</title></head><body>
<h1>Repair target</h1>
<p>Measured: {html.escape(str(summary.get('measured')))} ({html.escape(res.mode)}); nominal:
{html.escape(str(summary.get('nominal')))}.</p>
<p>Service deformation: twist at the tip {d['twist_deg_at_tip']:.4f}°, largest bend {d['max_bend_mm']:.4f} mm
(relative to the hub). Target vs undamaged points: max {summary['target_vs_measured']['max'] * 1000:.1f} µm,
RMS {summary['target_vs_measured']['rms'] * 1000:.2f} µm. The naive target (nominal, best-fitted) is up to
{summary['naive_vs_target']['max'] * 1000:.0f} µm from this target over the damaged regions.</p>
<h2>Missing material: {summary['volume_mm3']:.3f} mm³</h2>
<table border="1" cellpadding="3"><tr><th>kind</th><th>area (mm²)</th><th>max depth (mm)</th><th>volume (mm³)</th>
<th>span (mm)</th><th>chord (0 LE – 1 TE)</th></tr>{rows}</table>
<p><img src="missing_map.png" alt="missing material map"></p>
<p>Files: {", ".join(files)}, summary.json.</p>
</body></html>
"""
    with open(os.path.join(folder, "report.html"), "w", encoding="utf-8") as f:
        f.write(page)
