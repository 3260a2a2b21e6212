# SPDX-License-Identifier: LGPL-2.1-or-later
"""What an independent hostile sweep of the streaming readers, the memory budget and the
outputs found after they were written: each case failed before its fix.

The same bar as ``test_hostile_inputs.py``: a refusal is exit 2, one ``bladerecon: error:``
line, no traceback, nothing left, inputs and special files untouched; a file that is good is
read as its LF twin is.
"""
from __future__ import annotations

import os
import signal
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io import readers
from test_hostile_inputs import data, out, refused, run_in_process  # noqa: F401  (fixtures)
from test_readers_fast import same, tables

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "resources" / "sample"


# --------------------------------------------------------------------------- readers
def test_cr_only_line_ends_are_read_as_their_lf_twin(tmp_path):
    """An old Mac export (CR line ends, no LF) was refused as needing 46 GB: the careful
    parser's budget counted every cell of the file as columns of its first line."""
    lf = SAMPLE / "measured.csv"
    cr = tmp_path / "cr.csv"
    cr.write_bytes(lf.read_bytes().replace(b"\n", b"\r"))
    want = readers.read_points(lf)
    got = readers.read_points(cr, memory_limit=1.0)
    assert np.array_equal(got.points, want.points) and np.array_equal(got.section, want.section)
    assert got.section_names == want.section_names and np.array_equal(got.line, want.line)



@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=tables(), require=st.booleans())
def test_any_table_with_cr_line_ends_reads_as_with_lf(tmp_path, text, require):
    """Property: a random point table (test_readers_fast's) with CR-only line ends gives the
    PointSet, or the error, its LF twin gives, within a budget just over the careful parser's
    need (the CR file's first line is not the whole file)."""
    lf, cr = tmp_path / "lf.txt", tmp_path / "cr.txt"
    body = text.replace("\r\n", "\n")
    lf.write_text(body)
    cr.write_bytes(body.replace("\n", "\r").encode())
    try:
        want = readers.read_points(lf, require)
    except BladeReconError as err:
        with pytest.raises(BladeReconError) as got:
            readers.read_points(cr, require, memory_limit=0.1002)
        assert str(got.value) == str(err).replace(str(lf), str(cr))
        return
    same(readers.read_points(cr, require, memory_limit=0.1002), want)


@pytest.mark.parametrize("name,body,words", [
    ("huge.ply", b"ply\nformat ascii 1.0\nelement vertex 999999999999999\nproperty float x\nproperty float y\n"
                 b"property float z\nend_header\n1 2 3\n", "says 999999999999999 vertices"),
    ("huge.pcd", b"# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 999999999999\n"
                 b"HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 999999999999\nDATA ascii\n1 2 3\n", "says 999999999999 points"),
], ids=["ply", "pcd"])
def test_a_scan_header_promising_more_points_than_its_file_holds_is_named_as_such(capfd, data, out, name, body, words):
    """A 120-byte PLY saying 10^15 vertices was refused as needing 320 million GB of memory
    (advice: thin the points); the header that does not match its file is what is wrong."""
    path = data / name
    path.write_bytes(body)
    line = refused(capfd, ["reconstruct", path, "--slice", "4", "--quiet"], (data, out))
    assert words in line and "memory" not in line, line


# --------------------------------------------------------------------------- outputs
@pytest.mark.parametrize("name,words", [("old.csv", "a file"), ("full", "a folder"), ("link", "symbolic link to"),
                                        ("fifo", "FIFO")], ids=["file", "folder", "link-to-a-file", "fifo"])
def test_simulator_link_never_replaces_what_is_there(capfd, data, out, name, words):
    """``simulate-instrument --link NAME`` renamed its pty link over NAME and deleted the name at
    the end: someone's result file of that name was gone. Only a new name, or a link to a pty
    an earlier run left, is taken; refused before the pty is made (no 60 s wait for START)."""
    line = refused(capfd, ["simulate-instrument", "--link", out / name], (data, out))
    assert words in line and "--link" in line, line
    assert (out / "old.csv").read_text() == "old result\n"


