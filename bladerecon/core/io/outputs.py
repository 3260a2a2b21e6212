# SPDX-License-Identifier: LGPL-2.1-or-later
"""Honest failures: outputs that are ours or refused, written all or nothing; one line for
every OS failure; option values checked when the command line is parsed; file bytes shown
escaped.

A measuring cell runs the commands unattended, as root, on other people's files, into shared
folders that fill up. So:

* **Outputs are ours or refused** (:func:`check_file_target`, :func:`check_folder_target`):
  before any work, a target that exists and is not a regular file (a device, FIFO, socket,
  symbolic link, a folder where a file is meant, a file where a folder is meant) is refused;
  a report folder that exists and holds files is refused unless the command's ``--force``;
  an output that names an input is refused; a disk with no free block is refused.
* **All or nothing** (:class:`Outputs`): every output is written to a temporary file or
  folder beside its target (``.NAME.XXXXXXXX.part``) and put in place only by
  :meth:`Outputs.commit`, after the whole command succeeded. On any failure - a bad input
  found late, a report that cannot be written, a full disk, Ctrl-C - the temporaries are
  removed: nothing new is left and nothing old is lost.
* **One line for every OS failure** (:func:`os_error_message`): ``OSError`` becomes
  ``cannot write PATH: disk full`` (ENOSPC), ``... permission denied`` (EACCES), ``read-only
  file system`` (EROFS), ... in this one place; :class:`Outputs` names the target, never
  the temporary name.
* **Option values** (:func:`positive`, :func:`finite`, :func:`count`, :func:`fraction`):
  argparse ``type=`` functions that refuse NaN, infinities, wrong signs and ranges while the
  command line is parsed; :func:`one_line_errors` makes a parser's errors one
  ``bladerecon: error:`` line; :func:`check_samples` refuses a step that would make more
  than :data:`MAX_SAMPLES` points and names the smallest step allowed.
* **File bytes in messages** (:func:`shown`): control characters escaped, long text cut.

Standard library only (the core never imports FreeCAD). Lengths in mm.
"""
from __future__ import annotations

import argparse
import contextlib
import errno
import math
import os
import shutil
import signal
import stat
import sys
import tempfile
import threading
import unicodedata
from dataclasses import dataclass
from typing import Iterable

from bladerecon.core.errors import BladeReconError

__all__ = ["Outputs", "shown", "escaped", "signals_held", "os_error_message", "os_error", "check_file_target", "check_folder_target",
           "check_input", "check_coordinates", "check_samples", "write_problem", "positive", "finite",
           "count", "fraction", "one_line_errors", "MAX_SAMPLES", "COORDINATE_LIMIT", "SHOWN_LIMIT"]

SHOWN_LIMIT = 60                  # characters of file text shown in a message
MAX_SAMPLES = 2_000_000           # points a --step may make (~50 MB of coordinates)
COORDINATE_LIMIT = 1.0e6          # mm: one kilometre; no blade is measured beyond it


# --------------------------------------------------------------------------- signals
@contextlib.contextmanager
def signals_held():
    """Ctrl-C and SIGTERM held while the block runs and delivered after it (to the handler that
    was in place). For FreeCAD reading a STEP file: interrupted there, OpenCASCADE's reader
    threads crash on the objects being torn down and the command ends with status 1."""
    # in the workbench (FreeCADGui loaded) there is no Ctrl-C to hold and Qt owns the signals
    if threading.current_thread() is not threading.main_thread() or "FreeCADGui" in sys.modules:
        yield
        return
    got: list[int] = []
    wanted = (signal.SIGINT, signal.SIGTERM)
    before = {s: signal.signal(s, lambda signum, frame: got.append(signum)) for s in wanted}
    try:
        yield
    finally:
        for s, handler in before.items():
            signal.signal(s, handler)
        if got:
            handler = before[got[0]]
            if callable(handler):
                handler(got[0], None)
            elif handler == signal.SIG_DFL:
                os.kill(os.getpid(), got[0])


# --------------------------------------------------------------------------- text shown
def _escape(ch: str) -> str:
    if unicodedata.category(ch) not in ("Cc", "Cf", "Cs", "Co", "Cn", "Zl", "Zp"):
        return ch
    code = ord(ch)
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}" if code < 0x10000 else f"\\U{code:08x}"


