# SPDX-License-Identifier: LGPL-2.1-or-later
"""Stream-surface (meridional) sections of a radial or mixed-flow rotor blade cloud (issue 25 §3).

Planes and cylinders cut an impeller or a radial turbine blade into open hub-to-shroud curves;
its airfoils lie on surfaces of revolution between hub and shroud. From the cloud alone:

1. every node's meridional coordinates (a, r) about the rotor axis (a along it, r from it)
   and its angle θ about the blade's mean angle;
2. the **hub and shroud lines**: the outline of the meridional footprint (an alpha shape of
   the Delaunay triangles, :func:`_boundary_loop`) cut at its four sharpest corners (LE and TE
   at hub and shroud); of the two pairs of opposite sides the longer is hub and shroud, the
   hub the side nearer the axis; both smoothed, resampled and continued straight 10 % past
   their ends (:func:`find_channel`);
3. stream surfaces ``(1 - s) hub(τ) + s shroud(τ)`` (straight quasi-orthogonals at equal
   fractions τ of the lines' lengths); every node's (τ, s) by Newton steps from a grid;
4. a section on the stream surface ``s_k`` takes the nodes of a thin shell of ``s`` around it
   in the unrolled coordinates ``(m', r·θ)`` (mm along the stream surface, mm around),
   ordered by geometry (:func:`bladerecon.core.sections.cloud.order_slab`), moved onto the
   stream surface along the quasi-orthogonal and mapped back to 3D. The unrolled sections
   and the map back are kept (``CloudSections.unrolled``, ``to_world``): the sections in
   m'–θ for their parameters.

Units: mm.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.core.sections.cloud import SLAB_POINTS, CloudSections, _camber_order, _drop_close, \
    _first_crossing, _uncross, order_slab

__all__ = ["Channel", "find_channel", "meridional_sections"]


class Channel:
    """The meridional channel between a hub line and a shroud line (a, r) mm, each given by
    200 points at equal fractions ``tau`` of its length; the stream surface at span fraction
    ``s`` is ``(1 - s) hub(tau) + s shroud(tau)`` (straight quasi-orthogonals)."""

    def __init__(self, axis: np.ndarray, hub: np.ndarray, shroud: np.ndarray) -> None:
        self.axis, self.hub, self.shroud = axis, hub, shroud
        self.tau = np.linspace(0.0, 1.0, len(hub))
        ss = np.linspace(-0.25, 1.25, 61)
        grid = (1 - ss)[None, :, None] * hub[:, None, :] + ss[None, :, None] * shroud[:, None, :]
        self._grid_ts = np.stack(np.meshgrid(self.tau, ss, indexing="ij"), axis=-1).reshape(-1, 2)
        self._tree = cKDTree(grid.reshape(-1, 2))

    def point(self, tau, s) -> np.ndarray:
        """Meridional points (a, r) mm at (tau, s)."""
        tau = np.asarray(tau, float)
        h = np.column_stack([np.interp(tau, self.tau, self.hub[:, j]) for j in range(2)])
        sh = np.column_stack([np.interp(tau, self.tau, self.shroud[:, j]) for j in range(2)])
        return (1 - np.asarray(s, float))[..., None] * h + np.asarray(s, float)[..., None] * sh

    def coordinates(self, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(tau, s) of meridional points: nearest grid node, then Newton steps on
        ``(1 - s) H(tau) + s S(tau) = M``."""
        _, k = self._tree.query(M)
        ts = self._grid_ts[k].copy()
        eps = 1e-4
        for _ in range(4):
            f = self.point(ts[:, 0], ts[:, 1]) - M
            dt = (self.point(ts[:, 0] + eps, ts[:, 1]) - self.point(ts[:, 0] - eps, ts[:, 1])) / (2 * eps)
            ds = self.point(ts[:, 0], np.ones(len(ts))) - self.point(ts[:, 0], np.zeros(len(ts)))
            J = np.stack([dt, ds], axis=-1)
            det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
            ok = np.abs(det) > 1e-12
            step = np.zeros_like(ts)
            step[ok, 0] = (J[ok, 1, 1] * f[ok, 0] - J[ok, 0, 1] * f[ok, 1]) / det[ok]
            step[ok, 1] = (-J[ok, 1, 0] * f[ok, 0] + J[ok, 0, 0] * f[ok, 1]) / det[ok]
            ts -= step
        return ts[:, 0], ts[:, 1]

    def stream_length(self, tau, s) -> np.ndarray:
        """Meridional arc length (mm) from tau = 0 along the stream surface s."""
        t = np.linspace(0.0, 1.0, 401)
        c = self.point(t, np.full(t.size, s))
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))])
        return np.interp(tau, t, arc), t, arc

    def lines(self, count: int = 25) -> dict:
        k = np.linspace(0, len(self.hub) - 1, count).round().astype(int)
        return {"hub_a_r_mm": self.hub[k].round(4).tolist(), "shroud_a_r_mm": self.shroud[k].round(4).tolist()}


