# SPDX-License-Identifier: LGPL-2.1-or-later
"""A simulated instrument controller that plays a measurement of the sample blade.

:func:`plan_measurement` builds the byte lines of a measurement with faults injected
deterministically from a seed (and what a perfect reader must report);
:class:`PtyLink` is a pseudo-terminal whose slave name is published through a stable
symlink (as ``socat ... link=``) so a disconnect can close it and a new one appear under
the same path; :func:`play` waits for ``START`` and streams, honouring ``STOP``.
Every byte written is also appended to ``sent`` so tests can compare it with the journal.
Nothing here waits forever: no ``START`` within ``start_timeout``, or a host that takes no
byte for ``io_timeout`` s, ends :func:`play` with :class:`TimeoutError` saying which.
"""
from __future__ import annotations

import fcntl
import os
import select
import struct
import termios
import time
import tty
from dataclasses import dataclass, field

import numpy as np

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.instrument import Calibration, format_record

__all__ = ["Faults", "MeasurementPlan", "plan_measurement", "PtyLink", "PortLink", "play"]


@dataclass(frozen=True)
class Faults:
    """Fractions are of the point records; S and E records are never faulted."""
    bad_checksum: float = 0.0
    garbled: float = 0.0
    out_of_range: float = 0.0   # extra P records with an empty D
    disconnects: int = 0        # a record cut in half, then the link drops
    dropped_block: int = 0      # consecutive records never sent (a seq gap)
    seed: int = 0


@dataclass
class MeasurementPlan:
    lines: list[bytes]
    disconnect_after: set[int]               # line indices after which the link drops
    good_points: np.ndarray                  # points a perfect reader keeps, in order (mm)
    good_sections: np.ndarray
    names: list[str]
    expected: dict = field(default_factory=dict)