@pytest.mark.parametrize("journal", ["{o}/fifo", "/dev/full", "{o}/new.journal"], ids=["fifo", "dev-full", "new"])
def test_acquire_replay_with_a_journal_is_a_conflict_not_ignored(capfd, data, out, journal):
    """``acquire --replay J --journal FILE`` exited 0 and never wrote FILE (a user then looks
    for a journal that is not there)."""
    argv = ["acquire", "--replay", data / "j.journal", "-o", out / "a.csv", "--quiet",
            "--journal", journal.format(o=out)]
    line = refused(capfd, argv, (data, out))
    assert "--journal" in line and "--replay" in line, line


def test_cloud_scale_on_a_section_file_is_refused_not_ignored(capfd, data, out):
    """``reconstruct SECTIONS.csv --cloud-scale 1000`` (a file in metres, the user thinks) exited
    0 with the sections unscaled: the option applies only to clouds (issue 23 §5)."""
    line = refused(capfd, ["reconstruct", data / "m.csv", "--cloud-scale", "1000", "-o", out / "r.step", "--quiet"],
                   (data, out))
    assert "--cloud-scale" in line and "sections" in line, line


# --------------------------------------------------------------------------- batch and blisk OUTDIR
def _lot(folder: Path, n: int) -> Path:
    manifest = folder / "lot.csv"
    manifest.write_text("blade,file\n" + "".join(f"b{k},m.csv\n" for k in range(1, n + 1)))
    return manifest


@pytest.mark.parametrize("command", ["batch", "blisk"])
def test_lot_outdir_through_a_link_is_refused(capfd, data, out, command):
    """``batch``/``blisk -o LINK`` wrote the lot through a symbolic link into the folder it
    points to (every other output refuses a link)."""
    (out / "real").mkdir()
    (out / "outlink").symlink_to(out / "real")
    argv = (["batch", _lot(data, 2)] if command == "batch" else ["blisk", data / "m.csv", "--blades", "3"]) + \
        ["--nominal", data / "n.step", "-o", out / "outlink", "--quiet"]
    line = refused(capfd, argv, (data, out))
    assert "symbolic link" in line, line


def test_blisk_with_a_bad_line_late_in_the_scan_leaves_no_outdir(capfd, data, out):
    """The scan is read after OUTDIR is made: a bad line there was one honest line, exit 2, and
    an empty OUTDIR left behind."""
    rows = (data / "m.csv").read_text().splitlines()
    rows[300] = "3,1,abc,2"
    bad = data / "late_bad.csv"
    bad.write_text("\n".join(rows) + "\n")
    line = refused(capfd, ["blisk", bad, "--nominal", data / "n.step", "--blades", "3", "-o", out / "lot",
                           "--quiet"], (data, out))
    assert "line 301" in line, line


@pytest.mark.timeout(120)
def test_sigterm_stops_a_batch_and_its_workers_at_once(data, tmp_path):
    """SIGTERM (or Ctrl-C) during a batch: the command said 'no output was completed' but its
    pool went on to run every blade not started yet, and wrote them all. Now the running blade
    is stopped (its temporaries removed), no other is started, and the blades done are kept."""
    import os
    import signal
    import subprocess
    import sys
    import time

    n = 8
    manifest = _lot(data, n)
    lot = tmp_path / "lot"
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    proc = subprocess.Popen([sys.executable, "-m", "bladerecon", "batch", str(manifest), "--nominal",
                             str(data / "n.step"), "-o", str(lot), "--workers", "1"],
                            stderr=subprocess.PIPE, text=True, env=env)
    seen = []
    for line in proc.stderr:           # the first blade done: the pool is running
        seen.append(line)
        if "blades done" in line:
            break
    proc.send_signal(signal.SIGTERM)
    t0 = time.monotonic()
    rest = proc.communicate(timeout=60)[1]
    took = time.monotonic() - t0
    assert proc.returncode == 143, "".join(seen) + rest
    assert "Traceback" not in rest and "terminated" in rest, rest
    blades = sorted(p.name for p in lot.iterdir() if p.name.startswith("b"))
    # the one done, at most the one running: the others never started (a count, not a time: the
    # 60 s timeout above only keeps a hang from stalling the suite)
    assert 1 <= len(blades) <= 2, (blades, took)
    assert not [p for p in lot.rglob(".*")], "temporaries left"
    assert "kept in" in rest, rest


# --------------------------------------------------------------------------- control bytes in messages
def test_a_missing_input_named_with_escape_sequences_is_shown_escaped(capfd, data, out):
    """The memory budget reads the file's head before the reader does: its 'file not found'
    (and 'NUL byte') lines printed the name's escape sequences raw."""
    name = data / "no\x1b[31mX\x07.csv"
    line = refused(capfd, ["sections", name, "--quiet"], (data, out))
    assert "no\\x1b[31mX\\x07.csv" in line, line


