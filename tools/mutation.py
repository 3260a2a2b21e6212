#!/usr/bin/python3
# SPDX-License-Identifier: LGPL-2.1-or-later
"""``make mutation``: mutmut over ``bladerecon/core``, module by module, with the tests that cover
each module, in a throw-away clone of this checkout's HEAD (mutmut edits the files it mutates:
never the checkout you work in). mutmut comes from PyPI into ``.cache/mutation-venv`` (a
development tool that sees the system's numpy/scipy/FreeCAD; never a runtime dependency).

Writes ``bench/results/mutation.md``: per module the mutants killed / survived / timed out and
the score (killed + timed out over all tested), and every survivor's diff for review (kill it
with a test, or explain it as equivalent). ``MUTATION_MODULES=alignment,fitting make mutation``
runs a subset. Not run by CI: hours on two cores.
"""
from __future__ import annotations

import datetime
import json
import os
import platform
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VENV = ROOT / ".cache" / "mutation-venv"
MUTMUT = VENV / "bin" / "mutmut"
PYTHON = "/usr/bin/python3"

#: name -> (paths to mutate, test files that cover them)
MODULES: dict[str, tuple[str, str]] = {
    "projection": ("bladerecon/core/geometry/projection/", "tests/test_projection.py"),
    "alignment": ("bladerecon/core/analysis/alignment.py", "tests/test_alignment.py"),
    "section_curves": ("bladerecon/core/surface/section_curves.py", "tests/test_reconstruct.py"),
    "segmentation": ("bladerecon/core/sections/segmentation.py", "tests/test_segmentation.py"),
    "parameters": ("bladerecon/core/sections/parameters.py", "tests/test_section_parameters.py"),
    "fairing": ("bladerecon/core/sections/fairing.py", "tests/test_fairing.py"),
    "fitting": ("bladerecon/core/geometry/fitting.py", "tests/test_fitting.py tests/test_bspline.py"),
    "surface_analysis": ("bladerecon/core/analysis/surface_analysis.py", "tests/test_surface_analysis.py"),
}
STATUS = {"ok_killed": "killed", "bad_survived": "survived", "bad_timeout": "timeout",
          "ok_suspicious": "suspicious", "skipped": "skipped", "untested": "untested"}


def _venv() -> None:
    if MUTMUT.exists():
        return
    subprocess.run([PYTHON, "-m", "venv", "--system-site-packages", str(VENV)], check=True)
    subprocess.run([str(VENV / "bin" / "pip"), "install", "-q", "mutmut>=2.5,<3"], check=True)


def _run(name: str, repo: Path, log) -> dict:
    paths, tests = MODULES[name]
    cache = repo / ".mutmut-cache"
    if cache.exists():
        cache.unlink()
    runner = f"{PYTHON} -m pytest -x -q -p no:cacheprovider {tests}"
    env = dict(os.environ, PYTHONPATH=str(repo), QTWEBENGINE_DISABLE_SANDBOX="1")
    started = datetime.datetime.now()
    subprocess.run([str(MUTMUT), "run", "--paths-to-mutate", paths, "--runner", runner, "--tests-dir", "tests",
                    "--simple-output"], cwd=repo, env=env, stdout=log, stderr=subprocess.STDOUT)
    minutes = (datetime.datetime.now() - started).total_seconds() / 60
    counts = dict.fromkeys(STATUS.values(), 0)
    db = sqlite3.connect(cache)
    rows = db.execute("select id, status from Mutant order by id").fetchall()
    db.close()                    # before mutmut reads the cache itself (a held connection locks it)
    survived = []
    for mid, status in rows:
        counts[STATUS.get(status, status)] = counts.get(STATUS.get(status, status), 0) + 1
        if status == "bad_survived":
            survived.append(mid)
    survivors = []
    for mid in survived:
        show = subprocess.run([str(MUTMUT), "show", str(mid)], cwd=repo, env=env, capture_output=True, text=True)
        survivors.append((mid, (show.stdout or show.stderr).strip()))
    tested = counts["killed"] + counts["survived"] + counts["timeout"]
    score = (counts["killed"] + counts["timeout"]) / tested if tested else float("nan")
    return {"name": name, "paths": paths, "tests": tests, "counts": counts, "score": score,
            "survivors": survivors, "minutes": minutes}


def _markdown(results: list[dict], head: str) -> str:
    today = datetime.date.today().isoformat()
    lines = ["# Mutation testing of `bladerecon/core`", "",
             f"`make mutation` (tools/mutation.py, mutmut 2.5 in .cache/mutation-venv); table written {today} "
             f"at commit {head} on a {os.cpu_count()}-core machine, Python {platform.python_version()}; each "
             "module's own run date and commit are in its row.",
             "Score = (killed + timed out) / tested. Survivors are listed for review: each must be "
             "killed by a test or explained as equivalent.", "",
             "| module | mutated | tests | killed | survived | timeout | score | minutes | run |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        c = r["counts"]
        lines.append(f"| {r['name']} | `{r['paths']}` | `{r['tests']}` | {c['killed']} | {c['survived']} | "
                     f"{c['timeout']} | {100 * r['score']:.1f} % | {r['minutes']:.0f} | {r['date']} {r['commit']} |")
    for r in results:
        if r["survivors"]:
            lines += ["", f"## Survivors in {r['name']}", ""]
            for mid, diff in r["survivors"]:
                lines += [f"Mutant {mid}:", "", "```diff", diff, "```", ""]
    return "\n".join(lines) + "\n"


def main() -> int:
    wanted = [m.strip() for m in os.environ.get("MUTATION_MODULES", ",".join(MODULES)).split(",") if m.strip()]
    unknown = [m for m in wanted if m not in MODULES]
    if unknown:
        print(f"mutation: unknown module(s) {', '.join(unknown)}; known: {', '.join(MODULES)}", file=sys.stderr)
        return 2
    _venv()
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    results = []
    with tempfile.TemporaryDirectory(prefix="bladerecon-mutation-") as tmp:
        repo = Path(tmp) / "repo"
        subprocess.run(["git", "clone", "-q", str(ROOT), str(repo)], check=True)
        with open(Path(tmp) / "mutmut.log", "w") as log:
            for name in wanted:
                print(f"mutation: {name} ...", file=sys.stderr, flush=True)
                r = _run(name, repo, log)
                c = r["counts"]
                print(f"mutation: {name}: {c['killed']} killed, {c['survived']} survived, {c['timeout']} timeout "
                      f"({100 * r['score']:.1f} %) in {r['minutes']:.0f} min", file=sys.stderr, flush=True)
                r["commit"], r["date"] = head, datetime.date.today().isoformat()
                store = ROOT / "bench" / "results" / "mutation"
                store.mkdir(parents=True, exist_ok=True)
                (store / f"{name}.json").write_text(json.dumps(r, indent=1) + "\n")
    # the table holds every module run so far (a subset run replaces only its own modules)
    results = [json.loads((ROOT / "bench" / "results" / "mutation" / f"{m}.json").read_text())
               for m in MODULES if (ROOT / "bench" / "results" / "mutation" / f"{m}.json").exists()]
    out = ROOT / "bench" / "results" / "mutation.md"
    out.write_text(_markdown(results, head))
    print(f"mutation: wrote {out.relative_to(ROOT)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
