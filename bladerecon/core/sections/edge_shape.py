# SPDX-License-Identifier: LGPL-2.1-or-later
"""The shape of an edge that is not a circle (issue 24 §3): elliptic edges and blunt (flat,
square-cut) trailing edges.

:func:`~bladerecon.core.sections.parameters.measure_section` fits every edge with a circle;
when the circle's arc points scatter far beyond the flanks' noise (``not a circle``), this
module says what the edge is instead, in the section plane (mm, degrees):

* **flat** (a blunt edge cut straight across, its corners rounded or sharp): the supporting
  line of the edge that the most points lie on (within ``tol`` of it), searched over cut
  directions within ±60° of square to the camber line, then fitted to its points by total least
  squares. Reported: the flat's measured length (its points' extent), its width between the two
  flanks (each flank a straight line fitted to its points between one and three edge radii
  behind the flat, met with the flat's line: the edge thickness at the cut, as drawings give
  it), its direction and the angle of its normal from the camber line (0: square to it), its
  midpoint (the edge point, the chord's end).
* **ellipse** (a designed elliptic edge): centre, semi-axes ``a`` (along the major axis, which
  leans by ``axis_angle_deg`` from the camber line) and ``b``, fitted by least squares on the
  Sampson distances (the algebraic residual over its gradient: the distance to first order) of
  the points ahead of the ellipse's minor axis, where a designed edge ellipse meets its flanks;
  the window follows the centre until it stops moving. Its major axis lies within 10° of the
  camber line (a designed edge ellipse lies along it). Reported: ``a``, ``b``, ``a/b``, the
  radius of curvature at the tip ``b²/a``, the tip (the edge point), the rms distance.
* otherwise **irregular** (a damaged or worn edge): no figures beyond the circle's.

An edge is called flat when its flat holds at least 3 points over a length of at least one
circle radius (an elliptic or round tip of radius ρ stays within ``tol`` of a line over only
2√(2ρ·tol)), else elliptic when the ellipse passes the roundness test the circle failed (rms ≤ 4 ×
the flanks' rms + 3 µm) with at most a fifth of the circle's rms, and its axis along the camber
line is more than 5 % the longer. A flat must also cross the camber line.
"""
from __future__ import annotations

import numpy as np

__all__ = ["edge_shape", "fit_edge_ellipse", "find_flat"]

#: cut directions tried for a flat: the normal of the flat within ±60° of the camber line, 0.25° apart
FLAT_ANGLES = np.radians(np.arange(-60.0, 60.0 + 1e-9, 0.25))
MIN_FLAT_POINTS = 3
#: points an ellipse is fitted to at least (with the two flanks' tangency: 8 equations, 5 unknowns)
MIN_ELLIPSE_POINTS = 6
#: an ellipse is taken only when it fits the edge at most this share of the circle's rms (a round
#: edge distorted by noise or by a slab slid onto its plane fits an ellipse barely better: on a
#: propeller cloud 5.1 against 5.4 µm, a designed 2.4:1 ellipse 1.9 against 44 µm) and its axes
#: differ by more than MIN_ELLIPSE_RATIO
ELLIPSE_GAIN = 0.2
MIN_ELLIPSE_RATIO = 1.05
#: a designed edge ellipse lies along the camber line: one tilted further is no such ellipse (a
#: tilted one fitted ahead of its minor axis comes out long by 12-35 %, its tilt halved)
MAX_ELLIPSE_TILT_DEG = 10.0
#: a flat's curvature times the edge circle's radius must stay below this (a round edge: 1)
MAX_FLAT_BEND = 0.3
#: no flat is looked for when the tolerance (3 × the flanks' noise + 1 µm) exceeds this fraction of
#: the edge circle's radius: within it an arc of that radius stays by a line over 0.6 radii
MAX_FLAT_TOL = 0.05


def _frame(points2d: np.ndarray, centre: np.ndarray, axis: np.ndarray) -> np.ndarray:
    """Points (n, 2) as (s, t): s along the camber axis into the blade from the circle's centre,
    t across (left of the axis)."""
    ay = np.array([-axis[1], axis[0]])
    q = points2d - centre
    return np.column_stack([q @ axis, q @ ay])