def shown(text, limit: int = SHOWN_LIMIT) -> str:
    """``text`` (str, bytes or a path) safe for a one-line message on a terminal: control and
    format characters (escape sequences, newlines, NUL, bidi overrides) escaped as ``\\xNN``,
    cut after ``limit`` characters with ``…``."""
    if isinstance(text, (bytes, bytearray)):
        text = bytes(text).decode("utf-8", errors="backslashreplace")
    text = os.fspath(text) if isinstance(text, os.PathLike) else str(text)
    if isinstance(text, bytes):
        text = text.decode("utf-8", errors="backslashreplace")
    out, n = [], 0
    for ch in text:
        piece = _escape(ch)
        if n + len(piece) > limit:
            out.append("…")
            break
        out.append(piece)
        n += len(piece)
    return "".join(out)


def escaped(text) -> str:
    """``text`` with control and format characters escaped as :func:`shown` does, never cut: for
    whole message lines, which may hold names from the command line or a manifest."""
    text = str(text)
    return shown(text, 10 * len(text) + 1)


# --------------------------------------------------------------------------- OS errors
_WHY = {
    errno.ENOSPC: "disk full",
    errno.EDQUOT: "disk quota exceeded",
    errno.EACCES: "permission denied",
    errno.EPERM: "operation not permitted",
    errno.EROFS: "read-only file system",
    errno.EISDIR: "it is a folder",
    errno.ENOTDIR: "a part of the path is not a folder",
    errno.ELOOP: "too many levels of symbolic links (a loop?)",
    errno.EMFILE: "too many open files in this process",
    errno.ENFILE: "too many open files on the system",
    errno.ENAMETOOLONG: "the name is too long",
    errno.ENOENT: "no such file or folder",
    errno.EEXIST: "it already exists",
    errno.ENOTEMPTY: "the folder is not empty",
    errno.EFBIG: "the file is too large for the file system",
    errno.EIO: "input/output error (a failing disk or a lost network share)",
    errno.EXDEV: "the temporary file is on another file system",
    errno.EBUSY: "it is busy (a mount point?)",
    errno.ETXTBSY: "it is a running program",
    errno.ENXIO: "no such device",
    errno.ENOMEM: "out of memory",
}
_ADVICE = {
    errno.ENOSPC: "free space there or choose another folder",
    errno.EDQUOT: "free space there or choose another folder",
    errno.EACCES: "check the permissions or choose another folder",
    errno.EPERM: "check the permissions or choose another folder",
    errno.EROFS: "choose a writable folder",
    errno.EMFILE: "close other files or raise the limit (ulimit -n)",
    errno.ENFILE: "close other programs' files and run again",
    errno.ELOOP: "name the file itself",
    errno.ENAMETOOLONG: "choose a shorter name",
}


def os_error_message(err: OSError, path=None, verb: str = "write") -> str:
    """One line for an ``OSError``: ``cannot VERB PATH: why; what to do`` (PATH escaped)."""
    where = path if path is not None else (err.filename if err.filename is not None else "the output")
    why = _WHY.get(err.errno) or (err.strerror or type(err).__name__).lower()
    advice = _ADVICE.get(err.errno)
    return f"cannot {verb} {shown(where, 200)}: {why}" + (f"; {advice}" if advice else "")


def os_error(err: OSError, path=None, verb: str = "write") -> BladeReconError:
    """:func:`os_error_message` as the exception the command line prints (exit status 2)."""
    return BladeReconError(os_error_message(err, path, verb))


def _kind(mode: int) -> str:
    for test, name in ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISLNK, "a symbolic link"), (stat.S_ISDIR, "a folder"),
                       (stat.S_ISREG, "a file")):
        if test(mode):
            return name
    return "not a regular file"


def _free_bytes(folder: str) -> int | None:
    try:
        st = os.statvfs(folder)
    except OSError:
        return None
    if st.f_blocks == 0:            # no blocks at all: /proc, /sys (not a disk that is full)
        return None
    blocks = st.f_bfree if os.geteuid() == 0 else st.f_bavail    # root may use the reserve
    return blocks * st.f_frsize


