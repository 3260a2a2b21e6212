# SPDX-License-Identifier: LGPL-2.1-or-later
"""Parallel blocks: the points cut into blocks of ``_CHUNK``, run ``_THREADS`` at a time in
forked children writing to anonymous shared memory, or on threads where a fork is not safe.

:mod:`.search` reads ``_THREADS`` from here when it runs (as ``parallel._THREADS``), so this
one setting governs every parallel step.
"""
from __future__ import annotations

import mmap
import os
import signal
import sys
import threading
from concurrent.futures import ThreadPoolExecutor

import numpy as np

__all__ = ["_for_each_block", "_can_fork", "_fork_blocks", "_shared"]

_CHUNK = 16_384             # points per block: cache-sized, bounds memory for a million points
_THREADS = min(4, os.cpu_count() or 1)   # blocks run in parallel: forked processes, or threads


def _for_each_block(m: int, work, chunk: int = _CHUNK, shared: bool = False) -> None:
    """Call ``work(start, stop, kd_workers)`` on blocks of ``chunk`` points, in parallel
    when there are several blocks; each block writes its own rows of the outputs.

    With ``shared`` (the outputs live in shared memory, :func:`_shared`) and where a fork is
    safe (:func:`_can_fork`), the blocks are split between this process and forked
    children: numpy's many short calls scale far better over processes than over threads,
    which hand the GIL to and fro. Otherwise threads (numpy and the k-d tree release the
    GIL for their loops).
    """
    blocks = [(s, min(s + chunk, m)) for s in range(0, m, chunk)]
    n = min(_THREADS, len(blocks))
    if n <= 1:
        for s, e in blocks:
            work(s, e, -1)
    elif shared and _can_fork():
        _fork_blocks([blocks[k::n] for k in range(n)], work)
    else:
        with ThreadPoolExecutor(n) as pool:
            list(pool.map(lambda block: work(block[0], block[1], 1), blocks))


def _can_fork() -> bool:
    """A fork is safe in a single-threaded process on Linux without a GUI toolkit loaded (in
    FreeCAD's GUI, whose Qt threads Python does not see, threads are used instead; only the
    module names are looked at, nothing is imported); ``BLADERECON_PROCESSES=0`` turns it off."""
    return (sys.platform.startswith("linux") and hasattr(os, "fork") and threading.active_count() == 1
            and os.environ.get("BLADERECON_PROCESSES", "1") != "0"
            and not any(name in sys.modules for name in _GUI_MODULES))


_GUI_MODULES = ("FreeCADGui", "PySide", "PySide2", "PySide6", "PyQt5", "PyQt6", "tkinter")


def _fork_blocks(groups: list[list[tuple[int, int]]], work) -> None:
    """Run the first group of blocks here and each other group in a forked child; a child
    that fails (or cannot be forked) has its blocks run here afterwards.

    Ctrl-C and SIGTERM are held from each fork until its child is on the list of those to
    stop: arriving in between, they would leave that child running on after the command."""
    children = []
    waiting: set[int] = set()
    try:
        for group in groups[1:]:
            mask = signal.pthread_sigmask(signal.SIG_BLOCK, _STOP_SIGNALS)
            try:
                pid = os.fork()
            except OSError:
                pid = None
            if pid == 0:                               # the child: its blocks, then leave at once
                signal.pthread_sigmask(signal.SIG_SETMASK, mask)
                code = 1
                try:
                    for s, e in group:
                        work(s, e, 1)
                    code = 0
                finally:
                    os._exit(code)
            children.append((pid, group))
            if pid is not None:
                waiting.add(pid)
            signal.pthread_sigmask(signal.SIG_SETMASK, mask)     # a held signal arrives here
        for s, e in groups[0]:
            work(s, e, 1)
        for pid, group in children:
            failed = pid is None or os.waitpid(pid, 0)[1] != 0
            waiting.discard(pid)
            if failed:
                for s, e in group:
                    work(s, e, 1)
    except BaseException:         # Ctrl-C, SIGTERM, an error here: no child outlives the call
        for pid in waiting:
            try:
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
            except OSError:
                pass
        raise


_STOP_SIGNALS = {signal.SIGINT, signal.SIGTERM}


def _shared(shape: tuple[int, ...], dtype=float) -> np.ndarray:
    """An array in anonymous shared memory: what forked children write, the parent sees."""
    size = int(np.prod(shape)) * np.dtype(dtype).itemsize
    return np.frombuffer(mmap.mmap(-1, max(size, 1)), dtype=dtype, count=int(np.prod(shape))).reshape(shape)
