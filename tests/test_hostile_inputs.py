# SPDX-License-Identifier: LGPL-2.1-or-later
"""Hostile input and honest failures: the commands a measuring cell runs unattended, as root,
on other people's files, into shared folders that fill up.

Every case runs the command in this process (``bladerecon.cli.main.main``) and asserts: exit
status 2, exactly one ``bladerecon: error:`` line on stderr, no traceback and no internal
error, no output left (the watched folders hold exactly what they held: names, types, sizes,
times), inputs byte-identical, and the special files (a FIFO made here, /dev/null, /dev/full)
still what they were. The full-disk cases use a tiny tmpfs mounted here and the read-only
cases a read-only bind mount (both need root; skipped with the reason otherwise). The
option checks are also tested as properties with hypothesis.
"""
from __future__ import annotations

import errno
import hashlib
import math
import os
import shutil
import socket
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bladerecon.cli.main import build_parser, main
from bladerecon.core.errors import BladeReconError
from bladerecon.core.io import outputs

ROOT = Path(__file__).resolve().parents[1]
SAMPLE = ROOT / "resources" / "sample"
EXAMPLES = ROOT / "resources" / "examples"
SPECIAL = ("/dev/null", "/dev/full")
PROPERTY = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])


# --------------------------------------------------------------------------- the files
def _write_inputs(d: Path) -> None:
    shutil.copy(SAMPLE / "measured_plan.csv", d / "m.csv")
    shutil.copy(SAMPLE / "nominal.step", d / "n.step")
    shutil.copy(EXAMPLES / "sinc_zmap.xyz", d / "z.xyz")
    shutil.copy(EXAMPLES / "sample_capture.journal", d / "j.journal")
    shutil.copy(EXAMPLES / "calibration.json", d / "cal.json")
    lines = (d / "m.csv").read_text().splitlines()
    head, rows = lines[0], [r.split(",") for r in lines[1:]]
    # the same points as one cloud (no sections): deviation's report then has no section table to cut
    (d / "cloud.csv").write_text("x,y,z\n" + "".join(",".join(r[1:]) + "\n" for r in rows))
    one = [list(r) for r in rows]
    one[5][1] = "1e300"
    (d / "one1e300.csv").write_text("\n".join([head] + [",".join(r) for r in one]) + "\n")
    (d / "all1e300.csv").write_text("\n".join([head] + [",".join([r[0]] + [repr(float(v) * 1e300) for v in r[1:]])
                                                         for r in rows]) + "\n")
    (d / "nul.csv").write_bytes(b"section,x,y,z\n0,1,2,3\n0,1\x00,2,3\n" + bytes(range(256)))
    (d / "utf16.csv").write_bytes("section,x,y,z\n0,1,2,3\n".encode("utf-16"))
    (d / "ctl.csv").write_bytes(b"section,x,y,z\n0,1,2,3\n0,1,2,\x1b[31m\x1b]0;owned\x07red\n")
    (d / "ctlhead.csv").write_bytes(b"\x1b[2J\x1b[31mpwned,a,b\n1,2,3\n")
    # the same plan in metres (a nominal in mm): the unit check names the factor
    (d / "metres.csv").write_text("\n".join([head] + [",".join([r[0]] + [repr(float(v) / 1000.0) for v in r[1:]])
                                                        for r in rows]) + "\n")
    (d / "text.step").write_text("this is not a STEP file\n")
    (d / "empty.step").write_bytes(b"")
    (d / "cloud.bin").write_bytes(b"1 2 3\n" * 10 + b"\xff\xfe\x00\x01" * 100)
    (d / "folder").mkdir()
    os.mkfifo(d / "fifo")


