# SPDX-License-Identifier: LGPL-2.1-or-later
"""What a user of best_fit can see, judged by referees the code does not share (issue 26 §5).

The nominals here have closest points in closed form, given as ``project`` callbacks:

- a *pinwheel*: half-planes through an axis (normals tangential). A rotation by θ about the
  axis puts every point at signed distance ρ sin θ from its plane and the Gauss-Newton step
  is exactly -tan θ (the linearised residual is ρ sin θ + ρ cos θ · w), so the whole
  iteration is known: θ_{k+1} = θ_k - tan θ_k, RMS_k = |sin θ_k| · sqrt(mean ρ²). With a
  plane across the axis added it fixes all six motions and the rigid step is the same.
- labelled planes (three orthogonal ones; a shallow wedge), and three balls.

Rotations are checked against scipy.spatial.transform.Rotation, the robust weights against
scipy's MAD, error messages by the words a user needs (``\\b`` word boundaries, so a word
glued to another is not the word).
"""
from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.spatial.transform import Rotation
from scipy.stats import median_abs_deviation

from bladerecon.core.analysis.alignment import (
    Alignment,
    SurfaceProjector,
    _biweight,
    apply_transform,
    best_fit,
    rotation_about,
)
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.spline import BSplineSurface

PLAIN_KEYS = {"mode", "matrix", "rotation_deg", "axis", "translation_mm", "rms_before", "rms_after",
              "iterations", "converged", "robust"}
ROBUST_KEYS = PLAIN_KEYS | {"robust_cutoff_mm", "points_weighted_out"}


class Planes:
    """Point i belongs to the plane through Q[i] with unit normal N[i] (a probe that knows which
    face it touches). Counts its calls."""

    def __init__(self, Q, N, jitter: float = 0.0):
        self.Q, self.N = np.asarray(Q, float), np.asarray(N, float)
        self.rng, self.jitter, self.calls = np.random.default_rng(3), jitter, 0

    def __call__(self, P):
        self.calls += 1
        d = np.einsum("ij,ij->i", P - self.Q, self.N)
        if self.jitter:                         # a probe whose feet wander: never the same answer twice
            d = d + self.rng.normal(scale=self.jitter, size=d.shape)
        return P - d[:, None] * self.N, self.N


def pinwheel(rho, z, blades=4, at=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), cross_plane=False):
    """Points on ``blades`` half-planes through the line (at, axis), at radii ``rho`` and heights
    ``z`` along the axis, their projector, and the radius of each point (0 on the cross plane).
    ``cross_plane``: also a grid of points on the plane through ``at`` normal to the axis."""
    e3 = np.asarray(axis, float) / np.linalg.norm(axis)
    e1 = np.cross((0.0, 0.0, 1.0) if abs(e3[2]) < 0.9 else (1.0, 0.0, 0.0), e3)
    e1 /= np.linalg.norm(e1)
    Q = np.column_stack([e1, np.cross(e3, e1), e3])                  # local (x, y, z) -> (e1, e2, axis)
    pts, nrm, rr = [], [], []
    for b in range(blades):
        phi = 2 * np.pi * b / blades
        e_r, e_phi = np.array([np.cos(phi), np.sin(phi), 0]), np.array([-np.sin(phi), np.cos(phi), 0])
        for r in rho:
            for h in z:
                pts.append(r * e_r + h * np.array([0, 0, 1.0]))
                nrm.append(e_phi)
                rr.append(r)
    if cross_plane:
        for x in (-6.0, -2.0, 2.0, 6.0):
            for y in (-6.0, -2.0, 2.0, 6.0):
                pts.append(np.array([x, y, 0.0]))
                nrm.append(np.array([0, 0, 1.0]))
                rr.append(0.0)
    P = np.asarray(at, float) + np.asarray(pts) @ Q.T
    N = np.asarray(nrm) @ Q.T
    return P, Planes(np.broadcast_to(np.asarray(at, float), P.shape), N), np.asarray(rr)