def _meridional(P: np.ndarray, axis: np.ndarray):
    a = P @ axis
    e1 = np.cross(axis, np.eye(3)[np.argmin(np.abs(axis))])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    x, y = P @ e1, P @ e2
    r = np.hypot(x, y)
    theta = np.arctan2(y, x)
    mean = np.angle(np.mean(np.exp(1j * theta)))
    theta = np.angle(np.exp(1j * (theta - mean)))
    return np.column_stack([a, r]), theta, mean, e1, e2


def _boundary_loop(M: np.ndarray) -> np.ndarray:
    """The outline of the meridional footprint as one closed loop of points: the boundary
    edges of the Delaunay triangles with all edges under ``k`` x the median spacing (an
    alpha shape), ``k`` raised from 5 until one loop holds the boundary."""
    from scipy.spatial import Delaunay

    tri = Delaunay(M)
    simp = tri.simplices
    e = np.linalg.norm(M[simp] - M[np.roll(simp, 1, axis=1)], axis=2).max(axis=1)
    d, _ = cKDTree(M).query(M, 2)
    spacing = float(np.median(d[:, 1]))
    best = None
    for k in (5.0, 8.0, 12.0, 20.0):
        keep = simp[e < k * spacing]
        edges = np.sort(np.concatenate([keep[:, [0, 1]], keep[:, [1, 2]], keep[:, [2, 0]]]), axis=1)
        uniq, cnt = np.unique(edges, axis=0, return_counts=True)
        bnd = uniq[cnt == 1]
        nb: dict = {}
        for i, j in bnd:
            nb.setdefault(int(i), []).append(int(j))
            nb.setdefault(int(j), []).append(int(i))
        start = int(bnd[np.argmin(M[bnd[:, 0], 0]), 0])
        loop, seen, cur = [start], {start}, start
        while True:
            cand = [v for v in nb[cur] if v not in seen]
            if not cand:
                break
            cur = cand[0]
            loop.append(cur)
            seen.add(cur)
        if best is None or len(loop) > len(best):
            best = loop
        if len(loop) >= 0.9 * len(nb):
            break
    return M[best]


def _resample(line: np.ndarray, count: int = 200, smooth: int = 3) -> np.ndarray:
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
    t = np.linspace(0.0, arc[-1], count)
    out = np.column_stack([np.interp(t, arc, line[:, j]) for j in range(2)])
    for _ in range(smooth):
        out[1:-1] = 0.25 * out[:-2] + 0.5 * out[1:-1] + 0.25 * out[2:]
    return out


def _extend(line: np.ndarray, share: float = 0.1) -> np.ndarray:
    """The line continued straight past both ends by ``share`` of its points (nodes on the
    round LE and TE lie a little beyond the outline's corners)."""
    k = max(2, int(share * len(line)))
    step0, step1 = line[1] - line[0], line[-1] - line[-2]
    head = line[0] - np.outer(np.arange(k, 0, -1), step0)
    tail = line[-1] + np.outer(np.arange(1, k + 1), step1)
    return np.concatenate([head, line, tail])


def find_channel(M: np.ndarray, axis: np.ndarray, seed: int = 0) -> Channel:
    """Hub and shroud lines of the meridional points ``M`` (a, r) mm: the outline of the
    footprint is cut at its four sharpest corners (where the LE and TE meet hub and
    shroud); of the two pairs of opposite sides the longer is hub and shroud, the hub the one
    nearer the axis."""
    rng = np.random.default_rng(seed)
    sub = M[rng.permutation(len(M))[:4000]]
    loop = _resample(_boundary_loop(sub), 400, smooth=0)
    n = len(loop)
    per = np.linalg.norm(np.diff(loop, axis=0), axis=1).mean()
    w = max(2, int(round(0.015 * n)))
    a = loop[(np.arange(n) + w) % n] - loop
    b = loop - loop[(np.arange(n) - w) % n]
    turn = np.abs(np.angle((b[:, 0] + 1j * b[:, 1]) * np.conj(a[:, 0] + 1j * a[:, 1])))
    corners = []
    for i in np.argsort(-turn):
        if all(min(abs(i - c), n - abs(i - c)) > 2 * w for c in corners):
            corners.append(int(i))
        if len(corners) == 4:
            break
    if len(corners) < 4:
        raise BladeReconError("the blade's meridional outline has no four corners (LE, TE at hub and "
                              "shroud): cannot find the hub and shroud lines")
    corners.sort()
    sides = [np.concatenate([loop[corners[k]:], loop[:corners[(k + 1) % 4] + 1]]) if k == 3
             else loop[corners[k]:corners[k + 1] + 1] for k in range(4)]
    lengths = [len(sd) * per for sd in sides]
    pair = (0, 2) if lengths[0] + lengths[2] >= lengths[1] + lengths[3] else (1, 3)
    hub, shroud = sides[pair[0]], sides[pair[1]][::-1]       # both run the same way round
    if hub[:, 1].mean() > shroud[:, 1].mean():
        hub, shroud = shroud, hub
    return Channel(axis, _extend(_resample(hub)), _extend(_resample(shroud)))