def write_problem(folder: str, probe_bytes: int = 65536) -> str | None:
    """Why writing into ``folder`` fails, as the one line of :func:`os_error_message`, or None.

    For writers that do not say (OpenCASCADE's STEP writer reports only "failed"): no free
    block is ENOSPC; else a probe file is written, synced and removed.
    """
    free = _free_bytes(folder)
    if free is not None and free < probe_bytes:
        return os_error_message(OSError(errno.ENOSPC, "No space left on device"), folder)
    try:
        fd, probe = tempfile.mkstemp(prefix=".bladerecon-probe.", dir=folder)
    except OSError as err:
        return os_error_message(err, folder)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(b"\0" * probe_bytes)
            fh.flush()
            os.fsync(fh.fileno())
    except OSError as err:
        return os_error_message(err, folder)
    finally:
        try:
            os.unlink(probe)
        except OSError:
            pass
    return None


# --------------------------------------------------------------------------- targets and inputs
def _named(what: str, path) -> str:
    return f"{what} {shown(path, 200)}" if what else shown(path, 200)


def _same_file(a: str, b: str) -> bool:
    if os.path.abspath(a) == os.path.abspath(b):
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def _parent(path: str, what: str) -> str:
    parent = os.path.dirname(os.path.abspath(path)) or os.sep
    try:
        st = os.stat(parent)
    except FileNotFoundError:
        raise BladeReconError(f"{_named(what, path)}: folder {shown(parent, 200)} does not exist; "
                              "create it first") from None
    except OSError as err:
        raise os_error(err, path) from None
    if not stat.S_ISDIR(st.st_mode):
        raise BladeReconError(f"{_named(what, path)}: {shown(parent, 200)} is {_kind(st.st_mode)}, not a folder")
    return parent


def _lstat(path: str):
    try:
        return os.lstat(path)
    except FileNotFoundError:
        return None
    except OSError as err:
        raise os_error(err, path) from None


def _refuse_inputs(path: str, what: str, inputs: Iterable) -> None:
    for given in inputs:
        if given and _same_file(path, os.fspath(given)):
            raise BladeReconError(f"{_named(what, path)} is an input file: choose another name "
                                  "(inputs are never overwritten)")


def _refuse_full(parent: str, path: str) -> None:
    free = _free_bytes(parent)
    if free is not None and free <= 0:
        raise os_error(OSError(errno.ENOSPC, "No space left on device"), path)


def check_file_target(path, what: str = "", inputs: Iterable = ()) -> str:
    """Refuse a file output we must not write; returns its absolute path.

    Refused: an empty name or one ending in a separator, a missing parent folder, an existing
    target that is not a regular file (device, FIFO, socket, symbolic link, folder), an input
    file, a disk with no free block. An existing regular file will be replaced.
    """
    path = os.fspath(path)
    if not path or path.endswith(os.sep) or os.path.basename(path) in ("", ".", ".."):
        raise BladeReconError(f"{_named(what, path)}: names a folder; give a file name")
    parent = _parent(path, what)
    st = _lstat(path)
    if st is not None and not stat.S_ISREG(st.st_mode):
        extra = "; name the file itself (outputs are never written through links)" if stat.S_ISLNK(st.st_mode) \
            else "; give a file name" if stat.S_ISDIR(st.st_mode) \
            else " (outputs replace only regular files); give a file name"
        raise BladeReconError(f"{_named(what, path)} is {_kind(st.st_mode)}, not a regular file{extra}")
    _refuse_inputs(path, what, inputs)
    _refuse_full(parent, path)
    return os.path.abspath(path)


def check_folder_target(path, what: str = "", force: bool = False, inputs: Iterable = ()) -> tuple[str, bool]:
    """Refuse a report folder we must not write; returns (absolute path, whether it exists).

    Refused: a missing parent, an existing target that is not a folder (file, device, FIFO,
    symbolic link), an input file, a full disk, and an existing folder that holds anything
    unless ``force`` (then the report's files replace files of the same name in it; other
    files are kept).
    """
    path = os.fspath(path)
    if not path:
        raise BladeReconError(f"{what}: give a folder name")
    path = path.rstrip(os.sep) or os.sep
    parent = _parent(path, what)
    st = _lstat(path)
    exists = st is not None
    if exists and not stat.S_ISDIR(st.st_mode):
        extra = "; name the folder itself (outputs are never written through links)" if stat.S_ISLNK(st.st_mode) \
            else "; give a new folder name"
        raise BladeReconError(f"{_named(what, path)} is {_kind(st.st_mode)}, not a folder{extra}")
    _refuse_inputs(path, what, inputs)
    if exists:
        try:
            full = bool(os.listdir(path))
        except OSError as err:
            raise os_error(err, path) from None
        if full and not force:
            option = " --force" if what.startswith("--") else " force"
            raise BladeReconError(f"{_named(what, path)}: the folder exists and is not empty: choose a new folder, "
                                  f"or add{option} to write into it (files of the report's names are replaced, "
                                  "others kept)")
    _refuse_full(path if exists else parent, path)
    return os.path.abspath(path), exists


