"""BladeRecon workbench GUI: commands, view providers, task panels (imports FreeCADGui).

Only :mod:`bladerecon.gui.paths` is importable without FreeCAD.
"""
