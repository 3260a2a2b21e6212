# SPDX-License-Identifier: LGPL-2.1-or-later
"""Deviation against a real CAD-like nominal: trimmed B-spline airfoil faces, hub and tip caps on
surfaces of revolution (the test nominal, written as STEP, IGES and BREP by a fixture).
"""
from __future__ import annotations

import numpy as np
import pytest

from fc_fixtures import require_freecad

FreeCAD, Part = require_freecad()

from bladerecon.fc.nominal_faces import write_multiface_nominal  # noqa: E402
from bladerecon.samples.multiface import multiface_spec  # noqa: E402

V = FreeCAD.Vector


@pytest.fixture(scope="module")
def spec():
    return multiface_spec()


@pytest.fixture(scope="module")
def files(spec, tmp_path_factory):
    return write_multiface_nominal(tmp_path_factory.mktemp("multiface"), spec)


def _is_iso_line(face, edge) -> bool:
    c2, a, b = face.curveOnSurface(edge)
    uv = np.array([(p.x, p.y) for p in c2.discretize(Number=50, First=a, Last=b)])
    return bool(np.ptp(uv[:, 0]) < 1e-9 or np.ptp(uv[:, 1]) < 1e-9)


# --------------------------------------------------------------------------- the nominal
def test_the_test_nominal_is_a_real_cad_blade(files, spec):
    """One solid: four airfoil faces restricting one B-spline surface, trimmed at the hub
    and the tip by curves that are no iso-lines; the caps on a surface of revolution (hub)
    and a cone (tip), trimmed by the blade's outline; STEP and IGES read back."""
    shape = Part.read(files["step"])
    assert len(shape.Solids) == 1 and shape.isValid() and shape.Solids[0].isClosed()
    faces = shape.Faces
    kinds = sorted(type(f.Surface).__name__ for f in faces)
    assert kinds == ["BSplineSurface"] * 4 + ["Cone", "SurfaceOfRevolution"]
    airfoil = [f for f in faces if type(f.Surface).__name__ == "BSplineSurface"]
    poles = [np.array([[tuple(p) for p in row] for row in f.Surface.getPoles()]) for f in airfoil]
    assert all(p.shape == spec.airfoil.poles.shape and np.abs(p - spec.airfoil.poles).max() < 1e-9 for p in poles)
    u_ranges = sorted(f.ParameterRange[:2] for f in airfoil)          # four restrictions in u that tile it
    assert np.allclose([r[0] for r in u_ranges[1:]], [r[1] for r in u_ranges[:-1]], atol=1e-9)
    assert abs(u_ranges[0][0]) < 1e-9 and abs(u_ranges[-1][1] - 1.0) < 1e-9
    for f in faces:                                   # every face is bounded by some non-iso pcurve
        assert not all(_is_iso_line(f, e) for e in f.Edges)
    iges = Part.read(files["iges"])
    assert len(iges.Faces) == 6
    assert abs(Part.read(files["brep"]).Volume - shape.Volume) < 1e-6 * shape.Volume
