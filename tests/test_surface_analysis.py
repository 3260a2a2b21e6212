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


def skewed_saddle() -> BSplineSurface:
    """z = xy over a skewed parameterisation x = u + v/2, y = v: degree 1 in u, 2 in v, exact.
    F = S_u·S_v and M = S_uv·n are nowhere zero, so every term of K, H and the principal
    directions counts (a sphere or a cylinder in orthogonal parameters has F = M = 0)."""
    x = np.array([[0.0, 0.25, 0.5], [1.0, 1.25, 1.5]])        # Bézier coefficients in v, at u = 0 and 1
    y = np.array([[0.0, 0.5, 1.0], [0.0, 0.5, 1.0]])
    z = np.array([[0.0, 0.0, 0.5], [0.0, 0.5, 1.5]])         # u v + v²/2 = x y
    return BSplineSurface(np.stack([x, y, z], axis=-1), np.array([0.0, 1.0]), np.array([2, 2]),
                          np.array([0.0, 1.0]), np.array([3, 3]), 1, 2, False, False)


def test_curvatures_and_directions_of_a_skewed_saddle_against_the_monge_patch():
    """Closed form of z = f(x, y) = xy (a Monge patch, do Carmo §3-3 ex. 5): with W² = 1 + x² + y²,
    K = -1/W⁴ and, for the upward normal (which S_u x S_v is here), the textbook H = -xy/W³; this
    module's convex-positive sign makes it +xy/W³. Principal directions: eigenvectors of the
    shape operator I⁻¹ II in (x, y), lifted to (dx, dy, y dx + x dy)."""
    from bladerecon.core.geometry.bspline import evaluate_surface

    s = skewed_saddle()
    rng = np.random.default_rng(3)
    u, v = rng.uniform(0.05, 0.95, 200), rng.uniform(0.05, 0.95, 200)
    p = evaluate_surface(s, u, v)
    x, y = p[:, 0], p[:, 1]
    assert np.allclose(p[:, 2], x * y, atol=1e-12)              # the surface is the saddle
    c = surface_curvature(s, u, v)
    W2 = 1.0 + x ** 2 + y ** 2
    K, H = -1.0 / W2 ** 2, x * y / W2 ** 1.5
    assert np.allclose(c.gaussian, K, rtol=1e-9, atol=1e-12)
    assert np.allclose(c.mean, H, rtol=1e-9, atol=1e-12)
    root = np.sqrt(H ** 2 - K)
    assert np.allclose(c.k1, H + root, rtol=1e-9) and np.allclose(c.k2, H - root, rtol=1e-9)
    assert np.allclose(c.normal, np.column_stack([-y, -x, np.ones_like(x)]) / np.sqrt(W2)[:, None], atol=1e-12)
    for i in range(len(x)):
        first = np.array([[1 + y[i] ** 2, x[i] * y[i]], [x[i] * y[i], 1 + x[i] ** 2]])
        second = -np.array([[0.0, 1.0], [1.0, 0.0]]) / np.sqrt(W2[i])      # convex-positive sign
        k, vec = np.linalg.eig(np.linalg.solve(first, second))
        for kk, d in ((c.k1[i], c.dir1[i]), (c.k2[i], c.dir2[i])):
            a = vec[:, np.argmin(np.abs(k - kk))].real
            e = np.array([a[0], a[1], y[i] * a[0] + x[i] * a[1]])
            assert abs(abs(d @ e) / np.linalg.norm(e) - 1.0) < 1e-9, (i, d, e)
            assert abs(np.linalg.norm(d) - 1.0) < 1e-12


def test_section_curvature_of_a_parabolic_cylinder_in_closed_form():
    """S(u, v) = (u, v, a u²), exact at degree (2, 1): the section at v is the parabola
    z = a u², κ = 2a / (1 + 4a²u²)^{3/2}; S_u x S_v points up, into the parabola's hollow, so
    the convex-positive sign makes it negative. The samples run over the whole open domain."""
    a = 0.2
    poles = np.zeros((3, 2, 3))
    for i, (x, z) in enumerate(((-2.0, 0.8), (0.0, -0.8), (2.0, 0.8))):   # a u² on [-2, 2]: Bézier
        for j, y in enumerate((0.0, 5.0)):
            poles[i, j] = (x, y, z)
    s = BSplineSurface(poles, np.array([0.0, 1.0]), np.array([3, 3]), np.array([0.0, 1.0]), np.array([2, 2]),
                       2, 1, False, False)
    u, pts, kappa, normal = section_curvature(s, 0.3, 101)
    assert u[0] == 0.0 and u[-1] == 1.0 and len(u) == 101
    x = pts[:, 0]
    assert np.allclose(pts[:, 1], 1.5) and np.allclose(pts[:, 2], a * x ** 2, atol=1e-12)
    assert np.allclose(kappa, -2 * a / (1 + 4 * a * a * x ** 2) ** 1.5, rtol=1e-9)
    up = np.column_stack([-2 * a * x, np.zeros_like(x), np.ones_like(x)])
    assert np.allclose(normal, up / np.linalg.norm(up, axis=1)[:, None], atol=1e-12)
    # flipped normal: the same curve reads convex
    assert np.allclose(section_curvature(s, 0.3, 101, normal_sign=-1.0)[2], -kappa, rtol=1e-12)