def pinwheel_rms(theta: float, rho: np.ndarray) -> float:
    """RMS distance of the pinwheel's points turned by theta (rad) about its axis."""
    return abs(math.sin(theta)) * math.sqrt(np.mean(rho ** 2))


def theta_giving_second_step(step2: float) -> float:
    """The start angle θ0 whose second Gauss-Newton step tan(θ0 - tan θ0) is -step2 (rad)."""
    return brentq(lambda t: math.tan(t - math.tan(t)) + step2, 1e-6, 0.3, xtol=1e-20, rtol=1e-15)


def farthest(P: np.ndarray) -> float:
    """The convergence test's size: distance of the farthest point from the centroid (mm)."""
    return float(np.max(np.linalg.norm(P - P.mean(axis=0), axis=1)))


def three_planes(n=4):
    """Points on the planes x = 0, y = 0, z = 0 (coordinates 2..10 mm in the plane)."""
    g = np.linspace(2.0, 10.0, n)
    a, b = (x.ravel() for x in np.meshgrid(g, g))
    zero = np.zeros_like(a)
    P = np.vstack([np.column_stack(c) for c in ((zero, a, b), (a, zero, b), (a, b, zero))])
    N = np.repeat(np.eye(3), len(a), axis=0)
    return P, Planes(np.zeros_like(P), N)


BALLS = (np.array([0.0, 0.0, 0.0]), np.array([40.0, 0.0, 0.0]), np.array([10.0, 30.0, 5.0]))
RADII = (5.0, 6.0, 7.0)


def balls_project(P):
    """Closest points on the nearest of three balls (a CMM calibration artefact)."""
    d = np.stack([np.linalg.norm(P - c, axis=1) - r for c, r in zip(BALLS, RADII)])
    k = np.argmin(np.abs(d), axis=0)
    C, R = np.asarray(BALLS)[k], np.asarray(RADII)[k]
    n = (P - C) / np.linalg.norm(P - C, axis=1)[:, None]
    return C + R[:, None] * n, n


def on_balls(per_ball: int, seed: int = 1) -> np.ndarray:
    """``per_ball`` points on each ball, on its upper half (directions spread at random)."""
    rng = np.random.default_rng(seed)
    out = []
    for c, r in zip(BALLS, RADII):
        d = rng.normal(size=(per_ball, 3))
        d[:, 2] = np.abs(d[:, 2]) + 0.3
        out.append(c + r * d / np.linalg.norm(d, axis=1)[:, None])
    return np.vstack(out)


def misplaced(P, axis=(1.0, 2.0, 3.0), angle_deg=2.0, shift=(0.3, -0.2, 0.1)):
    """P moved by a known rigid motion (scipy builds it); returns the points and the 4x4 motion."""
    a = np.asarray(axis) / np.linalg.norm(axis)
    M = np.eye(4)
    M[:3, :3] = Rotation.from_rotvec(np.radians(angle_deg) * a).as_matrix()
    M[:3, 3] = shift
    return apply_transform(P, M), M


# --- rotations ---------------------------------------------------------------------------------


def test_rotation_about_matches_scipy_and_keeps_its_centre_fixed():
    M = rotation_about((0.0, 0.0, 2.0), 30.0)                 # axis need not be unit; centre the origin
    assert np.allclose(M[:3, :3], Rotation.from_euler("z", 30.0, degrees=True).as_matrix(), rtol=0, atol=1e-15)
    assert np.array_equal(M[:3, 3], np.zeros(3)) and np.array_equal(M[3], [0, 0, 0, 1])
    centre = np.array([5.0, -2.0, 7.0])
    M = rotation_about((1.0, 2.0, 3.0), 40.0, centre)
    R = Rotation.from_rotvec(np.radians(40.0) * np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0)).as_matrix()
    p = np.array([[1.0, 1.0, 1.0], [-3.0, 4.0, 0.5]])
    assert np.allclose(apply_transform(p, M), centre + (p - centre) @ R.T, rtol=0, atol=1e-13)
    assert np.allclose(apply_transform(centre, M), centre, rtol=0, atol=1e-13)