def meridional_sections(P: np.ndarray, axis=(0.0, 0.0, 1.0), n_sections: int | None = None,
                        span_range: tuple[float, float] | None = None) -> CloudSections:
    """Sections of a radial / mixed-flow blade cloud (mm) on stream surfaces between hub and
    shroud, at span fractions ``span_range`` (default 0.05 to 0.95)."""
    P = np.asarray(P, float)
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    M, theta, theta0, e1, e2 = _meridional(P, axis)
    ch = find_channel(M, axis)
    tau, s = ch.coordinates(M)
    s_lo, s_hi = span_range if span_range is not None else (0.05, 0.95)
    if not 0.0 <= s_lo < s_hi <= 1.0:
        raise BladeReconError(f"--span-range {s_lo:g}:{s_hi:g}: on a radial rotor give span fractions "
                              "0 <= A < B <= 1 between hub and shroud")
    inside = (s >= s_lo) & (s <= s_hi)
    n_in = int(inside.sum())
    width = SLAB_POINTS * (s_hi - s_lo) / max(n_in, 1)
    if n_sections is None:
        n_sections = int(np.clip((s_hi - s_lo) / (4.0 * width), 5, 15))
    width = min(width, (s_hi - s_lo) / (3.0 * n_sections))
    pos = np.linspace(s_lo, s_hi, n_sections)
    sections, rows, counts, merged, flat = [], [], [], 0, []
    height = float(np.mean(np.linalg.norm(ch.shroud - ch.hub, axis=1)))   # mean channel width, mm
    for sk in pos:
        sel = np.flatnonzero(np.abs(s - sk) <= 0.5 * width)
        where = f"stream surface at span fraction {sk:.3f}"
        if len(sel) < 12:
            raise BladeReconError(f"{where}: {len(sel)} points in the shell, needs at least 12: give a denser cloud")
        x, t_tab, arc = ch.stream_length(tau[sel], sk)
        rk = ch.point(tau[sel], np.full(len(sel), sk))[:, 1]
        q = np.column_stack([x, rk * theta[sel]])
        order, _, info = order_slab(q, where)
        # the shells are thin (a fiftieth of the channel): moving along the quasi-orthogonal is
        # closer than the planar slabs' slide along the surface (measured: 0.05 against 0.1-0.5 mm)
        q2 = q[order]
        order, q2 = _drop_close(order, q2)
        fix = _uncross(q2, np.arange(len(q2)))
        if _first_crossing(q2[fix]) is not None:
            fix = _uncross(q2, _camber_order(q2))
        order, q2 = order[fix], q2[fix]
        ar = ch.point(np.interp(q2[:, 0], arc, t_tab), np.full(len(q2), sk))
        th = theta0 + q2[:, 1] / ar[:, 1]
        X = np.outer(ar[:, 0], axis) + ar[:, 1:2] * (np.outer(np.cos(th), e1) + np.outer(np.sin(th), e2))
        sections.append(X)
        flat.append(np.column_stack([q2, np.full(len(q2), sk * height)]))
        rows.append(sel[order])
        counts.append(int(len(sel)))
        merged += info["pieces_merged"]
    info = {"kind": "stream-surfaces", "cloud_points": int(len(P)), "axis": [float(v) for v in axis],
            "span_fractions": [float(v) for v in pos], "sections": int(n_sections), "shell_span_fraction": float(width),
            "slab_points": counts, "pieces_merged": int(merged), "channel": ch.lines(),
            "points_left_out": {"hub_side": int((s < s_lo).sum()), "shroud_side": int((s > s_hi).sum())}}
    info["unrolled_height_mm"] = height

    def to_world(U: np.ndarray) -> np.ndarray:
        """Unrolled (m' along the stream surface, r·θ, s·H) mm -> world mm."""
        U = np.asarray(U, float)
        sv = U[:, 2] / height
        t = np.linspace(0.0, 1.0, 701)
        grid_s = np.linspace(sv.min(), sv.max(), 41) if np.ptp(sv) > 0 else np.array([sv[0], sv[0] + 1e-9])
        arcs = np.array([ch.stream_length(t, g)[0] for g in grid_s])          # (G, T) m'(tau) per s
        w = np.interp(sv, grid_s, np.arange(len(grid_s)))
        i0 = np.clip(np.floor(w).astype(int), 0, len(grid_s) - 2)
        f = (w - i0)[:, None]
        rows = (1 - f) * arcs[i0] + f * arcs[i0 + 1]                        # (n, T)
        k = np.clip((rows < U[:, :1]).sum(axis=1), 1, len(t) - 1)
        a0, a1 = rows[np.arange(len(U)), k - 1], rows[np.arange(len(U)), k]
        tau = t[k - 1] + (t[k] - t[k - 1]) * (U[:, 0] - a0) / np.where(a1 > a0, a1 - a0, 1.0)
        ar = ch.point(tau, sv)
        th = theta0 + U[:, 1] / ar[:, 1]
        return np.outer(ar[:, 0], axis) + ar[:, 1:2] * (np.outer(np.cos(th), e1) + np.outer(np.sin(th), e2))

    between = np.flatnonzero((s >= pos[0]) & (s <= pos[-1]))
    return CloudSections(sections, rows, axis, pos, info, flat, to_world, between, P)