def test_zebra_depends_only_on_the_reflection_angle_about_the_stripe_axis():
    """The light is a cylinder of bands about the stripe axis: turning every normal about that
    axis (the default view looks along it) by one band period (2π/12) leaves the picture, by
    half a period inverts it; the view's length does not matter."""
    rng = np.random.default_rng(8)
    n = rng.normal(size=(500, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]

    def turned(angle):
        c, s_ = np.cos(angle), np.sin(angle)
        return n @ np.array([[c, -s_, 0.0], [s_, c, 0.0], [0.0, 0.0, 1.0]]).T

    base = zebra(n, smooth=True)
    assert np.allclose(zebra(turned(2 * np.pi / 12), smooth=True), base, atol=1e-9)
    assert np.allclose(zebra(turned(np.pi / 12), smooth=True), 1.0 - base, atol=1e-9)
    assert np.allclose(zebra(n, view=(0.0, 0.0, -3.0), smooth=True), base, atol=1e-12)
    assert np.array_equal(zebra(n), (base >= 0.5).astype(float))


def test_principal_curvatures_and_directions_of_random_second_order_patches_against_numpy_eig():
    """Any (S_u, S_v, S_uu, S_uv, S_vv) is the 2-jet of some surface: over 2000 random jets (skewed,
    unequal scales, both branches of the null-vector choice) the principal curvatures and
    directions must be the eigenpairs of the shape operator I⁻¹ II computed by numpy.linalg.eig
    (the referee): d lifted as a_u S_u + a_v S_v, parallel up to sign, unit, tangent."""
    rng = np.random.default_rng(11)
    m = 2000
    Su, Sv = rng.normal(size=(m, 3)) * rng.uniform(0.2, 5, (m, 1)), rng.normal(size=(m, 3))
    # curvatures from 1e-4 to 1e2 per mm: the umbilic test must be relative to their size
    Suu, Suv, Svv = (rng.normal(size=(m, 3)) * 10.0 ** rng.uniform(-4, 2, (m, 1)) for _ in range(3))
    c = curvature_from_derivatives(Su, Sv, Suu, Suv, Svv)
    n = np.cross(Su, Sv)
    n /= np.linalg.norm(n, axis=1)[:, None]
    first = np.stack([np.stack([np.sum(Su * Su, 1), np.sum(Su * Sv, 1)], -1),
                      np.stack([np.sum(Su * Sv, 1), np.sum(Sv * Sv, 1)], -1)], -2)
    second = -np.stack([np.stack([np.sum(Suu * n, 1), np.sum(Suv * n, 1)], -1),
                        np.stack([np.sum(Suv * n, 1), np.sum(Svv * n, 1)], -1)], -2)
    k, vec = np.linalg.eig(np.linalg.solve(first, second))
    k, vec = k.real, vec.real
    hi = np.argmax(k, axis=1)
    rows = np.arange(m)
    scale = np.abs(k).max(axis=1) + 1e-300
    # two eigenvalues closer than 1e-6 of their size: the directions are ill-posed, skip those rows
    distinct = np.abs(k[:, 0] - k[:, 1]) > 1e-6 * scale
    assert distinct.sum() > 0.99 * m
    assert np.allclose(c.k1, k[rows, hi], rtol=1e-8, atol=1e-10 * scale.max())
    assert np.allclose(c.k2, k[rows, 1 - hi], rtol=1e-8, atol=1e-10 * scale.max())
    for d, col in ((c.dir1, hi), (c.dir2, 1 - hi)):
        a = vec[rows, :, col]
        e = a[:, :1] * Su + a[:, 1:] * Sv
        e /= np.linalg.norm(e, axis=1)[:, None]
        cos = np.abs(np.sum(d * e, axis=1))
        assert np.all(cos[distinct] > 1 - 1e-8), np.min(cos[distinct])
        assert np.allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
        assert np.allclose(np.sum(d * n, axis=1), 0.0, atol=1e-12)


@pytest.mark.parametrize("R", [4.0, 1000.0])
def test_at_an_umbilic_the_first_direction_is_s_u(R):
    """Every direction is principal on a sphere: the documented choice is S_u (unit), at any size
    (the umbilic test is relative to the first fundamental form: a 1 m sphere in mm has E G ~ 1e12)."""
    rng = np.random.default_rng(5)
    th, ph = rng.uniform(0, 2 * np.pi, 100), rng.uniform(-1.2, 1.2, 100)
    d = sphere_derivatives(R, th, ph)
    c = curvature_from_derivatives(*d)
    su = d[0] / np.linalg.norm(d[0], axis=1)[:, None]
    assert np.allclose(c.dir1, su, atol=1e-9)
    assert np.allclose(c.dir2, np.cross(c.normal, su), atol=1e-9)


def test_curvature_results_are_read_only():
    """The workbench hands one Curvature to several views: none may change it under the others."""
    import dataclasses

    c = curvature_from_derivatives(*sphere_derivatives(2.0, np.array([0.3]), np.array([0.2])))
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.mean = c.mean * 2


def test_section_curvature_sign_on_a_gently_curved_small_section():
    """The convex/concave sign must come from the direction of C'' against the normal, not its
    size: the parabola z = a u² with a = 0.01 on [0, 1] has C''·n ≈ 0.02, far below 1."""
    a = 0.01
    poles = np.zeros((3, 2, 3))
    for i, (x, z) in enumerate(((0.0, 0.0), (0.5, 0.0), (1.0, a))):        # a u² on [0, 1]: Bézier
        for j, y in enumerate((0.0, 1.0)):
            poles[i, j] = (x, y, z)
    s = BSplineSurface(poles, np.array([0.0, 1.0]), np.array([3, 3]), np.array([0.0, 1.0]), np.array([2, 2]),
                       2, 1, False, False)
    _, pts, kappa, _ = section_curvature(s, 0.5, 21)
    x = pts[:, 0]
    assert np.allclose(kappa, -2 * a / (1 + 4 * a * a * x ** 2) ** 1.5, rtol=1e-9)


def test_zebra_against_its_closed_form_for_any_view_and_stripe_axis():
    """The documented picture, computed here from the definition: r = d - 2 (d·n) n, its angle
    about the unit stripe axis a measured from e1 = a x X̂ (a x Ŷ when |a_x| ≥ 0.9), e2 = a x e1;
    white where cos(stripes angle) ≥ 0. The phase origin is pinned so that the same part gives the
    same picture in every version. Inputs need not be unit vectors."""
    rng = np.random.default_rng(21)
    n = rng.normal(size=(400, 3))
    n /= np.linalg.norm(n, axis=1)[:, None]
    cases = [((0.0, 0.0, -1.0), (0.0, 0.0, 1.0)), ((0.3, -2.0, 0.5), (0.0, 0.0, 3.0)),
             ((1.0, 0.2, -0.4), (1.2, 0.0, 1.6)), ((0.0, 1.0, 1.0), (2.0, 0.0, 0.0)),
             ((0.2, 0.1, -1.0), (0.95, 0.31, 0.0)), ((0.5, -0.2, -1.0), (0.3, 0.5, 0.8)),
             ((-0.3, 0.6, 0.2), (0.93, 0.2, 0.3))]
    for view, axis in cases:
        d = np.array(view) / np.linalg.norm(view)
        a = np.array(axis) / np.linalg.norm(axis)
        r = d - 2 * (n @ d)[:, None] * n
        ref = np.array([0.0, 1.0, 0.0]) if abs(a[0]) >= 0.9 else np.array([1.0, 0.0, 0.0])
        e1 = np.cross(a, ref)
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        angle = np.arctan2(r @ e2, r @ e1)
        want = 0.5 + 0.5 * np.cos(7 * angle)
        got = zebra(n, view=view, stripe_axis=axis, stripes=7, smooth=True)
        assert np.allclose(got, want, atol=1e-12), (view, axis)
    # the default view looks down -z along the default +z stripe axis
    assert np.allclose(zebra(n, smooth=True), zebra(n, view=(0, 0, -1), stripe_axis=(0, 0, 1), smooth=True))
    # (with an even band count a reversed view gives the same picture: r turns by π)
    assert not np.allclose(zebra(n, stripes=7, smooth=True), zebra(n, view=(0, 0, 1), stripes=7, smooth=True))
