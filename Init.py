# SPDX-License-Identifier: LGPL-2.1-or-later
# BladeRecon: headless registration (runs in FreeCAD and FreeCADCmd). Keep it light.
#
# FreeCAD (0.20, 1.0) runs this file for an addon in <FreeCAD.getUserAppDataDir()>/Mod/BladeRecon
# (Linux: ~/.local/share/FreeCAD/Mod/BladeRecon, where the Addon Manager clones it; a symlink
# there works too) and puts that folder on sys.path first, so `import bladerecon` needs nothing
# here. ~/.FreeCAD/Mod is not read since 0.20 ("User path has changed ..."): move an addon from
# there. This file is exec'd, not imported: no __file__; the code stays at top level.
import FreeCAD

# File > Open / Import of measured points: the module is imported only when a file is chosen.
FreeCAD.addImportType("BladeRecon measured points (*.csv *.xyz *.pts *.asc *.dat)", "bladerecon.fc.importer")
