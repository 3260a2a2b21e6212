# SPDX-License-Identifier: LGPL-2.1-or-later
"""B-spline geometry every stage uses: the hand-off dataclasses, vectorised evaluation,
curve fitting (interpolation, least squares) and exact point-to-surface projection."""
