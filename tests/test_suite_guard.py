# SPDX-License-Identifier: LGPL-2.1-or-later
"""The suite's own guard: a test that hangs fails with its name instead of stopping the run."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent


def test_a_hanging_test_fails_by_name_and_the_run_goes_on(tmp_path):
    shutil.copy(HERE / "conftest.py", tmp_path / "conftest.py")
    (tmp_path / "test_probe.py").write_text(
        "import time, pytest\n"
        "@pytest.mark.timeout(1)\n"
        "def test_waits_forever():\n"
        "    while True:\n"
        "        time.sleep(0.05)\n"
        "def test_after_it():\n"
        "    pass\n")
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
                         capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert run.returncode == 1, run.stdout + run.stderr
    assert "test_probe.py::test_waits_forever did not finish in 1 s" in run.stdout
    assert "1 failed, 1 passed" in run.stdout
