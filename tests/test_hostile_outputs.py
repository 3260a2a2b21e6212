# SPDX-License-Identifier: LGPL-2.1-or-later
"""The output transaction and the one-line OS errors of :mod:`bladerecon.core.io.outputs`
(no FreeCAD), and the two fc/report paths that map OpenCASCADE's and the OS's failures."""
from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

import pytest

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io import outputs
from bladerecon.core.io.outputs import Outputs, os_error_message, shown


def listing(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


# --------------------------------------------------------------------------- the transaction
def test_commit_puts_files_and_folders_in_place_with_the_usual_modes(tmp_path):
    old = tmp_path / "old.csv"
    old.write_text("old\n")
    old.chmod(0o640)
    with Outputs() as outs:
        a = outs.file(tmp_path / "new.csv", "--csv")
        b = outs.file(old, "-o")
        rep = outs.folder(tmp_path / "report", "--report")
        assert outs.file(None, "--aligned") is None and outs.folder(None, "--plots") is None
        for p in (a, b, rep):
            assert os.path.basename(p).startswith(".") and p.endswith(".part")
        Path(a).write_text("a\n")
        Path(b).write_text("b\n")
        Path(rep, "report.html").write_text("<html>")
        assert sorted(os.listdir(tmp_path))[0].startswith(".")        # nothing visible yet but the old file
        assert old.read_text() == "old\n"
        outs.commit()
    umask = os.umask(0)
    os.umask(umask)
    assert listing(tmp_path) == ["new.csv", "old.csv", "report", "report/report.html"]
    assert (tmp_path / "new.csv").read_text() == "a\n" and old.read_text() == "b\n"
    assert stat.S_IMODE(old.stat().st_mode) == 0o640                                  # the old file's mode kept
    assert stat.S_IMODE((tmp_path / "new.csv").stat().st_mode) == 0o666 & ~umask
    assert stat.S_IMODE((tmp_path / "report").stat().st_mode) == 0o777 & ~umask


@pytest.mark.parametrize("failure", [BladeReconError("bad nominal"), OSError(errno.ENOSPC, "full"),
                                     KeyboardInterrupt(), RuntimeError("bug")],
                         ids=["user-error", "disk-full", "ctrl-c", "internal"])
def test_any_failure_leaves_nothing_new_and_loses_nothing_old(tmp_path, failure):
    (tmp_path / "old.csv").write_text("old\n")
    (tmp_path / "rep").mkdir()
    (tmp_path / "rep" / "keep.txt").write_text("keep\n")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    with pytest.raises((BladeReconError, KeyboardInterrupt, RuntimeError)):
        with Outputs() as outs:
            Path(outs.file(tmp_path / "old.csv", "--csv")).write_text("new")
            Path(outs.file(tmp_path / "new.csv", "--aligned")).write_text("new")
            Path(outs.folder(tmp_path / "rep", "--report", force=True), "keep.txt").write_text("new")
            Path(outs.folder(tmp_path / "plots", "--plots"), "p.png").write_text("new")
            raise failure
    assert {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()} == before
    assert listing(tmp_path) == ["old.csv", "rep", "rep/keep.txt"]


def test_an_os_error_names_the_target_not_the_temporary(tmp_path):
    with pytest.raises(BladeReconError) as info:
        with Outputs() as outs:
            temp = outs.file(tmp_path / "d.csv", "--csv")
            raise OSError(errno.ENOSPC, "No space left on device", temp)
    assert str(info.value) == f"cannot write {tmp_path / 'd.csv'}: disk full; free space there or choose another folder"
    with pytest.raises(BladeReconError) as info:
        with Outputs() as outs:
            temp = outs.folder(tmp_path / "rep", "--report")
            raise BladeReconError(f"cannot write {temp}/report.html: disk full")
    assert str(info.value) == f"cannot write {tmp_path / 'rep'}/report.html: disk full"
    assert listing(tmp_path) == []


def test_force_merges_into_an_existing_folder_and_keeps_other_files(tmp_path):
    rep = tmp_path / "rep"
    rep.mkdir()
    (rep / "keep.txt").write_text("keep\n")
    (rep / "report.html").write_text("old\n")
    with pytest.raises(BladeReconError, match="--force"):
        with Outputs() as outs:
            outs.folder(rep, "--report")
    with Outputs() as outs:
        temp = outs.folder(rep, "--report", force=True)
        assert Path(temp).parent == rep                      # filled inside: the folder itself is writable
        Path(temp, "report.html").write_text("new\n")
        outs.commit()
    assert listing(rep) == ["keep.txt", "report.html"] and (rep / "report.html").read_text() == "new\n"
    # an empty folder is taken without --force: nothing in it to lose
    (tmp_path / "empty").mkdir()
    with Outputs() as outs:
        Path(outs.folder(tmp_path / "empty", "--plots"), "a.png").write_text("png")
        outs.commit()
    assert listing(tmp_path / "empty") == ["a.png"]


def test_a_folder_in_the_way_of_a_report_file_stops_the_commit_before_any_rename(tmp_path):
    rep = tmp_path / "rep"
    (rep / "report.html").mkdir(parents=True)
    (tmp_path / "old.csv").write_text("old\n")
    with pytest.raises(BladeReconError, match="report.html there is a folder"):
        with Outputs() as outs:
            Path(outs.file(tmp_path / "old.csv", "--csv")).write_text("new\n")
            temp = outs.folder(rep, "--report", force=True)
            Path(temp, "report.html").write_text("new\n")
            outs.commit()
    assert (tmp_path / "old.csv").read_text() == "old\n"
    assert listing(tmp_path) == ["old.csv", "rep", "rep/report.html"]


def test_two_outputs_with_one_name_and_an_output_naming_an_input_are_refused(tmp_path):
    src = tmp_path / "in.csv"
    src.write_text("1 2 3\n")
    os.link(src, tmp_path / "hardlink.csv")
    with pytest.raises(BladeReconError, match="same output"):
        with Outputs() as outs:
            outs.file(tmp_path / "a.csv", "--csv")
            outs.file(str(tmp_path / "x" / ".." / "a.csv"), "--aligned")
    for name in ("in.csv", "hardlink.csv"):
        with pytest.raises(BladeReconError, match="input file"):
            with Outputs(inputs=[src]) as outs:
                outs.file(tmp_path / name, "-o")
    assert listing(tmp_path) == ["hardlink.csv", "in.csv"]


# --------------------------------------------------------------------------- one line per OS failure
@pytest.mark.parametrize("code,words", [
    (errno.ENOSPC, "disk full"), (errno.EDQUOT, "quota"), (errno.EACCES, "permission denied"),
    (errno.EROFS, "read-only file system"), (errno.EISDIR, "is a folder"), (errno.ENOTDIR, "not a folder"),
    (errno.ELOOP, "symbolic links"), (errno.EMFILE, "too many open files"), (errno.ENFILE, "too many open files"),
    (errno.EIO, "input/output error"), (errno.ENAMETOOLONG, "too long"), (errno.EPERM, "not permitted")])
def test_every_os_failure_is_one_line(code, words):
    text = os_error_message(OSError(code, os.strerror(code), "/shared/out\n\x1b[2Jx.csv"))
    assert text.startswith("cannot write /shared/out\\x0a\\x1b[2Jx.csv: ") and words in text
    assert "\n" not in text and "\x1b" not in text


def test_a_real_full_disk_from_dev_full():
    with pytest.raises(OSError) as info:
        with open("/dev/full", "wb") as fh:
            fh.write(b"x" * 10)
            fh.flush()
    assert os_error_message(info.value, "out.csv") == ("cannot write out.csv: disk full; free space there or "
                                                       "choose another folder")
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)


