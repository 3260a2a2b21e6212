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
import shutil
import sqlite3
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
VENV = ROOT / ".cache" / "mutation-venv"
MUTMUT = VENV / "bin" / "mutmut"
PYTHON = "/usr/bin/python3"

_PROJECTION_TESTS = ("tests/test_projection_newton_contract.py tests/test_projection_grid_contract.py "
                     "tests/test_projection_contract.py tests/test_projection.py")
_PROJECTION_SLOW = ("--deselect tests/test_projection.py::test_speed_one_million_points_print "
                   "--deselect tests/test_projection.py::test_feet_round_a_thin_edge_are_found "
                   "--deselect tests/test_projection.py::test_collapsed_low_degree_and_far "
                   "--deselect tests/test_projection.py::test_against_opencascade_on_a_thin_blade "
                   "--deselect tests/test_projection.py::test_blocks_and_threads_give_the_same_answer "
                   "--deselect tests/test_projection.py::test_forked_blocks_threads_and_one_process_agree "
                   "--deselect tests/test_projection.py::test_torus_orthogonality_and_brute_force "
                   "--deselect tests/test_projection.py::test_creased_surface_feet_on_and_beside_the_crease "
                   "--deselect tests/test_projection.py::test_blade_against_polished_brute_force_with_points_around_the_edges")

#: name -> (paths to mutate, test files that cover them [, pytest arguments that leave out tests
#: too slow to run once per mutant: the score is then a lower bound of the whole suite's])
MODULES: dict[str, tuple[str, ...]] = {
    # the projection package is run part by part (about 2000 mutants at ~5 a minute in all)
    **{f"projection_{part}": (paths, _PROJECTION_TESTS, _PROJECTION_SLOW) for part, paths in (
        ("newton", "bladerecon/core/geometry/projection/newton.py"),
        ("search", "bladerecon/core/geometry/projection/search.py,bladerecon/core/geometry/projection/restarts.py,"
                   "bladerecon/core/geometry/projection/feet.py"),
        ("grid", "bladerecon/core/geometry/projection/grid.py"),
        ("rest", "bladerecon/core/geometry/projection/evaluation.py,bladerecon/core/geometry/projection/surface.py,"
                 "bladerecon/core/geometry/projection/curve.py,bladerecon/core/geometry/projection/points.py,"
                 "bladerecon/core/geometry/projection/parallel.py,bladerecon/core/geometry/projection/cache.py,"
                 "bladerecon/core/geometry/projection/stats.py,bladerecon/core/geometry/projection/__init__.py"))},
    "alignment": ("bladerecon/core/analysis/alignment.py", "tests/test_alignment_contract.py tests/test_alignment.py"),
    "section_curves": ("bladerecon/core/surface/section_curves.py", "tests/test_section_curves_contract.py tests/test_reconstruct.py",
                       "--deselect tests/test_reconstruct.py::test_plan_layout_within_50_um_of_truth "
                       "--deselect tests/test_reconstruct.py::test_dense_noisy_sections_within_10_um_of_truth "
                       "--deselect tests/test_reconstruct.py::test_angle_pairing_seed000_gives_equal_counts_and_a_close_surface"),
    "segmentation": ("bladerecon/core/sections/segmentation.py", "tests/test_segmentation_contract.py tests/test_segmentation.py"),
    "parameters": ("bladerecon/core/sections/parameters.py", "tests/test_parameters_contract.py tests/test_section_parameters.py",
                   "--deselect tests/test_section_parameters.py::test_cli_sections_with_step_nominal_gives_small_differences "
                   "--deselect tests/test_section_parameters.py::test_edge_radii_at_400_noisy_points_and_120_exact_points "
                   "--deselect tests/test_section_parameters.py::test_cli_sections_json_keys_and_plots "
                   "--deselect tests/test_section_parameters.py::test_cli_sections_with_a_section_file_nominal_and_throat "
                   "--deselect tests/test_section_parameters.py::test_sparse_plan_sections_give_chord_thickness_stagger"),
    "edge_shape": ("bladerecon/core/sections/edge_shape.py", "tests/test_edge_shape_contract.py tests/test_edge_shape.py"),
    "fairing": ("bladerecon/core/sections/fairing.py", "tests/test_fairing_contract.py tests/test_fairing.py",
                "--deselect tests/test_fairing.py::test_nasa_rotor67_design_table_has_no_bad_points "
                "--deselect tests/test_fairing.py::test_surface_from_faired_sections_within_3um_of_the_truth"),
    "fitting": ("bladerecon/core/geometry/fitting.py", "tests/test_fitting.py tests/test_bspline.py tests/test_fitting_contract.py"),
    "surface_analysis": ("bladerecon/core/analysis/surface_analysis.py", "tests/test_surface_analysis.py"),
}
#: survivors reviewed as equivalent (no test can tell them apart from the code), one file per
#: module (<module>.toml): matched by the removed and the added line of the mutant's diff, each
#: with the reason
EQUIVALENT = ROOT / "tools" / "mutation_equivalent"
#: mutmut's "suspicious" is a mutant the tests killed, only more slowly than the baseline run
STATUS = {"ok_killed": "killed", "bad_survived": "survived", "bad_timeout": "timeout",
          "ok_suspicious": "killed", "skipped": "skipped", "untested": "untested"}