def test_rigid_fit_reports_the_angle_and_axis_of_a_tilted_rotation():
    """Three balls misplaced by 2° about (1, 2, 3) and a 0.37 mm shift: the fit is the inverse
    motion, so its angle is 2° and its axis -(1, 2, 3)/√14 (scipy's rotation vector agrees).
    Exact data: the fit is exact to rounding; 1e-9° and 1e-9 mm leave a factor ~1000."""
    P = on_balls(8)
    Pm, M = misplaced(P)
    fit = best_fit(Pm, balls_project, "rigid")
    a = np.array([1.0, 2.0, 3.0]) / math.sqrt(14.0)
    assert fit.rotation_deg == pytest.approx(2.0, abs=1e-9)
    assert np.allclose(fit.axis, -a, rtol=0, atol=1e-9)
    assert np.allclose(Rotation.from_matrix(fit.matrix[:3, :3]).as_rotvec(), -np.radians(2.0) * a, rtol=0, atol=1e-11)
    assert np.allclose(fit.matrix, np.linalg.inv(M), rtol=0, atol=1e-9)
    assert fit.translation_mm.shape == (3,) and np.array_equal(fit.translation_mm, fit.matrix[:3, 3])
    assert fit.converged is True and fit.rms_after < 1e-12


def test_default_mode_is_rigid():
    Pm, M = misplaced(on_balls(8))
    fit = best_fit(Pm, balls_project)
    assert fit.mode == "rigid" and np.allclose(fit.matrix, np.linalg.inv(M), rtol=0, atol=1e-9)


def test_rotate_z_turns_about_the_given_axis_through_the_origin_by_default():
    """A pinwheel about the x axis through the origin, turned by 0.02 rad about that line:
    rotate-z with axis (2, 0, 0) (not unit) and no centre turns it back exactly; a centre
    anywhere off the line could not bring every point back onto its plane."""
    P, project, rho = pinwheel(rho=(2.0, 5.0, 9.0), z=(-3.0, 0.0, 4.0), axis=(1.0, 0.0, 0.0))
    theta = 0.02
    turned = apply_transform(P, rotation_about((1.0, 0.0, 0.0), np.degrees(theta)))
    fit = best_fit(turned, project, "rotate-z", axis=(2.0, 0.0, 0.0))
    assert np.allclose(fit.matrix, rotation_about((1.0, 0.0, 0.0), -np.degrees(theta)), rtol=0, atol=1e-12)
    assert fit.rotation_deg == pytest.approx(np.degrees(theta), abs=1e-10)
    assert np.allclose(fit.axis, [-1.0, 0.0, 0.0], rtol=0, atol=1e-12)
    assert fit.rms_before == pytest.approx(pinwheel_rms(theta, rho), rel=1e-12) and fit.rms_after < 1e-13


# --- the iteration: steps, stopping rule, history -------------------------------------------------


def test_iteration_history_is_the_closed_form_sequence():
    """rotate-z on a pinwheel started at θ0 with second step 1.5e-9 rad: steps tan θ0 (large),
    1.5e-9 (at or above the 1e-9 rad angle limit: goes on), ~1e-27 (stops). So 3 iterations, and
    history = RMS at θ0, θ1, θ2, θ3 (one entry before the fit and one per step). Points within
    12 mm: rounding of a residual ~3e-15 mm, so atol 1e-13 on the near-zero entries."""
    P, project, rho = pinwheel(rho=(2.0, 6.0, 10.0), z=(0.0, 5.0, 10.0))
    theta0 = theta_giving_second_step(1.5e-9)
    thetas = [theta0]
    for _ in range(3):
        thetas.append(thetas[-1] - math.tan(thetas[-1]))
    fit = best_fit(apply_transform(P, rotation_about((0, 0, 1), np.degrees(theta0))), project, "rotate-z")
    assert fit.iterations == 3 and fit.converged is True
    assert len(fit.history) == fit.iterations + 1
    expected = [pinwheel_rms(t, rho) for t in thetas]
    assert np.allclose(fit.history, expected, rtol=1e-6, atol=1e-13), (fit.history, expected)
    assert fit.history[0] == fit.rms_before and fit.history[-1] == fit.rms_after
    assert project.calls == fit.iterations + 1            # one projection before, one per step after the first, one at the end
    assert fit.as_dict()["iterations"] == 3 and fit.as_dict()["converged"] is True


