# SPDX-License-Identifier: LGPL-2.1-or-later
"""The instrument line protocol, sequence tracking and the laser-machine calibration.

Pure Python + numpy: no serial I/O here (that is :mod:`bladerecon.acquire`). Units are
millimetres and degrees at every interface.

Protocol (ours; line-based ASCII, 115200 8N1 by default)
========================================================
Every record is ``$<body>*<CK>\\r\\n``; ``CK`` is two hex digits, the XOR of the bytes
between ``$`` and ``*`` (as in NMEA 0183)::

    $P,<seq>,<X>,<Y>,<Z>,<W_deg>,<D>*CK    laser machine reading; D empty = out of range
    $Q,<seq>,<x>,<y>,<z>*CK                a point already in part coordinates (CMM)
    $S,<seq>,<section_id>*CK               the following points belong to section_id
    $E,<seq>*CK                            end of measurement

``seq`` starts at 1 and increases by 1 over all record kinds. Classification of a line:
no ``$...*HH`` frame -> ``malformed``; frame with a wrong checksum -> ``bad_checksum``;
checksum right but fields unreadable -> ``malformed``. A ``$`` inside a line starts a
new record: the bytes before it (a record cut by a disconnect) count as one ``malformed``.

Calibration (laser machine)
===========================
Machine frame: the X, Y, Z axes. With the sensor origin at the axis readings
``O = (X, Y, Z)``, the laser spot is ::

    s = O + sensor_offset + D * beam_direction          (machine frame)

The rotary table turns the blade by +W (right hand) about the axis through
``rotary_axis_point`` along ``rotary_axis_direction``; the point in the blade frame is
the spot turned back by -W::

    p = a + R(k, -W) (s - a)                            (Rodrigues' formula)

so the blade frame is the machine frame at W = 0.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from functools import reduce
from operator import xor
from pathlib import Path

import numpy as np

from bladerecon.core.errors import BladeReconError

__all__ = [
    "checksum",
    "format_record",
    "parse_line",
    "Record",
    "SequenceTracker",
    "Calibration",
    "load_calibration",
    "Acquisition",
    "COUNTER_KEYS",
]

COUNTER_KEYS = ("records", "points", "sections", "bad_checksum", "malformed", "out_of_range",
                "missing_seq", "duplicates", "reconnects")
_SECTION_FORBIDDEN = set(b',;"')
_HOST_COMMANDS = (b"START", b"STOP")


def checksum(body: bytes) -> int:
    """XOR of the bytes of ``body`` (the text between ``$`` and ``*``), NMEA 0183 style."""
    return reduce(xor, body, 0)


def format_record(body: str) -> bytes:
    """``body`` -> ``$body*CK\\r\\n`` (ASCII)."""
    raw = body.encode("ascii")
    return b"$%s*%02X\r\n" % (raw, checksum(raw))


@dataclass(frozen=True)
class Record:
    """One valid record. ``values``: (X, Y, Z, W, D) for P (D None when out of range),
    (x, y, z) for Q, (section_id,) for S, () for E."""
    kind: str
    seq: int
    values: tuple


def parse_line(line: bytes) -> Record | str:
    """One line without its ``\\r\\n`` -> a :class:`Record`, or the fault name
    ``'malformed'`` / ``'bad_checksum'``. The caller splits off text before an inner ``$``."""
    n = len(line)
    if n < 5 or line[0] != 0x24 or line[n - 3] != 0x2A:  # '$', '*'
        return "malformed"
    try:
        ck = int(line[n - 2:], 16)
    except ValueError:
        return "malformed"
    body = line[1:n - 3]
    if reduce(xor, body, 0) != ck:
        return "bad_checksum"
    fields = body.split(b",")
    kind = fields[0]
    try:
        seq = int(fields[1])
        if seq < 0:
            return "malformed"
        if kind == b"P" and len(fields) == 7:
            d = fields[6]
            values = (float(fields[2]), float(fields[3]), float(fields[4]), float(fields[5]),
                      float(d) if d else None)
            if not all(math.isfinite(v) for v in values if v is not None):
                return "malformed"
            return Record("P", seq, values)
        if kind == b"Q" and len(fields) == 5:
            values = (float(fields[2]), float(fields[3]), float(fields[4]))
            if not all(math.isfinite(v) for v in values):
                return "malformed"
            return Record("Q", seq, values)
        if kind == b"S" and len(fields) == 3:
            label = fields[2].strip()
            if not label or label[0] == 0x23 or _SECTION_FORBIDDEN & set(label) or not label.isascii():
                return "malformed"
            return Record("S", seq, (label.decode("ascii"),))
        if kind == b"E" and len(fields) == 2:
            return Record("E", seq, ())
    except (ValueError, IndexError):
        return "malformed"
    return "malformed"


class SequenceTracker:
    """Which sequence numbers arrived in a valid record.

    ``accept(seq)`` is False for a duplicate (already received: e.g. re-sent after a
    resume), which the caller drops. ``missing`` counts the numbers from ``first_seq`` up to
    the highest received that never arrived in a valid record.
    """

    def __init__(self, first_seq: int = 1) -> None:
        self.first_seq = first_seq
        self.highest = first_seq - 1
        self._gaps: set[int] = set()
        self._early: set[int] = set()  # below first_seq: counted, never missing

    def accept(self, seq: int) -> bool:
        if seq > self.highest:
            self._gaps.update(range(self.highest + 1, seq))
            self.highest = seq
            return True
        if seq in self._gaps:
            self._gaps.discard(seq)
            return True
        if seq < self.first_seq and seq not in self._early:
            self._early.add(seq)
            return True
        return False

    @property
    def missing(self) -> int:
        return len(self._gaps)


@dataclass(frozen=True)
class Calibration:
    """Laser machine calibration (mm; directions are normalised). See the module docstring.

    ``d_range``: the valid laser readings (mm); a reading outside it counts as out of range.
    """
    beam_direction: tuple[float, float, float] = (-1.0, 0.0, 0.0)
    sensor_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotary_axis_point: tuple[float, float, float] = (0.0, 0.0, 0.0)
    rotary_axis_direction: tuple[float, float, float] = (0.0, 0.0, 1.0)
    d_range: tuple[float, float] = (-math.inf, math.inf)

    def __post_init__(self) -> None:
        for name in ("beam_direction", "rotary_axis_direction"):
            v = np.asarray(getattr(self, name), dtype=float)
            norm = float(np.linalg.norm(v))
            if v.shape != (3,) or not np.all(np.isfinite(v)) or norm < 1e-12:
                raise BladeReconError(f"calibration: {name} must be 3 finite numbers, not all zero; got {getattr(self, name)!r}")
            object.__setattr__(self, name, tuple((v / norm).tolist()))
        for name in ("sensor_offset", "rotary_axis_point"):
            v = np.asarray(getattr(self, name), dtype=float)
            if v.shape != (3,) or not np.all(np.isfinite(v)):
                raise BladeReconError(f"calibration: {name} must be 3 finite numbers (mm); got {getattr(self, name)!r}")
            object.__setattr__(self, name, tuple(v.tolist()))
        lo, hi = (float(x) for x in self.d_range)
        if not lo < hi:
            raise BladeReconError(f"calibration: d_range must be [min, max] with min < max (mm); got {self.d_range!r}")
        object.__setattr__(self, "d_range", (lo, hi))

    def to_points(self, X, Y, Z, W, D) -> np.ndarray:
        """Readings (mm, W in degrees; arrays of one length) -> (n, 3) points in the blade frame."""
        origin = np.column_stack([np.asarray(X, float), np.asarray(Y, float), np.asarray(Z, float)])
        spot = origin + np.asarray(self.sensor_offset) + np.asarray(D, float)[:, None] * np.asarray(self.beam_direction)
        return _rotate(spot, np.asarray(self.rotary_axis_point), np.asarray(self.rotary_axis_direction),
                       -np.radians(np.asarray(W, float)))

    def to_readings(self, points, W, D) -> np.ndarray:
        """Inverse of :meth:`to_points` for chosen W (deg) and D (mm): (n, 5) X, Y, Z, W, D."""
        W = np.broadcast_to(np.asarray(W, float), (len(points),))
        D = np.broadcast_to(np.asarray(D, float), (len(points),))
        spot = _rotate(np.asarray(points, float), np.asarray(self.rotary_axis_point),
                       np.asarray(self.rotary_axis_direction), np.radians(W))
        origin = spot - np.asarray(self.sensor_offset) - D[:, None] * np.asarray(self.beam_direction)
        return np.column_stack([origin, W, D])


def _rotate(p: np.ndarray, a: np.ndarray, k: np.ndarray, angle: np.ndarray) -> np.ndarray:
    """Turn points ``p`` (n, 3) by ``angle`` (rad, per point) about the axis (a, unit k): Rodrigues."""
    r = p - a
    c = np.cos(angle)[:, None]
    s = np.sin(angle)[:, None]
    return a + r * c + np.cross(k, r) * s + np.outer(r @ k, k) * (1.0 - c)


_CAL_FIELDS = ("beam_direction", "sensor_offset", "rotary_axis_point", "rotary_axis_direction")


def load_calibration(path: str | Path) -> Calibration:
    """Read a calibration JSON file::

        {"beam_direction": [-1, 0, 0], "sensor_offset": [0, 0, 0],
         "rotary_axis_point": [0, 0, 0], "rotary_axis_direction": [0, 0, 1],
         "d_range": [5, 45]}

    All four vectors are required (mm); ``d_range`` is optional. Problems raise
    :class:`BladeReconError` naming the file and the field.
    """
    path = Path(path)
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise BladeReconError(f"calibration {path}: file not found; give an existing JSON file") from None
    except (OSError, UnicodeDecodeError) as err:
        raise BladeReconError(f"calibration {path}: cannot read ({err}); check the file") from None
    except json.JSONDecodeError as err:
        raise BladeReconError(f"calibration {path} line {err.lineno}: not valid JSON ({err.msg}); fix the file") from None
    if not isinstance(data, dict):
        raise BladeReconError(f"calibration {path}: expected a JSON object with {', '.join(_CAL_FIELDS)}")
    missing = [f for f in _CAL_FIELDS if f not in data]
    if missing:
        raise BladeReconError(f"calibration {path}: missing field(s) {', '.join(missing)}; "
                              f"give each as [x, y, z] in mm (see README, Live acquisition)")
    unknown = sorted(set(data) - set(_CAL_FIELDS) - {"d_range", "comment"})
    if unknown:
        raise BladeReconError(f"calibration {path}: unknown field(s) {', '.join(unknown)}; check the spelling")
    kwargs = {}
    for name in (*_CAL_FIELDS, "d_range"):
        if name not in data:
            continue
        value = data[name]
        size = 2 if name == "d_range" else 3
        if (not isinstance(value, list) or len(value) != size
                or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)):
            raise BladeReconError(f"calibration {path}: {name} must be a list of {size} numbers; got {value!r}")
        kwargs[name] = tuple(float(x) for x in value)
    try:
        return Calibration(**kwargs)
    except BladeReconError as err:
        raise BladeReconError(f"{path}: {err}") from None


@dataclass
class Acquisition:
    """Parses raw bytes into records and points; counts every fault (see :data:`COUNTER_KEYS`).

    Feed it any chunks (:meth:`feed`): an incomplete trailing line is kept until the rest
    arrives, also across reconnects. ``done`` turns True at the ``$E`` record.
    """
    calibration: Calibration = field(default_factory=Calibration)
    max_line: int = 4096
    counts: dict = field(default_factory=lambda: dict.fromkeys(COUNTER_KEYS, 0))
    done: bool = False
    _pending: bytes = b""

    def __post_init__(self) -> None:
        self.tracker = SequenceTracker()
        self.section_names: list[str] = []
        self._section_index: dict[str, int] = {}
        self._current = -1
        self._readings: list[tuple] = []   # (X, Y, Z, W, D, section)
        self._direct: list[tuple] = []     # (x, y, z, section)
        self.bytes = 0

    def feed(self, chunk: bytes) -> None:
        self.bytes += len(chunk)
        data = self._pending + chunk
        lines = data.split(b"\n")
        self._pending = lines.pop()
        if len(self._pending) > self.max_line:  # no line end in sight: garbage (wrong baud?)
            self.counts["malformed"] += 1
            self._pending = b""
        for line in lines:
            self._line(line)

    def finish(self) -> None:
        """End of input: an unterminated last line counts as malformed."""
        if self._pending.strip():
            self.counts["malformed"] += 1
        self._pending = b""

    def _line(self, line: bytes) -> None:
        if line.endswith(b"\r"):
            line = line[:-1]
        if not line or line in _HOST_COMMANDS:  # host commands echoed back (loop://, echoing links)
            return
        cut = line.rfind(b"$")
        if cut != 0:
            self.counts["malformed"] += 1  # garbage, or a record cut short before this one
            if cut < 0:
                return
            line = line[cut:]
        rec = parse_line(line)
        if isinstance(rec, str):
            self.counts[rec] += 1
            return
        if not self.tracker.accept(rec.seq):
            self.counts["duplicates"] += 1
            return
        self.counts["records"] += 1
        kind = rec.kind
        if kind == "P":
            X, Y, Z, W, D = rec.values
            lo, hi = self.calibration.d_range
            if D is None or not lo <= D <= hi:
                self.counts["out_of_range"] += 1
                return
            self._readings.append((X, Y, Z, W, D, self._section()))
            self.counts["points"] += 1
        elif kind == "Q":
            self._direct.append((*rec.values, self._section()))
            self.counts["points"] += 1
        elif kind == "S":
            name = rec.values[0]
            if name not in self._section_index:
                self._section_index[name] = len(self.section_names)
                self.section_names.append(name)
            self._current = self._section_index[name]
            self.counts["sections"] = len(self.section_names)
        else:
            self.done = True

    def _section(self) -> int:
        if self._current < 0:  # points before any $S go to section "0"
            self._current = self._section_index.setdefault("0", len(self.section_names))
            if self._current == len(self.section_names):
                self.section_names.append("0")
            self.counts["sections"] = len(self.section_names)
        return self._current

    def summary(self) -> dict:
        out = dict(self.counts)
        out["missing_seq"] = self.tracker.missing
        return out

    def points(self) -> tuple[np.ndarray, np.ndarray]:
        """All points (n, 3) in the blade frame (mm) and their section index, in arrival order
        (laser points first, then direct points when a stream mixes both)."""
        parts, secs = [], []
        readings, direct = list(self._readings), list(self._direct)  # a snapshot while a reader thread appends
        if readings:
            r = np.asarray(readings, dtype=float)
            parts.append(self.calibration.to_points(r[:, 0], r[:, 1], r[:, 2], r[:, 3], r[:, 4]))
            secs.append(r[:, 5].astype(int))
        if direct:
            q = np.asarray(direct, dtype=float)
            parts.append(q[:, :3])
            secs.append(q[:, 3].astype(int))
        if not parts:
            return np.zeros((0, 3)), np.zeros(0, dtype=int)
        return np.concatenate(parts), np.concatenate(secs)

