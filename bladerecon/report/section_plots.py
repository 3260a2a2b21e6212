# SPDX-License-Identifier: LGPL-2.1-or-later
"""PNG of a segmented section (matplotlib, Agg): regions coloured, camber line, edge circles.

Coordinates are those of the section's plane (mm): e1 = +x projected, e2 = normal x e1.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.geometry.bspline import evaluate_curve
from bladerecon.core.sections.segmentation import LE, PRESSURE, REGION_NAMES, SUCTION, TE

__all__ = ["plot_section"]

COLOURS = {LE: "tab:red", SUCTION: "tab:blue", TE: "tab:orange", PRESSURE: "tab:green"}


def _region_curve(seg, region, n=600):
    a, b = seg.region_interval(region)
    lo, hi = seg.curve.domain
    t = lo + np.mod(np.linspace(a, b, n) - lo, hi - lo)
    return evaluate_curve(seg.curve, t)


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
    for a in [ax, *zooms]:
        if nominal_seg is not None:
            nom = fr.to_plane(nominal_seg.frame.to_space(
                evaluate_curve(nominal_seg.curve, np.linspace(*nominal_seg.curve.domain, 4000))))
            a.plot(nom[:, 0], nom[:, 1], "--", color="0.5", lw=0.8, label="nominal")
        for region in (LE, SUCTION, TE, PRESSURE):
            c = _region_curve(seg, region)
            a.plot(c[:, 0], c[:, 1], "-", color=COLOURS[region], lw=1.4, label=REGION_NAMES[region])
            m = seg.labels == region
            a.plot(seg.points2d[m, 0], seg.points2d[m, 1], ".", color=COLOURS[region], ms=3)
        a.plot(camber[:, 0], camber[:, 1], "-", color="purple", lw=0.8, label="camber")
        a.plot([seg.le[0], seg.te[0]], [seg.le[1], seg.te[1]], ":", color="k", lw=0.6)
        joints = evaluate_curve(seg.curve, np.array(list(seg.t_joints.values())))
        a.plot(joints[:, 0], joints[:, 1], "kx", ms=7, label="joints")
        a.plot(*seg.le, "ro", ms=5)
        a.plot(*seg.te, "o", color="tab:orange", ms=5)
        for centre, r in ((params.le_center, params.le_radius), (params.te_center, params.te_radius)):
            if r is not None:
                c2 = fr.to_plane(centre.reshape(1, 3))[0]
                ang = np.linspace(0, 2 * np.pi, 200)
                a.plot(c2[0] + r * np.cos(ang), c2[1] + r * np.sin(ang), "-", color="k", lw=0.5)
        if seg.throat is not None:
            a.plot(*seg.throat["point"], "m*", ms=10, label="throat")
        a.set_aspect("equal")
        a.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    ax.set_title(f"section {seg.index}: chord {params.chord:.3f} mm, stagger {params.stagger_deg:.2f}°, "
                 f"t_max {params.max_thickness:.3f} mm at {params.max_thickness_pos:.2f} mm, "
                 f"r_LE {_f(params.le_radius)}, r_TE {_f(params.te_radius)} mm", fontsize=9)
    for a, centre, r, name in ((zooms[0], seg.le, params.le_radius, "LE"), (zooms[1], seg.te, params.te_radius, "TE")):
        half = max(5 * r, 0.008 * params.chord) if r else 0.012 * params.chord
        a.set_xlim(centre[0] - half, centre[0] + half)
        a.set_ylim(centre[1] - half, centre[1] + half)
        a.set_title(f"{name} region (points coloured by region; x = joints)", fontsize=8)
    fig.tight_layout()
    try:
        fig.savefig(path, dpi=90)
    finally:                      # a full disk: the figure is not kept open
        plt.close(fig)


def _f(v):
    return "n/a" if v is None else f"{v:.3f}"