@pytest.mark.parametrize("step2, iterations", [(1.5e-9, 3), (0.6e-9, 2)])
def test_a_step_under_1e_9_rad_ends_the_iteration(step2, iterations):
    """Points within 11.2 mm of their centroid: the shift limit (1e-7 mm / 11.2 mm = 9e-9 rad)
    is looser than the angle limit 1e-9 rad, which decides. Second steps 50 % above / 40 %
    below it, far beyond rounding (~1e-16 rad)."""
    P, project, _ = pinwheel(rho=(2.0, 6.0, 10.0), z=(0.0, 5.0, 10.0))
    assert farthest(P) * 1e-9 < 1e-7 / 5
    theta0 = theta_giving_second_step(step2)
    fit = best_fit(apply_transform(P, rotation_about((0, 0, 1), np.degrees(theta0))), project, "rotate-z")
    assert fit.iterations == iterations


@pytest.mark.parametrize("shift2, iterations", [(1.5e-7, 3), (0.6e-7, 2)])
def test_a_step_moving_the_farthest_point_under_1e_7_mm_ends_the_iteration(shift2, iterations):
    """A pinwheel of radius 100-500 mm whose axis passes 2.2 m from the origin: the farthest
    point from the centroid (≈ 500 mm) moves |step| x 500 mm, so the 1e-7 mm limit (2e-10 rad)
    decides over the angle limit. Second steps moving it 1.5e-7 / 0.6e-7 mm; the coordinates'
    rounding (2e3 mm x 1.1e-16 = 2e-13 mm) is 1e-6 of the margin."""
    at = (2000.0, 1000.0, 0.0)
    P, project, _ = pinwheel(rho=(100.0, 300.0, 500.0), z=(0.0, 5.0, 10.0), at=at)
    size = farthest(P)
    assert 500.0 <= size < 500.1
    theta0 = theta_giving_second_step(shift2 / size)
    turned = apply_transform(P, rotation_about((0, 0, 1), np.degrees(theta0), at))
    fit = best_fit(turned, project, "rotate-z", centre=at)
    assert fit.iterations == iterations


def test_rigid_default_centre_is_the_centroid():
    """A pinwheel with a cross plane (fixes all six motions) 10 m from the origin, turned about
    its axis so that the second step is 3e-10 rad: about the centroid (on the axis) that step
    moves the farthest point 3e-10 x 11.4 mm and the fit stops after 2 steps, undoing the turn
    exactly. (About the origin the same step would be a 3e-6 mm shift: a third step.)"""
    at = (1.0e4, 0.0, 0.0)
    P, project, rho = pinwheel(rho=(2.0, 6.0, 10.0), z=(1.0, 5.0, 10.0), at=at, cross_plane=True)
    theta0 = theta_giving_second_step(3e-10)
    fit = best_fit(apply_transform(P, rotation_about((0, 0, 1), np.degrees(theta0), at)), project)
    assert fit.iterations == 2 and len(fit.history) == 3
    assert fit.rotation_deg == pytest.approx(np.degrees(theta0), rel=1e-9)
    assert np.allclose(fit.axis, [0.0, 0.0, -1.0], rtol=0, atol=1e-9)
    assert np.allclose(fit.matrix, rotation_about((0, 0, 1), -np.degrees(theta0), at), rtol=0, atol=1e-9)
    # the cross plane's points lie on it throughout: they add 0 to the sum of squares
    assert fit.history[0] == pytest.approx(pinwheel_rms(theta0, rho), rel=1e-9)
    assert fit.history[1] == pytest.approx(pinwheel_rms(theta0 - math.tan(theta0), rho), rel=1e-3)


