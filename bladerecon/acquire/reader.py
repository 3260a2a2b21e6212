# SPDX-License-Identifier: LGPL-2.1-or-later
"""Read an instrument over a serial line without losing anything that arrived.

Every chunk of bytes is appended to the raw journal, flushed and ``fsync``-ed *before* it
is parsed, so a crash or a power cut loses nothing that arrived and any capture can be
replayed (:func:`replay`). The journal is created (never overwritten) only once the port
is open, so a capture that cannot start leaves no file behind. Reads take only what is already waiting (``in_waiting``), or
one byte when nothing is, so a port that drops mid-read cannot discard a partly filled
buffer; an incomplete trailing line is kept across reads and reconnects.

When the port fails (it vanishes, or pyserial raises), the reader closes it and reopens it
with back-off (0.05 s doubling to 1 s), then sends ``START`` again; when nothing arrives
for ``timeout`` s it sends ``START`` again on the open port (reopening would flush input
pyserial may already hold). Both count as ``reconnects``. It stops at the ``$E`` record.
"""
from __future__ import annotations

import os
import select
import time
from pathlib import Path
from typing import Callable

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.instrument import Acquisition, Calibration

__all__ = ["InstrumentReader", "replay", "open_port", "default_journal"]

_POLL = 0.02  # s to sleep after a small chunk: keeps the CPU load low at 115200 baud
_BIG_CHUNK = 512  # 115200 baud brings ~230 bytes per _POLL: sleep only then


def default_journal(output: str) -> str:
    """The journal beside ``output`` when none is named: ``OUTPUT-stem.<UTC time>.journal``."""
    stem = os.path.splitext(output)[0]
    return f"{stem}.{time.strftime('%Y%m%dT%H%M%S', time.gmtime())}.journal"


def _serial():
    """pyserial, or a one-line error saying how to get it."""
    try:
        import serial
    except ImportError:
        raise BladeReconError("pyserial is not installed; install it (pip install pyserial, "
                              "or apt install python3-serial) and retry") from None
    return serial


def open_port(port: str, baud: int):
    """Open ``port`` (a device, or any pyserial URL: ``loop://``, ``socket://host:port``)."""
    serial = _serial()

    kwargs = {"baudrate": baud, "timeout": _POLL, "write_timeout": 1.0}
    if "://" not in port:
        kwargs["exclusive"] = True
    try:
        return serial.serial_for_url(port, **kwargs)
    except serial.SerialException as err:
        text = str(err)
        if "lock" in text.lower() or "busy" in text.lower() or "Errno 16" in text:
            raise BladeReconError(f"port {port}: busy (another program holds it); close that program and retry") from None
        if "No such file" in text or "Errno 2" in text:
            raise BladeReconError(f"port {port}: does not exist; check the name (ls /dev/tty*) and that the instrument is plugged in") from None
        raise BladeReconError(f"port {port}: cannot open ({text}); check the name and permissions") from None
    except (ValueError, OSError) as err:
        raise BladeReconError(f"port {port}: cannot open ({err}); check the name, the URL and --baud") from None


def _read_available(port) -> bytes:
    """What has arrived, in one piece that no later failure can discard.

    pyserial's ``read(n)`` collects into a buffer over several system calls and raises
    without returning it when the link fails, so ask only for what ``in_waiting`` says is
    there (one call), or one byte. ``socket://`` reports readiness, not a byte count, in
    ``in_waiting``: there one ``recv`` on its socket is the single call.
    """
    import serial

    sock = getattr(port, "_socket", None)
    if sock is not None:
        ready, _, _ = select.select([sock], [], [], _POLL)
        if not ready:
            return b""
        data = sock.recv(1 << 16)
        if not data:
            raise serial.SerialException("socket closed by the instrument")
        return data
    waiting = port.in_waiting
    return port.read(waiting if waiting else 1)


class _Journal:
    """Append-only raw journal: write, flush and fsync each chunk.

    An existing file is refused at once; the file itself is created by :meth:`create`, once
    there is something to journal (the port is open)."""

    def __init__(self, path: str | os.PathLike | None, fsync: bool = True) -> None:
        self.path = None if path is None else Path(path)
        self.fsync = fsync
        self.fd = None
        if self.path is not None and self.path.exists():
            raise self._exists()

    def _exists(self) -> BladeReconError:
        return BladeReconError(f"journal {self.path}: already exists; choose another name "
                               "(journals are never overwritten) or replay it with --replay")

    def create(self) -> None:
        if self.path is None or self.fd is not None:
            return
        try:
            self.fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND, 0o644)
        except FileExistsError:
            raise self._exists() from None
        except OSError as err:
            raise BladeReconError(f"journal {self.path}: cannot create ({err.strerror}); check the folder") from None

    def append(self, data: bytes) -> None:
        if self.fd is None:
            return
        view = memoryview(data)
        while view:
            view = view[os.write(self.fd, view):]
        if self.fsync:
            os.fsync(self.fd)

    def close(self) -> None:
        if self.fd is not None:
            os.close(self.fd)
            self.fd = None


