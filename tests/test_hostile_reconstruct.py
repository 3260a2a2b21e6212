# SPDX-License-Identifier: LGPL-2.1-or-later
"""``reconstruct``'s outputs through the same checks as the other commands' (the hostile-input
suite's helpers): a device, FIFO, link or folder named as an output is refused in one line
before any work, and a run that fails late (a bad nominal) leaves no STEP and no report."""
from __future__ import annotations

import pytest

from section_files import write_sections_csv
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


def _crossing_file(path):
    """The sample plan with section 3 moved to 1 mm under section 4 and tilted 10° about x
    through its centre: its plane meets section 4's on the blade (centres still in span order)."""
    import numpy as np
    root = __import__("pathlib").Path(__file__).resolve().parents[1]
    rows = np.loadtxt(root / "resources" / "sample" / "measured_plan.csv", delimiter=",", skiprows=1)
    s3 = rows[:, 0] == 3
    p = rows[s3, 1:].copy()
    c = p.mean(axis=0)
    a = np.radians(10.0)
    R = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    p = (p - c) @ R.T + c + [0.0, 0.0, 79.0 - c[2]]
    rows[s3, 1:] = p
    write_sections_csv(path, [rows[rows[:, 0] == k, 1:] for k in range(int(rows[:, 0].max()) + 1)])


@pytest.mark.parametrize("command", [["reconstruct", "{d}/cross.csv", "-o", "{o}/x.step", "--quiet"],
                                     ["sections", "{d}/cross.csv", "--lenient", "--json", "--quiet"]],
                         ids=["reconstruct", "sections"])
def test_sections_crossing_their_neighbours_are_refused(capfd, data, out, command):  # noqa: F811
    """Issue 23 §6: a section whose plane meets its neighbour's on the blade would fold the
    surface: refused in one line naming both sections and how far, nothing written."""
    cross = data / "cross.csv"
    if not cross.exists():
        _crossing_file(cross)
    line = refused(capfd, [a.format(d=data, o=out) for a in command], (data, out))
    assert "sections '3' and '4' cross" in line and "mm" in line, line
