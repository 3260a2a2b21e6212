# SPDX-License-Identifier: LGPL-2.1-or-later
"""Exact minimum distance from many points to a B-spline surface or curve.

Seed 001 §2: the deviation of a measured point P from the reconstructed surface S is the
length of the shortest segment P -> S(u, v), whose foot satisfies the orthogonality
conditions (eq. 10)

    S_u · (S - P) = 0,    S_v · (S - P) = 0,

and where several feet satisfy them the closest one counts (eq. 11). Here eq. 10 is solved
by a trust-region Newton iteration on f = |S - P|^2 / 2, vectorised over all points (the
only Python loops run over iterations, never over points), started from the nearest
sample of a grid on the surface (a k-d tree). Eq. 11: where another part of the surface
comes close enough to hold a closer foot - the other side of a thin leading or trailing
edge, ~1 mm away - or the point lies near a centre of curvature, Newton starts again
from the nearest samples there, and from the foot moved round the edge; the closest foot
wins. Seed 000 Tables 1-2 report
max / mean / std of these distances: :func:`distance_stats`.

Evaluation uses the piecewise polynomial form of the spline: on each knot span (surface:
each patch) the basis functions are polynomials, stored once as Taylor coefficients about
the span centre (NURBS Book §2.2 and A2.3 for the derivatives that give them), so a point
costs a table look-up and two nested Horner schemes instead of the Cox-de Boor recursion.
Each Newton step is refined on the local quadratic Taylor model, and the last, tiny step
is taken by Taylor expansion with a bound on its error, so most points need only one or
two evaluations after the start sample.

Where eq. 10 has no root - the foot on a clamped edge of the surface, or on a crease (a
knot of multiplicity >= degree) - Newton holds that parameter on the edge and minimises
along the other (the boundary case of eq. 11). Collapsed edges (S_u or S_v = 0, a cone
apex) are handled too.

Units: millimetres everywhere (points, feet, distances, ``tol``).

The package, one concern a module (none imports another in a circle):

* :mod:`.evaluation` - the splines as tables of polynomial pieces, and their evaluation;
* :mod:`.grid` - the start grids: samples in a k-d tree, their covers and separations;
* :mod:`.newton` - the trust-region Newton iteration (eq. 10) for surfaces and curves;
* :mod:`.feet` - the best feet found so far, the focal ratio, the curvature at a foot;
* :mod:`.restarts` - extra starts from other samples in reach and round a thin edge (eq. 11);
* :mod:`.search` - the global search that runs the above over all points;
* :mod:`.parallel` - blocks of points in forked children (shared memory) or on threads;
* :mod:`.points` - input checks, the voxel order of the points, the rounding noise;
* :mod:`.cache` - the models and start grids of the splines used last;
* :mod:`.surface`, :mod:`.curve` - the public projections; :mod:`.stats` - distance statistics.
"""
from __future__ import annotations

from bladerecon.core.geometry.projection.curve import CurveProjection, project_points_to_curve
from bladerecon.core.geometry.projection.stats import distance_stats
from bladerecon.core.geometry.projection.surface import Projection, project_points_to_surface, surface_derivatives_fast

__all__ = [
    "Projection",
    "CurveProjection",
    "project_points_to_surface",
    "project_points_to_curve",
    "distance_stats",
    "surface_derivatives_fast",
]
