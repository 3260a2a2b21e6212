# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon``: see :mod:`bladerecon.cli.main`."""
import sys

try:
    from bladerecon.cli.main import main
except KeyboardInterrupt:       # Ctrl-C while the first modules load: one line, as later
    print("bladerecon: interrupted; no output was completed", file=sys.stderr)
    sys.exit(130)

sys.exit(main())