def test_translate_is_exact_in_one_step_and_stops_at_the_second():
    """Translation onto three orthogonal planes is linear: step 1 is exact, step 2 moves nothing
    and ends the fit; so 2 iterations exactly, and max_iter=1 is not enough."""
    P, project = three_planes()
    t = np.array([0.3, -0.2, 0.1])
    fit = best_fit(P + t, project, "translate")
    assert fit.iterations == 2 and len(fit.history) == 3
    assert np.allclose(fit.translation_mm, -t, rtol=0, atol=1e-14) and fit.translation_mm.shape == (3,)
    assert np.array_equal(fit.matrix[:3, :3], np.eye(3))
    assert fit.rotation_deg == 0.0 and np.array_equal(fit.axis, [0.0, 0.0, 1.0])   # no rotation: the z axis
    d = fit.as_dict()
    assert set(d) == PLAIN_KEYS and d["translation_mm"] == pytest.approx(list(-t), abs=1e-14)
    assert d["axis"] == [0.0, 0.0, 1.0] and d["rotation_deg"] == 0.0 and d["robust"] is False
    assert fit.points_weighted_out == 0 and fit.weights is None and fit.cutoff_mm is None
    with pytest.raises(BladeReconError, match=r"\bdid not converge in 1 iterations\b"):
        best_fit(P + t, project, "translate", max_iter=1)


def test_max_iter_is_the_number_of_steps_allowed():
    """The 3-step pinwheel fit (second step 1.5e-9 rad) passes with max_iter=3 and fails with 2;
    with max_iter=1 the message gives the RMS at θ1 and at θ0 (closed form, 6 digits)."""
    P, project, rho = pinwheel(rho=(2.0, 6.0, 10.0), z=(0.0, 5.0, 10.0))
    theta0 = theta_giving_second_step(1.5e-9)
    turned = apply_transform(P, rotation_about((0, 0, 1), np.degrees(theta0)))
    assert best_fit(turned, project, "rotate-z", max_iter=3).iterations == 3
    with pytest.raises(BladeReconError, match=r"\bdid not converge in 2 iterations\b"):
        best_fit(turned, project, "rotate-z", max_iter=2)
    theta0 = 0.05
    turned = apply_transform(P, rotation_about((0, 0, 1), np.degrees(theta0)))
    with pytest.raises(BladeReconError) as e:
        best_fit(turned, project, "rotate-z", max_iter=1)
    msg = str(e.value)
    assert re.search(r"\balignment 'rotate-z' did not converge in 1 iterations\b", msg), msg
    m = re.search(r"\bRMS residual ([0-9.e+-]+) mm \(was ([0-9.e+-]+) mm\)", msg)
    assert m, msg
    assert float(m.group(1)) == pytest.approx(pinwheel_rms(theta0 - math.tan(theta0), rho), rel=1e-5)
    assert float(m.group(2)) == pytest.approx(pinwheel_rms(theta0, rho), rel=1e-5)
    assert re.search(r"\bcheck that the points belong to this nominal\b", msg), msg
    assert re.search(r"\bor use --align none$", msg), msg


def test_default_max_iter_is_50():
    """A probe whose feet wander by 1e-5 mm at every call: each step is ~1e-7 rad, never under
    1e-9 rad, so the fit gives up after its default 50 steps (51 projections)."""
    P, _, _ = pinwheel(rho=(2.0, 6.0, 10.0), z=(0.0, 5.0, 10.0))
    _, exact, _ = pinwheel(rho=(2.0, 6.0, 10.0), z=(0.0, 5.0, 10.0))
    wandering = Planes(exact.Q, exact.N, jitter=1e-5)
    with pytest.raises(BladeReconError, match=r"\bdid not converge in 50 iterations\b"):
        best_fit(apply_transform(P, rotation_about((0, 0, 1), 0.5)), wandering, "rotate-z")
    assert wandering.calls == 51


# --- refusals -------------------------------------------------------------------------------------


