# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon``: see :mod:`bladerecon.cli.main`."""
import os        # on a normal start-up already loaded by Python's own (site): at once
import sys

# One BLAS thread unless the user set it: the commands parallelise their long work themselves,
# and on a busy machine OpenBLAS's threads turned each small product of the section analysis
# (8000 x 2 by 2) from 5 µs into 2-4 ms (`sections` on 21 sections: 0.78 -> 0.69 s, 2026-11-27).
# Only OpenBLAS reads it (Debian's default BLAS for numpy); another BLAS keeps its own setting.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

try:
    import signal

    from bladerecon.cli.stops import resend_swallowed
    # Ctrl-C swallowed by an import's callback while the first modules load: sent again
    with resend_swallowed({KeyboardInterrupt: signal.SIGINT}):
        from bladerecon.cli.main import main
        code = main()
except KeyboardInterrupt:       # Ctrl-C while the first modules load: one line, as later
    print("bladerecon: interrupted; no output was completed", file=sys.stderr, flush=True)
    os._exit(130)               # not sys.exit: the interpreter's clean-up of a half-loaded module
sys.exit(code)
