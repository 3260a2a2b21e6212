# SPDX-License-Identifier: LGPL-2.1-or-later
"""Peak memory of a command as the machine sees it: the proportional set size (PSS, shared
pages split between the processes sharing them) summed over the process and every process it
forks, sampled every 20 ms from /proc/PID/smaps_rollup. Forked workers count in full, unlike
``ru_maxrss`` (the largest single process). A referee the measured code does not share."""
from __future__ import annotations

import os
import subprocess
import time


def _children(pid: int) -> list[int]:
    out = []
    try:
        for tid in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{tid}/children") as f:
                out += [int(c) for c in f.read().split()]
    except OSError:
        pass
    return out


def _pss_kb(pid: int) -> int:
    try:
        with open(f"/proc/{pid}/smaps_rollup") as f:
            for line in f:
                if line.startswith("Pss:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return 0


def peak_memory(cmd: list[str], env: dict | None = None, timeout: float = 600) -> tuple[int, float, str]:
    """Run ``cmd``; return (exit status, peak total PSS in bytes, stderr)."""
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    peak, end = 0, time.monotonic() + timeout
    while proc.poll() is None and time.monotonic() < end:
        tree, todo = [], [proc.pid]
        while todo:
            p = todo.pop()
            tree.append(p)
            todo += _children(p)
        peak = max(peak, sum(_pss_kb(p) for p in tree))
        time.sleep(0.02)
    if proc.poll() is None:
        proc.kill()
    _, err = proc.communicate()
    return proc.returncode, peak * 1024.0, err