def _venv() -> None:
    if MUTMUT.exists():
        return
    subprocess.run([PYTHON, "-m", "venv", "--system-site-packages", str(VENV)], check=True)
    subprocess.run([str(VENV / "bin" / "pip"), "install", "-q", "mutmut>=2.5,<3"], check=True)


def _run(name: str, repo: Path, log) -> dict:
    paths, tests, *extra = MODULES[name]
    cache = repo / ".mutmut-cache"
    if cache.exists():
        cache.unlink()
    # mutmut counts any exit code but 1 as "survived": the runner below turns pytest's answer
    # into 0 (every test passed) or 1 (anything else: a failure, a mutant that breaks collection,
    # a crash) and logs every exit code that was neither 0 nor 1, for the table
    runner = f"{PYTHON} {repo / 'tools' / 'mutation.py'} --run-tests {tests} {' '.join(extra)}".strip()
    odd = repo / ".mutation-odd-exits"
    odd.unlink(missing_ok=True)
    # no bytecode: a mutant of the same size written within the second of the previous one
    # would run the previous one's cached .pyc (seen: killed mutants reported as survivors)
    for stale in repo.rglob("__pycache__"):
        shutil.rmtree(stale, ignore_errors=True)
    env = dict(os.environ, PYTHONPATH=str(repo), QTWEBENGINE_DISABLE_SANDBOX="1", PYTHONDONTWRITEBYTECODE="1")
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
        if STATUS.get(status) == "survived":
            survived.append(mid)
    survivors = []
    for mid in survived:
        show = subprocess.run([str(MUTMUT), "show", str(mid)], cwd=repo, env=env, capture_output=True, text=True)
        survivors.append((mid, (show.stdout or show.stderr).strip()))
    # exit codes other than 0/1, and runs killed by mutmut's timer (a start without an end): such a
    # kill is read by mutmut as a survivor unless it notices the timeout (seen under heavy load)
    events = odd.read_text().splitlines() if odd.exists() else []
    odd_exits = [e.split()[1] for e in events if e.startswith("end") and e.split()[1] not in ("0", "1")]
    odd_exits += ["killed"] * (sum(e == "start" for e in events) - sum(e.startswith("end") for e in events))
    tested = counts["killed"] + counts["survived"] + counts["timeout"]
    score = (counts["killed"] + counts["timeout"]) / tested if tested else float("nan")
    return {"name": name, "paths": paths, "tests": " ".join([tests, *extra]), "counts": counts, "score": score,
            "survivors": survivors, "minutes": minutes,
            "odd_exits": odd_exits}


def _changed_lines(diff: str) -> tuple[str, str]:
    """The removed and the added line of a one-line mutant's diff (stripped)."""
    body = [l for l in diff.splitlines() if l[:1] in "-+" and not l.startswith(("---", "+++"))]
    minus = " ".join(l[1:].strip() for l in body if l.startswith("-"))
    plus = " ".join(l[1:].strip() for l in body if l.startswith("+"))
    return minus, plus


def _equivalents() -> list[dict]:
    import tomllib

    out = []
    for f in sorted(EQUIVALENT.glob("*.toml")):
        out += [dict(e, module=f.stem) for e in tomllib.loads(f.read_text()).get("equivalent", [])]
    return out


def _classify(r: dict, reviewed: list[dict]) -> tuple[list, list]:
    """Split a module's survivors into (open survivors, (mutant, diff, reason) equivalents)."""
    open_, equivalent = [], []
    for mid, diff in r["survivors"]:
        minus, plus = _changed_lines(diff)
        why = next((e["why"] for e in reviewed if e["module"] == r["name"]
                    and e["original"] in minus and e["mutant"] in plus), None)
        (equivalent.append((mid, diff, why)) if why else open_.append((mid, diff)))
    return open_, equivalent


