"""``python3 -m bladerecon``: see :mod:`bladerecon.cli.main`."""
import sys

from bladerecon.cli.main import main

sys.exit(main())
