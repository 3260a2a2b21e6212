# SPDX-License-Identifier: LGPL-2.1-or-later
"""bladerecon.fc.convert: OpenCASCADE evaluates a converted spline exactly like the core."""
from __future__ import annotations

import numpy as np
import pytest

from bladerecon.core.geometry.bspline import curve_derivatives, evaluate_curve, evaluate_surface, surface_derivatives
from bladerecon.core.errors import BladeReconError
from bladerecon.core.geometry.spline import BSplineCurve
from fc_fixtures import blade_surface, clamped_knots, clamped_surface, periodic_knots, require_freecad

FreeCAD, Part = require_freecad()

from bladerecon.fc.convert import from_part_curve, from_part_surface, make_face, to_part_curve, to_part_surface  # noqa: E402

N_PARAMS = 10_000
TOL_MM = 1e-9


def _random_params(surface, n, rng):
    (u0, u1), (v0, v1) = surface.u_domain, surface.v_domain
    # a periodic direction is also sampled outside its period (both sides must wrap alike)
    pad = (u1 - u0) * 0.5 if surface.u_periodic else 0.0
    return rng.uniform(u0 - pad, u1 + pad, n), rng.uniform(v0, v1, n)


def _occ_values(part_surface, u, v):
    return np.array([tuple(part_surface.value(a, b)) for a, b in zip(u, v)])


@pytest.fixture(params=["periodic_u", "clamped"])
def surface(request):
    return blade_surface() if request.param == "periodic_u" else clamped_surface()


def test_periodic_fixture_is_what_the_test_claims():
    s = blade_surface()
    assert s.u_periodic and not s.v_periodic and s.shape == (40, 6)
    assert len(np.unique(np.round(np.diff(s.u_knots), 6))) > 10  # non-uniform
    assert s.u_mults.max() == 2  # one double knot


def test_points_equal_core_on_10000_random_parameters(surface):
    rng = np.random.default_rng(7)
    u, v = _random_params(surface, N_PARAMS, rng)
    part_surface = to_part_surface(surface)
    assert part_surface.isUPeriodic() == surface.u_periodic
    assert part_surface.isVPeriodic() == surface.v_periodic
    assert (part_surface.NbUPoles, part_surface.NbVPoles) == surface.shape
    err = np.abs(_occ_values(part_surface, u, v) - evaluate_surface(surface, u, v)).max()
    assert err <= TOL_MM


def test_derivatives_equal_core(surface):
    """getDN(u, v, k, l) against surface_derivatives for every k + l <= 2, and the normals."""
    rng = np.random.default_rng(8)
    u, v = _random_params(surface, 2000, rng)
    part_surface = to_part_surface(surface)
    core = surface_derivatives(surface, u, v, 2)
    for k, l in [(1, 0), (0, 1), (2, 0), (1, 1), (0, 2)]:
        occ = np.array([tuple(part_surface.getDN(a, b, k, l)) for a, b in zip(u, v)])
        scale = max(1.0, np.abs(core[:, k, l]).max())
        assert np.abs(occ - core[:, k, l]).max() <= TOL_MM * scale, (k, l)
    normal = np.cross(core[:, 1, 0], core[:, 0, 1])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    occ_normal = np.array([tuple(part_surface.normal(a, b)) for a, b in zip(u, v)])
    assert np.abs(occ_normal - normal).max() <= 1e-9


def test_round_trip_from_part_surface(surface):
    back = from_part_surface(to_part_surface(surface))
    for field in ("poles", "u_knots", "u_mults", "v_knots", "v_mults"):
        np.testing.assert_array_equal(getattr(back, field), getattr(surface, field), err_msg=field)
    assert (back.u_degree, back.v_degree) == (surface.u_degree, surface.v_degree)
    assert (back.u_periodic, back.v_periodic) == (surface.u_periodic, surface.v_periodic)


def test_from_part_surface_accepts_a_face():
    s = blade_surface()
    np.testing.assert_array_equal(from_part_surface(make_face(s)).poles, s.poles)


def test_from_part_surface_rejects_rational_and_non_bspline():
    part_surface = to_part_surface(clamped_surface())
    part_surface.setWeight(3, 2, 2.0)
    with pytest.raises(BladeReconError, match="rational"):
        from_part_surface(part_surface)
    with pytest.raises(BladeReconError, match="B-spline surface"):
        from_part_surface(Part.Plane())


def test_make_face_spans_the_whole_domain():
    s = blade_surface()
    face = make_face(s)
    assert face.isValid()
    assert isinstance(face.Surface, Part.BSplineSurface)
    np.testing.assert_allclose(face.ParameterRange, [*s.u_domain, *s.v_domain], atol=1e-12)


@pytest.mark.parametrize("periodic", [True, False])
def test_curve_round_trip_and_values(periodic):
    rng = np.random.default_rng(3)
    if periodic:
        knots, mults = periodic_knots(17, rng, double_at=5)
        poles = rng.normal(0, 20, (17, 3))
    else:
        knots, mults = clamped_knots(17, 3, rng)
        poles = rng.normal(0, 20, (17, 3))
    curve = BSplineCurve(poles, knots, mults, 3, periodic)
    part_curve = to_part_curve(curve)
    u = rng.uniform(-0.5, 1.5, N_PARAMS) if periodic else rng.uniform(0, 1, N_PARAMS)
    occ = np.array([tuple(part_curve.value(t)) for t in u])
    assert np.abs(occ - evaluate_curve(curve, u)).max() <= TOL_MM
    occ_d1 = np.array([tuple(part_curve.getD1(t)[1]) for t in u[:2000]])
    assert np.abs(occ_d1 - curve_derivatives(curve, u[:2000], 1)[:, 1]).max() <= TOL_MM * np.abs(occ_d1).max()
    back = from_part_curve(part_curve)
    np.testing.assert_array_equal(back.poles, curve.poles)
    np.testing.assert_array_equal(back.knots, curve.knots)
    np.testing.assert_array_equal(back.mults, curve.mults)
    assert back.periodic == periodic and back.degree == 3


def test_curve_with_2d_poles_lies_in_z0():
    rng = np.random.default_rng(4)
    knots, mults = clamped_knots(6, 3, rng)
    curve = BSplineCurve(rng.normal(0, 5, (6, 2)), knots, mults, 3, False)
    occ = np.array([tuple(to_part_curve(curve).value(t)) for t in np.linspace(0, 1, 50)])
    np.testing.assert_allclose(occ[:, :2], evaluate_curve(curve, np.linspace(0, 1, 50)), atol=TOL_MM)
    assert np.all(occ[:, 2] == 0)


def test_from_part_curve_rejects_non_bspline():
    with pytest.raises(BladeReconError, match="B-spline curve"):
        from_part_curve(Part.LineSegment(FreeCAD.Vector(), FreeCAD.Vector(1, 0, 0)))