def _markdown(results: list[dict], head: str) -> str:
    today = datetime.date.today().isoformat()
    reviewed = _equivalents()
    lines = ["# Mutation testing of `bladerecon/core`", "",
             f"`make mutation` (tools/mutation.py, mutmut 2.5 in .cache/mutation-venv); table written {today} "
             f"at commit {head} on a {os.cpu_count()}-core machine, Python {platform.python_version()}; each "
             "module's own run date and commit are in its row.",
             "Score = (killed + timed out) / (tested - equivalent): the survivors reviewed as equivalent "
             "(`tools/mutation_equivalent/<module>.toml`, each with its reason, listed below) leave the count; "
             "every other survivor is listed for a test to kill.", "",
             "| module | mutated | tests | killed | survived | equivalent | timeout | score | minutes | run |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    split = {}
    for r in results:
        c = r["counts"]
        open_, equivalent = split[r["name"]] = _classify(r, reviewed)
        tested = c["killed"] + c["survived"] + c["timeout"] - len(equivalent)
        score = (c["killed"] + c["timeout"]) / tested if tested else float("nan")
        lines.append(f"| {r['name']} | `{r['paths']}` | `{r['tests']}` | {c['killed']} | {len(open_)} | "
                     f"{len(equivalent)} | {c['timeout']} | {100 * score:.1f} % | {r['minutes']:.0f} | "
                     f"{r['date']} {r['commit']} |")
    for r in results:
        open_, equivalent = split[r["name"]]
        if open_:
            lines += ["", f"## Survivors in {r['name']}", ""]
            for mid, diff in open_:
                lines += [f"Mutant {mid}:", "", "```diff", diff, "```", ""]
        if equivalent:
            lines += ["", f"## Equivalent in {r['name']}", "", "| mutant | line | mutated to | why no test can tell |",
                      "|---|---|---|---|"]
            for mid, diff, why in equivalent:
                minus, plus = _changed_lines(diff)
                cell = lambda t: t.replace("|", "\\|")             # a | inside a table cell
                lines.append(f"| {mid} | `{cell(minus)}` | `{cell(plus)}` | {cell(why)} |")
    return "\n".join(lines) + "\n"


def _write_table(head: str) -> Path:
    """The table holds every module run so far (a subset run replaces only its own modules)."""
    store = ROOT / "bench" / "results" / "mutation"
    results = [json.loads((store / f"{m}.json").read_text()) for m in MODULES if (store / f"{m}.json").exists()]
    out = ROOT / "bench" / "results" / "mutation.md"
    out.write_text(_markdown(results, head))
    return out


def _run_tests(args: list[str]) -> int:
    """The mutmut runner: pytest on ``args``; 0 if every test passed, else 1 (and the odd code logged)."""
    # a mutant that makes a test loop forever fails it in a minute (the suite's own time limit,
    # capped), not after mutmut's timer: the loop mutants of fairing's run detection took 3-4
    # minutes each that way; the tests run per mutant are the fast ones (slow ones deselected)
    env = dict(os.environ, PYTHONDONTWRITEBYTECODE="1")
    env.setdefault("BLADERECON_TEST_TIMEOUT_CAP", "60")
    log = Path.cwd() / ".mutation-odd-exits"
    with open(log, "a") as f:                 # "start" without its end: mutmut's timer killed this run
        f.write("start\n")
    rc = subprocess.run([PYTHON, "-m", "pytest", "-x", "-q", "-p", "no:cacheprovider", *args], env=env).returncode
    with open(log, "a") as f:
        f.write(f"end {rc}\n")
    return 0 if rc == 0 else 1


def main() -> int:
    if sys.argv[1:2] == ["--run-tests"]:
        return _run_tests(sys.argv[2:])
    wanted = [m.strip() for m in os.environ.get("MUTATION_MODULES", ",".join(MODULES)).split(",") if m.strip()]
    unknown = [m for m in wanted if m not in MODULES]
    if unknown:
        print(f"mutation: unknown module(s) {', '.join(unknown)}; known: {', '.join(MODULES)}", file=sys.stderr)
        return 2
    head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    if "--table" in sys.argv[1:]:            # only rewrite the table (after reviewing equivalents)
        print(f"mutation: wrote {_write_table(head).relative_to(ROOT)}", file=sys.stderr)
        return 0
    _venv()
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
    out = _write_table(head)
    print(f"mutation: wrote {out.relative_to(ROOT)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
