# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon <command>``: the entry point (:mod:`.main`) and one module per
command (reconstruct, deviation, sections, plan, tspline, acquire)."""
