# SPDX-License-Identifier: LGPL-2.1-or-later
"""The verdict part of the deviation report (issue 19 §4): a pass/fail table first, whisker
plots of every section's zones against their tolerance bands, parameter bars against limits.

Everything is drawn from the ``deviation --plan`` summary (its ``verdict``, ``sections`` and
``fit``), so the report shows exactly what the JSON says. Deviations in µm, limits as given.
"""
from __future__ import annotations

import html
import os

import numpy as np

__all__ = ["verdicts_html", "verdict_plots"]

_ZONE_LABELS = {"leading_edge": "LE", "trailing_edge": "TE", "flanks": "flanks"}
_PASS, _FAIL = "#c8f0c8", "#f6c0c0"


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _cell(ok, text: str) -> str:
    colour = _PASS if ok else _FAIL
    return f'<td style="background:{colour}">{html.escape(text)}</td>'


def _zone_cell(z: dict | None) -> str:
    if not z:
        return "<td>–</td>"
    return _cell(z["pass"], f"{'pass' if z['pass'] else 'FAIL'} {z['min'] * 1000:+.1f} / {z['max'] * 1000:+.1f} "
                            f"(±{z['tol'] * 1000:g})")


def verdicts_html(summary: dict) -> str:
    """The verdict table: blade verdict, then one row per section: profile (or form) zones in
    µm (min / max, ±tol), each parameter's difference against its limits."""
    if "verdict" not in summary:
        return ""
    sections = summary["sections"]
    params = sorted({k for s in sections for k in s["parameters"]},
                    key=lambda k: ("chord", "max_thickness", "le_radius", "te_radius", "stagger_deg",
                                   "position").index(k) if k in ("chord", "max_thickness", "le_radius", "te_radius",
                                                                  "stagger_deg", "position") else 99)
    zones = [z for z in _ZONE_LABELS if any(z in s["profile"] for s in sections)]
    use_form = any(s.get("form") for s in sections)
    head = "".join(f"<th>{'form' if use_form else 'profile'} {_ZONE_LABELS[z]} (µm)</th>" for z in zones)
    head += "".join(f"<th>{html.escape(p)}</th>" for p in params)
    rows = []
    for s in sections:
        zt = s["form"] if use_form and s.get("form") else s["profile"]
        cells = "".join(_zone_cell(zt.get(z)) for z in zones)
        for p in params:
            v = s["parameters"].get(p)
            if v is None:
                cells += "<td>–</td>"
            elif v["difference"] is None:
                cells += _cell(False, f"FAIL: {v.get('note', 'not measured')}")
            else:
                lo, hi = v["limits"]
                cells += _cell(v["pass"], f"{'pass' if v['pass'] else 'FAIL'} {v['difference']:+.4f} [{lo:g}, {hi:g}]")
        rows.append(f"<tr><th>{html.escape(s['label'])}</th>{_cell(s['verdict'] == 'pass', s['verdict'])}{cells}</tr>")
    fit = summary.get("fit", {})
    fit_text = f"fit: {html.escape(str(fit.get('mode')))}, per section: {html.escape(str(fit.get('per_section')))}"
    if fit.get("max_normalised") is not None:
        fit_text += f"; largest |deviation| / zone half-width after the fit: {fit['max_normalised']:.3f}"
    ls = fit.get("least_squares", {}).get("max_normalised")
    if fit.get("mode") == "zone" and ls is not None:
        fit_text += f" (least squares: {ls:.3f})"
    ok = summary["verdict"] == "pass"
    colour = _PASS if ok else _FAIL
    return (f'<h2>Verdict: <span style="background:{colour};padding:0 0.4em">{"PASS" if ok else "FAIL"}</span></h2>'
            f"<p>Inspection plan <code>{html.escape(str(summary.get('inspection_plan', {}).get('source', '')))}</code>; "
            f"{fit_text}. Zones: min / max deviation (µm) against ±half-width; parameters: measured − nominal "
            f"(mm, stagger in °; position: centroid offset, mm) against [lower, upper].</p>"
            f"<table><tr><th>section</th><th>verdict</th>{head}</tr>" + "\n".join(rows) + "</table>")


def verdict_plots(folder: str, summary: dict) -> list[tuple[str, str]]:
    """verdict_zones.png (whiskers per section and zone, tolerance bands) and
    verdict_parameters.png (differences against limits); returns (file, caption) pairs."""
    if "verdict" not in summary:
        return []
    plt = _plt()
    out = []
    sections = summary["sections"]
    zones = [z for z in _ZONE_LABELS if any(z in s["profile"] for s in sections)]
    if zones:
        fig, ax = plt.subplots(figsize=(max(6.0, 1.2 * len(sections) + 2), 4.2))
        width = 0.8 / len(zones)
        for j, z in enumerate(zones):
            for i, s in enumerate(sections):
                zt = s.get("form") or s["profile"]
                v = zt.get(z)
                if not v:
                    continue
                x = i - 0.4 + width * (j + 0.5)
                ax.add_patch(plt.Rectangle((x - width / 2, -v["tol"] * 1000), width, 2 * v["tol"] * 1000,
                                           color="#dde8ff", zorder=0))
                colour = "green" if v["pass"] else "red"
                ax.plot([x, x], [v["min"] * 1000, v["max"] * 1000], color=colour, lw=2)
                ax.plot([x - width / 3, x + width / 3], [v["min"] * 1000] * 2, color=colour)
                ax.plot([x - width / 3, x + width / 3], [v["max"] * 1000] * 2, color=colour)
                if i == 0:
                    ax.annotate(_ZONE_LABELS[z], (x, v["tol"] * 1000), ha="center", va="bottom", fontsize=7)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_xticks(range(len(sections)), [s["label"] for s in sections])
        ax.set_xlim(-0.6, len(sections) - 0.4)
        ax.set_xlabel("section (zones LE, TE, flanks left to right)")
        ax.set_ylabel("deviation (µm)")
        fig.tight_layout()
        fig.savefig(os.path.join(folder, "verdict_zones.png"), dpi=110)
        plt.close(fig)
        what = "form (after the per-section fit)" if any(s.get("form") for s in sections) else "profile"
        out.append(("verdict_zones.png", f"Min–max {what} deviation per section and zone (green pass, red fail) "
                                         "against the ± tolerance band (blue)"))
    params = [p for p in ("chord", "max_thickness", "le_radius", "te_radius", "stagger_deg", "position")
              if any(p in s["parameters"] for s in sections)]
    if params:
        fig, axes = plt.subplots(1, len(params), figsize=(2.6 * len(params) + 1, 3.4), squeeze=False)
        for ax, p in zip(axes[0], params):
            diffs, colours, lims = [], [], None
            for s in sections:
                v = s["parameters"].get(p)
                diffs.append(np.nan if v is None or v["difference"] is None else v["difference"])
                colours.append("green" if v is not None and v["pass"] else "red")
                lims = v["limits"] if v is not None else lims
            ax.bar(range(len(sections)), np.nan_to_num(diffs), color=colours)
            if lims is not None:
                for lim in lims:
                    ax.axhline(lim, color="k", ls="--", lw=0.8)
            ax.axhline(0, color="k", lw=0.5)
            ax.set_title(p + (" (°)" if p.endswith("_deg") else " (mm)"), fontsize=9)
            ax.set_xticks(range(len(sections)), [s["label"] for s in sections], fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(folder, "verdict_parameters.png"), dpi=110)
        plt.close(fig)
        out.append(("verdict_parameters.png", "Section parameters: measured − nominal per section (green pass, "
                                              "red fail) against the plan's limits (dashed)"))
    return out
