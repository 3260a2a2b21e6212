# SPDX-License-Identifier: LGPL-2.1-or-later
"""Running ``python3 -m bladerecon`` as a user does, from the tests: this interpreter, this
checkout on PYTHONPATH, output captured as text."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def run(*args, timeout: float = 600) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-m", "bladerecon", *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=timeout)
