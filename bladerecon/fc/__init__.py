# SPDX-License-Identifier: LGPL-2.1-or-later
"""FreeCAD adapters: numpy <-> Part conversion, STEP I/O, OpenCASCADE measurements.

Modules here import FreeCAD and Part (through :func:`bladerecon.fc.freecad_env.import_freecad`,
which finds FreeCAD's lib folder), never FreeCADGui.
"""
from bladerecon.fc.freecad_env import import_freecad

__all__ = ["import_freecad"]
