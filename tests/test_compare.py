# SPDX-License-Identifier: LGPL-2.1-or-later
"""Shape error against a nominal: + where material is outside, on the core and the OCC path."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError

from bladerecon.samples.blade import SampleBlade

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def fc():
    try:
        from bladerecon.fc.freecad_env import import_freecad
        _, Part = import_freecad()
    except BladeReconError as exc:  # FreeCAD not found (a broken FreeCAD import fails the test)
        pytest.skip(f"FreeCAD not available: {exc}")
    from bladerecon.fc import compare
    return compare, Part


def test_known_outward_and_inward_offsets_on_the_sample_nominal(fc):
    compare, _ = fc
    blade = SampleBlade()
    rng = np.random.default_rng(0)
    h, t = rng.random(400), rng.random(400)
    p = np.concatenate([blade.point(a, b).reshape(1, 3) for a, b in zip(h, t)])
    n = np.concatenate([blade.normal(a, b).reshape(1, 3) for a, b in zip(h, t)])
    offset = np.where(np.arange(400) % 2 == 0, 0.02, -0.015)      # mm: half outside, half inside
    dev = compare.deviation_to_nominal(p + offset[:, None] * n, str(ROOT / "resources/sample/nominal.step"))
    assert dev.method == "core-projection"
    assert np.abs(dev.signed - offset).max() < 1e-3 * 0.5          # nominal is within 0.25 µm of the truth


def test_planar_faces_in_closed_form_with_the_same_sign(fc):
    """A box: six planes measured in closed form (not OCC per point), signed outward."""
    compare, Part = fc
    box = Part.makeBox(10, 10, 10)
    pts = np.array([[5.0, 5.0, 10.5], [5.0, 5.0, 9.0], [-0.25, 5.0, 5.0]])
    dev = compare.deviation_to_nominal(pts, box)
    assert dev.method == "+".join(f"{k}:core-plane" for k in range(6))
    assert np.allclose(dev.signed, [0.5, -1.0, 0.25], atol=1e-9)
