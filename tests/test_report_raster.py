# SPDX-License-Identifier: LGPL-2.1-or-later
"""The zebra image of the reports is drawn by our own orthographic z-buffer
(``bladerecon.report.deviation._orthographic_image``); judged here on a sphere, whose picture is
known in closed form: a disc of the sphere's radius, the hemisphere facing the eye in front, the
pole that points up at the top and the one that points right on the right."""
from __future__ import annotations

import numpy as np
import pytest

from bladerecon.report.deviation import _orthographic_image

R = 10.0
W, H = 300, 240


def _sphere(nu: int = 360, nv: int = 181) -> np.ndarray:
    lon = np.linspace(0.0, 2.0 * np.pi, nu)                     # closed: the seam repeated, as a blade's u
    lat = np.linspace(-0.5 * np.pi, 0.5 * np.pi, nv)
    lo, la = np.meshgrid(lon, lat, indexing="ij")
    return R * np.stack([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)], axis=-1)


@pytest.mark.parametrize("elev, azim", [(15.0, -60.0), (0.0, 0.0), (40.0, 120.0)])
def test_a_sphere_is_a_full_disc_of_its_front_hemisphere(elev, azim):
    xyz = _sphere()
    e, a = np.radians(elev), np.radians(azim)
    eye = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    value = np.where(xyz @ eye > 0.0, 0.0, 0.5)                 # front black, back grey
    img = _orthographic_image(xyz, value, elev, azim, W, H)
    # the silhouette is a circle of radius R; the image fits the sphere's extent (2R here, the
    # 1-degree grid reaches within 1 - cos(0.5 deg) < 4e-5 of it) into 96 % of the shorter side
    r_px = 0.96 * (min(W, H) - 1) / 2.0
    rows, cols = np.mgrid[0:H, 0:W]
    rho = np.hypot(cols - 0.5 * (W - 1), rows - 0.5 * (H - 1))
    covered = img < 1.0
    inside, outside = rho < r_px - 1.0, rho > r_px + 1.0       # a pixel's rounding either side of the rim
    assert covered[inside].all()                                # no hole
    assert not covered[outside].any()
    # nearest sample wins: the back hemisphere (grey) shows nowhere but on the rim, where front
    # and back meet within a pixel
    assert (img[rho < r_px - 2.0] == 0.0).all()
    assert abs(covered.sum() / (np.pi * r_px ** 2) - 1.0) < 0.02


def test_up_is_up_and_the_views_right_is_right():
    """matplotlib's convention: from azimuth 0 (eye on +x), +y is to the right, +z up."""
    xyz = _sphere()
    r_px = 0.96 * (H - 1) / 2.0
    for k in (2, 1):                                    # the +z cap, then the +y cap, marked 0.5
        value = np.where(xyz[..., k] > 0.95 * R, 0.5, 0.0)
        img = _orthographic_image(xyz, value, 0.0, 0.0, W, H)
        rows, cols = np.nonzero((img > 0.45) & (img < 1.0))
        assert rows.size > 10
        # seen side on, the cap (beyond 0.95 R along its axis) lies beyond 0.9 R from the
        # disc's centre, on the side named (a pixel of rounding)
        if k == 2:
            assert rows.max() < 0.5 * (H - 1) - 0.9 * r_px + 1
        else:
            assert cols.min() > 0.5 * (W - 1) + 0.9 * r_px - 1


def test_upsample_is_linear_interpolation():
    from bladerecon.report.deviation import _upsample

    a = np.random.default_rng(1).normal(size=(5, 7, 2))
    for axis in (0, 1):
        fine = _upsample(a, 3, axis)
        n = a.shape[axis]
        t = np.arange((n - 1) * 3 + 1) / 3
        ref = np.apply_along_axis(lambda col: np.interp(t, np.arange(n), col), axis, a)
        np.testing.assert_allclose(fine, ref, atol=1e-12)
    assert _upsample(a, 1, 0) is a
