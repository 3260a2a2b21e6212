# SPDX-License-Identifier: LGPL-2.1-or-later
"""Repair target of a damaged blade (issue 18): numpy/scipy only."""
from bladerecon.core.repair.deformation import SpanField, fit_span_field
from bladerecon.core.repair.target import RepairResult, adapt_surface, repair_target

__all__ = ["SpanField", "fit_span_field", "RepairResult", "adapt_surface", "repair_target"]
