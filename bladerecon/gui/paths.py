# SPDX-License-Identifier: LGPL-2.1-or-later
"""Where the workbench's icons and .ui files are, computed from this file (no FreeCAD import)."""
from __future__ import annotations

import os

__all__ = ["REPO_ROOT", "RESOURCES", "ICONS", "UI", "icon", "ui_file"]

REPO_ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
RESOURCES = os.path.join(REPO_ROOT, "resources")
ICONS = os.path.join(RESOURCES, "icons")
UI = os.path.join(RESOURCES, "ui")


def icon(name: str) -> str:
    """Absolute path of an icon in resources/icons (``name`` with or without ``.svg``)."""
    return os.path.join(ICONS, name if name.endswith(".svg") else name + ".svg")


def ui_file(name: str) -> str:
    """Absolute path of a Qt Designer file in resources/ui (``name`` with or without ``.ui``)."""
    return os.path.join(UI, name if name.endswith(".ui") else name + ".ui")
