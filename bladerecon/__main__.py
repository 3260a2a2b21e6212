# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon``: see :mod:`bladerecon.cli.main`."""
import sys

from bladerecon.cli.main import main

sys.exit(main())
