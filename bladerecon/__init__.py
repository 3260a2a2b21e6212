# SPDX-License-Identifier: LGPL-2.1-or-later
"""BladeRecon: measured blade sections to a native B-spline surface (FreeCAD workbench).

Data flows one way: points -> sections -> curves -> surface -> analysis -> export.
``bladerecon.core`` is numpy/scipy only; ``bladerecon.fc`` adapts to FreeCAD/Part;
``bladerecon.gui`` holds the workbench commands.
"""
__version__ = "0.1.0"
