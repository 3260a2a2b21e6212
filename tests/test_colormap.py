# SPDX-License-Identifier: LGPL-2.1-or-later
"""Colour maps of the 3D view (numpy only): checked against analytic shapes and plain definitions."""
from __future__ import annotations

import numpy as np

from bladerecon.gui import colormap


def test_diverging_ends_and_middle():
    rgb = colormap.diverging(np.array([-1.0, 0.0, 1.0]))
    np.testing.assert_allclose(rgb, colormap.DIVERGING[[0, 2, 4]])
    assert rgb[0, 2] > rgb[0, 0] and rgb[2, 0] > rgb[2, 2]      # blue below, red above


def test_deviation_colours_order_follows_the_deviation():
    d = np.linspace(-0.01, 0.01, 201)
    rgb = colormap.deviation_colours(d, 0.01)
    redness = rgb[:, 0] - rgb[:, 2]
    assert np.all(np.diff(redness) >= -1e-12) and redness[0] < 0 < redness[-1]
    beyond = colormap.deviation_colours(np.array([-0.02, 0.02, np.nan]), 0.01)
    np.testing.assert_allclose(beyond, [colormap.BELOW, colormap.ABOVE, [0.5, 0.5, 0.5]])


def test_deviation_limit():
    assert colormap.deviation_limit(np.array([-0.004, 0.008]), 0.03) == 0.008     # all in tolerance: own range
    assert colormap.deviation_limit(np.array([-0.2, 0.1]), 0.03) == 0.06          # 2 x tolerance at most
    ticks = dict(colormap.legend_ticks(0.06, 0.03))
    assert ticks[-0.03].startswith("-tol") and ticks[0.03].startswith("+tol") and 0.0 in ticks


def test_grid_normals_of_a_cylinder_are_radial():
    """Cylinder of radius 5 about z, u around (periodic), v along z: S_u x S_v points outward."""
    u = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    v = np.linspace(0, 10, 11)
    uu, vv = np.meshgrid(u, v, indexing="ij")
    grid = np.stack([5 * np.cos(uu), 5 * np.sin(uu), vv], axis=-1)
    n = colormap.grid_normals(grid, u_periodic=True)
    radial = np.stack([np.cos(uu), np.sin(uu), np.zeros_like(uu)], axis=-1)
    np.testing.assert_allclose(n, radial, atol=1e-12)


def test_zebra_of_a_cylinder_counts_the_stripes():
    """Looking along -y at a cylinder about z with light bands along z: as the normal turns by
    a half turn the reflected ray turns a full turn, so 12 stripes per turn give 12 bands."""
    a = np.linspace(0.0, np.pi, 4001)           # the half of the cylinder facing the viewer (+y)
    normals = np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)])
    grey = colormap.zebra_colours(normals, view=np.array([0.0, -1.0, 0.0]), stripes=12, axis="span")[:, 0]
    bands = np.count_nonzero(np.diff((grey > 0.5).astype(int)) == 1)
    assert bands in (11, 12, 13)
    assert grey.min() < 0.1 and grey.max() > 0.9
    flat = colormap.zebra_colours(np.tile([0.0, 1.0, 0.0], (10, 1)), np.array([0.0, -1.0, 0.0]))
    assert np.ptp(flat) == 0                     # a plane shows one colour


def test_curvature_scale_shows_flanks_and_edges():
    """Flanks at 1/80 mm^-1, edges at 1/0.5: both ends of the scale are used, the flanks not washed out."""
    values = np.concatenate([np.full(900, 1 / 80), np.full(100, 1 / 0.5)])
    rgb, knee, limit = colormap.curvature_colours(values)
    assert knee == 0.25 / 80 and limit == 2.0
    pos = colormap.symlog_position(np.array([1 / 80, 2.0]), knee, limit)
    assert 0.15 < pos[0] < 0.4 and pos[1] == 1.0      # flanks a visible step from neutral, edges at the end
    assert not np.allclose(rgb[0], colormap.diverging(np.array([0.0]))[0])


def test_section_colours_distinct():
    c = colormap.section_colours(6)
    assert c.shape == (6, 3) and len(np.unique(np.round(c, 3), axis=0)) == 6