@pytest.fixture(scope="module")
def data(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("in")
    _write_inputs(d)
    return d


@pytest.fixture()
def out(tmp_path) -> Path:
    """A shared folder with what a cell finds there: an old result, a folder of someone's
    files, an empty folder, a FIFO, links (one a loop)."""
    o = tmp_path / "o"
    o.mkdir()
    (o / "old.csv").write_text("old result\n")
    (o / "full").mkdir()
    (o / "full" / "keep.txt").write_text("someone's file\n")
    (o / "empty").mkdir()
    os.mkfifo(o / "fifo")
    os.symlink(o / "old.csv", o / "link")
    os.symlink(o / "full", o / "dirlink")
    os.symlink("loop", o / "loop")
    return o


def _sock(folder: Path) -> Path | None:
    path = folder / "sock"
    if len(str(path)) > 100:
        return None
    s = socket.socket(socket.AF_UNIX)
    s.bind(str(path))
    s.close()          # the socket file stays
    return path


def snapshot(*folders: Path) -> dict:
    """Everything under the folders: type, size, mtime, and a digest of each regular file."""
    seen = {}
    for folder in folders:
        for dirpath, dirnames, filenames in os.walk(folder):
            for name in dirnames + filenames:
                p = os.path.join(dirpath, name)
                st_ = os.lstat(p)
                digest = None
                if stat.S_ISREG(st_.st_mode):
                    digest = hashlib.sha256(Path(p).read_bytes()).hexdigest()
                seen[p] = (stat.S_IFMT(st_.st_mode), st_.st_size if not stat.S_ISDIR(st_.st_mode) else 0,
                           st_.st_mtime_ns if not stat.S_ISDIR(st_.st_mode) else 0, digest)
    return seen


def special_files_intact(*fifos: Path) -> None:
    for dev in SPECIAL:
        assert stat.S_ISCHR(os.stat(dev).st_mode), f"{dev} is no longer a character device"
    for f in fifos:
        assert stat.S_ISFIFO(os.lstat(f).st_mode), f"{f} is no longer a FIFO"


def run_in_process(argv: list[str]) -> int:
    try:
        return main([str(a) for a in argv])
    except SystemExit as exc:      # argparse (the one-line error) exits
        return exc.code


def refused(capfd, argv: list, watch: tuple[Path, ...], code: int = 2) -> str:
    """Run ``argv``; assert the honest failure; return the error line."""
    before = snapshot(*watch)
    capfd.readouterr()
    got = run_in_process(argv)
    captured = capfd.readouterr()
    err = captured.err
    assert got == code, f"exit {got}, stderr:\n{err}"
    lines = [ln for ln in err.splitlines() if ln.startswith("bladerecon: error:")]
    if code == 2:
        assert len(lines) == 1, err
    assert "Traceback" not in err and "internal error" not in err, err
    assert "\x1b" not in err and "\x07" not in err, "raw control bytes reached the terminal"
    assert snapshot(*watch) == before, "an output was left or an input/old file changed"
    special_files_intact(*[p for w in watch for p in w.rglob("fifo")])
    return lines[0] if lines else err


# --------------------------------------------------------------------------- the cases
M, N, Z, J, C = "{d}/m.csv", "{d}/n.step", "{d}/z.xyz", "{d}/j.journal", "{d}/cal.json"
DEV = ["deviation", M, "--nominal", N, "--quiet"]
SEC = ["sections", M, "--lenient", "--quiet"]
PLAN = ["plan", N, "--heights", "10,50", "--quiet"]
TSP = ["tspline", Z, "--tolerance", "0.05", "--quiet"]
ACQ = ["acquire", "--replay", J, "--calibration", C, "--quiet"]
REC = ["reconstruct", M, "--quiet"]

# (category, id, argv, words the one error line holds)
CASES = [
    # ---- outputs are ours or refused: checked before any work
    ("target", "dev-csv-dev-full", DEV + ["--csv", "/dev/full"], "character device"),
    ("target", "dev-csv-dev-null", DEV + ["--csv", "/dev/null"], "character device"),
    ("target", "dev-csv-fifo", DEV + ["--csv", "{o}/fifo"], "FIFO"),
    ("target", "dev-csv-folder", DEV + ["--csv", "{o}/empty"], "is a folder"),
    ("target", "dev-csv-trailing-slash", DEV + ["--csv", "{o}/new/"], "names a folder"),
    ("target", "dev-csv-symlink", DEV + ["--csv", "{o}/link"], "symbolic link"),
    ("target", "dev-csv-symlink-loop", DEV + ["--csv", "{o}/loop/x.csv"], "symbolic links"),
    ("target", "dev-csv-under-a-file", DEV + ["--csv", "{o}/old.csv/x.csv"], "not a folder"),
    ("target", "dev-csv-no-folder", DEV + ["--csv", "{o}/nope/x.csv"], "does not exist"),
    ("target", "dev-csv-is-measured", DEV + ["--csv", M], "input file"),
    ("target", "dev-csv-is-nominal", DEV + ["--csv", N], "input file"),
    ("target", "dev-csv-same-as-aligned", DEV + ["--align", "rigid", "--csv", "{o}/a.csv", "--aligned", "{o}/a.csv"],
     "same output"),
    ("target", "dev-aligned-dev-full", DEV + ["--align", "rigid", "--aligned", "/dev/full"], "character device"),
    ("target", "dev-report-existing-file", DEV + ["--report", "{o}/old.csv"], "not a folder"),
    ("target", "dev-report-dev-null", DEV + ["--report", "/dev/null"], "character device"),
    ("target", "dev-report-fifo", DEV + ["--report", "{o}/fifo"], "FIFO"),
    ("target", "dev-report-full-folder", DEV + ["--report", "{o}/full"], "--force"),
    ("target", "dev-report-dirlink", DEV + ["--report", "{o}/dirlink", "--force"], "symbolic link"),
    ("target", "dev-report-socket", DEV + ["--report", "{s}"], "socket"),
    ("target", "sec-plots-dev-full", SEC + ["--plots", "/dev/full"], "character device"),
    ("target", "sec-plots-file", SEC + ["--plots", "{o}/old.csv"], "not a folder"),
    ("target", "sec-plots-fifo", SEC + ["--plots", "{o}/fifo"], "FIFO"),
    ("target", "sec-plots-full-folder", SEC + ["--plots", "{o}/full"], "--force"),
    ("target", "plan-o-folder", PLAN + ["-o", "{o}/empty"], "is a folder"),
    ("target", "plan-o-dev-full", PLAN + ["-o", "/dev/full"], "character device"),
    ("target", "plan-o-fifo", PLAN + ["-o", "{o}/fifo"], "FIFO"),
    ("target", "plan-o-socket", PLAN + ["-o", "{s}"], "socket"),
    ("target", "plan-o-is-nominal", PLAN + ["-o", N], "input file"),
    ("target", "tsp-o-dev-full", TSP + ["-o", "/dev/full"], "character device"),
    ("target", "tsp-o-fifo", TSP + ["-o", "{o}/fifo"], "FIFO"),
    ("target", "tsp-o-folder", TSP + ["-o", "{o}/full"], "is a folder"),
    ("target", "tsp-o-is-input", TSP + ["-o", Z], "input file"),
    ("target", "acq-o-dev-full", ACQ + ["-o", "/dev/full"], "character device"),
    ("target", "acq-o-fifo", ACQ + ["-o", "{o}/fifo"], "FIFO"),
    ("target", "acq-o-is-journal", ACQ + ["-o", J], "input file"),
    ("target", "sim-clean-dev-full", ["simulate-instrument", "--clean", "/dev/full"], "character device"),
    ("target", "sim-expected-fifo", ["simulate-instrument", "--expected", "{o}/fifo"], "FIFO"),
    # ---- option values, at parse time, naming the option
    ("option", "dev-tolerance-0", DEV + ["--tolerance", "0"], "--tolerance"),
    ("option", "dev-tolerance-nan", DEV + ["--tolerance", "nan"], "--tolerance"),
    ("option", "dev-tolerance-inf", DEV + ["--tolerance", "inf"], "--tolerance"),
    ("option", "dev-tolerance-text", DEV + ["--tolerance", "abc"], "--tolerance"),
    ("option", "sec-step-0", SEC + ["--step", "0"], "--step"),
    ("option", "sec-max-gap-negative", SEC + ["--max-gap", "-1"], "--max-gap"),
    ("option", "sec-beta1-90", SEC + ["--beta1", "90", "--beta2", "10"], "--beta1"),
    ("option", "sec-lift-0", SEC + ["--lift", "0"], "--lift"),
    ("option", "sec-offsets-negative", SEC + ["--offsets", "1,-2"], "--offsets"),
    ("option", "sec-offsets-nan", SEC + ["--offsets", "nan"], "--offsets"),
    ("option", "plan-step-0", PLAN + ["--step", "0"], "--step"),
    ("option", "plan-step-nan", PLAN + ["--step", "nan"], "--step"),
    ("option", "plan-tolerance-negative", PLAN + ["--tolerance", "-0.05"], "--tolerance"),
    ("option", "plan-axis-zero", PLAN + ["--axis", "0,0,0"], "--axis"),
    ("option", "plan-axis-inf", PLAN + ["--axis", "0,inf,1"], "--axis"),
    ("option", "plan-heights-nan", ["plan", N, "--heights", "10,nan", "--quiet"], "--heights"),
    ("option", "tsp-tolerance-0", TSP[:-3] + ["--tolerance", "0", "--quiet"], "--tolerance"),
    ("option", "tsp-max-iterations-negative", TSP + ["--max-iterations", "-1"], "--max-iterations"),
    ("option", "tsp-nd-0", TSP + ["--nd", "0"], "--nd"),
    ("option", "tsp-max-control-points-1", TSP + ["--max-control-points", "1"], "--max-control-points"),
    ("option", "acq-timeout-0", ACQ + ["-o", "{o}/a.csv", "--timeout", "0"], "--timeout"),
    ("option", "acq-give-up-inf", ACQ + ["-o", "{o}/a.csv", "--give-up", "inf"], "--give-up"),
    ("option", "acq-baud-0", ACQ + ["-o", "{o}/a.csv", "--baud", "0"], "--baud"),
    ("option", "sim-bad-checksum-2", ["simulate-instrument", "--bad-checksum", "2"], "--bad-checksum"),
    ("option", "sim-noise-negative", ["simulate-instrument", "--noise", "-1"], "--noise"),
    ("option", "rec-cloud-scale-0", REC + ["--slice", "5", "--cloud-scale", "0"], "--cloud-scale"),
    ("option", "rec-slab-negative", REC + ["--slice", "5", "--slab", "-1"], "--slab"),
    ("option", "rec-slice-1", REC + ["--slice", "1"], "--slice"),
    ("option", "rec-patches-around-3", REC + ["--surface", "local-bicubic", "--patches-around", "3"],
     "--patches-around"),
    ("option", "rec-fair-threshold-nan", REC + ["--fair", "--fair-threshold", "nan"], "--fair-threshold"),
    ("option", "rec-slice-radii-negative", REC + ["--slice-radii", "5,-6"], "--slice-radii"),
    # ---- a step that would make too many points: the smallest step allowed, before OCC allocates
    ("step", "sec-nominal-step-1e-6", SEC + ["--nominal", N, "--step", "1e-6"], "smallest step allowed"),
    ("step", "plan-step-1e-6", PLAN + ["--step", "1e-6", "-o", "{o}/p.csv"], "smallest step allowed"),
    # ---- hostile inputs: one line, file bytes escaped, nothing left
    ("input", "dev-one-1e300", DEV[:1] + ["{d}/one1e300.csv"] + DEV[2:] + ["--csv", "{o}/d.csv"], "1e+300"),
    ("input", "dev-all-1e300", DEV[:1] + ["{d}/all1e300.csv"] + DEV[2:] + ["--csv", "{o}/d.csv"], "beyond"),
    ("input", "sec-all-1e300", ["sections", "{d}/all1e300.csv", "--quiet"], "beyond"),
    ("input", "tsp-all-1e300", ["tspline", "{d}/all1e300.csv", "--tolerance", "0.05", "-o", "{o}/t.step", "--quiet"],
     "beyond"),
    ("input", "plan-all-1e300-sections", ["plan", "{d}/all1e300.csv", "-o", "{o}/p.csv", "--quiet"], "beyond"),
    ("input", "dev-nul-bytes", ["deviation", "{d}/nul.csv", "--nominal", N, "--csv", "{o}/d.csv", "--quiet"],
     "NUL byte"),
    ("input", "sec-utf16", ["sections", "{d}/utf16.csv", "--quiet"], "UTF-16"),
    ("input", "tsp-nul-bytes", ["tspline", "{d}/nul.csv", "--tolerance", "0.05", "--quiet"], "NUL byte"),
    ("input", "dev-control-bytes-cell", ["deviation", "{d}/ctl.csv", "--nominal", N, "--quiet"], "\\x1b[31m"),
    ("input", "sec-control-bytes-header", ["sections", "{d}/ctlhead.csv", "--quiet"], "\\x1b[2j"),
    ("input", "sec-dev-zero", ["sections", "/dev/zero", "--quiet"], "character device"),
    ("input", "sec-fifo", ["sections", "{d}/fifo", "--quiet"], "FIFO"),
    ("input", "dev-folder", ["deviation", "{d}/folder", "--nominal", N, "--quiet"], "folder"),
    ("input", "dev-nominal-fifo", DEV[:3] + ["{d}/fifo", "--quiet"], "FIFO"),
    ("input", "dev-nominal-text", DEV[:3] + ["{d}/text.step", "--csv", "{o}/d.csv", "--quiet"], "cannot read"),
    ("input", "dev-nominal-empty", DEV[:3] + ["{d}/empty.step", "--csv", "{o}/old.csv", "--quiet"], "empty"),
    ("input", "plan-nominal-text", ["plan", "{d}/text.step", "--heights", "10,50", "-o", "{o}/p.csv", "--quiet"],
     "cannot read"),
    ("input", "acq-replay-fifo", ["acquire", "--replay", "{d}/fifo", "-o", "{o}/a.csv", "--quiet"], "FIFO"),
    ("input", "acq-calibration-fifo", ACQ[:3] + ["--calibration", "{d}/fifo", "-o", "{o}/a.csv", "--quiet"], "FIFO"),
    ("input", "rec-cloud-binary", ["reconstruct", "{d}/cloud.bin", "--slice", "4", "--quiet"], "not a text"),
    # ---- plausibility: points in metres against a nominal in mm
    ("plausibility", "rec-nominal-metres", ["reconstruct", "{d}/metres.csv", "--nominal", N, "-o", "{o}/r.step",
                                            "--report", "{o}/rep", "--quiet"], "look like metres"),
    ("plausibility", "dev-nominal-metres", ["deviation", "{d}/metres.csv", "--nominal", N, "--csv", "{o}/d.csv",
                                            "--quiet"], "look like metres"),
]


def _argv(template: list, data: Path, out: Path, sock: Path | None) -> list[str]:
    return [a.format(d=data, o=out, s=sock) for a in template]


@pytest.mark.parametrize("category,argv,words", [c[0:1] + c[2:] for c in CASES], ids=[f"{c[0]}:{c[1]}" for c in CASES])
def test_refused_in_one_line_and_nothing_left(capfd, data, out, category, argv, words):
    sock = _sock(out) if any("{s}" in a for a in argv) else None
    if any("{s}" in a for a in argv) and sock is None:
        pytest.skip("the folder's path is too long for a socket")
    line = refused(capfd, _argv(argv, data, out, sock), (data, out))
    assert words in line, line
    if category == "option" and line.startswith("bladerecon: error: argument "):
        assert line.endswith("(see --help)")


def test_at_least_sixty_cases():
    assert len(CASES) >= 60
    assert len({c[1] for c in CASES}) == len(CASES)


# --------------------------------------------------------------------------- late failures: all or nothing
def _dev_all_outputs(data: Path, out: Path) -> list[str]:
    return _argv(["deviation", "{d}/cloud.csv", "--nominal", N, "--quiet", "--align", "translate", "--csv", "{o}/old.csv", "--aligned", "{o}/aligned.csv",
                        "--report", "{o}/report"], data, out, None)


def test_a_report_that_fails_late_leaves_nothing_and_loses_nothing(capfd, monkeypatch, data, out):
    """The CSV and the aligned points are complete when the report fails: neither is put in
    place, and the old result the CSV would replace is still there."""
    import bladerecon.report.deviation as report

    def fails(folder, *args, **kwargs):
        (Path(folder) / "deviations.csv").write_text("half")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(report, "write_deviation_report", fails)
    line = refused(capfd, _dev_all_outputs(data, out), (data, out))
    assert "cannot write" in line and "report" in line and "disk full" in line


def test_ctrl_c_leaves_nothing(capfd, monkeypatch, data, out):
    import bladerecon.report.deviation as report

    def interrupted(folder, *args, **kwargs):
        (Path(folder) / "deviations.csv").write_text("half")
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "write_deviation_report", interrupted)
    text = refused(capfd, _dev_all_outputs(data, out), (data, out), code=130)
    assert "interrupted" in text


