# SPDX-License-Identifier: LGPL-2.1-or-later
"""The ``acquire`` and ``simulate-instrument`` subcommands of ``python3 -m bladerecon``.

Outputs (``-o``, ``--clean``, ``--expected``) are all or nothing
(:class:`bladerecon.core.io.outputs.Outputs`); the raw journal and ``--sent`` are written as
the bytes arrive and kept on failure (that is what they are for), but their targets are
checked before the port is opened.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

from bladerecon.acquire.reader import default_journal
from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import (Outputs, _kind, check_file_target, check_input, count, escaped, finite,
                                        fraction, one_line_errors, os_error, positive, shown)

__all__ = ["add_parser", "run_acquire", "run_simulate"]


def add_parser(sub) -> None:
    a = sub.add_parser("acquire", help="read a measuring instrument over a serial line -> section points CSV",
                       description="Capture points from an instrument speaking the BladeRecon line protocol "
                                   "(README, Live acquisition). Every byte is journalled before it is parsed.")
    src = a.add_mutually_exclusive_group(required=True)
    src.add_argument("--port", help="anything pyserial opens: /dev/ttyUSB0, a pty, loop://, socket://host:port")
    src.add_argument("--replay", metavar="JOURNAL", help="parse a raw journal of an earlier capture instead")
    a.add_argument("--baud", type=count(1, 100_000_000), default=115200, help="baud rate (default 115200, 8N1)")
    a.add_argument("--calibration", metavar="FILE", help="laser machine calibration JSON (default: beam -X, table axis Z)")
    a.add_argument("-o", "--output", required=True,
                   help="points CSV to write (section,x,y,z; mm); put in place only when the capture succeeded")
    a.add_argument("--journal", metavar="FILE",
                   help="raw journal (default OUTPUT-stem.<UTC time>.journal); never overwritten")
    a.add_argument("--timeout", type=positive(3600.0, "s"), default=2.0,
                   help="s of silence before START is sent again (default 2)")
    a.add_argument("--give-up", type=positive(7 * 86400.0, "s"), default=30.0,
                   help="s without data before the capture fails (default 30)")
    a.add_argument("--json", action="store_true", help="print the JSON summary on stdout")
    a.add_argument("--quiet", action="store_true", help="no progress on stderr")
    one_line_errors(a)
    a.set_defaults(run=run_acquire)

    s = sub.add_parser("simulate-instrument", help="play a measurement of the sample blade on a serial line",
                       description="A controller speaking the BladeRecon protocol, with seeded faults.")
    s.add_argument("--blade", choices=("sample",), default="sample", help="the blade to measure (sample)")
    where = s.add_mutually_exclusive_group()
    where.add_argument("--port", help="write to this existing port (disconnects become pauses)")
    where.add_argument("--link", help="create a pty and publish it under this path (a symlink; default: print the pty)")
    s.add_argument("--baud", type=count(1, 100_000_000), default=115200)
    s.add_argument("--calibration", metavar="FILE", help="calibration JSON used to make the readings")
    s.add_argument("--sections", type=count(2, 1000), default=6)
    s.add_argument("--points", type=count(20, 1_000_000), default=2000, help="points per section")
    s.add_argument("--noise", type=finite(0.0, 1.0, "mm"), default=0.002, help="sigma of the point noise, mm (default 0.002)")
    s.add_argument("--seed", type=count(0, 2 ** 32 - 1), default=0)
    s.add_argument("--bad-checksum", type=fraction, default=0.0, help="fraction of point records with a wrong CK")
    s.add_argument("--garbled", type=fraction, default=0.0, help="fraction of point records garbled")
    s.add_argument("--out-of-range", type=fraction, default=0.0, help="fraction of extra readings with an empty D")
    s.add_argument("--disconnects", type=count(0, 10_000), default=0, help="number of link drops (a record cut in half)")
    s.add_argument("--drop-block", type=count(0, 10_000_000), default=0, help="records never sent in one block (a seq gap)")
    s.add_argument("--direct", action="store_true", help="send $Q part-coordinate records (a CMM)")
    s.add_argument("--rate", type=finite(0.0, None, "records/s"), default=None,
                   help="records/s (default: what --baud carries, ~10 bits per byte; 0 = as fast as possible)")
    s.add_argument("--sent", metavar="FILE", help="also write every byte sent to FILE")
    s.add_argument("--clean", metavar="FILE", help="write the points a perfect capture keeps (CSV)")
    s.add_argument("--expected", metavar="FILE", help="write the counters a perfect reader reports (JSON)")
    one_line_errors(s)
    s.set_defaults(run=run_simulate)


def _say(quiet: bool):
    def say(msg: str) -> None:
        if not quiet:
            print(f"bladerecon: {escaped(msg)}", file=sys.stderr, flush=True)
    return say


def run_acquire(args: argparse.Namespace) -> dict:
    """Run the capture; the points CSV is put in place only when the capture succeeded."""
    say = _say(args.quiet)
    if args.replay and args.journal:    # it would be neither written nor read
        raise BladeReconError("--journal names the journal of a live capture (--port); with --replay the journal is "
                              "the file replayed: leave out --journal")
    check_input(args.replay, "--replay")
    check_input(args.calibration, "--calibration")
    with Outputs(inputs=(args.replay, args.calibration)) as outs:
        temp = outs.file(args.output, "--output")
        summary, n_points, n_sections = _capture(args, say, temp)
        outs.commit()
    say(f"wrote {n_points} points in {n_sections} sections to {args.output}")
    return summary


def _capture(args, say, temp: str):
    from bladerecon.core.io.instrument import Calibration, load_calibration
    from bladerecon.core.io.readers import write_points_csv
    from bladerecon.acquire.reader import InstrumentReader, replay

    cal = load_calibration(args.calibration) if args.calibration else Calibration()
    t0 = time.monotonic()
    if args.replay:
        acq = replay(args.replay, cal)
        journal = args.replay
        seconds = time.monotonic() - t0
    else:
        journal = args.journal or default_journal(args.output)
        if os.path.abspath(journal) == os.path.abspath(args.output):
            raise BladeReconError(f"--journal {journal} is the output file; choose another name")
        if os.path.lexists(journal):
            raise BladeReconError(f"journal {journal}: already exists; choose another name "
                                  "(journals are never overwritten) or replay it with --replay")
        check_file_target(journal, "--journal", inputs=(args.calibration,))

        def progress(c: dict) -> None:
            say(f"{c['points']} points, {c['sections']} sections, errors: {c['bad_checksum']} checksum, "
                f"{c['malformed']} malformed, {c['missing_seq']} missing, {c['reconnects']} reconnects")

        say(f"reading {args.port} at {args.baud} baud; journal {journal}")
        reader = InstrumentReader(args.port, args.baud, cal, journal, args.timeout, args.give_up,
                                  None if args.quiet else progress)
        try:
            acq = reader.run()
        except OSError as err:      # the journal's disk: the journal is kept, as far as it got
            raise os_error(err, journal) from None
        seconds = reader.seconds
    summary = acq.summary()
    summary["seconds"] = round(seconds, 3)
    if not acq.done:
        say(f"no end record ($E) in {journal}: the capture is incomplete")
    points, section = acq.points()
    if len(points) == 0:
        raise BladeReconError(f"{args.port or args.replay}: no valid point arrived; nothing written "
                              f"(journal {journal} kept)")
    write_points_csv(temp, points, section, acq.section_names)
    summary["output"] = args.output
    summary["journal"] = journal
    summary["complete"] = bool(acq.done)
    return summary, len(points), len(acq.section_names)


def run_simulate(args: argparse.Namespace) -> dict:
    check_input(args.calibration, "--calibration")
    if args.link:
        _check_link(args.link)
    if args.sent:
        check_file_target(args.sent, "--sent", inputs=(args.calibration,))
    with Outputs(inputs=(args.calibration,)) as outs:
        clean = outs.file(args.clean, "--clean")
        expected = outs.file(args.expected, "--expected")
        summary = _simulate(args, clean, expected, outs)
    return summary


def _check_link(path: str) -> None:
    """The pty is published at ``--link`` by renaming a symbolic link over it, and the name is
    removed at the end: only a new name, or a link to a pty an earlier run left, may be used
    (a file of that name would be replaced, then deleted)."""
    if os.path.islink(path):
        try:
            points_to = os.readlink(path)
        except OSError as err:
            raise os_error(err, path, "read") from None
        if points_to.startswith("/dev/pts/"):
            return
        raise BladeReconError(f"--link {shown(path, 200)} is a symbolic link to {shown(points_to, 200)}, not to a "
                              "pseudo-terminal an earlier run left: choose a new name")
    if os.path.lexists(path):
        raise BladeReconError(f"--link {shown(path, 200)} exists ({_kind(os.lstat(path).st_mode)}): choose a new name "
                              "(the pty is published there as a symbolic link and the name removed at the end)")
    check_file_target(path, "--link")


def _simulate(args, clean, expected, outs: Outputs) -> dict:
    from bladerecon.core.io.instrument import Calibration, load_calibration
    from bladerecon.core.io.readers import write_points_csv
    from bladerecon.acquire.simulator import Faults, PortLink, PtyLink, play, sample_plan

    say = _say(False)
    cal = load_calibration(args.calibration) if args.calibration else Calibration()
    faults = Faults(args.bad_checksum, args.garbled, args.out_of_range, args.disconnects, args.drop_block, args.seed)
    plan = sample_plan(args.sections, args.points, args.noise, args.seed, cal, faults, args.direct)
    if clean:
        write_points_csv(clean, plan.good_points, plan.good_sections, plan.names)
    if expected:
        with open(expected, "w") as f:
            json.dump(plan.expected, f)
    outs.commit()     # the reference files are complete: a reader may start comparing
    if args.rate is None:
        mean_len = sum(map(len, plan.lines)) / len(plan.lines)
        rate = args.baud / 10.0 / mean_len
    else:
        rate = args.rate
    if args.port:
        try:
            link = PortLink(args.port, args.baud)
        except Exception as err:
            raise BladeReconError(f"port {args.port}: cannot open ({err}); check the name") from None
    else:
        link = PtyLink(args.link)
    say(f"{len(plan.lines)} record lines, {rate:.0f} records/s" if rate else f"{len(plan.lines)} record lines")
    t0 = time.monotonic()
    played = False
    try:
        sent = play(plan, link, args.sent, rate, say=say)
        played = True
    except TimeoutError as err:
        raise BladeReconError(f"simulate-instrument: {err}; start 'acquire' on the other end") from None
    finally:
        link.close(drain=played)  # after a failure nobody is reading: do not wait for it again
    return {"lines": len(plan.lines), "bytes": sent, "seconds": round(time.monotonic() - t0, 3), **plan.expected}
