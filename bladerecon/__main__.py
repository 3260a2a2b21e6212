"""``python3 -m bladerecon``: see :mod:`bladerecon.cli`."""
import sys

from .cli import main

sys.exit(main())