def check_input(path, what: str = "") -> None:
    """Refuse an input that exists but is not a regular file (a FIFO would block forever, a
    device such as /dev/zero never ends). A missing file is left to the reader's message."""
    if not path:
        return
    path = os.fspath(path)
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return
    except OSError as err:
        raise os_error(err, path, "read") from None
    if stat.S_ISDIR(st.st_mode):
        raise BladeReconError(f"{_named(what, path)}: is a folder, not a file: give the file")
    if not stat.S_ISREG(st.st_mode):
        raise BladeReconError(f"{_named(what, path)}: is {_kind(st.st_mode)}, not a regular file: "
                              "give a file (inputs are read whole)")


def check_coordinates(points, lines, source, limit: float = COORDINATE_LIMIT) -> None:
    """Refuse coordinates beyond ±``limit`` mm (a corrupt line, or the wrong units), naming the
    first such line; numbers that large overflow the geometry (squares beyond 1e308)."""
    import numpy as np

    P = np.asarray(points, float)
    if P.size == 0:
        return
    bad = np.flatnonzero(~(np.abs(P) <= limit).all(axis=1))
    if not bad.size:
        return
    k = int(bad[0])
    value = P[k][np.argmax(np.abs(P[k]))]
    where = f", line {int(lines[k])}" if lines is not None else ""
    more = f" ({bad.size} such points)" if bad.size > 1 else ""
    raise BladeReconError(f"{shown(source, 200)}{where}: coordinate {value:g} mm is beyond ±{limit:g} mm{more}: "
                          "a corrupt line or the wrong units: correct or delete it")


def check_samples(option: str, step: float, length_mm: float, limit: int = MAX_SAMPLES, what: str = "the cut") -> None:
    """Refuse a ``step`` that would make more than ``limit`` points along ``length_mm`` mm, naming
    the smallest step allowed."""
    n = length_mm / step if step > 0 else math.inf
    if n > limit:
        smallest = length_mm / limit
        raise BladeReconError(f"{option} {step:g}: {what} would make about {n:.3g} points (more than {limit:,}): "
                              f"the smallest step allowed here is {_round_up(smallest)} mm")


def _round_up(x: float) -> str:
    """``x`` rounded up to 2 significant digits (a step that is certainly allowed)."""
    if not (x > 0 and math.isfinite(x)):
        return f"{x:g}"
    e = math.floor(math.log10(x)) - 1
    digits = math.ceil(x / 10 ** e)
    while True:
        v = digits * 10 ** e
        text = f"{v:.2g}" if v < 1e-3 or v >= 1e4 else f"{v:.{max(0, -e)}f}"
        if float(text) >= x:
            return text
        digits += 1


# --------------------------------------------------------------------------- the transaction
@dataclass
class _Staged:
    target: str              # absolute path of the output
    shown_as: str            # the path as the user gave it (for messages)
    option: str
    temp: str                # temporary file or folder beside (or, for an existing folder, inside) it
    folder: bool
    existed: bool