def test_a_manifest_file_name_with_escape_sequences_is_shown_escaped(capfd, data, out):
    """A manifest's file name is bytes from a file: batch's closing error line printed it raw."""
    manifest = data / "ctl_lot.csv"
    manifest.write_text("blade,file\nb1,m.csv\nb2,nope\x1b]0;owned\x07.csv\n")
    argv = ["batch", manifest, "--nominal", data / "n.step", "-o", out / "lot", "--quiet"]
    capfd.readouterr()
    assert run_in_process(argv) == 2
    err = capfd.readouterr().err
    assert "\x1b" not in err and "\x07" not in err and "nope\\x1b]0;owned\\x07.csv" in err, err


def test_progress_lines_show_an_output_name_escaped(capfd, data, out):
    """The 'wrote NAME' progress line printed a user's escape sequences to the terminal."""
    csv = out / "d\x1b[2J\x07.csv"
    capfd.readouterr()
    assert run_in_process(["deviation", data / "m.csv", "--nominal", data / "n.step", "--csv", csv]) == 0
    err = capfd.readouterr().err
    assert "\x1b" not in err and "\x07" not in err and "wrote" in err, err
    assert csv.exists()


@pytest.mark.parametrize("command", ["batch", "blisk"])
def test_a_lot_whose_blades_all_fail_leaves_nothing(capfd, data, out, command):
    """Every blade over its memory budget (or unreadable): exit 2, and OUTDIR/lot/ (with the
    blisk's scan/) was still written as if it were a lot's result. Now nothing is left."""
    if command == "batch":
        argv = ["batch", _lot(data, 2), "--memory-limit", "0.01"]
    else:       # the split fits the budget, each blade's deviation does not
        argv = ["blisk", data / "m.csv", "--blades", "1", "--memory-limit", "0.4001"]
    line = refused(capfd, argv + ["--nominal", data / "n.step", "-o", out / "lot", "--quiet"], (data, out))
    assert "blades failed, nothing was written" in line and "memory" in line, line


# --------------------------------------------------------------------------- Ctrl-C: exit status 130
def _python(code: str):
    import os
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60)


def test_ctrl_c_is_held_while_a_step_file_is_read_and_delivered_after():
    """Ctrl-C while FreeCAD read the nominal: OpenCASCADE's reader threads crashed on the objects
    torn down and the command ended with status 1 (3 of 10 tries at that moment); the read now
    finishes and the interrupt comes after it."""
    # the child starts as a terminal's python does, with Ctrl-C raising KeyboardInterrupt: a
    # suite started in the background by a non-interactive shell hands it SIGINT ignored
    r = _python("import os, signal\n"
                "signal.signal(signal.SIGINT, signal.default_int_handler)\n"
                "from bladerecon.core.io.outputs import signals_held\n"
                "seen = []\n"
                "try:\n"
                "    with signals_held():\n"
                "        os.kill(os.getpid(), signal.SIGINT)\n"
                "        seen.append('read finished')\n"
                "except KeyboardInterrupt:\n"
                "    seen.append('interrupted after')\n"
                "print(seen, signal.getsignal(signal.SIGINT) is signal.default_int_handler)\n")
    assert r.stdout.strip() == "['read finished', 'interrupted after'] True", r.stdout + r.stderr


def test_an_interrupted_command_exits_130_whatever_its_libraries_do_at_exit():
    """After Ctrl-C the temporaries are gone and the line printed; a library that crashed in the
    interpreter's clean-up (FreeCAD interrupted mid-read) turned status 130 into 1."""
    r = _python("import atexit, os, sys\n"
                "atexit.register(lambda: os._exit(1))      # a library failing at clean-up\n"
                "def run(args):\n"
                "    raise KeyboardInterrupt\n"
                "from bladerecon.cli.main import main\n"
                "sys.argv = ['bladerecon', 'sections', 'm.csv']\n"
                "import bladerecon.cli.sections as s\n"
                "s.run_sections = run\n"
                "sys.exit(main())\n")
    assert r.returncode == 130 and "interrupted" in r.stderr, (r.returncode, r.stderr)


