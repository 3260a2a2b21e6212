# SPDX-License-Identifier: LGPL-2.1-or-later
# BladeRecon workbench: only the Workbench class. Commands live in bladerecon.gui.commands.
#
# This file is exec'd by FreeCAD, not imported: every import happens inside the methods.
import FreeCADGui


class BladeReconWorkbench(FreeCADGui.Workbench):
    """Measured blade sections to a native B-spline surface, deviation analysis and STEP."""

    MenuText = "BladeRecon"
    ToolTip = "Reconstruct a blade surface from measured section points and export STEP"

    def __init__(self):
        from bladerecon.gui import paths

        self.__class__.Icon = paths.icon("BladeRecon")

    def Initialize(self):
        from bladerecon.gui import acquire_command, commands, repair_command, tspline_command  # importing registers

        names = list(commands.COMMANDS) + [acquire_command.COMMAND_NAME, tspline_command.COMMAND_NAME,
                                           repair_command.COMMAND_NAME]
        self.appendToolbar("BladeRecon", names)
        self.appendMenu("BladeRecon", names)

    def Activated(self):
        pass

    def Deactivated(self):
        pass

    def ContextMenu(self, recipient):
        from bladerecon.gui import commands

        if recipient == "Tree":
            self.appendContextMenu("BladeRecon", [n for n, c in commands.COMMANDS.items() if c.IsActive()])

    def GetClassName(self):
        return "Gui::PythonWorkbench"


FreeCADGui.addWorkbench(BladeReconWorkbench())