def test_a_bad_nominal_after_the_measured_points_leaves_the_old_csv(capfd, data, out):
    line = refused(capfd, _argv(DEV[:3] + ["{d}/text.step", "--csv", "{o}/old.csv", "--quiet"], data, out, None),
                   (data, out))
    assert "text.step" in line
    assert (out / "old.csv").read_text() == "old result\n"


def test_force_writes_into_a_folder_that_holds_files_and_keeps_them(capfd, monkeypatch, data, out):
    import bladerecon.report.deviation as report

    def writes(folder, *args, **kwargs):
        (Path(folder) / "report.html").write_text("<html>")

    monkeypatch.setattr(report, "write_deviation_report", writes)
    argv = _argv(["deviation", "{d}/cloud.csv", "--nominal", N, "--quiet", "--report", "{o}/full", "--force"],
                 data, out, None)
    assert run_in_process(argv) == 0, capfd.readouterr().err
    assert sorted(p.name for p in (out / "full").iterdir()) == ["keep.txt", "report.html"]
    assert not [p for p in out.iterdir() if p.name.startswith(".")]


# --------------------------------------------------------------------------- a disk that is full
def _mount(args: list[str], where: Path) -> str | None:
    if os.geteuid() != 0:
        return "mounting a tmpfs or a read-only bind mount needs root"
    r = subprocess.run(["mount", *args, str(where)], capture_output=True, text=True)
    return None if r.returncode == 0 else f"mount refused: {r.stderr.strip()}"