def plan_measurement(sections: list[np.ndarray], calibration: Calibration, faults: Faults = Faults(),
                     direct: bool = False, decimals: int = 4) -> MeasurementPlan:
    """Records for ``sections`` (lists of (n, 3) blade-frame points, mm), faults injected.

    Laser records (``$P``) use the calibration inverse: W turns the point to face the
    sensor (W = -atan2 of the point about the rotary axis), D runs 20-30 mm. ``direct``
    gives ``$Q`` part-coordinate records. Values are rounded to ``decimals``; the good
    points are computed from the rounded values, exactly as a reader computes them.
    """
    rng = np.random.default_rng(faults.seed)
    names = [f"S{k + 1}" for k in range(len(sections))]
    rows: list[tuple[str, object, int]] = []   # (kind, values, section)
    for k, pts in enumerate(sections):
        rows.append(("S", names[k], k))
        n = len(pts)
        if direct:
            for p in np.round(pts, decimals):
                rows.append(("Q", tuple(p), k))
        else:
            rel = pts - np.asarray(calibration.rotary_axis_point)
            W = np.round(-np.degrees(np.arctan2(rel[:, 1], rel[:, 0])), decimals)
            D = np.round(20.0 + 10.0 * (np.arange(n) % 101) / 100.0, decimals)
            readings = np.round(calibration.to_readings(pts, W, D), decimals)
            oor = rng.random(n) < faults.out_of_range
            for i in range(n):
                if oor[i]:
                    rows.append(("P", (*readings[i, :4], None), k))
                rows.append(("P", tuple(readings[i]), k))
    rows.append(("E", None, -1))

    point_rows = [i for i, r in enumerate(rows) if r[0] in "PQ" and (r[0] == "Q" or r[1][4] is not None)]
    fault = {}  # row -> kind
    if faults.dropped_block:
        start = int(rng.integers(len(point_rows) // 3, 2 * len(point_rows) // 3))
        for i in point_rows[start:start + faults.dropped_block]:
            fault[i] = "dropped"
    free = [i for i in point_rows if i not in fault]
    pick = rng.permutation(free)
    nb = int(round(faults.bad_checksum * len(point_rows)))
    ng = int(round(faults.garbled * len(point_rows)))
    for i in pick[:nb]:
        fault[int(i)] = "bad_checksum"
    for i in pick[nb:nb + ng]:
        fault[int(i)] = "garbled"
    for i in pick[nb + ng:nb + ng + faults.disconnects]:
        fault[int(i)] = "disconnect"

    lines, disconnect_after, good, good_sec = [], set(), [], []
    fmt = f"{{:.{decimals}f}}"
    for seq, (kind, values, k) in enumerate(rows, start=1):
        if kind == "S":
            body = f"S,{seq},{values}"
        elif kind == "E":
            body = f"E,{seq}"
        else:
            body = ",".join([kind, str(seq)] + ["" if v is None else fmt.format(v) for v in values])
        what = fault.get(seq - 1)
        if what == "dropped":
            continue
        line = format_record(body)
        if what == "bad_checksum":
            line = line[:-4] + b"%02X\r\n" % (int(line[-4:-2], 16) ^ 0x5A)
        elif what == "garbled":
            cut = int(rng.integers(3, len(line) - 4))
            line = line[:cut] + bytes(rng.choice(list(b"#~%&!?^"), 3).tolist()) + b"\r\n"
        elif what == "disconnect":
            line = line[:len(line) // 2]
            disconnect_after.add(len(lines))
        lines.append(line)
        if what is None and kind in "PQ" and (kind == "Q" or values[4] is not None):
            good.append(values[:3] if kind == "Q" else values)
            good_sec.append(k)
    counts = {f: sum(1 for v in fault.values() if v == f) for f in ("bad_checksum", "garbled", "disconnect", "dropped")}
    n_oor = sum(1 for r in rows if r[0] == "P" and r[1][4] is None)
    if direct:
        pts = np.asarray(good, float).reshape(-1, 3)
    else:
        g = np.asarray(good, float).reshape(-1, 5)
        pts = calibration.to_points(g[:, 0], g[:, 1], g[:, 2], g[:, 3], g[:, 4])
    expected = {"records": len(rows) - len(fault), "points": len(good), "sections": len(sections),
                "bad_checksum": counts["bad_checksum"], "malformed": counts["garbled"] + counts["disconnect"],
                "out_of_range": n_oor, "missing_seq": len(fault), "duplicates": 0,
                "reconnects": counts["disconnect"]}
    return MeasurementPlan(lines, disconnect_after, pts, np.asarray(good_sec, int), names, expected)


class PtyLink:
    """A pseudo-terminal; its slave name is published at ``link`` (a symlink) when given.

    :meth:`write` and :meth:`drain` give up (``TimeoutError``) when the host takes no byte for
    ``io_timeout`` s: a reader that died must not leave the controller blocked forever."""

    def __init__(self, link: str | None = None, io_timeout: float = 10.0) -> None:
        self.link = link
        self.io_timeout = io_timeout
        self.master = self.slave = -1
        self.name = ""

    def open(self) -> str:
        try:
            self.master, self.slave = os.openpty()
            tty.setraw(self.slave)  # no echo, no CR/LF translation before the reader configures it
            self.name = os.ttyname(self.slave)
        except (OSError, termios.error) as err:
            self._close_fds()
            raise BladeReconError(f"cannot create a pseudo-terminal ({err}); check that /dev/pts is mounted, "
                                  "or give an existing port with --port") from None
        os.set_blocking(self.master, False)  # write() waits with a deadline, never in the kernel
        if self.link:
            tmp = f"{self.link}.{os.getpid()}.tmp"
            try:
                os.symlink(self.name, tmp)
                os.replace(tmp, self.link)  # appears atomically under the stable name
            except OSError as err:
                self._close_fds()
                raise BladeReconError(f"--link {self.link}: cannot create ({err.strerror}); check the folder") from None
        return self.link or self.name

    def read_command(self, timeout: float) -> bytes:
        r, _, _ = select.select([self.master], [], [], timeout)
        if not r:
            return b""
        try:
            return os.read(self.master, 1024)
        except OSError:
            return b""

    def write(self, data: bytes) -> None:
        """Write all of ``data``; ``TimeoutError`` when the host takes none of it for ``io_timeout`` s."""
        view = memoryview(data)
        end = time.monotonic() + self.io_timeout
        while view:
            try:
                n = os.write(self.master, view)
            except BlockingIOError:
                n = 0
            if n:
                view = view[n:]
                end = time.monotonic() + self.io_timeout
                continue
            left = end - time.monotonic()
            if left <= 0:
                raise TimeoutError(f"the host read nothing for {self.io_timeout:g} s ({len(view)} bytes unsent)")
            select.select([], [self.master], [], min(left, 0.1))

    def _unread(self) -> int:
        return struct.unpack("I", fcntl.ioctl(self.slave, termios.FIONREAD, struct.pack("I", 0)))[0]

    def drain(self, timeout: float | None = None, quiet: float = 0.1) -> bool:
        """Wait until the reader has taken every byte: the slave's input queue stays empty
        for ``quiet`` s (bytes may still sit in the kernel's flip buffer for a moment, and
        closing the master discards them). False when bytes are still unread after
        ``timeout`` s (default ``io_timeout``)."""
        end = time.monotonic() + (self.io_timeout if timeout is None else timeout)
        empty_since = None
        while time.monotonic() < end:
            now = time.monotonic()
            if self._unread() == 0:
                empty_since = empty_since or now
                if now - empty_since >= quiet:
                    return True
            else:
                empty_since = None
            time.sleep(0.005)
        return False

    def close(self, drain: bool = True) -> None:
        if drain and self.master >= 0:
            self.drain()
        if self.link and os.path.islink(self.link):
            os.unlink(self.link)  # the name vanishes first, then the device
        self._close_fds()

    def _close_fds(self) -> None:
        for fd in (self.master, self.slave):
            if fd >= 0:
                os.close(fd)
        self.master = self.slave = -1


class PortLink:
    """An existing port opened with pyserial (``--port``); a disconnect is a pause."""

    def __init__(self, port: str, baud: int, io_timeout: float = 10.0) -> None:
        import serial
        self.port = serial.serial_for_url(port, baudrate=baud, timeout=0, write_timeout=io_timeout)
        self.name = port
        self.io_timeout = io_timeout

    def open(self) -> str:
        return self.name

    def read_command(self, timeout: float) -> bytes:
        end = time.monotonic() + timeout
        while True:
            data = self.port.read(self.port.in_waiting or 1)
            if data or time.monotonic() >= end:
                return data
            time.sleep(0.01)

    def write(self, data: bytes) -> None:
        import serial
        try:
            self.port.write(data)
            self.port.flush()
        except serial.SerialTimeoutException:
            raise TimeoutError(f"the port took no data for {self.io_timeout:g} s (flow control held?)") from None

    def drain(self, timeout: float | None = None) -> bool:
        return True

    def close(self, drain: bool = True) -> None:
        pass


def _wait_for(link, word: bytes, timeout: float) -> bool:
    buf = b""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        buf = (buf + link.read_command(0.05))[-64:]
        if word in buf:
            return True
    return False


def _drain(link) -> None:
    if not link.drain():
        raise TimeoutError(f"the host stopped reading (bytes still unread after {link.io_timeout:g} s)")


def play(plan: MeasurementPlan, link, sent_path: str | None = None, rate: float = 0.0,
         pause: float = 0.3, start_timeout: float = 60.0, say=lambda msg: None) -> int:
    """Stream ``plan`` on ``link`` after ``START``; ``rate`` records/s (0 = as fast as the link
    takes them). At a disconnect the link is closed for ``pause`` s and reopened (a pty
    reappears under the same link name); the stream resumes after the next ``START``.
    Returns the number of bytes sent. ``TimeoutError`` when no ``START`` comes within
    ``start_timeout`` s (at the start, after a disconnect or after ``STOP``) or the host
    stops reading (the link's ``io_timeout``)."""
    sent = open(sent_path, "wb") if sent_path else None
    total = 0
    batch = max(1, int(rate * 0.02)) if rate else 200
    try:
        say(f"waiting for START on {link.open()}")
        if not _wait_for(link, b"START", start_timeout):
            raise TimeoutError(f"no START from the host in {start_timeout:g} s")
        t0 = time.monotonic()
        i = 0
        while i < len(plan.lines):
            j = i
            chunk = []
            while j < len(plan.lines) and j - i < batch:
                chunk.append(plan.lines[j])
                j += 1
                if j - 1 in plan.disconnect_after:
                    break
            data = b"".join(chunk)
            link.write(data)
            if sent:
                sent.write(data)
                sent.flush()
            total += len(data)
            if j - 1 in plan.disconnect_after:
                say(f"disconnect after record line {j}")
                _drain(link)
                link.close()
                time.sleep(pause)
                say(f"back on {link.open()}, waiting for START")
                if not _wait_for(link, b"START", start_timeout):
                    raise TimeoutError(f"no START from the host in {start_timeout:g} s after the disconnect")
            elif b"STOP" in link.read_command(0):
                if not _wait_for(link, b"START", start_timeout):
                    raise TimeoutError(f"no START from the host in {start_timeout:g} s after its STOP")
            i = j
            if rate:
                ahead = t0 + i / rate - time.monotonic()
                if ahead > 0:
                    time.sleep(ahead)
        _drain(link)
    finally:
        if sent:
            sent.close()
    return total


def sample_plan(n_sections: int = 6, n_points: int = 2000, noise: float = 0.002, seed: int = 0,
                calibration: Calibration | None = None, faults: Faults = Faults(),
                direct: bool = False) -> MeasurementPlan:
    """A measurement of :class:`~bladerecon.samples.blade.SampleBlade` (mm)."""
    from bladerecon.samples.blade import SampleBlade, sample_sections
    sections = sample_sections(SampleBlade(), n_sections, n_points, "uniform", noise, seed)
    return plan_measurement(sections, calibration or Calibration(), faults, direct)
