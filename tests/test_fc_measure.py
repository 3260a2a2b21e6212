# SPDX-License-Identifier: LGPL-2.1-or-later
"""bladerecon.fc.occ_measure: OpenCASCADE point-to-shape distances, the referee of tests and benchmarks."""
from __future__ import annotations

import numpy as np
import pytest

from bladerecon.core.geometry.bspline import surface_derivatives
from bladerecon.core.errors import BladeReconError
from fc_fixtures import blade_surface, require_freecad, tapered_tube

FreeCAD, Part = require_freecad()

from bladerecon.fc.convert import make_face  # noqa: E402
from bladerecon.fc.export import make_solid  # noqa: E402
from bladerecon.fc.occ_measure import distance_method_timings, occ_distances, occ_target_faces  # noqa: E402

BOX_POINTS = np.array([
    (5, 5, 12),    # above the top face
    (5, 12, 5),    # beside a side face
    (12, 12, 5),   # off a vertical edge
    (12, 12, 12),  # off a corner
    (5, 5, 6),     # inside, nearest the top
    (5, 5, 9),     # inside, 1 below the top
    (-1, 5, 5),    # outside the x = 0 face
    (1, 5, 5),     # inside, 1 from the x = 0 face
])
BOX_SIGNED = np.array([2, 2, np.sqrt(8), np.sqrt(12), -4, -1, 1, -1])


def _offset_points(surface, offsets, rng, v_range=(0.02, 0.98)):
    """Points at known signed offsets (mm) along the core normal Su x Sv."""
    n = len(offsets)
    u = rng.uniform(*surface.u_domain, n)
    v = rng.uniform(*v_range, n)
    d = surface_derivatives(surface, u, v, 1)
    normal = np.cross(d[:, 1, 0], d[:, 0, 1])
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return d[:, 0, 0] + offsets[:, None] * normal


@pytest.mark.parametrize("variant", ["solid", "reversed solid", "closed shell", "reversed shell"])
def test_box_signed_distances_are_outward_positive(variant):
    box = Part.makeBox(10, 10, 10)
    shape = box if "solid" in variant else Part.Shell(box.Faces)
    if variant.startswith("reversed"):
        shape = shape.copy()
        shape.reverse()
    np.testing.assert_allclose(occ_distances(BOX_POINTS, shape, signed=True), BOX_SIGNED, atol=1e-12)
    np.testing.assert_allclose(occ_distances(BOX_POINTS, shape), np.abs(BOX_SIGNED), atol=1e-12)


def test_open_face_sign_follows_the_face_orientation():
    top = Part.makeBox(10, 10, 10).Faces[5]  # z = 10, normal +z
    points = np.array([(5, 5, 12), (5, 5, 7)])
    np.testing.assert_allclose(occ_distances(points, top, signed=True), [2, -3], atol=1e-12)
    flipped = top.copy()
    flipped.reverse()
    np.testing.assert_allclose(occ_distances(points, flipped, signed=True), [-2, 3], atol=1e-12)


def test_bspline_face_distances_match_known_offsets():
    s = blade_surface()
    rng = np.random.default_rng(11)
    offsets = rng.uniform(-0.3, 0.3, 300)
    points = _offset_points(s, offsets, rng)
    signed = occ_distances(points, make_face(s), signed=True)
    assert np.abs(signed - offsets).max() <= 1e-9


def test_subdivided_face_gives_the_same_distances():
    s = blade_surface(n_u=150)
    face = make_face(s)
    pieces, _ = occ_target_faces(face)
    assert len(pieces) > 1  # 150 spans in u are cut into patches
    rng = np.random.default_rng(12)
    # also beyond the hub and tip, where the foot lies on a boundary edge
    points = _offset_points(s, rng.uniform(-2, 2, 150), rng, v_range=(-0.1, 1.1))
    whole = occ_distances(points, face, signed=True, subdivide=False)
    split = occ_distances(points, face, signed=True, subdivide=True)
    assert np.abs(whole - split).max() <= 1e-9


def test_solid_from_make_solid_is_positive_outside():
    s = tapered_tube()
    solid = make_solid(s)
    rng = np.random.default_rng(13)
    offsets = rng.uniform(-1, 1, 200)
    points = _offset_points(s, offsets, rng, v_range=(0.2, 0.8))
    signed = occ_distances(points, solid, signed=True)
    # Su x Sv points outward for this counter-clockwise section
    np.testing.assert_allclose(signed, offsets, atol=1e-9)


def test_points_accept_any_n_by_3_layout():
    box = Part.makeBox(10, 10, 10)
    assert occ_distances([5, 5, 12], box).shape == (1,)
    assert occ_distances(np.zeros((0, 3)), box).shape == (0,)


def test_shape_without_faces_is_an_error():
    with pytest.raises(BladeReconError, match="no faces"):
        occ_distances(BOX_POINTS, Part.makeLine((0, 0, 0), (1, 0, 0)))


def test_distance_method_timings_cover_every_call():
    s = blade_surface()
    rng = np.random.default_rng(14)
    timings = distance_method_timings(_offset_points(s, rng.uniform(-1, 1, 5), rng), make_face(s))
    assert set(timings) == {
        "Vertex.distToShape(face)", "Face.distToShape(Vertex)", "Surface.parameter + value",
        "Surface.projectPoint LowerDistance", "Vertex.distToShape(patches)",
    }
    assert all(t > 0 for t in timings.values())