@pytest.fixture(scope="module")
def tiny(tmp_path_factory):
    where = tmp_path_factory.mktemp("tiny")
    why = _mount(["-t", "tmpfs", "-o", "size=256k", "tmpfs"], where)
    if why:
        pytest.skip(why)
    yield where
    subprocess.run(["umount", str(where)], check=False)


def _fill(where: Path, leave: int) -> None:
    """Leave ``leave`` bytes free on the tmpfs at ``where``."""
    filler = where / "filler"
    if filler.exists():
        filler.unlink()
    st_ = os.statvfs(where)
    with open(filler, "wb") as fh:
        fh.write(b"\0" * (st_.f_bavail * st_.f_frsize - leave))
    assert os.statvfs(where).f_bavail * os.statvfs(where).f_frsize == leave


FULL_DISK = [
    # (id, argv with {t} the tmpfs, bytes left free: 0 = refused before any work, else fails while writing)
    ("dev-csv-already-full", DEV + ["--csv", "{t}/d.csv"], 0),
    ("dev-csv", DEV + ["--csv", "{t}/d.csv"], 4096),
    ("dev-report", ["deviation", "{d}/cloud.csv", "--nominal", N, "--report", "{t}/report", "--quiet"], 4096),
    ("dev-aligned-and-csv", DEV + ["--align", "translate", "--aligned", "{t}/a.csv", "--csv", "{t}/d.csv"], 4096),
    ("plan-o-already-full", PLAN + ["-o", "{t}/p.csv"], 0),
    ("plan-o", ["plan", N, "--heights", "1,20,40,60,80,99", "-o", "{t}/p.csv", "--quiet"], 4096),
    ("tsp-o-step", TSP + ["-o", "{t}/t.step"], 4096),
    ("acq-o", ACQ + ["-o", "{t}/a.csv"], 4096),
    ("sec-plots", SEC + ["--plots", "{t}/plots"], 4096),
]


