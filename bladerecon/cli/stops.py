# SPDX-License-Identifier: LGPL-2.1-or-later
"""Ctrl-C and SIGTERM that Python swallowed, sent again.

Raised where Python ignores exceptions (an import lock's weakref callback, a Cython module's
set-up, a ``__del__``), a stop was printed as "Exception ignored" with a traceback and the
command ran on to the end (status 0, outputs written; FreeCAD 1.0 under load, 2026-11-27).
:class:`resend_swallowed` installs a ``sys.unraisablehook`` that sends the signal again a moment
later, from a timer (raised inside the hook it would be swallowed as well), to land in ordinary
code. Leaving the block cancels the timers not yet fired and restores the hook and the warning
filters (the interrupted import's warnings are dropped while stopping).
"""
from __future__ import annotations

import os
import signal
import sys
import threading
import warnings

__all__ = ["resend_swallowed", "RESEND_LIMIT"]

#: stops swallowed again and again (a loop of callbacks): after this many, ``on_limit`` ends it
RESEND_LIMIT = 1000
#: seconds before the signal is sent again
RESEND_DELAY = 0.002


class resend_swallowed:
    """``with resend_swallowed({KeyboardInterrupt: signal.SIGINT}, on_limit): ...``.

    ``stops``: exception type -> the signal whose handler raises it. ``on_limit(signum)``
    (should not return) is called when the same block swallowed more than ``RESEND_LIMIT``."""

    def __init__(self, stops: dict, on_limit=None):
        self.stops = stops
        self.on_limit = on_limit
        self.timers: list[threading.Timer] = []
        self.count = 0

    def __enter__(self):
        self.previous = sys.unraisablehook
        self.filters = warnings.catch_warnings()
        self.filters.__enter__()
        sys.unraisablehook = self._hook
        return self

    def __exit__(self, *exc) -> bool:
        for timer in self.timers:
            timer.cancel()
        sys.unraisablehook = self.previous
        self.filters.__exit__(*exc)
        return False

    def _hook(self, unraisable) -> None:
        kind = unraisable.exc_type
        signum = next((s for t, s in self.stops.items() if kind is not None and issubclass(kind, t)), None)
        if signum is None or not callable(signal.getsignal(signum)):
            self.previous(unraisable)
            return
        stops = tuple(self.stops)
        armed = False
        while not armed:
            try:
                warnings.simplefilter("ignore")
                self.count += 1
                if self.count > RESEND_LIMIT and self.on_limit is not None:
                    self.on_limit(signum)
                timer = threading.Timer(RESEND_DELAY, os.kill, (os.getpid(), signum))
                timer.daemon = True
                self.timers.append(timer)
                timer.start()
                armed = True
            except stops:
                # the signal an earlier timer sent landed here, inside this hook, where it is
                # swallowed too ("Exception ignored in sys.unraisablehook"; seen on a loaded
                # machine: the command then ran on to status 0): send it again
                continue
