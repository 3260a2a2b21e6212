# SPDX-License-Identifier: LGPL-2.1-or-later
"""A memory budget for a command (issue 23 §4): the job's need estimated before the work starts
and refused in one line when it does not fit, rather than found out by the kernel's OOM killer
or a MemoryError half way.

The estimates are upper bounds measured on this project's own runs (peak memory of the process
and its forked workers, FreeCAD included; see ``tests/test_memory_budget.py`` and
``bench/results/deviation_e2e.md``), not guesses from array sizes.
"""
from __future__ import annotations

import os

from bladerecon.core.errors import BladeReconError

__all__ = ["available_bytes", "budget_bytes", "check_budget", "deviation_need", "GB"]

GB = 1e9
#: default budget: this share of the memory available when the command starts
DEFAULT_SHARE = 0.5
#: ``deviation``: interpreter, FreeCAD, the nominal's start grid (a 1500 x 16-pole face included)
DEVIATION_BASE = 0.40 * GB
#: ``deviation``: bytes per measured point (feet, derivatives, the suspects' restarts in
#: blocks, outputs). Measured, total PSS of the process and its forked worker: on a 1500 x
#: 16-pole face 0.25 GB at 31 000 points, 0.38 GB at 100 000, 0.73 GB at 1M; on the sample
#: face 0.43 GB at 1M
DEVIATION_PER_POINT = 500.0


def available_bytes() -> float | None:
    """Memory available to a new job (``MemAvailable`` of /proc/meminfo), None when unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, ValueError, IndexError):
        pass
    try:
        return float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, AttributeError):
        return None


def budget_bytes(limit_gb: float | None) -> tuple[float | None, str]:
    """The budget in bytes and how it was set (for the message); None: unknown, no check."""
    if limit_gb is not None:
        return limit_gb * GB, "--memory-limit"
    avail = available_bytes()
    if avail is None:
        return None, ""
    return DEFAULT_SHARE * avail, f"half the {avail / GB:.1f} GB available; --memory-limit GB sets it"


def deviation_need(n_points: int) -> float:
    """Peak memory (bytes) of ``deviation`` on ``n_points`` points, an upper bound."""
    return DEVIATION_BASE + DEVIATION_PER_POINT * n_points


def check_budget(what: str, need: float, limit_gb: float | None, advice: str) -> None:
    """Refuse (one line) a job whose estimated need is over the budget, before it starts."""
    budget, how = budget_bytes(limit_gb)
    if budget is not None and need > budget:
        raise BladeReconError(f"{what} needs about {need / GB:.2f} GB of memory, more than the budget of "
                              f"{budget / GB:.2f} GB ({how}): {advice}")