@pytest.mark.parametrize("argv,leave", [c[1:] for c in FULL_DISK], ids=[c[0] for c in FULL_DISK])
def test_full_disk_is_one_line_and_leaves_nothing(capfd, data, tiny, argv, leave):
    _fill(tiny, leave)
    try:
        line = refused(capfd, [a.format(d=data, t=tiny) for a in argv], (data, tiny))
    finally:
        (tiny / "filler").unlink()
    assert "disk full" in line and str(tiny) in line and ".part" not in line, line
    assert "OpenCASCADE" not in line


@pytest.fixture(scope="module")
def readonly(tmp_path_factory):
    src = tmp_path_factory.mktemp("rosrc")
    (src / "old.csv").write_text("old\n")
    where = tmp_path_factory.mktemp("ro")
    why = _mount(["--bind", str(src)], where)
    if why:
        pytest.skip(why)
    r = subprocess.run(["mount", "-o", "remount,bind,ro", str(where)], capture_output=True, text=True)
    if r.returncode:
        subprocess.run(["umount", str(where)], check=False)
        pytest.skip(f"remounting read-only refused: {r.stderr.strip()}")
    yield where
    subprocess.run(["umount", str(where)], check=False)


READ_ONLY = [
    ("dev-report", DEV + ["--report", "{r}/report"]),
    ("dev-csv-replacing", DEV + ["--csv", "{r}/old.csv"]),
    ("sec-plots", SEC + ["--plots", "{r}/plots"]),
    ("plan-o", PLAN + ["-o", "{r}/p.csv"]),
    ("tsp-o", TSP + ["-o", "{r}/t.step"]),
]


