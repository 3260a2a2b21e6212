# SPDX-License-Identifier: LGPL-2.1-or-later
"""Stage 1, points in: measured point files (CSV, XYZ, section tables) and the instrument's
line protocol, read into plain arrays in millimetres."""
