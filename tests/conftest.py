# SPDX-License-Identifier: LGPL-2.1-or-later
"""The whole suite's guard against hangs: every test has a time limit.

A test that passes its limit fails with a message naming it (SIGALRM raises in the main
thread). A hang that Python cannot interrupt (a C call that never returns) is caught by
faulthandler a little later: it prints every thread's stack under a line naming the test and
ends the run (the dump holds the test's own frame), so the suite never waits forever.

The limit is ``BLADERECON_TEST_TIMEOUT`` seconds (default 300); a test may ask for more with
``@pytest.mark.timeout(SECONDS)``; ``BLADERECON_TEST_TIMEOUT_CAP`` caps both (mutation runs).
"""
from __future__ import annotations

import faulthandler
import os
import signal

import pytest

DEFAULT_LIMIT = float(os.environ.get("BLADERECON_TEST_TIMEOUT", "300"))
#: a cap on every limit, the marks' too (``make mutation``: a mutant that loops forever fails its
#: test in a minute instead of waiting for mutmut's timer, several minutes a mutant)
CAP = float(os.environ.get("BLADERECON_TEST_TIMEOUT_CAP", "inf"))
_GRACE = 60.0  # s after the limit before faulthandler ends the process


def pytest_configure(config):
    config.addinivalue_line("markers", "timeout(seconds): this test's time limit (default "
                            f"{DEFAULT_LIMIT:g} s, BLADERECON_TEST_TIMEOUT)")


class TimeLimitExceeded(Exception):
    """Raised in the main thread when a test passes its time limit."""


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    if not hasattr(signal, "SIGALRM"):
        yield
        return
    marker = item.get_closest_marker("timeout")
    limit = min(float(marker.args[0]) if marker and marker.args else DEFAULT_LIMIT, CAP)

    def expired(signum, frame):
        raise TimeLimitExceeded(f"{item.nodeid} did not finish in {limit:g} s (time limit; a hang?)")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, limit)
    # faulthandler's dump holds the test's own frame (file, function, line): that names it.
    faulthandler.dump_traceback_later(limit + _GRACE, exit=True)
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)



#: The slowest files (``--durations`` of a whole run, 2026-11-28), longest first. pytest-xdist
#: (``make test``: ``--dist loadfile``) hands files to the workers in collection order, so these
#: start first and the two workers finish together, instead of a 2-minute GUI file starting last.
SLOW_FILES_FIRST = ("test_docs_commands.py", "test_every_blade.py", "test_tspline.py", "test_memory_budget.py",
                    "test_repair.py", "test_deviation.py", "test_verdicts_cli.py", "test_workbench_gui.py",
                    "test_multiface_nominal.py", "test_batch.py", "test_edge_bad_points.py", "test_reconstruct.py",
                    "test_projection.py", "test_section_parameters.py", "test_fairing.py", "test_blisk.py")


def pytest_collection_modifyitems(config, items):
    rank = {name: k for k, name in enumerate(SLOW_FILES_FIRST)}
    # a stable sort: every file keeps its tests' order, the other files their alphabetical one
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))
