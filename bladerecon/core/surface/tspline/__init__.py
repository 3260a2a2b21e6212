# SPDX-License-Identifier: LGPL-2.1-or-later
"""Adaptive analysis-suitable T-spline (ASTS) fitting, seed 002 (Lu et al. 2020).

Everything here is numpy/scipy. The pieces, with the seed's section numbers:

* :class:`TMesh` — a T-mesh over the reduced domain [0,1]² extended by ``mu`` on every side
  (seed 002 §2.2.3, Fig. 4), stored as its faces (axis-aligned rectangles that tile
  [-mu, 1+mu]²). Nodes are the face corners; edges are the face sides.
* Local knot vectors by ray casting (§1.1, Sederberg et al. 2003): from node (u_i2, v_i2)
  the first two edges hit in +u give u_i3, u_i4, and so on; where a ray leaves the mesh the
  last knot is repeated (so the outer boundary carries triple knots and the blending
  functions sum to one on the reduced domain [0,1]²).
* Cubic blending functions ``B_i(u,v) = N[u_i](u) N[v_i](v)`` (eq. 2), evaluated by the
  Cox–de Boor recursion vectorised over all points into a sparse basis matrix A.
* Initial mesh (§2.2.2): split a cell across its longer side at the midpoint while it holds
  more than N_d parameter points or more than N_f feature points (the 10 % of points with
  the largest |Gaussian curvature|, §2.2.1).
* AST conversion (§2.3): T-junction extensions (Li–Scott: two knot intervals on the side of
  the missing edge, one on the other); greedy one-step extension of a T-junction that
  leaves the fewest crossing extensions, until none cross.
* Least squares for all poles (eqs. 5–8, sparse normal equations), then local refinement
  (§2.5): split the cells holding a point with error > eps, convert to AST, re-solve only
  the poles of new nodes and nodes whose knot vectors changed, over the points in their
  support (eq. 10), until max error <= eps or a documented limit.
* Bézier extraction (:func:`bezier_patches`): the 4x4 Bernstein control points of every
  Bézier element — a T-mesh face cut by any blending-function knot line that crosses it, so
  that every blending function is one polynomial on it.
* Closed seam for blades (our addition; ``fit_tspline(seam="closed-c1")``): u is periodic
  with period 1, but the T-mesh is not a periodic T-mesh. :func:`mirror_seam` gives both
  u-ends the same v lines, and every solve is over the null space of the seam equations
  S(0,v) = S(1,v), ∂S/∂u(0,v) = ∂S/∂u(1,v) (:func:`seam_reduction`). Seam elements are cut
  at the same v values on both ends, so the exported patches meet there.

Values may have any dimension: a z-map fits z over (x, y) (one column); a blade fits
x, y, z over the (u, v) of the section reconstruction (three columns). Errors are the
Euclidean norm of S(u_j, v_j) - V_j (eq. 8): the vertical error for a z-map, a parametric
upper bound of the point-to-surface distance for a blade. Units: those of the values (mm).

The package, one concern a module (none imports another in a circle):

* :mod:`.tmesh` - the T-mesh, its topology, local knot vectors and T-junctions;
* :mod:`.editing` - cell splits, the mu strip, AST conversion;
* :mod:`.basis` - cubic blending functions, the sparse basis matrix, Bernstein polynomials;
* :mod:`.features`, :mod:`.initial` - feature points and the initial mesh;
* :mod:`.parameters` - parameter normalisation, duplicates, model lengths;
* :mod:`.least_squares` - the sparse least squares, and the tensor-product peer fit;
* :mod:`.seam` - the closed seam for blades;
* :mod:`.fitting` - :func:`fit_tspline` and its result, evaluation;
* :mod:`.bezier` - Bézier extraction and the patches' evaluation.
"""
from __future__ import annotations

from bladerecon.core.surface.tspline.basis import basis_matrix, bspline_basis_1d
from bladerecon.core.surface.tspline.bezier import BezierPatch, bezier_patches, evaluate_patches, zmap_patches
from bladerecon.core.surface.tspline.editing import make_analysis_suitable
from bladerecon.core.surface.tspline.features import feature_mask, gaussian_curvature
from bladerecon.core.surface.tspline.fitting import (
    FitLimits,
    TSplineFit,
    evaluate,
    fit_tspline,
    greville,
    partition_of_unity,
)
from bladerecon.core.surface.tspline.initial import initial_mesh, tensor_mesh
from bladerecon.core.surface.tspline.least_squares import tensor_least_squares
from bladerecon.core.surface.tspline.parameters import duplicate_parameters, normalise_parameters, parameter_lengths
from bladerecon.core.surface.tspline.seam import SEAMS, mirror_seam, seam_reduction, seam_rows
from bladerecon.core.surface.tspline.tmesh import TMesh, crossings, is_analysis_suitable, local_knots, t_junctions

# public names of the module before the split that were not in its __all__ (bench and tests use them)
from bladerecon.core.surface.tspline.bezier import bezier_elements  # noqa: F401
from bladerecon.core.surface.tspline.editing import CUT_ORDERS, add_strip, split_longer_side  # noqa: F401
from bladerecon.core.surface.tspline.tmesh import TJunctions  # noqa: F401

__all__ = [
    "TMesh", "TSplineFit", "FitLimits", "bspline_basis_1d", "gaussian_curvature",
    "feature_mask", "initial_mesh", "make_analysis_suitable", "fit_tspline", "evaluate",
    "basis_matrix", "bezier_patches", "BezierPatch", "tensor_mesh", "duplicate_parameters",
    "normalise_parameters", "zmap_patches", "evaluate_patches", "partition_of_unity",
    "is_analysis_suitable", "t_junctions", "crossings", "local_knots", "tensor_least_squares", "parameter_lengths", "greville",
    "SEAMS", "mirror_seam", "seam_rows", "seam_reduction",
]