def test_write_problem_says_what_the_os_says(tmp_path):
    assert outputs.write_problem(str(tmp_path)) is None
    assert "no such file" in outputs.write_problem(str(tmp_path / "nope"))
    assert listing(tmp_path) == []                     # the probe is removed


# --------------------------------------------------------------------------- text shown in messages
def test_shown_escapes_and_cuts():
    assert shown("plain µm text") == "plain µm text"
    assert shown("a\x1b[31mb\x07\u202e\n") == "a\\x1b[31mb\\x07\\u202e\\x0a"
    assert shown(b"\xff\x00ok") == "\\xff\\x00ok"
    assert shown("x" * 100, 10) == "x" * 10 + "…"
    assert shown("\x00" * 10, 9) == "\\x00\\x00…"        # never half an escape


def test_readers_refuse_binary_content_and_show_cells_escaped(tmp_path):
    from bladerecon.core.io.readers import read_points

    nul = tmp_path / "b.csv"
    nul.write_bytes(b"x,y,z\n1,2,3\n" + b"\x00")
    with pytest.raises(BladeReconError, match="NUL byte at offset 12"):
        read_points(nul)
    late = tmp_path / "late.xyz"      # a NUL past the first megabyte is found while the file streams
    head = b"0 0 0\n1 0 0\n\n0 0 1\n" + b"\n" * (1 << 20)
    late.write_bytes(head + b"\x00\n")
    with pytest.raises(BladeReconError, match=f"NUL byte at offset {len(head)}:"):
        read_points(late)
    ctl = tmp_path / "c\x1b[1m.csv"
    ctl.write_bytes(b"x,y,z\n1,2,3\n1,\x1b]0;title\x07,3\n")
    with pytest.raises(BladeReconError) as info:
        read_points(ctl)
    assert "\x1b" not in str(info.value) and "\x07" not in str(info.value)
    assert "c\\x1b[1m.csv, line 3: column 'y' has '\\x1b]0;title\\x07'" in str(info.value)