@pytest.mark.parametrize("mode, need", [("rigid", 12), ("translate", 6), ("rotate-z", 2)])
def test_minimum_point_count_is_twice_the_unknowns(mode, need):
    """Exactly ``need`` points on three balls fit (and recover the motion); one fewer is refused
    with the count. rotate-z: a 1° turn about z; the others a small tilted motion."""
    P = on_balls(4)
    order = np.argsort(np.arange(len(P)) % 4, kind="stable")       # first one point of each ball, ...
    P = P[order][:need]
    if mode == "rotate-z":
        M = rotation_about((0, 0, 1), 1.0)
    elif mode == "translate":
        M = np.eye(4)
        M[:3, 3] = (0.3, -0.2, 0.1)
    else:
        M = misplaced(P, angle_deg=1.0)[1]
    fit = best_fit(apply_transform(P, M), balls_project, mode)
    assert np.allclose(fit.matrix, np.linalg.inv(M), rtol=0, atol=1e-8), fit.matrix
    with pytest.raises(BladeReconError) as e:
        best_fit(apply_transform(P[:-1], M), balls_project, mode)
    assert re.search(rf"\balignment '{mode}' needs at least {need} points; got {need - 1}\b", str(e.value)), str(e.value)


def test_none_mode_measures_even_one_point_and_refuses_none():
    """``none`` has no unknowns: one point is enough to report its RMS (it used to be refused with
    'needs at least 0 points; got 1'); an empty array is refused as not an (m, 3) array."""
    p = np.array([[0.0, 0.0, 5.25]])                              # 0.25 mm above the first ball
    fit = best_fit(p, balls_project, "none")
    assert fit.rms_before == fit.rms_after == pytest.approx(0.25, abs=1e-15)
    with pytest.raises(BladeReconError, match=r"\balignment needs an \(m, 3\) array of points\b"):
        best_fit(np.empty((0, 3)), balls_project, "none")


def test_none_mode_reports_no_motion():
    P = on_balls(5)
    n = balls_project(P)[1]
    fit = best_fit(P + 0.02 * n, balls_project, "none", axis=(0.0, 3.0, 4.0))
    assert np.array_equal(fit.matrix, np.eye(4)) and fit.rotation_deg == 0.0
    assert np.allclose(fit.axis, [0.0, 0.6, 0.8], rtol=0, atol=1e-15)
    assert np.array_equal(fit.translation_mm, np.zeros(3)) and fit.iterations == 0 and fit.converged is True
    assert fit.rms_before == fit.rms_after == pytest.approx(0.02, rel=1e-12) and fit.history == [fit.rms_before]
    assert fit.weights is None and fit.cutoff_mm is None and fit.robust is False
    d = fit.as_dict()
    assert set(d) == PLAIN_KEYS
    assert (d["mode"], d["rotation_deg"], d["translation_mm"], d["iterations"], d["converged"], d["robust"]) == \
        ("none", 0.0, [0.0, 0.0, 0.0], 0, True, False)
    assert d["matrix"] == np.eye(4).tolist() and d["rms_before"] == d["rms_after"] == fit.rms_before


def test_unknown_mode_names_the_modes_to_use():
    with pytest.raises(BladeReconError) as e:
        best_fit(np.zeros((10, 3)), balls_project, "affine")
    m = re.search(r"\bunknown alignment mode 'affine': use one of (.*)$", str(e.value))
    assert m, str(e.value)
    assert m.group(1).split(", ") == ["none", "rigid", "translate", "rotate-z"]


def test_bad_point_array_is_refused():
    with pytest.raises(BladeReconError, match=r"\balignment needs an \(m, 3\) array of points \(mm\)"):
        best_fit(np.zeros((10, 2)), balls_project, "rigid")