class Outputs:
    """The outputs of one command, written all or nothing.

    ::

        with Outputs(inputs=(args.input, args.nominal)) as outs:   # before any work
            csv = outs.file(args.csv, "--csv")                     # checked; a temp path, or None
            report = outs.folder(args.report, "--report", force=args.force)
            ...                                                    # the work; write to csv, report
            outs.commit()                                          # every output put in place

    :meth:`file` / :meth:`folder` refuse a target as :func:`check_file_target` /
    :func:`check_folder_target` do, and create the temporary beside the target at once (which
    proves the folder writable). Leaving the block without :meth:`commit` (an exception,
    Ctrl-C) removes every temporary; an ``OSError`` leaving it becomes one
    :class:`BladeReconError` line naming the target (not the temporary), and a
    BladeReconError that names a temporary is rewritten to name the target.
    """

    def __init__(self, inputs: Iterable = ()) -> None:
        self.inputs = [os.fspath(p) for p in inputs if p]
        self.staged: list[_Staged] = []
        self.committed = False

    # -- staging
    def _check_new(self, target: str, shown_as: str, option: str) -> None:
        for s in self.staged:
            if s.target == target or _same_file(s.target, target):
                raise BladeReconError(f"{option} {shown(shown_as, 200)} and {s.option} {shown(s.shown_as, 200)} "
                                      "name the same output: give different names")

    def file(self, path, option: str = "") -> str | None:
        """Check the file output ``path`` and return the temporary to write instead (None for no path)."""
        if path is None:
            return None
        path = os.fspath(path)
        target = check_file_target(path, option, self.inputs)
        self._check_new(target, path, option)
        folder, name = os.path.split(target)
        try:
            fd, temp = tempfile.mkstemp(prefix=f".{name[:80]}.", suffix=".part", dir=folder)
            os.close(fd)
        except OSError as err:
            raise os_error(err, path) from None
        self.staged.append(_Staged(target, path, option, temp, False, os.path.lexists(target)))
        return temp

    def folder(self, path, option: str = "", force: bool = False) -> str | None:
        """Check the output folder ``path`` and return the temporary folder to fill instead."""
        if path is None:
            return None
        path = os.fspath(path)
        target, exists = check_folder_target(path, option, force, self.inputs)
        self._check_new(target, path, option)
        parent, name = os.path.split(target)
        try:
            if exists:   # filled inside: proves the folder itself writable; files moved up at commit
                temp = tempfile.mkdtemp(prefix=".bladerecon-", suffix=".part", dir=target)
            else:
                temp = tempfile.mkdtemp(prefix=f".{name[:80]}.", suffix=".part", dir=parent)
        except OSError as err:
            raise os_error(err, path) from None
        self.staged.append(_Staged(target, path, option, temp, True, exists))
        return temp

    def target(self, temp: str) -> str:
        """The output a temporary stands for (as the user named it)."""
        for s in self.staged:
            if s.temp == temp:
                return s.shown_as
        raise KeyError(temp)

    # -- the end
    def commit(self) -> None:
        """Put every output in place (checked first, then renamed), remove the temporaries."""
        umask = os.umask(0)
        os.umask(umask)
        moves: list[tuple[str, str]] = []
        try:
            for s in self.staged:            # check everything before the first rename
                if not s.folder:
                    self._settle_file(s, umask)
                    moves.append((s.temp, s.target))
                elif not s.existed:
                    os.chmod(s.temp, 0o777 & ~umask)
                    if os.path.lexists(s.target):
                        raise BladeReconError(f"{s.option} {shown(s.shown_as, 200)}: appeared while the command "
                                              "ran; nothing was written: run again")
                    moves.append((s.temp, s.target))
                else:
                    for name in sorted(os.listdir(s.temp)):
                        dest = os.path.join(s.target, name)
                        st = _lstat(dest)
                        if st is not None and not stat.S_ISREG(st.st_mode):
                            raise BladeReconError(f"{s.option} {shown(s.shown_as, 200)}: {shown(name)} there is "
                                                  f"{_kind(st.st_mode)}, not a file: move it away; nothing was written")
                        if st is not None:
                            _refuse_inputs(dest, s.option, self.inputs)
                        moves.append((os.path.join(s.temp, name), dest))
            for src, dest in moves:
                os.replace(src, dest)
        except OSError as err:
            raise self.error_for(err) from None
        self.committed = True
        self.discard()

    def _settle_file(self, s: _Staged, umask: int) -> None:
        """Give the new file the old one's mode and owner (root writing into a shared folder),
        or the usual mode; mkstemp made it 0600."""
        st = _lstat(s.target)
        if st is not None and not stat.S_ISREG(st.st_mode):   # appeared while the command ran
            raise BladeReconError(f"{s.option} {shown(s.shown_as, 200)} is now {_kind(st.st_mode)}, not a regular "
                                  "file; nothing was written")
        if st is None:
            os.chmod(s.temp, 0o666 & ~umask)
            return
        os.chmod(s.temp, stat.S_IMODE(st.st_mode))
        if os.geteuid() == 0:
            try:
                os.chown(s.temp, st.st_uid, st.st_gid)
            except OSError:
                pass

    def discard(self) -> None:
        """Remove every temporary that is left (all of them unless committed)."""
        for s in self.staged:
            try:
                if s.folder:
                    shutil.rmtree(s.temp, ignore_errors=True)
                elif os.path.lexists(s.temp):
                    os.unlink(s.temp)
            except OSError:
                pass
        self.staged = []

    def error_for(self, err: OSError) -> BladeReconError:
        """The one line for an OSError met while writing, naming the output it hit."""
        names = [n for n in (err.filename, getattr(err, "filename2", None)) if n is not None]
        for s in self.staged:
            for n in names:
                n = os.fspath(n)
                if n == s.temp or n.startswith(s.temp + os.sep) or os.path.basename(n).startswith(
                        f".{os.path.basename(s.temp)}."):
                    return os_error(err, s.shown_as)
                if os.path.abspath(n) == s.target or n.startswith(s.target + os.sep):
                    return os_error(err, s.shown_as)
        if err.errno in (errno.ENOSPC, errno.EDQUOT):
            for s in self.staged:
                free = _free_bytes(s.temp if s.folder else os.path.dirname(s.temp))
                if free is not None and free < 65536:
                    return os_error(err, s.shown_as)
        if names:
            return os_error(err, names[0])
        if len(self.staged) == 1:
            return os_error(err, self.staged[0].shown_as)
        return os_error(err, ", ".join(s.shown_as for s in self.staged) or None)

    def _rename_temps(self, message: str) -> str:
        for s in self.staged:
            message = message.replace(s.temp, s.shown_as)
            message = message.replace(shown(s.temp, 200), shown(s.shown_as, 200))
        return message

    def __enter__(self) -> "Outputs":
        return self

    def __exit__(self, etype, err, tb) -> bool:
        try:
            # a broken pipe with no file named is stdout's or stderr's (the reader went away), not an output's
            if isinstance(err, OSError) and not (isinstance(err, BrokenPipeError) and err.filename is None):
                raise self.error_for(err) from None
            if isinstance(err, BladeReconError) and self.staged:
                text = str(err)
                renamed = self._rename_temps(text)
                if renamed != text:
                    raise BladeReconError(renamed) from None
        finally:
            if not self.committed:
                self.discard()
        return False


