# SPDX-License-Identifier: LGPL-2.1-or-later
"""Point -> surface / curve minimum distance (seed 001 §2 eqs. 10-11): bladerecon.core.geometry.projection.

Checked against closed forms, orthogonality, dense brute force (then polished by a local
Newton from the brute-force optimum, so that a wrong root shows as a larger distance),
scipy, and OpenCASCADE's own projection on a thin blade with ~0.6 mm edge radii.
"""
from __future__ import annotations

import os
import time

import numpy as np
import pytest
from scipy.interpolate import BSpline
from scipy.optimize import minimize_scalar
from scipy.spatial import cKDTree

from bladerecon.core.geometry.projection import cache as proj_cache
from bladerecon.core.geometry.projection import evaluation as proj_evaluation
from bladerecon.core.geometry.projection import grid as proj_grid
from bladerecon.core.geometry.projection import parallel as proj_parallel
from bladerecon.core.geometry.projection import points as proj_points
from bladerecon.core.geometry.projection import search as proj_search
from bladerecon.core.geometry.projection import surface as proj_surface
from bladerecon.core.geometry.bspline import curve_curvature, curve_derivatives, evaluate_surface, surface_derivatives
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.projection import (
    distance_stats,
    project_points_to_curve,
    project_points_to_surface,
)
from bladerecon.core.geometry.spline import BSplineCurve, BSplineSurface

HUB_Z = 200.0


# --------------------------------------------------------------------------- test shapes
def _section(n: int, chord: float, camber: float, r_le: float = 0.9, r_te: float = 0.7, t_half: float = 1.6):
    """Closed thin cambered profile, n points clustered at both round edges (x, y), mm."""
    th = 2 * np.pi * np.arange(n) / n
    x = 0.5 * chord * (1 - np.cos(th))
    side = np.where(th <= np.pi, 1.0, -1.0)
    s = x / chord
    nose = np.sqrt(2 * r_le * x) + 1e-9
    tail = np.sqrt(2 * r_te * np.maximum(chord - x, 0.0)) + 1e-9
    body = t_half * (0.6 + 1.6 * s * (1 - s))
    tau = (nose**-4 + tail**-4 + body**-4) ** -0.25          # soft minimum: round edges
    y = 4 * camber * s * (1 - s)
    dy = 4 * camber * (1 - 2 * s) / chord
    nx, ny = -dy / np.hypot(1, dy), 1 / np.hypot(1, dy)
    return np.column_stack([x + side * tau * nx - chord / 2, y + side * tau * ny])


def blade_surface(nu: int = 40, nv: int = 8, span: float = 60.0) -> BSplineSurface:
    """Twisted, tapered thin blade: u periodic around the section, v clamped along the span.

    The profile points are used as poles, so the edges are rounded by the spline itself:
    leading/trailing edge radii come out at about 0.6 mm and the sides are ~1-3 mm apart.
    """
    rows = []
    for z in np.linspace(0.0, span, nv):
        f = z / span
        xy = _section(nu, chord=50 - 10 * f, camber=4 + 2 * f)
        a = np.radians(30 * f)
        xy = xy @ np.array([[np.cos(a), np.sin(a)], [-np.sin(a), np.cos(a)]])
        rows.append(np.column_stack([xy, np.full(nu, HUB_Z + z)]))
    poles = np.stack(rows, axis=1)
    v_knots = np.concatenate([[0.0], np.linspace(0, 1, nv - 2)[1:-1], [1.0]])
    v_mults = np.r_[4, np.ones(nv - 4, int), 4]
    return BSplineSurface(poles, np.linspace(0, 1, nu + 1), np.ones(nu + 1, int), v_knots, v_mults, 3, 3, True, False)


def torus_surface(R: float = 20.0, r: float = 5.0, nu: int = 12, nv: int = 8) -> BSplineSurface:
    """Torus-like surface periodic in both directions, non-uniform knots in u."""
    a = 2 * np.pi * np.arange(nu) / nu
    b = 2 * np.pi * np.arange(nv) / nv
    A, B = np.meshgrid(a, b, indexing="ij")
    poles = np.stack([(R + r * np.cos(B)) * np.cos(A), (R + r * np.cos(B)) * np.sin(A), r * np.sin(B)], axis=-1)
    steps = 1 + 0.3 * np.sin(np.arange(nu))
    u_knots = np.concatenate([[0.0], np.cumsum(steps)]) / steps.sum()
    return BSplineSurface(
        poles, u_knots, np.ones(nu + 1, int), np.linspace(0, 1, nv + 1), np.ones(nv + 1, int), 3, 3, True, True
    )


def plane_patch() -> BSplineSurface:
    """S(u, v) = (10 u, 20 v, 0) on [0, 1]^2: clamped cubic, poles at the Greville abscissae."""
    knots = np.array([0.0, 0.3, 0.5, 1.0])
    mults = np.array([4, 1, 1, 4])
    full = np.repeat(knots, mults)
    greville = np.array([full[i + 1 : i + 4].mean() for i in range(5)])
    G = np.meshgrid(greville, greville, indexing="ij")
    poles = np.stack([10 * G[0], 20 * G[1], np.zeros_like(G[0])], axis=-1)
    return BSplineSurface(poles, knots, mults, knots, mults, 3, 3, False, False)


