# SPDX-License-Identifier: LGPL-2.1-or-later
"""The suite's own guard against hangs (tests/conftest.py), run on a throw-away test file."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

TESTS = Path(__file__).resolve().parent


def _run(tmp_path: Path, env: dict) -> subprocess.CompletedProcess:
    (tmp_path / "conftest.py").write_text((TESTS / "conftest.py").read_text())
    (tmp_path / "test_sleeps.py").write_text(
        "import time\nimport pytest\n\n\n@pytest.mark.timeout(400)\ndef test_sleeps():\n    time.sleep(30)\n")
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120,
                          env=dict(os.environ, **env))


def test_the_cap_shortens_a_marked_limit_and_names_the_test(tmp_path):
    """BLADERECON_TEST_TIMEOUT_CAP caps a test's own mark too (mutation runs: a mutant looping
    forever fails in the cap, not after mutmut's timer): a 30 s sleep marked 400 s fails in 2 s
    with the line naming the test."""
    r = _run(tmp_path, {"BLADERECON_TEST_TIMEOUT_CAP": "2"})
    assert r.returncode == 1, r.stdout
    assert "test_sleeps.py::test_sleeps did not finish in 2 s (time limit; a hang?)" in r.stdout, r.stdout
    assert "1 failed" in r.stdout
