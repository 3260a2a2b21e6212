# SPDX-License-Identifier: LGPL-2.1-or-later
"""File > Open / File > Import of measured blade points (registered in Init.py).

FreeCAD calls ``open(filename)`` (a new document) or ``insert(filename, docname)``; both build a
MeasuredPoints object (:func:`bladerecon.fc.objects.make_measured_points`). A bad file raises
:class:`~bladerecon.core.errors.BladeReconError` with the CLI's one-line message, before the
document is touched.
"""
from __future__ import annotations

import os
from typing import Any

from bladerecon.fc.freecad_env import import_freecad

__all__ = ["open", "insert", "FILE_TYPES"]

FreeCAD, _ = import_freecad()

FILE_TYPES = "BladeRecon measured points (*.csv *.xyz *.pts *.asc *.dat)"


def insert(filename: str, docname: str) -> Any:
    """Add the points of ``filename`` (mm) to document ``docname`` (created if missing)."""
    from bladerecon.fc.objects import make_measured_points

    try:
        doc = FreeCAD.getDocument(docname)
    except NameError:
        doc = FreeCAD.newDocument(docname)
    obj = make_measured_points(doc, filename)
    doc.recompute()
    return obj


def open(filename: str) -> Any:  # noqa: A001  (FreeCAD's importer API name)
    """A new document named after ``filename`` holding its measured points."""
    name = os.path.splitext(os.path.basename(filename))[0] or "MeasuredPoints"
    doc = FreeCAD.newDocument(name)
    insert(filename, doc.Name)
    return doc
