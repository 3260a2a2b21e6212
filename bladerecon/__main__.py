# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon``: see :mod:`bladerecon.cli.main`."""
import os        # loaded already by Python's start-up (site): nothing here can be interrupted
import sys


def _interrupt_again(unraisable, previous=sys.unraisablehook):
    # Ctrl-C swallowed by an import's callback ("Exception ignored"): sent again a moment later
    # (raised inside this hook it would be swallowed as well)
    import signal
    if unraisable.exc_type is KeyboardInterrupt and callable(signal.getsignal(signal.SIGINT)):
        import threading
        threading.Timer(0.002, os.kill, (os.getpid(), signal.SIGINT)).start()
    else:
        previous(unraisable)


# One BLAS thread unless the user set it: the commands parallelise their long work themselves,
# and on a busy machine OpenBLAS's threads turned each small product of the section analysis
# (8000 x 2 by 2) from 5 µs into 2-4 ms (`sections` on 21 sections: 0.78 -> 0.69 s, 2026-11-27)
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

try:
    sys.unraisablehook = _interrupt_again
    from bladerecon.cli.main import main
    code = main()
except KeyboardInterrupt:       # Ctrl-C while the first modules load: one line, as later
    print("bladerecon: interrupted; no output was completed", file=sys.stderr, flush=True)
    os._exit(130)               # not sys.exit: the interpreter's clean-up of a half-loaded module
sys.exit(code)