def _from_frame(st, centre: np.ndarray, axis: np.ndarray) -> np.ndarray:
    ay = np.array([-axis[1], axis[0]])
    st = np.asarray(st, float)
    return centre + st[..., :1] * axis + st[..., 1:2] * ay


def _tls_line(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Total-least-squares line through P (k, 2): a point on it, its unit direction, rms distance."""
    m = P.mean(axis=0)
    _, sv, vt = np.linalg.svd(P - m, full_matrices=False)
    return m, vt[0], float(sv[-1] / np.sqrt(len(P)))


def find_flat(st: np.ndarray, radius: float, tol: float) -> dict | None:
    """The flat of a blunt edge in the edge frame (``st`` from :func:`_frame`, the tip at s < 0),
    or None when no supporting line holds ``MIN_FLAT_POINTS`` points over ``radius`` or more."""
    if tol > MAX_FLAT_TOL * radius:       # so noisy that an arc of the edge's radius passes for a line
        return None
    s_front = float(st[:, 0].min())
    front_index = np.flatnonzero(st[:, 0] <= s_front + 3.0 * radius)
    front = st[front_index]
    if len(front) < MIN_FLAT_POINTS:
        return None
    # outward normals of the candidate flats: (-cos φ, sin φ), φ the angle from the camber line
    nrm = np.column_stack([-np.cos(FLAT_ANGLES), np.sin(FLAT_ANGLES)])
    h = nrm @ front.T                                     # (angles, points) heights along each normal
    on = h >= h.max(axis=1, keepdims=True) - tol
    count = on.sum(axis=1)
    best = int(np.argmax(count))                          # most points; the first such angle
    sel = on[best]
    for _ in range(3):                                    # refit the line to its points, take its points again
        if sel.sum() < 2:
            return None
        m, d, _ = _tls_line(front[sel])
        n = np.array([-d[1], d[0]])
        if n[0] > 0:                                      # outward: towards the tip (s < 0)
            n = -n
        dist = (front - m) @ n
        # the flat is the profile's outermost line: points beyond it by more than tol would
        # cut it; points within tol of it are on it
        sel_new = np.abs(dist) <= tol
        if np.array_equal(sel_new, sel):
            break                                         # the line keeps its points: settled
        sel = sel_new
    k = int(sel.sum())
    if k < MIN_FLAT_POINTS:
        return None
    m, d, rms = _tls_line(front[sel])
    if d[1] < 0:                                          # along +t
        d = -d
    along = (front[sel] - m) @ d
    length = float(along.max() - along.min())
    if length < radius or np.max((front - m) @ n) > 3.0 * tol:
        return None
    # straight, not a gentle arc that noise lets pass within tol of a line: its curvature (a
    # parabola through its points) well below the edge circle's
    if k >= 4 and abs(2.0 * np.polyfit(along, (front[sel] - m) @ n, 2)[0]) * radius > MAX_FLAT_BEND:
        return None
    # across the edge: the flat meets the camber line (a straight flank of a kinked or wedge-shaped
    # round edge is a supporting line too, beside it)
    t = front[sel][:, 1]
    if not t.min() - 2.0 * tol <= 0.0 <= t.max() + 2.0 * tol:
        return None
    return {"point": m, "direction": d, "normal": n, "points": k, "rms": rms, "length": length,
            "ends": (m + along.min() * d, m + along.max() * d), "index": front_index[sel]}


def _flat_width(st: np.ndarray, flat: dict, radius: float) -> tuple[float | None, np.ndarray]:
    """Width of the flat between the flanks' lines and the midpoint between the two corners; the
    measured ends' midpoint and None when a flank has fewer than 3 points there. Each flank's
    points are those met walking along the loop away from the flat's ends, one to three radii
    behind it (a flat cut far from square leaves one flank on both sides of the camber line)."""
    m, n = flat["point"], flat["normal"]
    npts = len(st)
    idx = np.sort(flat["index"])
    gap = np.diff(np.r_[idx, idx[0] + npts])          # the flat is one run of the loop: it ends before its largest gap
    k = int(np.argmax(gap))
    ends = (int(idx[(k + 1) % len(idx)]), int(idx[k]))
    fallback = None, 0.5 * (flat["ends"][0] + flat["ends"][1])
    corners = []
    for start, step in zip(ends, (-1, 1)):
        walk = (start + step * np.arange(1, npts // 2)) % npts
        depth = (m - st[walk]) @ n                        # behind the flat, > 0
        deep = np.flatnonzero(depth > 3.0 * radius)
        if deep.size:
            walk, depth = walk[:deep[0]], depth[:deep[0]]
        pick = walk[depth >= radius]
        if len(pick) < 3:
            return fallback
        p0, fd, _ = _tls_line(st[pick])
        den = fd @ n
        if abs(den) < 1e-9:                               # a flank parallel to the flat: no corner
            return fallback
        corners.append(p0 + ((m - p0) @ n / den) * fd)
    width = float(np.linalg.norm(corners[1] - corners[0]))
    if not 0.8 * flat["length"] <= width <= 4.0 * radius:     # flank lines that do not close on the flat
        return fallback
    return width, 0.5 * (corners[0] + corners[1])


def _ellipse_residuals(z: np.ndarray, P: np.ndarray, lines=()) -> np.ndarray:
    """Sampson distances of P to the ellipse z = (cs, ct, a, b, θ), then for each flank line
    (n outward, offset d, weight w) its tangency: the line's distance from the centre minus the
    ellipse's support function along n, √(a²(n·e₁)² + b²(n·e₂)²), times w."""
    cs, ct, a, b, th = z
    c, s = np.cos(th), np.sin(th)
    ds, dt = P[:, 0] - cs, P[:, 1] - ct
    u, v = c * ds + s * dt, -s * ds + c * dt
    F = (u / a) ** 2 + (v / b) ** 2 - 1.0
    g = 2.0 * np.hypot(u / a ** 2, v / b ** 2)
    res = F / np.maximum(g, 1e-300)
    if not lines:
        return res
    tang = [w * (d - (n[0] * cs + n[1] * ct) - np.hypot(a * (n[0] * c + n[1] * s), b * (-n[0] * s + n[1] * c)))
            for n, d, w in lines]
    return np.concatenate([res, tang])


def _flank_lines(st: np.ndarray, z: np.ndarray) -> list:
    """The two flanks next to the ellipse z as straight lines (total least squares on the points
    from its minor axis to one major semi-axis behind it, each side of the major axis): (outward
    normal, offset, weight √points) each; none when a side has fewer than 3 points."""
    cs, ct, a, b, th = z
    e1 = np.array([np.cos(th), np.sin(th)])
    e2 = np.array([-e1[1], e1[0]])
    rel = st - np.array([cs, ct])
    along, across = rel @ e1, rel @ e2
    out = []
    for side in (1.0, -1.0):
        pick = (along >= 0) & (along <= a) & (np.sign(across) == side)
        if pick.sum() < 3:
            return []
        m, d, _ = _tls_line(st[pick])
        n = np.array([-d[1], d[0]])
        if n @ e2 * side < 0:
            n = -n
        out.append((n, float(n @ m), float(np.sqrt(pick.sum()))))
    return out


def _ellipse_distance(z: np.ndarray, P: np.ndarray) -> np.ndarray:
    """Signed orthogonal distance of P to the ellipse z (negative inside), to the closest foot
    wherever P is, deep inside a slender ellipse too.

    Eberly's construction: by symmetry the point is taken into the first quadrant of the ellipse's
    frame, (y₀, y₁) ≥ 0, with the semi-axes ordered a ≥ b. The closest foot is
    x = (a²y₀/(t + a²), b²y₁/(t + b²)) for the one root t > −b² of
    G(t) = (a y₀/(t + a²))² + (b y₁/(t + b²))² − 1, which decreases monotonically there; bisection
    brackets it without a start that could fall to a farther foot (Newton on the angle did, by the
    centre of curvature of a slender tip). On the major axis (y₁ = 0) inside the evolute the foot
    leaves the axis, x₀ = a²y₀/(a² − b²), in closed form.
    """
    cs, ct, a, b, th = (float(v) for v in z)
    c, s = np.cos(th), np.sin(th)
    ds, dt = P[:, 0] - cs, P[:, 1] - ct
    u, v = c * ds + s * dt, -s * ds + c * dt
    if a < b:                                             # the frame's first axis the major one
        a, b, u, v = b, a, v, u
    y0, y1 = np.abs(u), np.abs(v)
    g = (y0 / a) ** 2 + (y1 / b) ** 2 - 1.0
    # scaled unknown q = t / b² + 1 > 0: G = (r·z₀/(q − 1 + r))² + (z₁/q)² − 1, r = (a/b)²;
    # bisected in q (not t) so that a root by 0, a point just off the major axis, keeps its digits
    r = (a / b) ** 2
    z0, z1 = y0 / a, y1 / b
    axis = y1 <= 1e-12 * b                                # on the major axis (within round-off)
    lo = np.where(axis, 1.0, z1)                          # G(lo) ≥ 0
    hi = np.where(g < 0.0, 1.0, np.hypot(r * z0, z1))     # G(hi) ≤ 0
    for _ in range(400):                                  # float64 brackets shrink to a point first
        mid = 0.5 * (lo + hi)
        if not np.any((mid != lo) & (mid != hi)):
            break
        G = (r * z0 / (mid - 1.0 + r)) ** 2 + (z1 / mid) ** 2 - 1.0
        lo, hi = np.where(G > 0.0, mid, lo), np.where(G > 0.0, hi, mid)
    q = 0.5 * (lo + hi)
    x0, x1 = r * y0 / (q - 1.0 + r), y1 / q
    # on the major axis: the foot off the axis when a·y₀ < a² − b², else the vertex (a, 0)
    off = axis & (a * y0 < a * a - b * b)
    xd = np.where(off, a * y0 / max(a * a - b * b, 1e-300), 1.0)
    x0 = np.where(axis, a * xd, x0)
    x1 = np.where(axis, b * np.sqrt(np.maximum(1.0 - xd ** 2, 0.0)), x1)
    dist = np.hypot(x0 - y0, x1 - y1)
    return np.where(g < 0.0, -dist, dist)


def _fit_ellipse_window(P: np.ndarray, z, radius: float, st: np.ndarray):
    """Least squares on the Sampson distances of P from z (or from the edge circle); the
    major axis taken as the semi-axis nearer the camber line; None when it is no ellipse."""
    from scipy.optimize import least_squares

    if len(P) < MIN_ELLIPSE_POINTS:
        return None
    if z is None:                                         # from the edge circle (the frame's origin)
        z = np.array([0.0, 0.0, radius, radius, 0.0])
    lines = _flank_lines(st, z)
    z = least_squares(_ellipse_residuals, z, args=(P, lines), method="lm", xtol=1e-14, ftol=1e-14, gtol=1e-14).x.copy()
    if not np.all(np.isfinite(z)) or z[2] <= 0 or z[3] <= 0:
        return None
    if abs(np.cos(z[4])) < abs(np.sin(z[4])):
        z = np.array([z[0], z[1], z[3], z[2], z[4] + np.pi / 2])
    z[4] = (z[4] + np.pi / 2) % np.pi - np.pi / 2
    return z


def fit_edge_ellipse(st: np.ndarray, radius: float, max_rounds: int = 12) -> dict | None:
    """Ellipse through the points ahead of its minor axis (edge frame; see the module docstring).
    None when the fit does not settle on an ellipse ahead of the points."""

    s_front = float(st[:, 0].min())
    # first window: ahead of the circle's centre, at least the MIN_ELLIPSE_POINTS foremost points
    sel = st[:, 0] <= max(0.0, float(np.sort(st[:, 0])[min(MIN_ELLIPSE_POINTS, len(st)) - 1]))
    z, history = None, []
    for _ in range(max_rounds):
        if any(np.array_equal(sel, h) for h in history):
            # the window swings between sets that differ by a point at the junction (on the
            # flank and the ellipse alike, within the noise): fit the union once and stop
            k = next(i for i, h in enumerate(history) if np.array_equal(sel, h))
            sel = np.logical_or.reduce(history[k:])
            z = _fit_ellipse_window(st[sel], z, radius, st)
            break
        history.append(sel)
        z = _fit_ellipse_window(st[sel], z, radius, st)
        if z is None:
            return None
        new = st[:, 0] <= max(float(z[0]), float(np.sort(st[:, 0])[min(MIN_ELLIPSE_POINTS, len(st)) - 1]))
        if np.array_equal(new, sel):
            break                                         # the window stays: settled
        sel = new
    else:
        return None
    if z is None:
        return None
    P = st[sel]
    d = _ellipse_distance(z, P)
    cs, ct, a, b, th = (float(v) for v in z)
    # an edge's ellipse: about as wide as its circle, its tip at the foremost points, its axis
    # near the camber line; not a wild one that a few points of another shape allow
    tip_s = cs - a * np.cos(th)
    if not (0.3 * radius <= b <= 3.0 * radius and a <= 10.0 * radius and abs(th) <= np.radians(MAX_ELLIPSE_TILT_DEG)
            and abs(tip_s - s_front) <= 0.5 * radius and abs(ct) <= radius):
        return None
    return {"centre": np.array([cs, ct]), "a": a, "b": b, "angle": th, "points": int(len(P)),
            "rms": float(np.sqrt(np.mean(d ** 2))),
            "tip": np.array([cs - a * np.cos(th), ct - a * np.sin(th)])}


def edge_shape(points2d: np.ndarray, centre: np.ndarray, radius: float, axis: np.ndarray,
               flank_rms: float, roundness: float, circle_rms: float = np.inf) -> dict:
    """What an edge that is not a circle is (module docstring), in the section plane.

    ``points2d`` (n, 2): the section's points; ``centre``, ``radius``, ``axis``: its edge circle
    and the camber line's tangent there (into the blade); ``flank_rms``: the flanks' noise (mm);
    ``roundness``: the allowance added to 4 × ``flank_rms`` for a fit to pass (mm);
    ``circle_rms``: the circle's arc rms (mm), an ellipse's must be a fifth of it at most
    (ELLIPSE_GAIN). Returns ``{"shape": "flat"|"ellipse"|"irregular", ...}`` with 2D points
    (``tip``: the edge point).
    """
    st = _frame(np.asarray(points2d, float), centre, axis)
    noise = flank_rms if np.isfinite(flank_rms) else 0.0
    allowed = 4.0 * noise + roundness
    flat = find_flat(st, radius, 3.0 * noise + 0.001)
    if flat is not None:
        width, mid = _flat_width(st, flat, radius)
        d2 = flat["direction"][0] * axis + flat["direction"][1] * np.array([-axis[1], axis[0]])
        return {"shape": "flat", "width": width, "length": flat["length"], "points": flat["points"],
                "rms": flat["rms"], "direction": d2, "tip": _from_frame(mid, centre, axis)}
    ell = fit_edge_ellipse(st, radius)
    if (ell is not None and ell["rms"] <= min(allowed, ELLIPSE_GAIN * circle_rms)
            and ell["a"] / ell["b"] > MIN_ELLIPSE_RATIO):
        major = np.cos(ell["angle"]) * axis + np.sin(ell["angle"]) * np.array([-axis[1], axis[0]])
        return {"shape": "ellipse", "a": ell["a"], "b": ell["b"], "ratio": ell["a"] / ell["b"],
                "tip_radius": ell["b"] ** 2 / ell["a"], "points": ell["points"], "rms": ell["rms"],
                "axis_angle_deg": float(np.degrees(ell["angle"])), "major_axis": major,
                "centre": _from_frame(ell["centre"], centre, axis), "tip": _from_frame(ell["tip"], centre, axis)}
    return {"shape": "irregular"}