class InstrumentReader:
    """Capture one measurement from ``port``; :meth:`run` returns the :class:`Acquisition`.

    ``port``: a name/URL for :func:`open_port`, or a callable returning an open pyserial
    port (tests). ``timeout``: s of silence before ``START`` is sent again. ``give_up``: s
    without a valid record (port gone, silent or babbling) before the capture fails. ``progress`` is
    called about twice a second with the current counters.
    """

    def __init__(self, port: str | Callable, baud: int = 115200, calibration: Calibration | None = None,
                 journal: str | os.PathLike | None = None, timeout: float = 2.0, give_up: float = 30.0,
                 progress: Callable[[dict], None] | None = None, fsync: bool = True,
                 garbage_bytes: int = 4096) -> None:
        self.port_name = port if isinstance(port, str) else getattr(port, "__name__", "port")
        self._open = (lambda: open_port(port, baud)) if isinstance(port, str) else port
        self.baud = baud
        self.acq = Acquisition(calibration or Calibration())
        self.journal = _Journal(journal, fsync)
        self.timeout = timeout
        self.give_up = give_up
        self.progress = progress
        self.garbage_bytes = garbage_bytes
        self.seconds = 0.0

    def run(self) -> Acquisition:
        serial = _serial()

        t0 = time.monotonic()
        try:
            port = self._open()  # the first open fails at once: a wrong name is not a dropout
            try:
                self.journal.create()  # only now: a capture that cannot start leaves no file
            except BladeReconError:
                port.close()
                raise
            self._start(port)
            last_data = last_report = last_start = last_progress = time.monotonic()
            records = 0
            while not self.acq.done:
                try:
                    data = _read_available(port)
                except (serial.SerialException, OSError):
                    port = self._reconnect(port, last_progress)
                    last_data = last_start = time.monotonic()
                    continue
                now = time.monotonic()
                if data:
                    self.journal.append(data)  # journal first: nothing that arrived is lost
                    self.acq.feed(data)
                    last_data = now
                    if self.acq.counts["records"] != records:
                        records, last_progress = self.acq.counts["records"], now
                    self._check_garbage()
                    if len(data) < _BIG_CHUNK:
                        time.sleep(_POLL)
                if now - last_progress > self.give_up:
                    raise BladeReconError(f"port {self.port_name}: no valid record for {self.give_up:g} s; check the "
                                          f"instrument and the cable (journal {self.journal.path} kept)")
                if not data and now - last_data > self.timeout and now - last_start > self.timeout:
                    self._start(port)
                    last_start = now
                    self.acq.counts["reconnects"] += 1
                if self.progress and now - last_report > 0.5:
                    last_report = now
                    self.progress(self.acq.summary())
            self.acq.finish()
            try:
                port.close()
            except Exception:
                pass
        finally:
            self.journal.close()
            self.seconds = time.monotonic() - t0
        return self.acq

    def _start(self, port) -> None:
        import serial
        try:
            port.write(b"START\r\n")
            port.flush()
        except (serial.SerialException, OSError):
            pass  # the read that follows sees the broken port and reconnects

    def _reconnect(self, port, last_progress: float):
        try:
            port.close()
        except Exception:
            pass
        delay = 0.05
        while True:
            if time.monotonic() - last_progress > self.give_up:
                raise BladeReconError(f"port {self.port_name}: lost and not back within {self.give_up:g} s; "
                                      f"check the cable, then replay the journal {self.journal.path}")
            time.sleep(delay)
            delay = min(2 * delay, 1.0)
            try:
                port = self._open()
            except BladeReconError:
                continue
            self.acq.counts["reconnects"] += 1
            self._start(port)
            return port

    def _check_garbage(self) -> None:
        if self.acq.counts["records"] == 0 and self.acq.bytes > self.garbage_bytes:
            raise BladeReconError(
                f"port {self.port_name}: {self.acq.bytes} bytes arrived but no valid record; wrong baud rate "
                f"(--baud {self.baud})? journal {self.journal.path} kept")

    def summary(self) -> dict:
        out = self.acq.summary()
        out["seconds"] = round(self.seconds, 3)
        return out


def replay(journal: str | os.PathLike, calibration: Calibration | None = None,
           chunk: int = 1 << 16) -> Acquisition:
    """Parse a raw journal file exactly as the live reader parsed it."""
    acq = Acquisition(calibration or Calibration())
    try:
        with open(journal, "rb") as f:
            while block := f.read(chunk):
                acq.feed(block)
    except OSError as err:
        raise BladeReconError(f"journal {journal}: cannot read ({err.strerror}); check the path") from None
    acq.finish()
    return acq
