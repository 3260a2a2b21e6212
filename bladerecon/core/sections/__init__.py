# SPDX-License-Identifier: LGPL-2.1-or-later
"""Stage 2, points -> sections: ordering and orientation, slicing clouds, fairing bad points,
segmentation into LE/TE/flanks, edge fits, section parameters and measurement plans."""