@pytest.mark.parametrize("target", ["/proc/version", "/proc/self/x.csv", "/sys/kernel"])
def test_a_kernel_file_system_is_not_called_a_full_disk(capfd, data, out, target):
    """/proc and /sys have no blocks at all: an output there was refused as 'disk full; free
    space there', which no one can do. The write's own error is named instead."""
    option = "--plots" if target == "/sys/kernel" else "-o"
    argv = (["sections", data / "m.csv", "--lenient", "--force"] if option == "--plots"
            else ["plan", data / "n.step", "--heights", "10,50"]) + [option, target, "--quiet"]
    line = refused(capfd, argv, (data, out))
    assert "disk full" not in line and "cannot write" in line, line


def test_lot_outdir_on_a_read_only_file_system_is_the_usual_one_line(capfd, data, out):
    """batch/blisk -o on a read-only mount said 'cannot create the folder: Read-only file
    system' (the OS's words, none of the advice every other output gives)."""
    import os
    import subprocess

    if os.geteuid() != 0:
        pytest.skip("a read-only bind mount needs root")
    src, where = out / "rosrc", out / "ro"
    src.mkdir()
    where.mkdir()
    if subprocess.run(["mount", "--bind", str(src), str(where)]).returncode:
        pytest.skip("mount refused")
    try:
        if subprocess.run(["mount", "-o", "remount,bind,ro", str(where)]).returncode:
            pytest.skip("remount refused")
        line = refused(capfd, ["batch", _lot(data, 1), "--nominal", data / "n.step", "-o", where / "lot", "--quiet"],
                       (data,))
        assert "cannot write" in line and "read-only file system; choose a writable folder" in line, line
    finally:
        subprocess.run(["umount", str(where)])


def test_repair_progress_shows_an_input_name_escaped(capfd, data, out):
    """repair's 'reading NAME' line printed a file name's escape sequences raw (the other
    commands' progress lines were escaped first)."""
    measured = data / "r\x1b[31mX.csv"
    measured.write_bytes((data / "m.csv").read_bytes())
    capfd.readouterr()
    assert run_in_process(["repair", measured, "--nominal", data / "text.step", "-o", out / "r.step"]) == 2
    err = capfd.readouterr().err
    assert "\x1b" not in err and "reading" in err and "r\\x1b[31mX.csv" in err, err


# --------------------------------------------------------------------------- plausibility
def _plan_rows(tmp_path, name: str, change) -> Path:
    """The sample's 65-point plan with ``change(section, x, y, z, mean z of that section)``
    applied to each row, written as ``name``."""
    lines = (SAMPLE / "measured_plan.csv").read_text().splitlines()
    rows = [ln.split(",") for ln in lines[1:]]
    z = {}
    for r in rows:
        z.setdefault(r[0], []).append(float(r[3]))
    mean = {k: sum(v) / len(v) for k, v in z.items()}
    out = [lines[0]] + [",".join(change(r[0], float(r[1]), float(r[2]), float(r[3]), mean, i))
                        for i, r in enumerate(rows)]
    path = tmp_path / name
    path.write_text("\n".join(out) + "\n")
    return path


@pytest.mark.parametrize("command", ["reconstruct", "sections"])
def test_two_sections_at_one_height_are_refused(capfd, tmp_path, command):
    """Section '2' moved onto section '1''s plane (two profiles at one height): reconstruct
    wrote a folded STEP and sections measured both, exit 0. Now one line naming both."""
    def same_height(s, x, y, z, mean, i):
        return [s, f"{x:.6f}", f"{y:.6f}", f"{z - mean['2'] + mean['1'] if s == '2' else z:.6f}"]

    path = _plan_rows(tmp_path, "samez.csv", same_height)
    outs = tmp_path / "o"
    outs.mkdir()
    argv = [command, path, "--quiet"] + (["-o", outs / "x.step"] if command == "reconstruct" else ["--lenient"])
    line = refused(capfd, argv, (tmp_path,))
    assert "sections '1' (lines 67–131) and '2' (lines 132–196) lie at one span position" in line, line


def test_a_collinear_section_is_said_to_lie_on_a_line_not_to_cross(capfd, tmp_path):
    """A section whose points lie on a line was reported as crossing its neighbour (its
    plane is undefined); the one-line message now says what is wrong with it."""
    def on_a_line(s, x, y, z, mean, i):
        return [s, f"{i * 0.1:.6f}" if s == "1" else f"{x:.6f}", "0.000000" if s == "1" else f"{y:.6f}", f"{z:.6f}"]

    path = _plan_rows(tmp_path, "line.csv", on_a_line)
    line = refused(capfd, ["reconstruct", path, "-o", tmp_path / "x.step", "--quiet"], (tmp_path,))
    assert "section '1' (lines 67–131) has no area" in line and "lie on a line" in line and "cross" not in line, line


