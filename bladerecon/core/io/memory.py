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

__all__ = ["available_bytes", "budget_bytes", "check_budget", "deviation_need", "careful_read_need", "check_command",
           "command_need", "add_memory_option", "GB"]

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
#: reading a point file, before a command's own work: the interpreter and numpy
READ_BASE = 0.10 * GB
#: the careful parser (comments after values, quotes, text labels, ``;`` and decimal commas)
#: holds the lines and cells as Python strings: per line and per byte of file. Measured peak
#: RSS over the ~60 MB base, 600 000 lines: 770 B a line (``S12,x,y,z``, 63 B lines), 615
#: (``x;y;z`` with decimal commas, 28 B), 667 (900 000 ``x y z`` lines, 59 B)
CAREFUL_BYTES_PER_LINE = 550.0
CAREFUL_BYTES_PER_BYTE = 4.0
#: and per cell beyond the three coordinates (a wide quoted CMM export: 12 columns of 2-digit
#: cells took 1340 B a line, 30 columns 1900 B)
CAREFUL_BYTES_PER_CELL = 80.0
#: a PLY/PCD scan: the file's bytes, a byte of mask each, then the points as float64.
#: Measured: 3.3 (binary PLY with normals, 1M points) and 3.7 (ASCII PLY) bytes a byte; an
#: ASCII body also keeps six int64 arrays a line (3M short integer rows: 384 MB for 18 MB)
SCAN_BYTES_PER_BYTE = 5.0
SCAN_BYTES_PER_LINE = 80.0


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


#: every command that reads measured points: (base bytes, bytes per point), upper bounds of
#: the peak total PSS measured on this project's runs (``bench/bench_memory.py``,
#: ``bench/results/memory.md``). The point count is bounded before the file is read
#: (:func:`bladerecon.core.io.readers.points_upper_bound`).
COMMAND_NEED = {
    "deviation": (DEVIATION_BASE, DEVIATION_PER_POINT),
    # sections 3k-600k points: 0.11-0.28 GB; a whole-blade cloud 50k-800k: 0.29-0.38 GB;
    # --slice 6 at 200k/400k/800k: 0.13/0.13/0.15 GB
    "reconstruct": (0.40 * GB, 320.0),
    # 3k-180k points: 0.05-0.10 GB (48k: 0.07 GB; 0.12 GB with --plots, 0.22 GB with --nominal:
    # SECTIONS_NOMINAL and SECTIONS_PLOTS are added for those options)
    "sections": (0.08 * GB, 300.0),
    # blade sections 20k/100k/400k: 0.15/0.32/1.19 GB; --zmap 100k/400k/1M: 0.33/1.17/2.84 GB
    "tspline": (0.15 * GB, 3200.0),
    # damaged-blade clouds 15k/45k/150k/400k: 0.26/0.27/0.42/0.80 GB
    "repair": (0.30 * GB, 1600.0),
    # the scan split into blades and one local worker: 2.4k/240k/960k points 0.31/0.32/0.39 GB;
    # each further worker adds its own interpreter and FreeCAD (DEVIATION_BASE)
    "blisk": (0.40 * GB, 150.0),
    # per dense sample of the cut (about the sections' length / --step): 6.7k/33k/133k/333k
    # samples 0.21/0.27/0.41/0.45 GB
    "plan": (0.25 * GB, 1000.0),
}
#: ``sections --nominal`` loads FreeCAD and the nominal; ``--plots`` loads matplotlib
SECTIONS_NOMINAL = 0.20 * GB
SECTIONS_PLOTS = 0.06 * GB
#: what to do about a job over the budget, per command
_ADVICE = {
    "deviation": "split the point file, or raise --memory-limit",
    "reconstruct": "thin the points (every k-th point of each section), or raise --memory-limit",
    "sections": "thin the points (every k-th point of each section), or raise --memory-limit",
    "tspline": "thin the cloud, or raise --memory-limit",
    "repair": "thin the cloud, or raise --memory-limit",
    "blisk": "thin the scan, use fewer --workers, or raise --memory-limit",
    "plan": "give a larger --step, or raise --memory-limit",
}


def command_need(command: str, n_points: int) -> float:
    """Peak memory (bytes) of ``command`` on ``n_points`` measured points, an upper bound."""
    base, per_point = COMMAND_NEED[command]
    return base + per_point * n_points


def check_command(command: str, n_points: int, limit_gb: float | None, source: str, workers: int = 1,
                  what: str = "points", extra: float = 0.0) -> None:
    """Refuse ``command`` on a file of (at most) ``n_points`` points (or dense samples) when
    its need is over the budget: one line, before anything is read or computed. ``workers``:
    local worker processes beside the command's own; ``extra``: bytes its options add."""
    need = command_need(command, n_points) + DEVIATION_BASE * max(0, workers - 1) + extra
    check_budget(f"{command} of {source} (up to {n_points} {what}"
                 + (f", {workers} workers" if workers > 1 else "") + ")", need, limit_gb, _ADVICE[command])


def add_memory_option(parser) -> None:
    """The ``--memory-limit GB`` option every command that reads points has."""
    from bladerecon.core.io.outputs import positive

    parser.add_argument("--memory-limit", type=positive(1e6, "GB"), metavar="GB",
                        help="memory budget (default half the memory available at start): a job whose "
                             "estimated need is larger is refused before the work starts")


def careful_read_need(n_lines: int, n_bytes: int, n_columns: int = 3) -> float:
    """Peak memory (bytes) of reading a file of ``n_lines`` lines of ``n_columns`` cells and
    ``n_bytes`` bytes with the careful parser, an upper bound."""
    per_line = CAREFUL_BYTES_PER_LINE + CAREFUL_BYTES_PER_CELL * max(0, n_columns - 3)
    return READ_BASE + per_line * n_lines + CAREFUL_BYTES_PER_BYTE * n_bytes


def check_budget(what: str, need: float, limit_gb: float | None, advice: str) -> None:
    """Refuse (one line) a job whose estimated need is over the budget, before it starts."""
    budget, how = budget_bytes(limit_gb)
    if budget is not None and need > budget:
        raise BladeReconError(f"{what} needs about {_amount(need)} of memory, more than the budget of "
                              f"{_amount(budget)} ({how}): {advice}")


def _amount(n_bytes: float) -> str:
    return f"{n_bytes / GB:.2f} GB" if n_bytes >= 0.1 * GB else f"{n_bytes / 1e6:.3g} MB"
