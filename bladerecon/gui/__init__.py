# SPDX-License-Identifier: LGPL-2.1-or-later
"""BladeRecon workbench GUI: commands, view providers, task panels (imports FreeCADGui).

Only :mod:`bladerecon.gui.paths` and :mod:`bladerecon.gui.colormap` are importable without FreeCAD.
"""
