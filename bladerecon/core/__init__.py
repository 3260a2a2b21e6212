"""FreeCAD-free core of BladeRecon: numpy + scipy only (never import FreeCAD/Part here)."""
