# SPDX-License-Identifier: LGPL-2.1-or-later
"""FreeCAD-free core of BladeRecon: numpy + scipy only (never import FreeCAD/Part here)."""