@pytest.mark.parametrize("eps, refused", [(1.5e-9, True), (3e-9, False)])
def test_a_shallow_wedge_is_undetermined_below_1e_9(eps, refused):
    """Translation against a face x = 0 and two faces whose normals, in the y-z plane, are ε
    apart (45° and 45° + ε). Scaled to unit columns, the y and z columns are α = atan(tan ε /
    cos ε) ≈ ε apart, so the singular values are √(1 ± cos α) and 1: smallest / largest =
    tan(α/2) ≈ ε/2, refused below 1e-9. ε = 1.5e-9 gives 7.5e-10 (refused), 3e-9 gives 1.5e-9
    (fitted). Rounding of the normals: ~1e-16 in α."""
    alpha = math.atan(math.tan(eps) / math.cos(eps))
    assert (math.tan(alpha / 2) < 1e-9) is refused
    N = [(1.0, 0.0, 0.0)] * 4 + [(0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))] * 4 + \
        [(0.0, math.sin(math.pi / 4 + eps), math.cos(math.pi / 4 + eps))] * 4
    N = np.asarray(N)
    rng = np.random.default_rng(5)
    P = rng.uniform(-5, 5, (12, 3))
    P -= np.einsum("ij,ij->i", P, N)[:, None] * N                 # onto the faces (through the origin)
    P[:4, 0] += 0.1                                                # 0.1 mm off the x face
    project = Planes(np.zeros_like(P), N)
    if refused:
        with pytest.raises(BladeReconError) as e:
            best_fit(P, project, "translate")
        msg = str(e.value)
        assert re.search(r"\balignment 'translate' is undetermined\b", msg), msg
        assert re.search(r"\bsurface of revolution\b", msg) and re.search(r"\bmore restricted --align$", msg), msg
    else:
        fit = best_fit(P, project, "translate")
        # the y-z solve has condition 1 / tan(α/2) ≈ 7e8: rounding 2.2e-16 x 7e8 x 0.2 mm (the
        # residuals' norm) ≈ 3e-8 mm in y and z
        assert np.allclose(fit.translation_mm, [-0.1, 0.0, 0.0], rtol=0, atol=1e-6)


# --- robust fit -----------------------------------------------------------------------------------


def test_biweight_closed_form_inside_and_beyond_the_cutoff():
    """Residuals 50 x -1, 0, 50 x +1 and a symmetric pair ±x: median 0, MAD 1 (the pair lies
    beyond 1), so the cut-off is 4.685 x 1.4826 = 6.9460 mm; a pair at half the cut-off weighs
    (1 - 0.25)² = 0.5625, a pair at 1.5 cut-offs nothing."""
    c = 4.685 * 1.4826
    for u, expected in ((0.5, 0.5625), (1.5, 0.0)):
        r = np.concatenate([-np.ones(50), [0.0], np.ones(50), [-u * c, u * c]])
        w, cutoff = _biweight(r, np.ones_like(r))
        assert cutoff == pytest.approx(c, rel=1e-12)
        assert w[-2:] == pytest.approx([expected, expected], abs=1e-12)
        assert w[50] == 1.0 and w[0] == pytest.approx((1 - (1 / c) ** 2) ** 2, rel=1e-12)


def test_robust_scale_floors_on_an_exact_fit():
    """On points exactly on their faces the residuals' MAD is 0: the scale is floored at 1e-12 mm
    (cut-off 4.685e-12 mm) with no outlier, and at 1e-9 of the largest residual with two
    outliers at ±0.3 mm (cut-off 4.685 x 3e-10 mm), which are then weighted out."""
    P, project = three_planes()
    fit = best_fit(P, project, "translate", robust=True)
    assert fit.cutoff_mm == pytest.approx(4.685e-12, rel=1e-12) and fit.points_weighted_out == 0
    Q = P.copy()
    top = np.flatnonzero(P[:, 2] == 0)[:2]                        # two points of the z = 0 face
    Q[top, 2] = [0.3, -0.3]
    fit = best_fit(Q, project, "translate", robust=True)
    assert fit.cutoff_mm == pytest.approx(4.685 * 1e-9 * 0.3, rel=1e-12)
    assert fit.points_weighted_out == 2 and np.array_equal(np.flatnonzero(fit.weights == 0), np.sort(top))
    d = fit.as_dict()
    assert set(d) == ROBUST_KEYS and d["robust"] is True
    assert d["robust_cutoff_mm"] == fit.cutoff_mm and d["points_weighted_out"] == 2
    assert np.allclose(fit.translation_mm, 0.0, rtol=0, atol=1e-15)