# --------------------------------------------------------------------------- OpenCASCADE's failures
@pytest.fixture(scope="module")
def export():
    from bladerecon.fc.freecad_env import import_freecad

    try:
        import_freecad()
    except BladeReconError as err:
        pytest.skip(f"FreeCAD not available: {err}")
    from bladerecon.fc import export
    return export


def test_write_step_refuses_devices_fifos_and_links(export, tmp_path):
    import Part

    os.mkfifo(tmp_path / "fifo")
    os.symlink(tmp_path / "x.step", tmp_path / "link.step")
    for target, words in (("/dev/full", "character device"), (tmp_path / "fifo", "FIFO"),
                          (tmp_path / "link.step", "symbolic link")):
        with pytest.raises(BladeReconError, match=words):
            export.write_step(Part.makeBox(1, 1, 1), target)
    assert stat.S_ISFIFO(os.lstat(tmp_path / "fifo").st_mode) and stat.S_ISCHR(os.stat("/dev/full").st_mode)
    assert listing(tmp_path) == ["fifo", "link.step"]


def test_a_solid_opencascade_refuses_is_one_line(export, monkeypatch):
    from fc_fixtures import tapered_tube

    def refuses(surface, ends):
        raise RuntimeError("ShapeFix_Shell: failed")

    monkeypatch.setattr(export, "_capped_solid", refuses)
    with pytest.raises(BladeReconError, match="cannot make a solid: OpenCASCADE refused .*ShapeFix_Shell.*--solid"):
        export.make_solid(tapered_tube())


def test_a_report_folder_that_is_a_file_is_one_line(tmp_path):
    from bladerecon.report.reconstruct import write_report

    (tmp_path / "rep").write_text("a file")
    with pytest.raises(BladeReconError, match="is a file, not a folder"):
        write_report(str(tmp_path / "rep"), {}, None, None, None, None)


@pytest.mark.timeout(180)
def test_sigterm_ends_a_command_with_nothing_new_left(tmp_path):
    """SIGTERM (a batch system's kill, a closed terminal's hang-up turned to TERM) while a
    command works: exit 143 with one line, the report folder and the hidden temporaries gone,
    and no forked worker left running."""
    import signal
    import subprocess
    import sys
    import time

    root = Path(__file__).resolve().parent.parent
    lines = (root / "resources" / "sample" / "measured.csv").read_text().splitlines()
    big = tmp_path / "big.csv"
    big.write_text("\n".join([lines[0]] + lines[1:] * 40) + "\n")          # 480 000 points
    out = tmp_path / "out"
    out.mkdir()
    env = dict(os.environ, PYTHONPATH=str(root))
    proc = subprocess.Popen([sys.executable, "-m", "bladerecon", "deviation", str(big), "--nominal",
                             str(root / "resources" / "sample" / "nominal.step"), "--report", str(out / "rep")],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    end = time.monotonic() + 120
    while not any(p.name.startswith(".") for p in out.iterdir()):     # its temporaries exist: it is working
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < end, "no temporary appeared"
        time.sleep(0.02)
    time.sleep(0.5)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=60)
    if proc.returncode == 0:
        pytest.fail("the command finished before SIGTERM arrived: make the input larger")
    assert proc.returncode == 143, err
    assert err.strip().splitlines()[-1] == "bladerecon: terminated (SIGTERM); no output was completed", err
    assert "Traceback" not in err
    assert list(out.iterdir()) == []
    left = []                               # /proc, not pgrep: a minimal root has no procps
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            cmd = Path("/proc", pid, "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue                        # ended while we looked
        if str(big) in cmd:
            left.append(pid)
    assert not left, f"processes left running: {left}"
