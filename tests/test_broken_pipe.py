# SPDX-License-Identifier: LGPL-2.1-or-later
"""A reader that goes away (``bladerecon ... --json | head``, a log viewer closed): the command
ends quietly with SIGPIPE's status (141), as any Unix tool, never "internal error: BrokenPipeError"
with status 1; outputs committed before stay whole, outputs not yet committed are not left.

Found 2026-11-28: ``deviation ... --json | head -c 200`` printed "internal error: BrokenPipeError";
with stderr going to a closed pipe, the progress line's broken pipe was reported as "cannot write
OUT.csv: broken pipe" (an output named for stderr's fault), whose own line then broke again.
"""
from __future__ import annotations

import errno
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import Outputs

ROOT = Path(__file__).resolve().parent.parent
NOMINAL = ROOT / "resources" / "sample" / "nominal.step"
MEASURED = ROOT / "resources" / "sample" / "measured.csv"
PYTHON = "/usr/bin/python3"


def _closed_pipe() -> int:
    """The write end of a pipe whose read end is closed: every write to it fails with EPIPE."""
    r, w = os.pipe()
    os.close(r)
    return w


def _deviation(tmp_path: Path, *extra: str, stdout=subprocess.PIPE, stderr=subprocess.PIPE):
    out = tmp_path / "dev.csv"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.run([PYTHON, "-m", "bladerecon", "deviation", str(MEASURED), "--nominal", str(NOMINAL),
                           "--csv", str(out), *extra], stdout=stdout, stderr=stderr, env=env, timeout=240)
    return proc, out


def test_stderr_closed_before_the_first_line_ends_quietly_and_leaves_no_output(tmp_path):
    w = _closed_pipe()
    try:
        proc, out = _deviation(tmp_path, stderr=w)
    finally:
        os.close(w)
    assert proc.returncode == 141, proc.stdout
    assert proc.stdout == b""
    assert not out.exists()                           # the run stopped at its first line: nothing left
    assert not [p for p in tmp_path.iterdir()]        # no temporary either


def test_stdout_closed_under_json_ends_quietly_with_the_csv_whole(tmp_path):
    w = _closed_pipe()
    try:
        proc, out = _deviation(tmp_path, "--json", "--quiet", stdout=w)
    finally:
        os.close(w)
    assert proc.returncode == 141, proc.stderr
    assert proc.stderr == b""                         # no "internal error", no "Exception ignored"
    rows = np.loadtxt(out, delimiter=",", skiprows=1)  # committed before the summary was printed
    n_points = sum(1 for _ in open(MEASURED)) - 1
    assert rows.shape == (n_points, 8)
    assert np.isfinite(rows).all()


def test_a_broken_pipe_on_an_output_file_is_still_named(tmp_path):
    """Only a broken pipe that names no file is stdio's; one on a file is that output's line."""
    target = tmp_path / "x.csv"
    with pytest.raises(BladeReconError, match="x.csv"):
        with Outputs() as outs:
            tmp = outs.file(str(target), "--csv")
            raise BrokenPipeError(errno.EPIPE, "Broken pipe", tmp)
    with pytest.raises(BrokenPipeError):
        with Outputs() as outs:
            outs.file(str(target), "--csv")
            print("x", file=sys.stderr)
            raise BrokenPipeError(errno.EPIPE, "Broken pipe")
    assert not target.exists() and not list(tmp_path.iterdir())
