# SPDX-License-Identifier: LGPL-2.1-or-later
"""Peer for bench/bench_sections.py: engeom 0.5 ``airfoil2`` on the same sections.

Runs in the bench-only venv (.cache/bench-venv), never imported by the product or the tests.

    .cache/bench-venv/bin/python bench/peer_engeom_sections.py SECTIONS.npz OUT.json FX,FY [TOL [raw|spline]]

SECTIONS.npz holds arrays s0, s1, ... (n, 3) mm in planes z = const; FX,FY: the flow
direction. ``spline``: engeom is given 4000 points of a periodic interpolating cubic through
the points (scipy ``splprep``, per=1, s=0) instead of the raw polyline, which it needs on
sparse sections. Writes per section: chord, LE/TE points and radii, max thickness (mm), the time (s).
"""
import json
import sys
import time

import numpy as np
from engeom.airfoil2 import AfGeometry, OrientFwdAft, OrientUpperLower
from engeom.geom2 import Curve2


def measure(xy: np.ndarray, flow, tol: float) -> dict:
    curve = Curve2(xy, hull_ccw=True, force_closed=True)
    g = AfGeometry.from_geometric_analysis(curve, tol, OrientFwdAft.airflow(*flow), OrientUpperLower.curvature(),
                                           "full_round", "full_round")
    le, te = g.leading, g.trailing
    lp, tp = np.array([le.point.x, le.point.y]), np.array([te.point.x, te.point.y])
    return {"le": lp.tolist(), "te": tp.tolist(), "chord": float(np.linalg.norm(tp - lp)),
            "le_radius": le.geometry.radius, "te_radius": te.geometry.radius,
            "max_thickness": 2.0 * g.max_thickness_circle().radius}


def densify(xy: np.ndarray, n: int = 4000) -> np.ndarray:
    from scipy.interpolate import splev, splprep
    closed = np.vstack([xy, xy[:1]])
    tck, _ = splprep(closed.T, s=0, per=1)
    x, y = splev(np.arange(n) / n, tck)
    return np.column_stack([x, y])


def main() -> None:
    data = np.load(sys.argv[1])
    flow = tuple(float(v) for v in sys.argv[3].split(","))
    tol = float(sys.argv[4]) if len(sys.argv) > 4 else 1e-4
    spline = len(sys.argv) > 5 and sys.argv[5] == "spline"
    out = []
    t0 = time.perf_counter()
    for k in range(len(data.files)):
        p = data[f"s{k}"]
        try:
            xy = np.ascontiguousarray(p[:, :2])
            if spline:
                xy = densify(xy)
            out.append(measure(xy, flow, tol))
        except Exception as err:       # a failed section is a result of the peer, not of the bench
            out.append({"error": str(err)})
    json.dump({"sections": out, "seconds": time.perf_counter() - t0}, open(sys.argv[2], "w"))


if __name__ == "__main__":
    main()
