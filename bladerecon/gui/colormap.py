# SPDX-License-Identifier: LGPL-2.1-or-later
"""Colours for the 3D view: deviation, curvature and zebra maps, section colours (numpy only).

Everything here maps plain arrays to RGB in [0, 1] so that the view providers only copy the
result into coin nodes; no FreeCAD import, so the maps are tested without a GUI.
Lengths in mm, curvatures in 1/mm.
"""
from __future__ import annotations

import numpy as np

from bladerecon.core.analysis.surface_analysis import zebra

__all__ = ["verdict_colours", "DIVERGING", "diverging", "deviation_colours", "deviation_limit", "curvature_colours", "curvature_scale",
           "symlog_position",
           "zebra_colours", "section_colours", "grid_normals", "legend_ticks", "STRIPE_AXES"]

#: blue (inside the nominal) -> white (on it) -> red (outside): the colour convention of the
#: deviation report (matplotlib's coolwarm ends), so the GUI and the HTML report read alike.
DIVERGING = np.array([[0.230, 0.299, 0.754],
                      [0.552, 0.690, 0.996],
                      [0.867, 0.867, 0.867],
                      [0.958, 0.604, 0.482],
                      [0.706, 0.016, 0.150]])
#: colour outside the range (saturated ends are darker so an out-of-range point stands out)
BELOW = np.array([0.10, 0.10, 0.45])
ABOVE = np.array([0.45, 0.00, 0.05])
#: stripe light directions of the zebra command: the bands run parallel to this axis
STRIPE_AXES = {"span": (0.0, 0.0, 1.0), "x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0)}


def diverging(t: np.ndarray) -> np.ndarray:
    """RGB (m, 3) for t in [-1, 1] by piecewise-linear interpolation of :data:`DIVERGING`."""
    t = np.clip(np.asarray(t, float), -1.0, 1.0)
    x = (t + 1.0) * 0.5 * (len(DIVERGING) - 1)
    i = np.minimum(np.floor(x).astype(int), len(DIVERGING) - 2)
    f = (x - i)[:, None]
    return DIVERGING[i] * (1.0 - f) + DIVERGING[i + 1] * f


def deviation_limit(values: np.ndarray, tolerance: float) -> float:
    """Symmetric colour range (mm): twice the tolerance or the largest |deviation|, whichever is less.

    Within ±tolerance the map then spans the inner half of the scale; a part entirely in
    tolerance uses the full scale for its own range, so variation still shows.
    """
    v = np.abs(np.asarray(values, float))
    v = v[np.isfinite(v)]
    largest = float(v.max()) if v.size else tolerance
    return max(min(2.0 * tolerance, largest), 1e-9)


def deviation_colours(values: np.ndarray, limit: float) -> np.ndarray:
    """RGB per signed deviation (mm): diverging over [-limit, limit], darker beyond, grey for NaN."""
    d = np.asarray(values, float).ravel()
    rgb = diverging(np.nan_to_num(d / limit))
    rgb[d < -limit] = BELOW
    rgb[d > limit] = ABOVE
    rgb[~np.isfinite(d)] = 0.5
    return rgb


def curvature_scale(values: np.ndarray) -> tuple[float, float]:
    """(knee, limit) of the symmetric-log curvature scale: a quarter of the median |value|, and
    the 99th percentile of |value|.

    A blade's edges curve two orders of magnitude more than its flanks (1/r_LE against
    1/R_camber); a linear scale shows only the edges. Below the knee the scale is linear,
    above it logarithmic; with the knee under the typical flank value the flanks take about
    a quarter of each half of the bar, so their variation and the edges both read.
    """
    c = np.abs(np.asarray(values, float))
    c = c[np.isfinite(c)]
    if not c.size:
        return 1.0, 1.0
    knee = max(0.25 * float(np.median(c)), 1e-300)
    return knee, max(float(np.percentile(c, 99.0)), 2.0 * knee)


def symlog_position(values: np.ndarray, knee: float, limit: float) -> np.ndarray:
    """Position in [-1, 1] on the symmetric-log scale of :func:`curvature_scale`."""
    c = np.asarray(values, float)
    return np.sign(c) * np.log1p(np.abs(c) / knee) / np.log1p(limit / knee)


def curvature_colours(values: np.ndarray) -> tuple[np.ndarray, float, float]:
    """RGB per curvature value (1/mm or 1/mm^2) on the symmetric-log scale; and (knee, limit)."""
    knee, limit = curvature_scale(values)
    return diverging(np.nan_to_num(symlog_position(values, knee, limit))), knee, limit


def zebra_colours(normals: np.ndarray, view: np.ndarray, stripes: int = 12,
                  axis: str | tuple = "span") -> np.ndarray:
    """Black/white RGB per unit normal (m, 3): reflection of light bands (core ``zebra``).

    ``view`` is the viewing direction (camera to scene); ``axis`` one of :data:`STRIPE_AXES`
    or a 3-vector. Smooth (cosine) bands so the rasterised stripes are anti-aliased.
    """
    a = STRIPE_AXES[axis] if isinstance(axis, str) else axis
    g = zebra(normals, view=view, stripe_axis=a, stripes=stripes, smooth=True)
    g = np.clip((g - 0.5) * 3.0 + 0.5, 0.0, 1.0)     # sharpen the cosine towards bands
    return np.repeat(0.05 + 0.9 * g[:, None], 3, axis=1)


def section_colours(n_sections: int) -> np.ndarray:
    """A distinct RGB per section, hub to tip (hue from orange round to violet)."""
    import colorsys

    hues = np.linspace(0.05, 0.8, max(n_sections, 1))
    return np.array([colorsys.hsv_to_rgb(h, 0.85, 0.9) for h in hues])


def grid_normals(grid: np.ndarray, u_periodic: bool = True) -> np.ndarray:
    """Unit normals (nu, nv, 3) of a surface sampled on a grid (nu, nv, 3), by central differences.

    The orientation is that of S_u x S_v (u the first index). Used for shading; the analysis
    colours use the exact normals of the B-spline where they matter (zebra, curvature).
    """
    g = np.asarray(grid, float)
    if u_periodic:
        du = np.roll(g, -1, axis=0) - np.roll(g, 1, axis=0)
    else:
        du = np.gradient(g, axis=0)
    dv = np.gradient(g, axis=1)
    n = np.cross(du, dv)
    size = np.linalg.norm(n, axis=2, keepdims=True)
    return n / np.where(size > 0, size, 1.0)


def legend_ticks(limit: float, tolerance: float | None, unit: str = "mm") -> list[tuple[float, str]]:
    """(value in mm, label) for the colour bar: the ends, zero and the tolerance band.

    ``unit``: the labels' unit, ``"mm"`` or ``"µm"`` (the GUI's legends, as the HTML report)."""
    scale, fmt = (1000.0, "{:+.1f}") if unit in ("µm", "um") else (1.0, "{:+.4f}")

    def label(v: float) -> str:
        return fmt.format(v * scale)

    ticks = [(-limit, label(-limit)), (0.0, "0"), (limit, label(limit))]
    if tolerance is not None and 0 < tolerance < limit:
        ticks += [(-tolerance, f"-tol {label(tolerance)[1:]}"), (tolerance, f"+tol {label(tolerance)[1:]}")]
    return sorted(ticks)


#: pass / fail / not judged colours of the Verdict display mode (as the report's table)
VERDICT_PASS, VERDICT_FAIL, VERDICT_NONE = (0.10, 0.65, 0.15), (0.85, 0.10, 0.10), (0.6, 0.6, 0.6)


def verdict_colours(section: np.ndarray, section_verdicts: list[str]) -> np.ndarray:
    """RGB per point: green where its section passes, red where it fails, grey where there is
    no verdict. ``section_verdicts`` are DeviationAnalysis.SectionVerdicts lines, in section
    order (``"label: pass"`` or ``"label: fail: ..."``)."""
    import re

    said = [re.search(r": (pass|fail)(:|$)", line) for line in section_verdicts]
    ok = np.array([m.group(1) if m else "" for m in said])
    rgb = np.tile(np.array(VERDICT_NONE), (len(section), 1))
    known = (section >= 0) & (section < len(ok))
    verdict = np.where(known, ok[np.clip(section, 0, max(len(ok) - 1, 0))] if len(ok) else "", "")
    rgb[verdict == "pass"] = VERDICT_PASS
    rgb[verdict == "fail"] = VERDICT_FAIL
    return rgb
