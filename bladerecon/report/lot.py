# SPDX-License-Identifier: LGPL-2.1-or-later
"""The lot summary page: ``lot.html`` with the statistics table (mean, std, min/max, Cp/Cpk,
worst blades), the failed blades and ``trend.png`` (deviation and position per blade in
date/serial order). Written into a folder the caller stages (``bladerecon batch``)."""
from __future__ import annotations

import html
import os

__all__ = ["write_lot_report", "TREND_FEATURES"]

# Plotted against the blade order when the lot has them (deviation in µm, angles in °).
TREND_FEATURES = (("deviation.max_abs", "max |deviation| (µm)", 1000.0),
                  ("deviation.rms", "rms deviation (µm)", 1000.0),
                  ("deviation.mean", "mean deviation (µm)", 1000.0),
                  ("position.pitch_deg", "pitch error (°)", 1.0),
                  ("position.stagger_deg", "stagger error (°)", 1.0),
                  ("position.radial_mm", "radial error (µm)", 1000.0))


def write_lot_report(folder: str, lot: dict) -> None:
    """``trend.png`` and ``lot.html`` into ``folder``."""
    have = _trend(os.path.join(folder, "trend.png"), lot)
    with open(os.path.join(folder, "lot.html"), "w", encoding="utf-8") as fh:
        fh.write(_html(lot, have))


def _trend(path: str, lot: dict) -> bool:
    from bladerecon.core.lot.stats import feature_values

    records = {r["blade"]: r for r in lot["blades"]}
    order = lot["order"]
    values = {b: feature_values(records[b]) for b in order}
    rows = [(f, label, scale) for f, label, scale in TREND_FEATURES if any(f in v for v in values.values())]
    if not rows:
        return False
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(rows), 1, figsize=(9, 2.2 * len(rows) + 0.6), sharex=True, squeeze=False)
    x = list(range(len(order)))
    for ax, (feature, label, scale) in zip(axes[:, 0], rows):
        y = [values[b][feature] * scale if feature in values[b] else float("nan") for b in order]
        ax.plot(x, y, "o-", ms=3, lw=1)
        ax.set_ylabel(label, fontsize=8)
        ax.grid(alpha=0.3)
        limits = lot["lot"]["limits"].get(feature)
        for lim in limits or ():
            if lim is not None:
                ax.axhline(lim * scale, color="r", lw=0.8, ls="--")
    ax = axes[-1, 0]
    step = max(1, len(order) // 30)
    ax.set_xticks(x[::step])
    ax.set_xticklabels(order[::step], rotation=90, fontsize=6)
    ax.set_xlabel("blade (date, serial order)")
    fig.tight_layout()
    fig.savefig(path, dpi=90, metadata={"Software": None})
    plt.close(fig)
    return True


def _fmt(v) -> str:
    if v is None:
        return "–"
    if isinstance(v, float):
        return f"{v:.4g}"
    return html.escape(str(v))


def _html(lot: dict, trend: bool) -> str:
    head = lot["lot"]
    rows = []
    for feature, s in lot["statistics"].items():
        worst = ", ".join(f"{html.escape(w['blade'])} ({w['value']:.4g})" for w in s["worst"])
        rows.append(f"<tr><th>{html.escape(feature)}</th><td>{s['n']}</td><td>{_fmt(s['mean'])}</td>"
                    f"<td>{_fmt(s['std'])}</td><td>{_fmt(s['min'])}</td><td>{_fmt(s['max'])}</td>"
                    f"<td>{_fmt(s.get('lsl'))}</td><td>{_fmt(s.get('usl'))}</td>"
                    f"<td>{_fmt(s.get('cp'))}</td><td>{_fmt(s.get('cpk'))}</td><td>{worst}</td></tr>")
    failed = [r for r in lot["blades"] if r["status"] != "ok"]
    fail_html = ("<h2>Failed blades</h2><ul>" + "".join(
        f"<li><b>{html.escape(r['blade'])}</b>: {html.escape(r['error'])}</li>" for r in failed) + "</ul>"
                 if failed else "")
    worst = "".join(f"<li>{html.escape(w['blade'])}: max |deviation| {w['max_abs'] * 1000:.1f} µm, "
                    f"rms {w['rms'] * 1000:.1f} µm</li>" for w in lot["worst_blades"])
    blisk = ""
    if "blisk" in lot:
        b = lot["blisk"]
        blisk = (f"<p>Blisk: {b['blades']} blades about the {html.escape(b['axis'])} axis, "
                 f"{b['pitch_deg']:.6g}° apart.</p>")
    img = '<figure><img src="trend.png" alt="trend"><figcaption>Per blade, in date/serial order; dashed: ' \
          'limits</figcaption></figure>' if trend else ""
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>BladeRecon lot summary</title>
<style>body{{font-family:sans-serif;margin:2em}}table{{border-collapse:collapse}}
td,th{{border:1px solid #ccc;padding:2px 6px;font-size:90%}}th{{text-align:left}}</style></head><body>
<h1>Lot summary</h1>
<p>{head['blades']} blades, {head['ok']} measured, {head['failed']} failed · profile tolerance
±{head['tolerance_mm']:g} mm · best fit: {html.escape(head['align'])} · deviations in mm, section
parameters as measured − nominal (mm, angles in °), Cp/Cpk against the limits shown.</p>
{blisk}
{img}
<h2>Worst blades</h2><ol>{worst}</ol>
{fail_html}
<h2>Statistics per feature</h2>
<table><tr><th>feature</th><th>n</th><th>mean</th><th>std</th><th>min</th><th>max</th><th>LSL</th><th>USL</th>
<th>Cp</th><th>Cpk</th><th>worst blades</th></tr>
{''.join(rows)}
</table>
</body></html>
"""