_SWALLOWING_MAIN = """
import os, signal, sys, time, warnings, weakref
from bladerecon.cli import main as m

def fake_main(argv):
    class Held: pass
    def callback(_):
        os.kill(os.getpid(), signal.SIGTERM)     # the handler raises inside this callback
        for _ in range(100): pass
    held = Held()
    ref = weakref.ref(held, callback)
    del held
{work}
    return 0

m._main = fake_main
"""


def _run_swallowing_main(tmp_path, work: str, after: str) -> "subprocess.CompletedProcess":
    """``main(["x"])`` in a fresh process whose command work starts by having a SIGTERM raised
    (and swallowed) inside a weakref callback; ``work`` (indented) is the rest of that work,
    ``after`` runs once ``main`` has returned."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    script = _SWALLOWING_MAIN.format(work=work) + after
    return subprocess.run([sys.executable, "-c", script], env=dict(os.environ, PYTHONPATH=str(root)),
                          cwd=tmp_path, capture_output=True, text=True, timeout=60)


def test_a_stop_swallowed_as_the_command_ends_does_not_land_after_it(tmp_path):
    """A SIGTERM swallowed in a callback just as the command's work ends: the work is done (status
    0), and the signal sent again must not land after ``main`` has returned (it killed the
    caller with 143: a test process, FreeCAD's console); the hook and the warning filters are
    the caller's again."""
    proc = _run_swallowing_main(tmp_path, "", """
hook, filters = sys.unraisablehook, list(warnings.filters)
code = m.main(["x"])
time.sleep(0.2)
print("code", code, sys.unraisablehook is hook, list(warnings.filters) == filters)
""")
    assert proc.returncode == 0 and proc.stdout.strip() in ("code 0 True True", "code 143 True True"), \
        (proc.returncode, proc.stdout, proc.stderr)


def _python_itself_interrupted(err: str, sig) -> bool:
    """Ctrl-C in the first ~40 ms, while CPython imports its own modules (``site``, then runpy
    finding the package and writing its bytecode cache), before the first line of bladerecon
    runs: CPython prints its own traceback ("Fatal Python error: init_import_site", status 1, or
    runpy's frames, status -2; seen on FreeCAD 1.0's Python 3.13 under load). Nothing of ours can
    run there; only a traceback with no frame of ours, ending in KeyboardInterrupt, is let
    through."""
    if sig != signal.SIGINT or "bladerecon" in err:
        return False
    if err.startswith("Fatal Python error: init_import_site"):    # site and its .pth files
        return True
    frames = [line for line in err.splitlines() if line.lstrip().startswith('File "')]
    return (err.strip().endswith("KeyboardInterrupt") and bool(frames)
            and all('File "<frozen ' in line for line in frames))      # runpy finding the package


def test_a_signal_swallowed_by_an_import_callback_still_stops_the_command(tmp_path):
    """SIGTERM raised inside a weakref callback (importlib's module-lock callback, a Cython
    module's set-up) was printed as "Exception ignored" with a traceback, and the command ran on
    to the end with status 0 (FreeCAD 1.0 under load, 2026-11-27). It must stop the command a
    moment later with the usual line and 143, and the work after it must not finish."""
    marker = tmp_path / "ran_on.txt"
    proc = _run_swallowing_main(tmp_path, f"""
    start = time.monotonic()
    while time.monotonic() - start < 5.0:      # the command's work: stopped a moment later
        pass
    open({str(marker)!r}, "w").write("ran on")""", """
code = m.main(["x"])
print("code", code)
""")
    assert proc.stdout.strip() == "code 143", (proc.stdout, proc.stderr)
    assert proc.stderr.strip() == "bladerecon: terminated (SIGTERM); no output was completed", proc.stderr
    assert not marker.exists()


@pytest.mark.parametrize("sig,status", [(signal.SIGTERM, 143), (signal.SIGINT, 130)])
def test_a_signal_while_the_command_starts_is_one_line_never_a_traceback(tmp_path, sig, status):
    """SIGTERM or Ctrl-C while the command loads its modules (numpy, scipy, FreeCAD: the first
    half second) ended with a traceback and status 1 (SIGTERM raised outside the command's own
    handler), and inside FreeCAD's start-up as "FreeCAD found but this Python cannot load it"
    with status 2 (seen on FreeCAD 1.0 under load, 2026-11-27). At every delay: the signal's
    status and one line, or (before Python's handlers exist) killed by the signal itself, or
    done before it came."""
    import subprocess
    import sys
    import time

    root = Path(__file__).resolve().parent.parent
    seen = set()
    for delay in (0.0, 0.03, 0.06, 0.1, 0.15, 0.2, 0.3, 0.45, 0.6):
        proc = subprocess.Popen([sys.executable, "-m", "bladerecon", "deviation",
                                 str(root / "resources" / "sample" / "measured.csv"), "--nominal",
                                 str(root / "resources" / "sample" / "nominal.step"), "--quiet"],
                                env=dict(os.environ, PYTHONPATH=str(root)), cwd=tmp_path,
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
        time.sleep(delay)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=120)
        seen.add(proc.returncode)
        if _python_itself_interrupted(err, sig):
            continue
        assert proc.returncode in (status, -sig, 0), (delay, proc.returncode, err)
        assert "Traceback" not in err and len(err.strip().splitlines()) <= 1, (delay, err)
        if proc.returncode == status:
            assert err.strip() in ("bladerecon: terminated (SIGTERM); no output was completed",
                                   "bladerecon: interrupted; no output was completed"), err
    assert status in seen, seen


_STOP_IN_SCIPYS_GENERATED_CODE = r'''
import builtins, os, signal, sys
import scipy._lib.decorator as generated

def compile_then_stop(*args, **kwargs):       # the SIGTERM lands while scipy builds a function from source
    code = builtins.compile(*args, **kwargs)
    os.kill(os.getpid(), signal.SIGTERM)
    return code

generated.compile = compile_then_stop
from bladerecon.cli.main import main
sys.exit(main(sys.argv[1:]))
'''


def test_a_stop_while_scipy_builds_its_functions_is_one_line(tmp_path):
    """scipy builds some functions from generated source (scipy._lib.decorator) and prints that
    source for any exception in it: a SIGTERM there (0.15 s into `deviation`, under load) printed
    "Error in generated code: def bicgstab(...)" above the one line. The commands load those
    modules with the signals held; the stop is delivered after, as the one line and 143."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parent.parent
    proc = subprocess.run([sys.executable, "-c", _STOP_IN_SCIPYS_GENERATED_CODE, "deviation",
                           str(root / "resources" / "sample" / "measured.csv"), "--nominal",
                           str(root / "resources" / "sample" / "nominal.step"), "--quiet"],
                          env=dict(os.environ, PYTHONPATH=str(root)), cwd=tmp_path, capture_output=True, text=True,
                          timeout=120)
    assert proc.returncode == 143, (proc.returncode, proc.stderr)
    assert proc.stderr.strip() == "bladerecon: terminated (SIGTERM); no output was completed", proc.stderr


def test_a_resent_stop_landing_inside_the_hook_is_sent_again(monkeypatch):
    """The signal a timer sends again can land while the hook that armed an earlier one is still
    running (a loaded machine: the hook's thread start took longer than the 2 ms delay). Raised
    there, it is swallowed as well ("Exception ignored in sys.unraisablehook", FreeCAD 1.0 under
    load, 2026-11-28: the command ran on to status 0). The hook must arm the signal again."""
    import types

    from bladerecon.cli import stops

    class Stop(Exception):
        pass

    started, landings = [], [1]                   # one landing inside the hook, then none

    class Timer:
        def __init__(self, delay, fn, args):
            if landings:
                landings.pop()
                raise Stop()                      # what the signal handler raises at that moment
            self.args = args

        def start(self):
            started.append(self.args)

        def cancel(self):
            pass

    monkeypatch.setattr(stops.threading, "Timer", Timer)
    previous = signal.signal(signal.SIGUSR1, lambda *a: None)
    try:
        with stops.resend_swallowed({Stop: signal.SIGUSR1}) as r:
            r._hook(types.SimpleNamespace(exc_type=Stop))
    finally:
        signal.signal(signal.SIGUSR1, previous)
    assert started == [(os.getpid(), signal.SIGUSR1)] and not landings