def test_robust_weights_are_the_biweight_whatever_the_given_weights():
    """Given weights (0, 0.5, 2) scale each squared residual; the reported weight is the biweight
    alone, in [0, 1]: (1 - u²)², u = (r - median r) / (4.685 σ̂), σ̂ scipy's normal-consistent
    MAD of the final residuals (1.4826 vs 1/Φ⁻¹(3/4): 1e-6 relative, so atol 1e-5). A point
    given weight 0 reports 0; a 1 mm outlier reports 0."""
    P, project = three_planes(5)
    rng = np.random.default_rng(8)
    Q = P + rng.normal(scale=0.01, size=P.shape)
    Q[7] += 1.0
    given = np.where(np.arange(len(P)) % 2 == 0, 0.5, 2.0)
    given[3] = 0.0
    fit = best_fit(Q + (0.2, -0.1, 0.05), project, "translate", weights=given, robust=True)
    moved = apply_transform(Q + (0.2, -0.1, 0.05), fit.matrix)
    r = np.einsum("ij,ij->i", moved, project.N)                  # faces through the origin
    u = (r - np.median(r)) / (4.685 * median_abs_deviation(r, scale="normal"))
    expected = np.where(np.abs(u) < 1, (1 - u * u) ** 2, 0.0)
    expected[3] = 0.0
    assert np.all((fit.weights >= 0) & (fit.weights <= 1))
    assert np.allclose(fit.weights, expected, rtol=0, atol=1e-5)
    assert fit.weights[3] == 0.0 and fit.weights[7] == 0.0 and fit.points_weighted_out == 2


# --- the result type and the projector ------------------------------------------------------------


def test_alignment_defaults_and_immutability():
    """An Alignment built from its required fields only (as the zone fit builds one) is a
    converged, non-robust result with an empty history, and cannot be changed."""
    a = Alignment("zone", np.eye(4), 0.0, np.array([0.0, 0.0, 1.0]), np.zeros(3), 0.1, 0.05, 3)
    assert a.converged is True and a.history == [] and a.robust is False
    assert a.weights is None and a.cutoff_mm is None and a.points_weighted_out == 0
    assert set(a.as_dict()) == PLAIN_KEYS
    with pytest.raises(dataclasses.FrozenInstanceError):
        a.mode = "rigid"


def test_surface_projector_returns_unit_normals_and_counts_its_calls():
    """A flat B-spline patch z = 0 (0..10 mm): feet straight below, normals ±z of unit length."""
    plane = BSplineSurface(poles=np.array([[[0, 0, 0], [0, 10, 0]], [[10, 0, 0], [10, 10, 0]]], float),
                           u_knots=np.array([0.0, 1.0]), u_mults=np.array([2, 2]),
                           v_knots=np.array([0.0, 1.0]), v_mults=np.array([2, 2]), u_degree=1, v_degree=1)
    P = np.array([[2.0, 3.0, 0.4], [7.0, 1.0, -0.2]])
    project = SurfaceProjector(plane)
    assert project.calls == 0
    foot, normal = project(P)
    assert np.allclose(foot, P * [1, 1, 0], rtol=0, atol=1e-12)
    assert np.allclose(normal, [[0, 0, 1], [0, 0, 1]], rtol=0, atol=1e-12)
    project(P)
    assert project.calls == 2
    assert np.allclose(SurfaceProjector(plane, sign=-1.0)(P)[1], [[0, 0, -1], [0, 0, -1]], rtol=0, atol=1e-12)
    fit = best_fit(P, project, "none")
    assert fit.rms_before == pytest.approx(math.sqrt((0.4 ** 2 + 0.2 ** 2) / 2), rel=1e-12)
    assert project.calls == 3
