# SPDX-License-Identifier: LGPL-2.1-or-later
"""Alternating mesh-curve fairing and region repair on a grid of true blade points."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import cKDTree

from bladerecon.core.errors import BladeReconError
from bladerecon.samples.blade import t_at_length_fraction
from bladerecon.core.surface.fairing import fair_grid_alternating, fair_open_curve, repair_regions
from realdata_fixtures import BLADE

H = np.linspace(0.0, 1.0, 11)
N = 300


def _grid():
    return np.stack([BLADE.point(h, t_at_length_fraction(BLADE, h, (0.013 + np.arange(N)) / N)) for h in H])


def _dense(h):
    return cKDTree(BLADE.point(h, t_at_length_fraction(BLADE, h, np.arange(200000) / 200000)))


def test_clean_grid_is_already_fair():
    f = fair_grid_alternating(_grid())
    assert f.converged and f.passes == 1 and f.replaced_u == 0 and f.replaced_v == 0


def test_open_curve_run_replaced_ends_kept():
    x = np.linspace(0, 50, 40)
    P = np.c_[x, 0.002 * x ** 2, np.zeros(40)]
    Q = P.copy()
    Q[[17, 18]] += [0, 0.02, 0]
    out, bad = fair_open_curve(Q)
    assert list(np.flatnonzero(bad)) == [17, 18]
    assert np.abs(out[17:19] - P[17:19]).max() < 1e-3


def test_alternating_fairing_removes_bumps_in_both_directions():
    G = _grid()
    nrm = np.stack([BLADE.normal(h, t_at_length_fraction(BLADE, h, (0.013 + np.arange(N)) / N)) for h in H])
    B = G.copy()
    B[3, 60:63] += 0.015 * nrm[3, 60:63]          # a bump along a section
    B[4:7, 200] += 0.02 * nrm[4:7, 200]           # a bump along the span
    f = fair_grid_alternating(B)
    assert f.converged and f.passes <= 3
    assert f.replaced_u + f.replaced_v >= 6
    for j in (3, 4, 5, 6):
        assert _dense(H[j]).query(f.grid[j])[0].max() < 0.003
    with pytest.raises(BladeReconError, match="refused"):
        fair_grid_alternating(B, max_move=0.005)


def test_region_repair_rebuilds_an_unfair_region():
    G = _grid()
    nrm = np.stack([BLADE.normal(h, t_at_length_fraction(BLADE, h, (0.013 + np.arange(N)) / N)) for h in H])
    B = G.copy()
    B[5, 100:106] += 0.05 * nrm[5, 100:106]
    err = np.zeros((len(H) - 1, N))
    err[4:6, 100:105] = 0.05                      # the cells whose measured points were 0.05 mm off
    R, replaced = repair_regions(B, err)
    assert replaced[5, 101:105].all() and not replaced[:4].any() and not replaced[7:].any()
    assert _dense(H[5]).query(R[5, 95:111])[0].max() < 0.003
