# SPDX-License-Identifier: LGPL-2.1-or-later
"""Reports written beside the results: the reconstruct and deviation report folders (HTML,
CSV, PNG plots drawn with matplotlib's Agg backend)."""
