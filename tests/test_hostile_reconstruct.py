# SPDX-License-Identifier: LGPL-2.1-or-later
"""``reconstruct``'s outputs through the same checks as the other commands' (the hostile-input
suite's helpers): a device, FIFO, link or folder named as an output is refused in one line
before any work, and a run that fails late (a bad nominal) leaves no STEP and no report."""
from __future__ import annotations

import pytest

from test_hostile_inputs import data, out, refused  # noqa: F401  (fixtures)

REC = ["reconstruct", "{d}/m.csv", "--quiet"]


@pytest.mark.parametrize("extra,words", [
    (["-o", "/dev/full"], "character device"),
    (["-o", "/dev/null"], "character device"),
    (["-o", "{o}/fifo"], "FIFO"),
    (["-o", "{o}/full"], "folder"),
    (["-o", "{o}/link"], "link"),
    (["-o", "{d}/m.csv"], "input"),
    (["--report", "{o}/full"], "--force"),
    (["--report", "{o}/old.csv"], "not a folder"),
    (["-o", "{o}/x.step", "--nominal", "{d}/text.step"], ""),
    (["-o", "{o}/x.step", "--report", "{o}/r", "--nominal", "{d}/empty.step"], ""),
], ids=["dev-full", "dev-null", "fifo", "folder-as-file", "link", "input", "report-full", "report-file",
        "bad-nominal", "empty-nominal-with-report"])
def test_reconstruct_outputs_refused_or_all_or_nothing(capfd, data, out, extra, words):  # noqa: F811
    argv = [a.format(d=data, o=out) for a in REC + extra]
    line = refused(capfd, argv, (data, out))
    assert words.lower() in line.lower(), line