def _unit_normals(surface: BSplineSurface, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    d = surface_derivatives(surface, u, v, 1)
    n = np.cross(d[:, 1, 0], d[:, 0, 1])
    return d[:, 0, 0], n / np.linalg.norm(n, axis=1)[:, None]


def _polished_brute_force(surface: BSplineSurface, points: np.ndarray, n_u: int, n_v: int) -> tuple[np.ndarray, object]:
    """Dense-sampling minimum distance, and a local Newton from each dense optimum."""
    u_end = not surface.u_periodic
    v_end = not surface.v_periodic
    gu = np.linspace(*surface.u_domain, n_u, endpoint=u_end)
    gv = np.linspace(*surface.v_domain, n_v, endpoint=v_end)
    U, V = (a.ravel() for a in np.meshgrid(gu, gv, indexing="ij"))
    dense_d, k = cKDTree(evaluate_surface(surface, U, V)).query(points, workers=-1)
    return dense_d, project_points_to_surface(surface, points, U[k], V[k])


def _cosines(surface: BSplineSurface, res, points: np.ndarray) -> np.ndarray:
    """|S_u·(S-P)| / (|S_u||S-P|) and the same for S_v, the larger of the two, at the feet."""
    d = surface_derivatives(surface, res.u, res.v, 1)
    off = d[:, 0, 0] - points
    cos = []
    for der in (d[:, 1, 0], d[:, 0, 1]):
        cos.append(np.abs(np.sum(der * off, axis=1)) / (np.linalg.norm(der, axis=1) * np.linalg.norm(off, axis=1)))
    return np.maximum(*cos)


def _freecad():
    from bladerecon.fc.freecad_env import import_freecad

    try:
        return import_freecad()
    except BladeReconError as err:
        pytest.skip(f"FreeCAD not available: {err}")


def _to_part(Part, FreeCAD, s: BSplineSurface):
    V = FreeCAD.Vector
    bs = Part.BSplineSurface()
    bs.buildFromPolesMultsKnots(
        [[V(*map(float, p)) for p in row] for row in s.poles],
        [int(m) for m in s.u_mults], [int(m) for m in s.v_mults],
        [float(k) for k in s.u_knots], [float(k) for k in s.v_knots],
        s.u_periodic, s.v_periodic, s.u_degree, s.v_degree,
    )
    return bs


def _near_blade_points(s: BSplineSurface, m: int, rng: np.random.Generator) -> np.ndarray:
    """Half spread over the blade, half around its edges (u near 0 and 0.5), inside and out."""
    u = rng.random(m)
    u[m // 2 : 3 * m // 4] = 0.5 + rng.uniform(-0.06, 0.06, m // 4)      # trailing edge
    u[3 * m // 4 :] = rng.uniform(-0.06, 0.06, m - 3 * m // 4) % 1.0      # leading edge
    v = rng.random(m)
    foot, n = _unit_normals(s, u, v)
    off = np.where(np.arange(m) < m // 2, rng.normal(scale=0.3, size=m), rng.uniform(-1.3, 1.3, size=m))
    pts = foot + n * off[:, None] + rng.normal(scale=0.1, size=(m, 3))
    pts[:20, 2] = HUB_Z - 2 * rng.random(20)            # beyond the hub and tip edges
    pts[20:40, 2] = HUB_Z + 60 + 2 * rng.random(20)
    return pts


# --------------------------------------------------------------------------- evaluation
@pytest.mark.parametrize("make", [blade_surface, torus_surface, plane_patch])
def test_patch_table_matches_nurbs_book_evaluator(make):
    s = make()
    rng = np.random.default_rng(0)
    u = rng.uniform(*s.u_domain, 3000)
    v = rng.uniform(*s.v_domain, 3000)
    v[:5] = s.v_domain[1]
    ref = surface_derivatives(s, u, v, 2)
    ders = proj_evaluation._SurfaceModel(s).evaluate(u, v, 2)[4]
    for (k, l), a in zip([(0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)], ders):
        scale = max(np.abs(ref[:, k, l]).max(), np.abs(ref[:, 0, 0]).max())
        assert np.abs(a.T - ref[:, k, l]).max() <= 1e-12 * scale


def test_interval_lookup_matches_binary_search():
    rng = np.random.default_rng(13)
    for _ in range(200):
        b = np.unique(np.concatenate([[0.0, 1.0], rng.random(rng.integers(1, 60)) ** rng.uniform(0.2, 2)])) * 3.7 - 1.1
        just_below, just_above = np.nextafter(b[1:], -np.inf), np.nextafter(b[:-1], np.inf)
        u = np.concatenate([rng.uniform(b[0], b[-1], 2000), b, just_below, just_above])
        ref = np.clip(np.searchsorted(b, u, side="right") - 1, 0, b.size - 2)
        assert np.array_equal(proj_evaluation._Intervals(b)(u), ref)


# --------------------------------------------------------------------------- analytic
def test_plane_patch_closed_form_inside_and_beyond_the_boundary():
    s = plane_patch()
    P = np.array([[3.0, 7.0, 2.5], [3.0, 7.0, -1.0], [12.0, 5.0, 3.0], [-2.0, -3.0, 1.0], [4.0, 25.0, -2.0]])
    foot = np.array([[3.0, 7.0, 0.0], [3.0, 7.0, 0.0], [10.0, 5.0, 0.0], [0.0, 0.0, 0.0], [4.0, 20.0, 0.0]])
    res = project_points_to_surface(s, P)
    assert np.allclose(res.foot, foot, atol=1e-10)
    assert np.allclose(res.distance, np.linalg.norm(P - foot, axis=1), atol=1e-10)
    assert np.allclose(res.u, foot[:, 0] / 10, atol=1e-12) and np.allclose(res.v, foot[:, 1] / 20, atol=1e-12)
    assert np.array_equal(np.sign(res.signed), np.sign(P[:, 2]))         # S_u x S_v = +z
    assert np.allclose(res.normal, [0, 0, 1], atol=1e-12)
    assert res.converged.all()


def test_torus_orthogonality_and_brute_force():
    s = torus_surface()
    rng = np.random.default_rng(1)
    u, v = rng.random(3000), rng.random(3000)
    foot, n = _unit_normals(s, u, v)
    pts = foot + n * rng.uniform(-4.0, 6.0, size=(3000, 1)) + rng.normal(scale=0.5, size=(3000, 3))
    res = project_points_to_surface(s, pts)
    assert res.converged.all()
    far = res.distance > 1e-3
    assert _cosines(s, res, pts)[far].max() < 1e-9
    dense, polished = _polished_brute_force(s, pts, 1200, 600)
    assert (res.distance <= dense + 1e-9).all()
    assert (res.distance <= polished.distance + 1e-9).all()


def test_beyond_the_tip_edge_the_foot_is_on_the_end_section():
    """Past the clamped end of the span the foot is on the end section: the same point as
    the curve projection onto that section (the boundary case of the Newton iteration)."""
    s = blade_surface()
    edge = BSplineCurve(s.poles[:, -1], s.u_knots, s.u_mults, 3, True)
    rng = np.random.default_rng(2)
    t = rng.random(400)
    on_edge = curve_derivatives(edge, t, 0)[:, 0]
    pts = on_edge + np.column_stack([rng.normal(scale=0.3, size=(400, 2)), rng.uniform(1.0, 5.0, 400)])
    res = project_points_to_surface(s, pts)
    ref = project_points_to_curve(edge, pts)
    assert (res.v == 1.0).all() and res.converged.all()
    assert np.abs(res.distance - ref.distance).max() < 1e-9
    assert np.abs(res.foot - ref.foot).max() < 1e-7


def creased_surface() -> BSplineSurface:
    """Periodic u with a double (C1) knot, clamped v with a triple knot: a 16 degree crease."""
    rng = np.random.default_rng(14)
    nu, nv = 10, 9
    a = 2 * np.pi * np.arange(nu) / nu
    rows = [np.column_stack([(8 + 2 * np.sin(z / 10)) * np.cos(a), (5 + np.cos(z / 10)) * np.sin(a), np.full(nu, z)])
            for z in np.linspace(0, 30, nv)]
    poles = np.stack(rows, axis=1) + rng.normal(scale=0.3, size=(nu, nv, 3))
    u_knots = np.sort(np.concatenate([[0, 1], rng.random(nu - 2)]))
    u_mults = np.ones(nu, int)
    u_mults[3] = 2
    v_knots, v_mults = np.array([0, 0.25, 0.5, 0.75, 1.0]), np.array([4, 1, 3, 1, 4])
    return BSplineSurface(poles, u_knots, u_mults, v_knots, v_mults, 3, 3, True, False)


def test_creased_surface_feet_on_and_beside_the_crease():
    """A C0 knot line is a fold: there Newton holds the parameter on the crease (a
    boundary minimum of each smooth piece) and tries the piece on the other side."""
    s = creased_surface()
    rng = np.random.default_rng(15)
    u, v = rng.random(3000), rng.random(3000)
    foot, n = _unit_normals(s, u, v)
    pts = foot + n * rng.normal(scale=1.0, size=(3000, 1)) + rng.normal(scale=0.3, size=(3000, 3))
    below, n1 = _unit_normals(s, u[:1000], np.full(1000, 0.5 - 1e-12))
    _, n2 = _unit_normals(s, u[:1000], np.full(1000, 0.5))
    bisector = (n1 + n2) / np.linalg.norm(n1 + n2, axis=1)[:, None]
    pts = np.concatenate([pts, below + 0.5 * bisector, below - 0.5 * bisector])
    res = project_points_to_surface(s, pts)
    assert res.converged.all()
    assert np.sum(res.v == 0.5) > 500                     # feet held on the crease itself
    dense, polished = _polished_brute_force(s, pts, 1500, 1001)
    assert (res.distance <= dense + 1e-9).all()
    assert (res.distance <= polished.distance + 1e-9).all()


def cone_surface() -> BSplineSurface:
    """A cone whose apex row of poles collapses to one point (S_u = 0 at v = 1)."""
    a = 2 * np.pi * np.arange(12) / 12
    rows = [np.column_stack([10 * (1 - f) * np.cos(a), 10 * (1 - f) * np.sin(a), np.full(12, 20 * f)])
            for f in np.linspace(0, 1, 6)]
    v_knots, v_mults = np.array([0, 1 / 3, 2 / 3, 1.0]), np.array([4, 1, 1, 4])
    u_knots, u_mults = np.linspace(0, 1, 13), np.ones(13, int)
    return BSplineSurface(np.stack(rows, axis=1), u_knots, u_mults, v_knots, v_mults, 3, 3, True, False)


def _bumpy_poles() -> np.ndarray:
    g = np.stack([*np.meshgrid(np.arange(5) * 10.0, np.arange(4) * 10.0, indexing="ij"), np.zeros((5, 4))], axis=-1)
    return g + np.random.default_rng(17).normal(scale=3.0, size=(5, 4, 3))


def bilinear_surface() -> BSplineSurface:
    knots_u, knots_v = np.array([0, 0.25, 0.5, 0.75, 1]), np.array([0, 1 / 3, 2 / 3, 1])
    return BSplineSurface(_bumpy_poles(), knots_u, np.array([2, 1, 1, 1, 2]), knots_v, np.array([2, 1, 1, 2]), 1, 1)


def biquadratic_c0_surface() -> BSplineSurface:
    knots = np.array([0, 0.5, 1])
    return BSplineSurface(_bumpy_poles(), knots, np.array([3, 2, 3]), knots, np.array([3, 1, 3]), 2, 2)


@pytest.mark.parametrize("make, centre, spread", [
    (cone_surface, (0.0, 0.0, 20.0), 2.0),               # around the apex
    (bilinear_surface, None, 3.0),                       # every knot a crease
    (biquadratic_c0_surface, None, 3.0),                 # minima side by side at a corner
    (blade_surface, (0.0, 0.0, 0.0), 1e4),               # 10 m away: feet on the hub or tip edge
])
def test_collapsed_low_degree_and_far(make, centre, spread):
    s = make()
    rng = np.random.default_rng(18)
    if centre is None:
        pts = evaluate_surface(s, rng.random(3000), rng.random(3000)) + rng.normal(scale=spread, size=(3000, 3))
    else:
        pts = np.asarray(centre) + rng.normal(scale=spread, size=(3000, 3))
    res = project_points_to_surface(s, pts)
    assert res.converged.all() and np.isfinite(res.normal).all()
    dense, polished = _polished_brute_force(s, pts, 1000, 600)
    slack = 1e-9 * max(1.0, spread / 100)                 # rounding grows with the distance
    assert (res.distance <= dense + slack).all()
    assert (res.distance <= polished.distance + slack).all()


# --------------------------------------------------------------------------- blade
def test_blade_against_polished_brute_force_with_points_around_the_edges():
    s = blade_surface()
    pts = _near_blade_points(s, 6000, np.random.default_rng(4))
    res = project_points_to_surface(s, pts)
    assert res.converged.all()
    dense, polished = _polished_brute_force(s, pts, 4000, 300)
    assert (res.distance <= dense + 1e-9).all()
    worse = res.distance - polished.distance
    assert worse.max() <= 1e-9, f"wrong root for {np.sum(worse > 1e-9)} points"


def test_signed_distance_of_known_offsets_and_points_on_the_surface():
    s = blade_surface()
    rng = np.random.default_rng(5)
    u, v = rng.random(4000), rng.random(4000)
    foot, n = _unit_normals(s, u, v)
    delta = np.where(rng.random(4000) < 0.5, -0.2, 0.25)       # below the ~0.6 mm edge radii
    res = project_points_to_surface(s, foot + delta[:, None] * n)
    assert np.abs(res.signed - delta).max() < 1e-9
    assert np.abs(res.distance - np.abs(delta)).max() < 1e-9
    assert np.abs((res.u - u + 0.5) % 1.0 - 0.5).max() < 1e-9 and np.abs(res.v - v).max() < 1e-9
    assert np.abs(np.sum(res.normal * n, axis=1) - 1).max() < 1e-12
    on = project_points_to_surface(s, foot)
    assert on.distance.max() < 1e-9 and on.converged.all()


def test_against_opencascade_on_a_thin_blade():
    FreeCAD, Part = _freecad()
    s = blade_surface()
    bs = _to_part(Part, FreeCAD, s)
    rng = np.random.default_rng(6)
    u, v = rng.random(200), rng.random(200)
    occ_value = np.array([tuple(bs.value(a, b)) for a, b in zip(u, v)])
    assert np.abs(occ_value - evaluate_surface(s, u, v)).max() < 1e-9    # same spline in both
    pts = _near_blade_points(s, 2000, rng)
    res = project_points_to_surface(s, pts)
    face = bs.toShape()
    occ = np.array([Part.Vertex(FreeCAD.Vector(*p)).distToShape(face)[0] for p in pts])
    diff = np.abs(res.distance - occ)
    print(f"\nvs OpenCASCADE distToShape, 2000 points: max |difference| {diff.max():.2e} mm")
    assert diff.max() <= 1e-6


def test_local_projection_from_given_parameters():
    s = blade_surface()
    rng = np.random.default_rng(7)
    u, v = rng.random(500), rng.random(500)
    foot, n = _unit_normals(s, u, v)
    pts = foot + 0.05 * n
    res = project_points_to_surface(s, pts, u + 0.004, np.clip(v - 0.01, 0, 1))
    assert res.converged.all() and np.abs(res.distance - 0.05).max() < 1e-9


def test_blocks_and_threads_give_the_same_answer(monkeypatch):
    s = blade_surface()
    pts = _near_blade_points(s, 40_000, np.random.default_rng(8))
    monkeypatch.setattr(proj_parallel, "_THREADS", 1)
    one = project_points_to_surface(s, pts)
    monkeypatch.setattr(proj_parallel, "_THREADS", 2)
    monkeypatch.setattr(proj_surface, "_CHUNK", 7000)
    two = project_points_to_surface(s, pts)
    assert np.array_equal(one.distance, two.distance) and np.array_equal(one.u, two.u)


# Points inside the sample nominal (900 x 21 poles) near its thin trailing edge, where the
# grid-start search alone stopped 6 nm to 2.6 µm farther than the
# closest foot (found among 1 000 000 points spread like bench/bench_deviation.py's).
_TE_POINTS = np.array([
    [23.338622171066728, 13.941908837977108, 7.839029350877238],
    [21.78430348812766, 16.720227324126515, 26.0631146355806],
    [21.774880869071076, 16.757688667341856, 26.364912180840186],
    [21.66605038204694, 16.891979849833895, 28.18658119860012],
    [23.18484476128657, 14.148878131111314, 9.966723529773668],
    # two feet 95 nm and 0.5 nm apart in distance, side by side where the circular trailing
    # edge meets a flank: stopping the extra Newton runs early (when they come within a
    # cell of the first foot) missed the closer one with other grid sizes
    [20.606328061436887, 18.58666089489436, 52.90762454523905],
    [22.495407170560817, 15.166834716309111, 20.343683616374474],
])


@pytest.fixture
def fresh_cache():
    """The start-grid cache empty before and after, whatever the test does or fails at (tests
    that change the grid's settings must not leave their grids to the next test)."""
    proj_cache._cache.clear()
    yield
    proj_cache._cache.clear()


def test_feet_round_a_thin_edge_are_found(monkeypatch, fresh_cache):
    """Near a centre of curvature of the trailing edge the closest foot can lie round the
    edge from the one the grid start leads to; the restarts moved round the edge find it.
    Referee: dense sampling of the edge region polished by local Newton."""
    from bladerecon.samples.blade import SampleBlade, nominal_surface

    s = nominal_surface(SampleBlade())
    ours = project_points_to_surface(s, _TE_POINTS)
    gu = np.linspace(0.40, 0.55, 6000)
    gv = np.linspace(0.0, 1.0, 400)
    U, V = (a.ravel() for a in np.meshgrid(gu, gv, indexing="ij"))
    _, k = cKDTree(evaluate_surface(s, U, V)).query(_TE_POINTS)
    ref = project_points_to_surface(s, _TE_POINTS, U[k], V[k])
    assert np.all(ours.distance <= ref.distance + 1e-9), ours.distance - ref.distance
    assert ours.converged.all()
    monkeypatch.setattr(proj_search, "_TURN", np.inf)       # without the restarts round the edge
    without = project_points_to_surface(s, _TE_POINTS)
    assert (without.distance > ref.distance + 1e-6).sum() >= 3
    monkeypatch.undo()                                      # the restarts back
    for n_grid in (30_000, 120_000):                        # the same feet from other start grids
        monkeypatch.setattr(proj_grid, "_MAX_GRID_SAMPLES", n_grid)
        proj_cache._cache.clear()
        other = project_points_to_surface(s, _TE_POINTS)
        assert np.allclose(other.distance, ours.distance, rtol=0, atol=1e-12), n_grid
    proj_cache._cache.clear()


def _nominal():
    from bladerecon.samples.blade import SampleBlade, nominal_surface

    return nominal_surface(SampleBlade())


@pytest.mark.parametrize("make", [_nominal, blade_surface, torus_surface, creased_surface])
def test_strip_bound_holds_inside_the_cells_round_a_sample(make, fresh_cache):
    """The thin covers of the start grid (long cells round a tight nose): every surface point
    in the cells round a sample is at least ``strip_gap`` from any point, checked on surface
    points at random inside random cells and on points off them (periodic, clamped and
    creased directions)."""
    s = make()
    proj_cache._cache.clear()
    _, grid = proj_cache._surface_grid(s)
    assert grid.strips is not None
    rng = np.random.default_rng(41)
    n = 100_000
    k = rng.integers(0, grid.size, n)
    cells = grid.sample_cells(k)
    feet = []
    for axis, (g, size, closed, lo, hi) in enumerate(zip(grid.params, grid.sizes, grid.periodic,
                                                        (s.u_knots[0], s.v_knots[0]), (s.u_knots[-1], s.v_knots[-1]))):
        step = rng.choice([-1, 1], n)
        j = cells[axis] + step
        if closed:
            other = g[j % size] + (hi - lo) * (j // size)
        else:
            other = np.where((j >= 0) & (j < size), g[np.clip(j, 0, size - 1)], g[cells[axis]])
        feet.append(g[cells[axis]] + rng.random(n) * (other - g[cells[axis]]))
    S = evaluate_surface(s, *feet)
    P = S + rng.normal(size=(n, 3)) * rng.choice([0.01, 0.3, 2.0], n)[:, None]
    bound = grid.strip_gap(np.ascontiguousarray(P.T), k)
    assert np.all(bound <= np.linalg.norm(P - S, axis=1) + 1e-12)
    # where the cells are long (round the nominal's tight edges) it is tighter than the ball
    # of cover round the sample
    long = grid.strips.reshape(4, -1).min(axis=0)[k] < 0.25 * grid.cover[k]
    iso = np.linalg.norm(P - grid.tree.data[k], axis=1) - grid.cover[k]
    if make is _nominal:
        assert long.sum() > 1000 and np.mean(bound[long] > iso[long]) > 0.5
    proj_cache._cache.clear()


def test_forked_blocks_threads_and_one_process_agree(monkeypatch):
    """The blocks give the same feet whether they run here, in forked children (shared
    memory) or on threads; a child that fails has its blocks rerun by the parent."""
    s = blade_surface()
    pts = _near_blade_points(s, 30_000, np.random.default_rng(18))
    monkeypatch.setattr(proj_surface, "_CHUNK", 4000)
    monkeypatch.setattr(proj_search, "_MIN_BATCH", 500)
    runs = {}
    for name, threads, fork in (("one", 1, False), ("forked", 2, True), ("threads", 2, False)):
        monkeypatch.setattr(proj_parallel, "_THREADS", threads)
        monkeypatch.setattr(proj_parallel, "_can_fork", lambda fork=fork: fork)
        runs[name] = project_points_to_surface(s, pts)
    monkeypatch.undo()
    monkeypatch.setenv("BLADERECON_PROCESSES", "0")
    assert not proj_parallel._can_fork()
    for name in ("forked", "threads"):
        for field in ("u", "v", "distance", "signed"):
            assert np.array_equal(getattr(runs[name], field), getattr(runs["one"], field)), (name, field)
    parent = os.getpid()
    out = proj_parallel._shared((12,))

    def work(s0: int, e0: int, workers: int) -> None:
        if os.getpid() != parent:
            raise RuntimeError("a child that fails")
        out[s0:e0] = np.arange(s0, e0)

    monkeypatch.setattr(proj_parallel, "_THREADS", 3)
    monkeypatch.setattr(proj_parallel, "_can_fork", lambda: True)
    proj_parallel._for_each_block(12, work, chunk=2, shared=True)
    assert np.array_equal(out, np.arange(12))


# --------------------------------------------------------------------------- curves
def _clamped_curve() -> BSplineCurve:
    rng = np.random.default_rng(9)
    n = 12
    t = np.linspace(0, 3 * np.pi, n)
    poles = np.column_stack([10 * np.cos(t), 10 * np.sin(t), 3 * t]) + rng.normal(scale=0.5, size=(n, 3))
    knots = np.concatenate([[0.0], np.sort(rng.uniform(0.05, 0.95, n - 4)), [1.0]])
    return BSplineCurve(poles, knots, np.r_[4, np.ones(n - 4, int), 4], 3, False)


def test_curve_projection_against_brute_force_and_scipy():
    c = _clamped_curve()
    rng = np.random.default_rng(10)
    t = rng.random(600)
    pts = curve_derivatives(c, t, 0)[:, 0] + rng.normal(scale=2.0, size=(600, 3))
    pts[:10] = c.poles[0] - [3, 0, 4]                           # beyond the ends
    res = project_points_to_curve(c, pts)
    assert res.converged.all()
    dense_t = np.linspace(0, 1, 200_001)
    dense_d, k = cKDTree(curve_derivatives(c, dense_t, 0)[:, 0]).query(pts)
    assert (res.distance <= dense_d + 1e-9).all()
    sp = BSpline(c.full_knots(), c.poles, 3)
    h = dense_t[1]
    for p, t0, d in zip(pts[::10], dense_t[k[::10]], res.distance[::10]):
        best = minimize_scalar(lambda x: np.sum((sp(x) - p) ** 2), bounds=(max(t0 - h, 0), min(t0 + h, 1)),
                               method="bounded", options={"xatol": 1e-12})
        assert d <= np.sqrt(best.fun) + 1e-9 and np.sqrt(best.fun) - d < 1e-7


def test_many_points_on_a_plane_curve_in_blocks():
    """More points than a block on a 2D curve: they are put in voxel order (any dimension)
    and give the same feet as a few at a time."""
    c3 = _clamped_curve()
    c = BSplineCurve(poles=np.asarray(c3.poles)[:, :2], knots=c3.knots, mults=c3.mults,
                     degree=c3.degree, periodic=c3.periodic)
    P = np.random.default_rng(7).normal(size=(proj_parallel._CHUNK + 5000, 2)) * 5.0
    many = project_points_to_curve(c, P)
    few = project_points_to_curve(c, P[-500:])
    assert np.array_equal(many.distance[-500:], few.distance)
    assert np.array_equal(many.t[-500:], few.t)


def test_periodic_section_curve_with_tight_edges():
    s = blade_surface()
    c = BSplineCurve(s.poles[:, 3, :2], s.u_knots, s.u_mults, 3, True)      # a 2D section
    assert 1 / curve_curvature(c, np.linspace(0, 1, 4000)).max() < 0.7
    rng = np.random.default_rng(11)
    t = np.concatenate([rng.random(1000), rng.uniform(-0.06, 0.06, 500) % 1, 0.5 + rng.uniform(-0.06, 0.06, 500)])
    d = curve_derivatives(c, t, 1)
    n = np.column_stack([d[:, 1, 1], -d[:, 1, 0]]) / np.linalg.norm(d[:, 1], axis=1)[:, None]
    pts = d[:, 0] + n * rng.uniform(-1.3, 1.3, (2000, 1))
    res = project_points_to_curve(c, pts)
    dense_t = np.linspace(0, 1, 400_000, endpoint=False)
    _, k = cKDTree(curve_derivatives(c, dense_t, 0)[:, 0]).query(pts)
    polished = project_points_to_curve(c, pts, dense_t[k])
    assert res.converged.all()
    assert (res.distance <= polished.distance + 1e-9).all()
    on = project_points_to_curve(c, d[:, 0])
    assert on.distance.max() < 1e-9


def test_curve_with_a_corner():
    """A triple knot in a cubic: the closest point of points outside the corner is the corner."""
    poles = np.array([[0, 0], [3, 1], [6, 0], [8, 0], [10, 3], [11, 6], [14, 7]], dtype=float)
    c = BSplineCurve(poles, np.array([0, 0.5, 1.0]), np.array([4, 3, 4]), 3, False)
    corner = poles[3]
    rng = np.random.default_rng(16)
    ang = rng.uniform(-np.pi, np.pi, 1500)
    pts = corner + rng.uniform(0.05, 2.0, (1500, 1)) * np.column_stack([np.cos(ang), np.sin(ang)])
    res = project_points_to_curve(c, pts)
    dense_t = np.linspace(0, 1, 400_001)
    _, k = cKDTree(curve_derivatives(c, dense_t, 0)[:, 0]).query(pts)
    polished = project_points_to_curve(c, pts, dense_t[k])
    assert res.converged.all() and np.sum(res.t == 0.5) > 100
    assert (res.distance <= polished.distance + 1e-9).all()


# --------------------------------------------------------------------------- statistics, inputs
def test_distance_stats():
    st = distance_stats(np.array([0.1, -0.3, 0.2, 0.0]))
    assert st["n"] == 4 and st["max"] == pytest.approx(0.3) and st["min"] == 0.0
    assert st["mean"] == pytest.approx(0.15) and st["std"] == pytest.approx(np.std([0.1, 0.3, 0.2, 0.0]))
    assert st["rms"] == pytest.approx(np.sqrt(0.14 / 4))
    assert st["min_signed"] == pytest.approx(-0.3) and st["max_signed"] == pytest.approx(0.2)
    assert "min_signed" not in distance_stats(np.array([0.1, 0.2]))
    assert distance_stats(np.array([0.1, 0.2]), signed=True)["min_signed"] == pytest.approx(0.1)
    with pytest.raises(BladeReconError):
        distance_stats(np.array([]))


def test_bad_input():
    s = plane_patch()
    with pytest.raises(BladeReconError, match="NaN"):
        project_points_to_surface(s, np.array([[0.0, 0.0, 0.0], [np.nan, 1.0, 1.0]]))
    with pytest.raises(BladeReconError, match="row 2"):          # inf, and a sum that overflows
        project_points_to_surface(s, np.array([[1e308, 0.0, 0.0], [1e308, 0.0, 0.0], [0.0, -np.inf, 0.0]]))
    big = np.array([[1e308, 0.0, 0.0], [1e308, 0.0, 0.0]])           # finite, but their squares overflow
    with pytest.raises(BladeReconError, match=r"2 point\(s\) have coordinates beyond 1e\+100 mm \(first at row 0\)"):
        proj_points._check_points(big, 3)
    many = np.full((4000, 3), 1e98)                 # each within the limit, their squares' sum beyond
    assert proj_points._check_points(many, 3) is many or np.array_equal(proj_points._check_points(many, 3), many)
    with pytest.raises(BladeReconError, match=r"\(m, 3\)"):
        project_points_to_surface(s, np.zeros((4, 2)))
    with pytest.raises(ValueError):
        project_points_to_surface(s, np.zeros((4, 3)), u0=np.zeros(4))
    empty = project_points_to_surface(s, np.zeros((0, 3)))
    assert empty.distance.shape == (0,) and empty.foot.shape == (0, 3)


# --------------------------------------------------------------------------- speed
def test_speed_one_million_points_print():
    """Not a timed assert: prints the time for 1 000 000 measured-like points (within
    0.05 mm of the surface, spread evenly over its area) on the 40 x 8-pole blade."""
    m = int(os.environ.get("BLADERECON_BENCH_POINTS", "1000000"))
    s = blade_surface()
    rng = np.random.default_rng(12)
    model, batches, count = proj_evaluation._SurfaceModel(s), [], 0
    while count < m:
        S, Su, Sv = model.evaluate(rng.random(m), rng.random(m), 1)[4]
        n = np.cross(Su.T, Sv.T)
        area = np.linalg.norm(n, axis=1)
        keep = np.flatnonzero(rng.random(m) * area.max() < area)            # even over the area
        batches.append(S.T[keep] + n[keep] / area[keep, None] * rng.normal(scale=0.05, size=(keep.size, 1)))
        count += keep.size
    pts = np.concatenate(batches)[:m]
    wall, cpu = time.perf_counter(), time.process_time()
    res = project_points_to_surface(s, pts)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    print(f"\n{pts.shape[0]} points on a 40 x 8-pole surface: {wall:.2f} s wall, {cpu:.2f} s CPU "
          f"({proj_parallel._THREADS} threads, load {os.getloadavg()[0]:.1f}); converged {res.converged.mean():.6f}")
    assert res.converged.all() and res.distance.max() < 0.5


def test_normals_at_and_near_a_collapsed_apex_point_outward():
    """The cone's normal is known in closed form away from the apex: (2 cos a, 2 sin a, 1)/√5
    (radius 10 - z/2), and S_u x S_v points that way. A point whose foot is the apex (S_u = 0)
    lies above it, outside the cone: its normal is the direction to it and its signed distance
    positive (the limit normal of any one u alone may be at right angles to that direction and
    give either sign). Everywhere the signed distance has the sign of (P - foot)·n."""
    s = cone_surface()
    rng = np.random.default_rng(18)
    pts = np.array([0.0, 0.0, 20.0]) + rng.normal(scale=2.0, size=(3000, 3))
    res = project_points_to_surface(s, pts)

    def outward(xyz):
        r = np.hypot(xyz[:, 0], xyz[:, 1])
        n = np.column_stack([2 * xyz[:, 0] / r, 2 * xyz[:, 1] / r, np.ones(len(r))])
        return n / np.linalg.norm(n, axis=1, keepdims=True)

    apex = np.hypot(res.foot[:, 0], res.foot[:, 1]) < 1e-6
    assert 100 < apex.sum() < 2900                       # both kinds of feet are tested
    off = ~apex
    # the 12-pole periodic cubic is a circle to ~0.02 %: its normal is the cone's to about 1°
    assert np.einsum("ij,ij->i", res.normal[off], outward(res.foot[off])).min() > 0.999
    # apex feet: the points lie above the apex, inside the cone of its normals (63.4° about +z
    # for the exact cone; the cubic's radius runs 2-4 % under its poles', so up to ~65°)
    up = (pts[apex] - res.foot[apex]) / res.distance[apex, None]
    assert up[:, 2].min() > np.cos(np.radians(66.0))
    assert np.einsum("ij,ij->i", res.normal[apex], up).min() > 1 - 1e-9
    assert (res.signed[apex] > 0).all()
    side = np.einsum("ij,ij->i", pts - res.foot, res.normal)
    assert np.allclose(res.signed, np.sign(side) * res.distance, atol=1e-9)
    # the same cone with its normal turned inward (u reversed): every sign reverses
    flipped = BSplineSurface(s.poles[::-1], s.u_knots, s.u_mults, s.v_knots, s.v_mults, 3, 3, True, False)
    back = project_points_to_surface(flipped, pts)
    assert np.allclose(back.distance, res.distance, atol=1e-9)
    assert (back.signed[apex] < 0).all() and np.array_equal(np.sign(back.signed[off]), -np.sign(res.signed[off]))