@pytest.mark.parametrize("argv", [c[1] for c in READ_ONLY], ids=[c[0] for c in READ_ONLY])
def test_read_only_folder_is_one_line_before_any_work(capfd, data, readonly, argv):
    line = refused(capfd, [a.format(d=data, r=readonly) for a in argv], (data, readonly))
    assert "read-only file system" in line, line


# --------------------------------------------------------------------------- the real command line
def test_the_command_refuses_dev_full_and_leaves_it_a_device(data):
    """As a cell runs it: a separate process, exit status 2, one line, /dev/full untouched."""
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run([sys.executable, "-m", "bladerecon", "plan", str(data / "m.csv"), "-o", "/dev/full",
                        "--quiet"], capture_output=True, text=True, env=env, timeout=120)
    assert r.returncode == 2 and r.stderr.count("bladerecon: error:") == 1 and len(r.stderr.splitlines()) == 1
    assert "character device" in r.stderr
    special_files_intact()


# --------------------------------------------------------------------------- properties of the option checks
def _number_text():
    return st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                     st.sampled_from(["nan", "-inf", "1e400", "-0", "0x10", "", " ", "1,5", "abc", "1e-320"]),
                     st.text(max_size=8))


@PROPERTY
@given(text=_number_text())
def test_positive_accepts_exactly_the_finite_positive_numbers(text):
    try:
        value = float(text)
    except ValueError:
        value = None
    good = value is not None and math.isfinite(value) and value > 0
    if good:
        assert outputs.positive()(text) == value
    else:
        with pytest.raises(Exception) as info:
            outputs.positive()(text)
        assert "positive" in str(info.value) or "number" in str(info.value)
        assert "\n" not in str(info.value)


