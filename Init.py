# SPDX-License-Identifier: LGPL-2.1-or-later
# BladeRecon: headless registration (runs in FreeCAD and FreeCADCmd). Keep it light.
#
# FreeCAD puts an addon's folder on sys.path before running this file; the lines below
# only cover a folder reached some other way (e.g. a symlink into the user Mod folder that
# FreeCAD resolves differently). This file is exec'd, not imported: no __file__, and names
# defined here are not visible inside functions, so the code stays at top level.
import os
import sys

import FreeCAD

for _bladerecon_root in (
    os.path.join(FreeCAD.getUserAppDataDir(), "Mod", "BladeRecon"),
    os.path.join(os.path.expanduser("~"), ".local", "share", "FreeCAD", "Mod", "BladeRecon"),
    os.path.join(os.path.expanduser("~"), ".FreeCAD", "Mod", "BladeRecon"),
):
    if os.path.isfile(os.path.join(_bladerecon_root, "bladerecon", "__init__.py")):
        if _bladerecon_root not in sys.path:
            sys.path.append(_bladerecon_root)
        break

# File > Open / Import of measured points: the module is imported only when a file is chosen.
FreeCAD.addImportType("BladeRecon measured points (*.csv *.xyz *.pts *.asc *.dat)", "bladerecon.fc.importer")