# --------------------------------------------------------------------------- option values
def _number(text: str) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise argparse.ArgumentTypeError(f"{shown(text)!s} is not a number") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"{shown(text)} is not a finite number")
    return value


def finite(low: float | None = None, high: float | None = None, unit: str = ""):
    """argparse ``type``: a finite float in [low, high] (bounds optional)."""
    def parse(text: str) -> float:
        value = _number(text)
        if (low is not None and value < low) or (high is not None and value > high):
            span = (f"between {low:g} and {high:g}" if low is not None and high is not None
                    else f"at least {low:g}" if low is not None else f"at most {high:g}")
            raise argparse.ArgumentTypeError(f"{shown(text)}: give a number {span}" + (f" ({unit})" if unit else ""))
        return value
    parse.__name__ = "number"
    return parse


def positive(high: float | None = None, unit: str = "mm"):
    """argparse ``type``: a finite float > 0 (and <= ``high``)."""
    def parse(text: str) -> float:
        value = _number(text)
        if not value > 0 or (high is not None and value > high):
            span = f" up to {high:g}" if high is not None else ""
            raise argparse.ArgumentTypeError(f"{shown(text)}: give a positive number{span}" + (f" ({unit})" if unit else ""))
        return value
    parse.__name__ = "positive number"
    return parse


def count(low: int = 0, high: int | None = None):
    """argparse ``type``: a whole number in [low, high]."""
    def parse(text: str) -> int:
        try:
            value = int(str(text).strip())
        except ValueError:
            raise argparse.ArgumentTypeError(f"{shown(text)} is not a whole number") from None
        if value < low or (high is not None and value > high):
            span = f"between {low} and {high}" if high is not None else f"at least {low}"
            raise argparse.ArgumentTypeError(f"{shown(text)}: give a whole number {span}")
        return value
    parse.__name__ = "whole number"
    return parse


def fraction(text: str) -> float:
    """argparse ``type``: a share between 0 and 1."""
    return finite(0.0, 1.0)(text)


def one_line_errors(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Make ``parser`` report a bad command line in one ``bladerecon: error:`` line (exit 2),
    not argparse's usage block."""
    def error(message: str):
        sys.stderr.write(f"bladerecon: error: {shown(message, 400)} (see --help)\n")
        sys.exit(2)
    parser.error = error
    return parser