@PROPERTY
@given(text=_number_text(), option=st.sampled_from([("plan", "--step"), ("plan", "--tolerance"),
                                                     ("deviation", "--tolerance"), ("sections", "--max-gap"),
                                                     ("sections", "--step"), ("tspline", "--tolerance"),
                                                     ("acquire", "--timeout"), ("reconstruct", "--cloud-scale"),
                                                     ("reconstruct", "--slab")]))
def test_the_parsers_take_a_valid_value_and_name_the_option_of_a_bad_one(capsys, text, option):
    command, name = option
    base = {"plan": ["plan", "n.step"], "deviation": ["deviation", "m.csv", "--nominal", "n.step"],
            "sections": ["sections", "m.csv"], "tspline": ["tspline", "z.xyz", "--tolerance", "1"],
            "acquire": ["acquire", "--replay", "j", "-o", "a.csv"], "reconstruct": ["reconstruct", "m.csv"]}[command]
    try:
        value = float(text)
    except ValueError:
        value = None
    good = value is not None and math.isfinite(value) and value > 0 and not (name == "--timeout" and value > 3600) \
        and not (name == "--cloud-scale" and value > 1e9)
    capsys.readouterr()
    try:
        args = build_parser().parse_args(base + [f"{name}={text}"])
    except SystemExit as exc:
        err = capsys.readouterr().err
        assert not good and exc.code == 2, (text, err)
        assert err.count("\n") == 1 and err.startswith("bladerecon: error: argument ") and name in err, err
        return
    assert good, text
    assert getattr(args, name.lstrip("-").replace("-", "_")) == value


