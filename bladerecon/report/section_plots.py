# SPDX-License-Identifier: LGPL-2.1-or-later
"""PNG of a segmented section (matplotlib, Agg): regions coloured, camber line, edges as measured
(circle, ellipse or flat).

Coordinates are those of the section's plane (mm): e1 = +x projected, e2 = normal x e1.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.geometry.bspline import evaluate_curve
from bladerecon.core.sections.segmentation import LE, PRESSURE, REGION_NAMES, SUCTION, TE

__all__ = ["edge_outline", "plot_section"]

COLOURS = {LE: "tab:red", SUCTION: "tab:blue", TE: "tab:orange", PRESSURE: "tab:green"}


def _region_curve(seg, region, n=600):
    a, b = seg.region_interval(region)
    lo, hi = seg.curve.domain
    t = lo + np.mod(np.linspace(a, b, n) - lo, hi - lo)
    return evaluate_curve(seg.curve, t)


def edge_outline(frame, params, which: str, n: int = 200):
    """What the section's ``which`` ("le" or "te") edge was measured as, in the section plane
    (mm): the fitted ellipse (n points) or flat (its two ends) when the edge is one, else the
    edge circle; None without a radius. The parameters' 3D figures mapped by ``frame``."""
    fit = getattr(params, f"{which}_fit") or {}
    to2 = lambda p: frame.to_plane(np.asarray(p, float).reshape(1, 3))[0]            # noqa: E731
    if fit.get("shape") == "ellipse":
        e = fit["ellipse"]
        c = to2(e["centre"])
        major = to2(np.asarray(e["centre"]) + np.asarray(e["major_axis"])) - c
        major /= np.linalg.norm(major)
        minor = np.array([-major[1], major[0]])
        t = np.linspace(0, 2 * np.pi, n)
        return c + np.outer(e["a_mm"] * np.cos(t), major) + np.outer(e["b_mm"] * np.sin(t), minor)
    if fit.get("shape") == "flat":
        f = fit["flat"]
        m = to2(f["midpoint"])
        d = to2(np.asarray(f["midpoint"]) + np.asarray(f["direction"])) - m
        d /= np.linalg.norm(d)
        half = 0.5 * (f["length_mm"] if f["width_mm"] is None else f["width_mm"])
        return np.array([m - half * d, m + half * d])
    r = getattr(params, f"{which}_radius")
    if r is None:
        return None
    c = to2(getattr(params, f"{which}_center"))
    t = np.linspace(0, 2 * np.pi, n)
    return c + r * np.column_stack([np.cos(t), np.sin(t)])


def plot_section(path: str, seg, params, nominal_seg=None) -> None:
    """Write one PNG: full view and zooms on LE and TE."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(13, 7.5))
    ax = fig.add_subplot(2, 1, 1)
    zooms = [fig.add_subplot(2, 2, 3), fig.add_subplot(2, 2, 4)]
    fr = seg.frame
    camber = fr.to_plane(params.camber)
    # the chord's ends as measured (on an ellipse's tip or a flat's midpoint), not the segmentation's
    ends = fr.to_plane(np.vstack([params.le, params.te]))
    outlines = {which: edge_outline(fr, params, which) for which in ("le", "te")}
    nom = None if nominal_seg is None else fr.to_plane(nominal_seg.frame.to_space(
        evaluate_curve(nominal_seg.curve, np.linspace(*nominal_seg.curve.domain, 4000))))
    for a in [ax, *zooms]:
        if nom is not None:
            a.plot(nom[:, 0], nom[:, 1], "--", color="0.5", lw=0.8, label="nominal")
        for region in (LE, SUCTION, TE, PRESSURE):
            c = _region_curve(seg, region)
            a.plot(c[:, 0], c[:, 1], "-", color=COLOURS[region], lw=1.4, label=REGION_NAMES[region])
            m = seg.labels == region
            a.plot(seg.points2d[m, 0], seg.points2d[m, 1], ".", color=COLOURS[region], ms=3)
        a.plot(camber[:, 0], camber[:, 1], "-", color="purple", lw=0.8, label="camber")
        a.plot([ends[0][0], ends[1][0]], [ends[0][1], ends[1][1]], ":", color="k", lw=0.6, label="chord")
        joints = evaluate_curve(seg.curve, np.array(list(seg.t_joints.values())))
        a.plot(joints[:, 0], joints[:, 1], "kx", ms=7, label="joints")
        a.plot(*ends[0], "ro", ms=5)
        a.plot(*ends[1], "o", color="tab:orange", ms=5)
        for outline in outlines.values():
            if outline is not None:
                a.plot(outline[:, 0], outline[:, 1], "-", color="k", lw=0.5 if len(outline) > 2 else 1.5)
        if seg.throat is not None:
            a.plot(*seg.throat["point"], "m*", ms=10, label="throat")
        a.set_aspect("equal")
        a.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(f"section {seg.index}: chord {params.chord:.3f} mm, stagger {params.stagger_deg:.2f}°, "
                 f"t_max {params.max_thickness:.3f} mm at {params.max_thickness_pos:.2f} mm, "
                 f"r_LE {_f(params.le_radius)}, r_TE {_f(params.te_radius)} mm", fontsize=9)
    for a, end, name in ((zooms[0], ends[0], "LE"), (zooms[1], ends[1], "TE")):
        # the edge as drawn in the middle, its end point in view
        outline = outlines[name.lower()]
        centre = end if outline is None else 0.5 * (outline.min(axis=0) + outline.max(axis=0))
        size = 0.0 if outline is None else max(float(np.abs(outline - centre).max()), float(np.abs(end - centre).max()))
        half = max(1.4 * size, 0.008 * params.chord) if size else 0.012 * params.chord
        a.set_xlim(centre[0] - half, centre[0] + half)
        a.set_ylim(centre[1] - half, centre[1] + half)
        a.set_title(f"{name} region, {_edge_words(params, name.lower())} (points coloured by region; x = joints)",
                    fontsize=8)
    # fixed margins (the legend outside on the right): matplotlib's tight layout measured every
    # text first and took half of each plot's time (0.4 of 0.8 s)
    fig.subplots_adjust(left=0.05, right=0.88, bottom=0.06, top=0.95, hspace=0.28, wspace=0.15)
    try:
        fig.savefig(path, dpi=90)
    finally:                      # a full disk: the figure is not kept open
        plt.close(fig)


def _edge_words(params, which: str) -> str:
    """The drawn edge in words: ellipse semi-axes, flat width or circle radius (mm)."""
    fit = getattr(params, f"{which}_fit") or {}
    if fit.get("shape") == "ellipse":
        return f"ellipse {fit['ellipse']['a_mm']:.3f} × {fit['ellipse']['b_mm']:.3f} mm"
    if fit.get("shape") == "flat":
        f = fit["flat"]
        if f["width_mm"] is None:
            return f"flat {f['length_mm']:.3f} mm long"
        return f"flat {f['width_mm']:.3f} mm wide"
    return f"circle r {_f(getattr(params, f'{which}_radius'))} mm"


def _f(v):
    return "n/a" if v is None else f"{v:.3f}"
