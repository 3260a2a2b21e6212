# SPDX-License-Identifier: LGPL-2.1-or-later
"""Every command the documentation shows runs as written, in a plain copy of the repository.

Read: the fenced code blocks (```) of README.md and docs/*.md. A line ending in ``\\``
continues on the next. Run, in the order of the block:

* lines starting with ``/usr/bin/python3 -m bladerecon``, ``python3 -m bladerecon`` or
  ``make demo`` (``make demo``, ``make demo-acquire``);
* ``mkdir`` lines: the setup the block itself shows (``mkdir -p demo_out``).

Not run, and counted apart:

* ``make test``, ``make test-freecad1``, ``make bench``, ``make deps``: the suite itself
  (recursive), a second suite in a Debian 13 root, about eleven minutes of benchmarks, and the
  package installation every ``make demo`` run here does anyway;
* lines with a placeholder in CAPITALS (``INPUT``, ``MEASURED``, ``OUT.step``, ``PORT``,
  ``REPOSITORY_URL``...): synopses and templates for the reader's own files and devices,
  not commands;
* anything else (``git clone``, ``cd``, output shown as an example).

Each code block runs in a fresh temporary folder in which ``bladerecon/``, ``resources/``,
``tests/`` (for ``tests/data``) and ``Makefile`` are links to this checkout: what a plain
clone holds, and every output lands in the temporary folder (commands later in a block may
read what earlier ones wrote, as when a reader types them one after the other). The
environment is a plain shell's: no ``PYTHONPATH``, no variables of a calling ``make``. Each
command must exit with status 0; one with ``--json`` must print exactly one JSON document on
stdout, and ``make demo`` targets nothing but JSON documents. The last test prints how many
commands ran (``pytest -s`` shows it) and checks that it is every command found.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINKED = ("bladerecon", "resources", "tests", "Makefile")
RUN_PREFIXES = ("/usr/bin/python3 -m bladerecon", "python3 -m bladerecon", "make demo")
NOT_RUN_MAKE = re.compile(r"make\s+(test|test-freecad1|bench|deps)(\s|$)")
PLAIN_SHELL_DROPS = ("PYTHONPATH", "MAKEFLAGS", "MFLAGS", "MAKELEVEL", "MAKEOVERRIDES")


def has_placeholder(line: str) -> bool:
    """A word (or part of a path or option value) in CAPITALS: INPUT, OUT.step, CAL.json, PORT."""
    return any(re.fullmatch(r"[A-Z][A-Z0-9_]*[A-Z0-9]", tok)
               for tok in re.split(r"[\s/.,=\[\]|(){}:<>]+", line))


def code_blocks(text: str) -> list[tuple[int, list[str]]]:
    """(line number of the opening fence, logical lines) of every fenced block."""
    blocks, current, start, pending = [], None, 0, ""
    for number, raw in enumerate(text.splitlines(), start=1):
        if raw.lstrip().startswith("```"):
            if current is None:
                current, start = [], number
            else:
                blocks.append((start, current))
                current = None
            continue
        if current is None:
            continue
        line = pending + raw.strip()
        if line.endswith("\\"):
            pending = line[:-1].rstrip() + " "
            continue
        pending = ""
        if line:
            current.append(line)
    return blocks


def classify(line: str) -> str:
    """'run', 'setup', 'skipped' (a command deliberately not run) or 'other'."""
    if line.startswith("mkdir "):
        return "setup"
    if NOT_RUN_MAKE.match(line):
        return "skipped"
    if line.startswith(RUN_PREFIXES):
        return "skipped" if has_placeholder(line) else "run"
    return "other"


def documented_blocks() -> list[tuple[str, list[str]]]:
    found = []
    for doc in DOCS:
        for start, lines in code_blocks(doc.read_text(encoding="utf-8")):
            steps = [ln for ln in lines if classify(ln) in ("run", "setup")]
            if any(classify(ln) == "run" for ln in steps):
                found.append((f"{doc.relative_to(ROOT)}:{start}", steps))
    return found


BLOCKS = documented_blocks()
RAN: list[str] = []


def json_documents(text: str) -> list:
    """The JSON documents ``text`` consists of; ValueError if anything else is in it."""
    decoder, docs, i = json.JSONDecoder(), [], 0
    while True:
        while i < len(text) and text[i].isspace():
            i += 1
        if i == len(text):
            return docs
        doc, i = decoder.raw_decode(text, i)
        docs.append(doc)


def plain_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k not in PLAIN_SHELL_DROPS}


def test_the_reader_finds_commands_and_skips_what_it_should():
    """The extraction is not blind: a made-up page with each kind of line."""
    page = "\n".join([
        "text /usr/bin/python3 -m bladerecon reconstruct not-in-a-block.csv",
        "```",
        "mkdir -p demo_out",
        "/usr/bin/python3 -m bladerecon reconstruct resources/sample/measured.csv \\",
        "    -o demo_out/a.step --json",
        "/usr/bin/python3 -m bladerecon deviation MEASURED --nominal NOMINAL",
        "/usr/bin/python3 -m bladerecon reconstruct INPUT [-o OUT.step]",
        "make test",
        "make demo     # a comment",
        "make demo-acquire",
        "git clone REPOSITORY_URL somewhere",
        "```",
        "    /usr/bin/python3 -m bladerecon plan indented-not-fenced.step",
    ])
    (start, lines), = code_blocks(page)
    assert start == 2
    kinds = [classify(ln) for ln in lines]
    assert kinds == ["setup", "run", "skipped", "skipped", "skipped", "run", "run", "other"]
    assert lines[1] == "/usr/bin/python3 -m bladerecon reconstruct resources/sample/measured.csv -o demo_out/a.step --json"
    assert not has_placeholder("reconstruct tests/data/parablade_r67_cloud/NASA_R67_MoveSurface.txt")
    assert has_placeholder("acquire --port PTY -o acquired.csv")


def test_documents_read_nothing_outside_the_repository():
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        assert "../shared" not in text, f"{doc.name} points outside the repository"
        assert "scan.csv" not in text, f"{doc.name} uses a file the repository does not ship"


def test_relative_links_and_images_exist():
    broken = []
    for doc in DOCS:
        for target in re.findall(r"\]\(([^)\s]+)\)", doc.read_text(encoding="utf-8")):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            if not (doc.parent / target.split("#")[0]).exists():
                broken.append(f"{doc.relative_to(ROOT)}: {target}")
    assert not broken, broken


def test_readme_is_at_most_12_kb():
    assert (ROOT / "README.md").stat().st_size <= 12 * 1024


@pytest.mark.timeout(900)
@pytest.mark.parametrize("where,steps", BLOCKS, ids=[b[0] for b in BLOCKS])
def test_documented_commands_run(where, steps, tmp_path):
    for name in LINKED:
        (tmp_path / name).symlink_to(ROOT / name)
    for line in steps:
        run = subprocess.run(["bash", "-c", line], cwd=tmp_path, env=plain_env(),
                             capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, f"{where}: `{line}` exited {run.returncode}\n{run.stderr[-3000:]}"
        if classify(line) != "run":
            continue
        piped = re.search(r"[|>]", line.split("#")[0])
        if line.startswith("make demo"):
            try:
                docs = json_documents(run.stdout)
            except ValueError as err:
                pytest.fail(f"{where}: `{line}` printed more than JSON on stdout ({err}):\n{run.stdout[:2000]}")
            assert docs, f"{where}: `{line}` printed nothing on stdout"
            if line.split("#")[0].split() == ["make", "demo"]:
                assert len(docs) == 1 and isinstance(docs[0], dict), run.stdout[:2000]
        elif "--json" in line.split() and not piped:
            try:
                docs = json_documents(run.stdout)
            except ValueError as err:
                pytest.fail(f"{where}: `{line}` --json printed something else ({err}):\n{run.stdout[:2000]}")
            assert len(docs) == 1, f"{where}: `{line}` printed {len(docs)} JSON documents"
        RAN.append(f"{where}: {line}")


def test_every_documented_command_ran():
    expected = sum(1 for _, steps in BLOCKS for ln in steps if classify(ln) == "run")
    skipped = sum(1 for doc in DOCS for _, lines in code_blocks(doc.read_text(encoding="utf-8"))
                  for ln in lines if classify(ln) == "skipped")
    print(f"\ndocumented commands run: {len(RAN)} of {expected} "
          f"(in {len(BLOCKS)} code blocks; {skipped} not run: make test/bench/deps/test-freecad1 or placeholders)")
    assert expected > 0
    assert len(RAN) == expected, "some documented commands did not run (see the failures above)"