@PROPERTY
@given(low=st.integers(-5, 50), high=st.integers(-5, 60), value=st.integers(-100, 100))
def test_count_accepts_exactly_its_range(low, high, value):
    check = outputs.count(low, high)
    if low <= value <= high:
        assert check(str(value)) == value
    else:
        with pytest.raises(Exception, match="whole number"):
            check(str(value))


@PROPERTY
@given(step=st.floats(1e-12, 1e6), length=st.floats(1e-3, 1e7))
def test_a_step_is_refused_exactly_when_it_makes_too_many_points_and_the_step_named_is_allowed(step, length):
    too_many = length / step > outputs.MAX_SAMPLES
    try:
        outputs.check_samples("--step", step, length)
    except BladeReconError as err:
        assert too_many
        smallest = float(str(err).rsplit("allowed here is ", 1)[1].split()[0])
        assert smallest >= length / outputs.MAX_SAMPLES
        assert smallest <= 1.15 * length / outputs.MAX_SAMPLES
        outputs.check_samples("--step", smallest, length)       # the step it names is taken
    else:
        assert not too_many


@PROPERTY
@given(text=st.one_of(st.text(max_size=200), st.binary(max_size=200)), limit=st.integers(1, 80))
def test_shown_text_has_no_control_characters_and_is_cut(text, limit):
    import unicodedata

    s = outputs.shown(text, limit)
    assert len(s) <= limit + 1
    assert not any(unicodedata.category(ch) in ("Cc", "Cf", "Zl", "Zp") for ch in s)
    if isinstance(text, str) and len(text) <= limit and text.isprintable():
        assert s == text
