# SPDX-License-Identifier: LGPL-2.1-or-later
"""Curvatures, principal directions, combs and zebra: bladerecon.core.analysis.surface_analysis."""
from __future__ import annotations

import numpy as np
import pytest

from bladerecon.samples.blade import SampleBlade, nominal_surface
from bladerecon.core.geometry.spline import BSplineSurface
from bladerecon.core.analysis.surface_analysis import (
    curvature_from_derivatives,
    section_curvature,
    surface_curvature,
    zebra,
)


def sphere_derivatives(R: float, th: np.ndarray, ph: np.ndarray):
    """Exact derivatives of S = R (cos th cos ph, sin th cos ph, sin ph); S_u x S_v points outward."""
    c, s, cp, sp = np.cos(th), np.sin(th), np.cos(ph), np.sin(ph)
    Su = R * np.column_stack([-s * cp, c * cp, 0 * th])
    Sv = R * np.column_stack([-c * sp, -s * sp, cp])
    Suu = R * np.column_stack([-c * cp, -s * cp, 0 * th])
    Suv = R * np.column_stack([s * sp, -c * sp, 0 * th])
    Svv = R * np.column_stack([-c * cp, -s * cp, -sp])
    return Su, Sv, Suu, Suv, Svv


def cylinder_derivatives(R: float, th: np.ndarray, z: np.ndarray):
    """S = (R cos th, R sin th, z): outward S_u x S_v."""
    c, s = np.cos(th), np.sin(th)
    zero = 0 * th
    Su = np.column_stack([-R * s, R * c, zero])
    Sv = np.column_stack([zero, zero, zero + 1.0])
    Suu = np.column_stack([-R * c, -R * s, zero])
    return Su, Sv, Suu, np.zeros_like(Su), np.zeros_like(Su)


def test_sphere_is_umbilic_with_k_one_over_r():
    rng = np.random.default_rng(0)
    th, ph = rng.uniform(0, 2 * np.pi, 200), rng.uniform(-1.2, 1.2, 200)
    c = curvature_from_derivatives(*sphere_derivatives(4.0, th, ph))
    assert np.allclose(c.gaussian, 1 / 16) and np.allclose(c.mean, 0.25)
    assert np.allclose(c.k1, 0.25) and np.allclose(c.k2, 0.25)
    inward = curvature_from_derivatives(*sphere_derivatives(4.0, th, ph), normal_sign=-1.0)
    assert np.allclose(inward.mean, -0.25) and np.allclose(inward.gaussian, 1 / 16)


def test_cylinder_principal_directions():
    th, z = np.linspace(0, 6, 50), np.linspace(-3, 3, 50)
    c = curvature_from_derivatives(*cylinder_derivatives(2.0, th, z))
    assert np.allclose(c.gaussian, 0, atol=1e-15) and np.allclose(c.mean, 0.25)
    assert np.allclose(c.k1, 0.5) and np.allclose(c.k2, 0, atol=1e-15)
    # k1 around the circle, k2 along the axis
    assert np.allclose(np.abs(c.dir1 @ [0, 0, 1]), 0, atol=1e-12)
    assert np.allclose(np.abs(c.dir2 @ [0, 0, 1]), 1)
    assert np.allclose(np.einsum("ij,ij->i", c.dir1, c.normal), 0, atol=1e-12)


def paraboloid(R: float, ratio: float = 1.0) -> BSplineSurface:
    """z = (x^2 + ratio y^2) / (2R) on [-1, 1]^2 as a biquadratic Bezier patch (exact)."""
    x, q = np.array([-1.0, 0.0, 1.0]), np.array([1.0, -1.0, 1.0])
    poles = np.array([[[x[i], x[j], (q[i] + ratio * q[j]) / (2 * R)] for j in range(3)] for i in range(3)])
    k, m = np.array([0.0, 1.0]), np.array([3, 3])
    return BSplineSurface(poles, k, m, k, m, 2, 2)


def test_bspline_paraboloid_apex():
    R = 5.0
    c = surface_curvature(paraboloid(R), 0.5, 0.5)
    # S_u x S_v is +z and the surface bends towards it: concave from that side
    assert np.allclose(c.gaussian, 1 / R**2) and np.allclose(c.mean, -1 / R)
    saddle = surface_curvature(paraboloid(R, -0.5), 0.5, 0.5)
    assert np.allclose(saddle.gaussian, -0.5 / R**2)
    assert np.allclose(saddle.k1, 0.5 / R) and np.allclose(saddle.k2, -1 / R)
    assert np.allclose(np.abs(saddle.dir1), [[0, 1, 0]]) and np.allclose(np.abs(saddle.dir2), [[1, 0, 0]])


@pytest.fixture(scope="module")
def blade_nominal():
    return nominal_surface(SampleBlade(), n_span=11, n_profile=400)


def test_blade_section_comb_matches_the_analytic_edges(blade_nominal):
    # u = 0 is the LE: the comb there is the LE circle's curvature (~1/0.8 mm at mid-span),
    # convex; the flanks are far flatter
    u, pts, kappa, teeth = section_curvature(blade_nominal, 0.5, 2000)
    r_le = SampleBlade().section_laws(0.5).le_radius
    assert kappa[0] == pytest.approx(1 / r_le, rel=0.02)
    assert np.median(np.abs(kappa)) < 0.1
    assert np.allclose(np.linalg.norm(teeth, axis=1), 1)
    c = surface_curvature(blade_nominal, u[:1], np.array([0.5]))
    assert c.k1[0] == pytest.approx(kappa[0], rel=0.05)


def test_zebra_flat_is_constant_and_bands_alternate():
    flat = zebra(np.tile([0.0, 0.0, 1.0], (10, 1)))
    assert np.all(flat == flat[0])
    # normals tilting about the stripe axis sweep the reflected ray through the bands:
    # a tilt of a quarter band period (2 pi / stripes / 4 / 2 in normal angle) flips the band
    tilt = np.linspace(-0.6, 0.6, 2001)
    n = np.column_stack([np.sin(tilt), np.zeros_like(tilt), np.cos(tilt)])
    z = zebra(n, view=(0, 0, -1), stripe_axis=(0, 1, 0), stripes=12)
    changes = np.flatnonzero(np.diff(z) != 0)
    # reflected angle = 2 tilt; a band edge every pi/12 of it -> every pi/24 of tilt
    assert np.allclose(np.diff(tilt[changes]), np.pi / 24, atol=2e-3)
    s = zebra(n, view=(0, 0, -1), stripe_axis=(0, 1, 0), smooth=True)
    assert s.min() >= 0 and s.max() <= 1
