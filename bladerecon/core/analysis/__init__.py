# SPDX-License-Identifier: LGPL-2.1-or-later
"""Stage 5, surface -> analysis: best-fit alignment to the nominal, curvature and zebra of a
surface, fairness numbers of sections and surfaces."""
