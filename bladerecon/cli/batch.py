# SPDX-License-Identifier: LGPL-2.1-or-later
"""``python3 -m bladerecon batch MANIFEST --nominal NOMINAL -o OUTDIR``: a production lot.

Issue 21. Every blade of the lot goes through the ``deviation`` command's own path
(:func:`bladerecon.cli.deviation._run`) into ``OUTDIR/<blade>/`` (``summary.json`` = the
blade's ``deviation --json`` object, ``deviations.csv``, with ``--report`` its report),
written all or nothing per blade; then ``OUTDIR/lot/`` gets the lot statistics
(:mod:`bladerecon.core.lot.stats`): ``lot.json`` (results only, so two runs of the same lot
give the same bytes) and ``lot.html`` with the trend plot.

Blades are independent tasks (:func:`run_blade`): ``--workers K`` runs them on a local pool
of K processes, ``--scheduler tcp://HOST:PORT`` on a Dask distributed cluster. Each task
runs single-threaded (BLAS and the projection's blocks), so the numbers do not depend on
where it ran. A blade that fails gets its one-line error in ``lot.json``; the batch goes on
and exits with status 2. ``blisk`` (:mod:`bladerecon.cli.blisk`) uses the same engine.
"""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import sys
import tempfile
import threading
import time

from bladerecon.core.errors import BladeReconError
from bladerecon.core.io.outputs import (Outputs, check_input, count, escaped, one_line_errors, os_error, positive,
                                        shown)

__all__ = ["add_parser", "add_lot_options", "run_batch", "run_blade", "run_lot", "read_plan_limits"]

_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
_LOCK = threading.Lock()          # FreeCAD is not thread safe: one blade at a time per process
_NOMINALS: dict = {}              # per worker process: nominal path+hash -> Nominal (position errors)


def add_parser(sub) -> None:
    b = sub.add_parser("batch", help="a production lot: every blade's deviation, lot statistics, Cp/Cpk (Dask optional)",
                       description="Run the deviation of every blade of a lot (a manifest CSV "
                                   "blade,file[,nominal][,serial][,date] or a folder of point files) into "
                                   "OUTDIR/<blade>/, then the lot statistics into OUTDIR/lot/.")
    b.add_argument("manifest", help="manifest CSV (paths relative to it) or a folder of point files")
    b.add_argument("--nominal", help="nominal blade STEP/IGES/BREP/FCStd for blades the manifest gives none")
    add_lot_options(b)
    one_line_errors(b)
    b.set_defaults(run=run_batch)


def add_lot_options(p) -> None:
    """The options ``batch`` and ``blisk`` share."""
    p.add_argument("-o", "--output", required=True, metavar="OUTDIR", help="folder for the blades' results and lot/")
    p.add_argument("--plan", metavar="TOML", help="inspection plan (docs/verdicts.md): every blade judged by it "
                                                  "(its verdict in lot.json), and its [parameters] limits give "
                                                  "Cp/Cpk of the section parameters")
    p.add_argument("--align", choices=("none", "rigid", "translate", "rotate-z"), default="none",
                   help="best fit of each blade before comparing (as deviation --align)")
    p.add_argument("--robust", action="store_true", help="with --align: robust best fit (as deviation --robust)")
    p.add_argument("--tolerance", type=positive(), default=0.03, metavar="MM",
                   help="profile tolerance ±MM (default 0.03): within_tolerance_pct and the Cp/Cpk limits of "
                        "the deviation statistics")
    p.add_argument("--report", action="store_true",
                   help="each blade's deviation report and section parameters too (about 20 s a blade)")
    p.add_argument("--workers", type=count(1, 256), default=1, metavar="K", help="local worker processes (default 1)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="run the blades on this Dask distributed scheduler (shared storage for the files)")
    p.add_argument("--resume", action="store_true",
                   help="skip blades whose results exist for the same input and nominal bytes and options")
    p.add_argument("--force", action="store_true", help="write into an OUTDIR that holds files (blade folders "
                                                        "and lot/ are replaced)")
    p.add_argument("--json", action="store_true", help="print the lot summary object to stdout")
    p.add_argument("--quiet", action="store_true", help="no progress messages on stderr")
    from bladerecon.core.io.memory import add_memory_option
    add_memory_option(p)


def _say(args, msg: str) -> None:
    if not args.quiet:
        print(f"bladerecon: {escaped(msg)}", file=sys.stderr, flush=True)


# --------------------------------------------------------------------------- the plan's limits
def read_plan_limits(path: str) -> dict[str, tuple[float, float]]:
    """``section.*.<parameter> -> (lower, upper)`` from an inspection plan's ``[parameters]``
    table (measured − nominal, mm or °; issue 19's TOML). Only two-number limits are used."""
    import tomllib

    check_input(path, "--plan")
    try:
        with open(path, "rb") as fh:
            plan = tomllib.load(fh)
    except FileNotFoundError:
        raise BladeReconError(f"--plan {path}: no such file") from None
    except (OSError, tomllib.TOMLDecodeError) as err:
        raise BladeReconError(f"--plan {path}: cannot read the plan: {err}") from None
    params = plan.get("parameters", {})
    if not isinstance(params, dict):
        raise BladeReconError(f"--plan {path}: [parameters] must be a table of name = [lower, upper]")
    limits = {}
    for name, value in params.items():
        if isinstance(value, list):
            if (len(value) != 2 or not all(isinstance(v, (int, float)) for v in value) or not value[0] < value[1]):
                raise BladeReconError(f"--plan {path}: parameters.{name} = {value!r}: give [lower, upper], lower < upper")
            limits[f"section.*.{name}"] = (float(value[0]), float(value[1]))
    return limits


# --------------------------------------------------------------------------- one blade (a task)
def run_blade(job: dict) -> dict:
    """Run one blade (in a worker process or a Dask worker); returns its lot record. Never
    raises for the blade's own faults: those become ``{"status": "error", "error": line}``."""
    with _LOCK:
        from bladerecon.core.geometry.projection import parallel

        parallel._THREADS = 1           # one blade per core: the pool is the parallelism
        try:
            _RUNNING.set()
            return _run_blade(job)
        except _Stopped:
            os._exit(143)                # the blade's temporaries are gone and old results back: stop here
        except BladeReconError as err:
            return _failed(job, str(err))
        except Exception as err:  # noqa: BLE001 - one blade's internal error must not stop the lot
            return _failed(job, f"internal error: {type(err).__name__}: {err}")
        finally:
            _RUNNING.clear()


def _shown(job: dict, message: str) -> str:
    """``message`` on one line, with the job's absolute paths as the user named them (lot.json
    holds no absolute paths)."""
    for path, shown in ((job["file"], job["shown"]), (job["nominal"], job["nominal_shown"]),
                        (job["out"], os.path.join(job["out_shown"], job["blade"]))):
        if path:
            message = message.replace(path, shown)
    return " ".join(message.split())


def _failed(job: dict, message: str) -> dict:
    return {"blade": job["blade"], "serial": job["serial"], "date": job["date"], "status": "error",
            "error": _shown(job, message)}


def _inputs(job: dict) -> dict:
    from bladerecon.core.lot.manifest import file_sha256

    return {"file_sha256": file_sha256(job["file"]), "nominal_sha256": file_sha256(job["nominal"]),
            "options": job["options"], "position": job["position"] is not None}


def _blade_memory_limit(args) -> float | None:
    """Each blade's memory budget (GB): the lot's (``--memory-limit``, default half the memory
    available) shared by the local workers that run at once; on a Dask scheduler each worker
    machine's own default, or ``--memory-limit`` as given."""
    from bladerecon.core.io.memory import GB, budget_bytes

    if getattr(args, "scheduler", None):
        return getattr(args, "memory_limit", None)
    budget, _ = budget_bytes(getattr(args, "memory_limit", None))
    if budget is None:
        return None
    return budget / GB / max(1, int(getattr(args, "workers", 1) or 1))


def _run_blade(job: dict) -> dict:
    from bladerecon.cli import deviation

    check_input(job["file"], "MEASURED")     # before hashing: a FIFO would block the worker for good
    check_input(job["nominal"], "--nominal")
    inputs = _inputs(job)
    if job["resume"]:
        summary = _stored(job["out"], inputs)
        if summary is not None:
            return _record(job, summary, inputs, resumed=True)
    opts = job["options"]
    # deviation's own defaults for every option batch does not set (a new deviation option then
    # needs nothing here), with batch's choices on top
    ns = argparse.Namespace(**{**_deviation_defaults(), "measured": job["file"], "nominal": job["nominal"],
                               "align": opts["align"], "robust": opts["robust"], "tolerance": opts["tolerance"],
                               "csv": "deviations.csv", "report": "report" if opts["report"] else None,
                               "aligned": None, "force": False, "json": True, "quiet": True,
                               "plan": opts.get("plan"), "inspection_plan": _inspection_plan(opts.get("plan")),
                               "memory_limit": job.get("memory_limit")})
    moved = _move_aside(job["out"])
    try:
        with Outputs(inputs=(job["file"], job["nominal"])) as outs:
            tmp = outs.folder(job["out"], f"blade {job['blade']}")
            temps = {"csv": os.path.join(tmp, "deviations.csv"), "aligned": None,
                     "report": os.path.join(tmp, "report") if opts["report"] else None}
            summary = deviation._run(ns, temps)
            if job["position"] is not None:
                summary["position"] = _position(job)
            _write_json(os.path.join(tmp, "summary.json"), summary)
            _write_json(os.path.join(tmp, "inputs.json"), inputs)
            outs.commit()
    except BaseException:
        if moved:
            os.replace(moved, job["out"])      # the old results stay as they were
        raise
    if moved:
        shutil.rmtree(moved, ignore_errors=True)
    return _record(job, summary, inputs, resumed=False)


def _move_aside(folder: str) -> str | None:
    """An existing blade folder moved to a hidden name beside it (restored if the blade fails)."""
    if not os.path.lexists(folder):
        return None
    if not os.path.isdir(folder) or os.path.islink(folder):
        raise BladeReconError(f"{folder}: exists and is not a folder: move it away")
    aside = tempfile.mkdtemp(prefix=f".{os.path.basename(folder)}.old-", dir=os.path.dirname(folder))
    os.rmdir(aside)
    os.replace(folder, aside)
    return aside


def _write_json(path: str, obj) -> None:
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(obj, fh, indent=1)
        fh.write("\n")


def _stored(folder: str, inputs: dict) -> dict | None:
    """The blade's stored summary if it was made from the same inputs and options."""
    try:
        with open(os.path.join(folder, "inputs.json"), encoding="utf-8") as fh:
            old = json.load(fh)
        with open(os.path.join(folder, "summary.json"), encoding="utf-8") as fh:
            summary = json.load(fh)
    except (OSError, ValueError):
        return None
    return summary if old == inputs and inputs["file_sha256"] is not None else None


def _position(job: dict) -> dict:
    """Blade-to-blade position errors (blisk) of the blade's points (turned back into blade 0's
    place): pitch, stagger, axial from the fit with the radial slide locked
    (:func:`~bladerecon.core.lot.blisk.position_fit`), radial from a free rigid fit (weakly
    determined on a flank-only scan: see docs/batch.md). The fit's inverse is the blade's motion."""
    import numpy as np

    from bladerecon.cli.deviation import _read_measured
    from bladerecon.core.analysis.alignment import best_fit
    from bladerecon.core.lot.blisk import position_errors, position_fit
    from bladerecon.fc.deviation import load_nominal

    key = (job["nominal"], _inputs(job)["nominal_sha256"])
    if key not in _NOMINALS:
        _NOMINALS.clear()
        _NOMINALS[key] = load_nominal(job["nominal"])
    nominal = _NOMINALS[key]
    points, _, _ = _read_measured(job["file"])
    axis = np.asarray(job["position"]["axis"], float)
    locked = position_fit(points, nominal.projector(), nominal.centre, axis)
    errors = position_errors(np.linalg.inv(locked), nominal.centre, axis)
    free = best_fit(points, nominal.projector(), "rigid")     # radial: only a free fit can see it
    errors["radial_mm"] = position_errors(np.linalg.inv(free.matrix), nominal.centre, axis)["radial_mm"]
    errors["fit_rms_mm"] = float(free.rms_after)
    return errors


def _inspection_plan(path: str | None):
    """The inspection plan (issue 19) each blade is judged by, read where the blade runs."""
    if not path:
        return None
    from bladerecon.core.inspection.plan import read_inspection_plan

    return read_inspection_plan(path)


def _failed_features(summary: dict) -> list[str]:
    """``section <label>: <zone or parameter>`` for every failed check of a judged blade."""
    out = []
    for sec in summary.get("sections", []):
        label = sec.get("label", sec.get("index"))
        for group in ("profile", "parameters"):
            for name, check in (sec.get(group) or {}).items():
                if isinstance(check, dict) and check.get("pass") is False:
                    out.append(f"section {label}: {name}")
    return out


def _record(job: dict, summary: dict, inputs: dict, resumed: bool) -> dict:
    """The blade's entry in lot.json: results only (no timings, no paths)."""
    from bladerecon.core.lot.stats import DEVIATION_FEATURES

    rec = {"blade": job["blade"], "serial": job["serial"], "date": job["date"], "status": "ok",
           "input_sha256": inputs["file_sha256"], "points": summary["points"],
           "stats": {k: summary[k] for k in DEVIATION_FEATURES}}
    if summary.get("alignment", {}).get("mode", "none") != "none":
        al = summary["alignment"]
        rec["alignment"] = {"rotation_deg": al["rotation_deg"], "translation_mm": al["translation_mm"]}
    table = summary.get("sections")
    if "verdict" in summary:            # with an inspection plan: the verdicts, and the parameters apart
        rec["verdict"] = summary["verdict"]
        rec["failed"] = _failed_features(summary)
        table = summary.get("section_parameters")
    if isinstance(table, dict) and "rows" in table:
        rec["sections"] = [{"index": int(row["index"]), "name": str(name), "difference": row["difference"]}
                           for row, name in zip(table["rows"], table["names"])]
    elif isinstance(table, dict) and "error" in table:
        rec["sections_error"] = _shown(job, table["error"])
    if "position" in summary:
        rec["position"] = summary["position"]
    if resumed:
        rec["_resumed"] = True          # for the progress line only; dropped before lot.json
    return rec


# --------------------------------------------------------------------------- the lot
def make_jobs(blades, args, out: str, position: dict | None = None) -> list[dict]:
    """One job (a plain dict: it travels to worker processes and Dask workers) per blade."""
    options = {"align": args.align, "robust": bool(args.robust), "tolerance": float(args.tolerance),
               "report": bool(args.report), "plan": os.path.abspath(args.plan) if args.plan else None}
    jobs = []
    for b in blades:
        nominal = b.nominal or (os.path.abspath(args.nominal) if args.nominal else None)
        if nominal is None:
            raise BladeReconError(f"blade {b.name}: no nominal: give --nominal or a nominal column in the manifest")
        jobs.append({"blade": b.name, "file": b.file, "shown": b.shown, "nominal": nominal,
                     "nominal_shown": os.path.basename(nominal), "serial": b.serial, "date": b.date,
                     "out": os.path.join(out, b.name), "out_shown": args.output, "options": options,
                     "resume": bool(args.resume), "position": position,
                     "memory_limit": _blade_memory_limit(args)})
    return jobs


@contextlib.contextmanager
def output_folder(args):
    """OUTDIR (:func:`prepare_output`) for the run inside the block; when the block fails (a bad
    scan found late, Ctrl-C, SIGTERM before a blade was done) an OUTDIR this run created and
    nothing filled is removed again: a failed run leaves nothing new."""
    existed = os.path.lexists(os.path.abspath(args.output))
    out = prepare_output(args)
    try:
        yield out
    except BaseException as err:
        if not existed:
            if isinstance(err, BladeReconError) and not os.path.lexists(os.path.join(out, "lot")):
                shutil.rmtree(out, ignore_errors=True)   # no lot summary: nothing here is a result
            else:
                try:
                    os.rmdir(out)       # only when empty: blades done (for --resume) and lot/ stay
                except OSError:
                    pass
        raise


def prepare_output(args) -> str:
    """OUTDIR, absolute: created if missing; one that holds files needs --resume or --force."""
    out = os.path.abspath(args.output)
    if os.path.islink(out):
        raise BladeReconError(f"-o {shown(args.output, 200)} is a symbolic link: name the folder itself "
                              "(outputs are never written through links)")
    if os.path.lexists(out) and not os.path.isdir(out):
        raise BladeReconError(f"-o {args.output}: exists and is not a folder: give a folder name")
    if os.path.isdir(out) and os.listdir(out) and not (args.resume or args.force):
        raise BladeReconError(f"-o {args.output}: the folder holds files: add --resume to keep the blades done, "
                              "--force to redo them, or choose a new folder")
    if not os.path.isdir(os.path.dirname(out)):
        raise BladeReconError(f"-o {args.output}: the folder it goes in does not exist")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as err:
        raise os_error(err, args.output) from None    # read-only, disk full, ...: the one line every output gives
    return out


def run_lot(jobs: list[dict], args, out: str, extra: dict | None = None, limits: dict | None = None) -> dict:
    """Run the jobs (pool or Dask), write ``OUTDIR/lot/``; returns the lot summary."""
    from bladerecon.core.lot.stats import lot_statistics, tolerance_limits

    records = _execute(jobs, args)
    for r in records:
        r.pop("_resumed", None)
    all_limits = {**tolerance_limits(args.tolerance), **(limits or {})}
    failed = [r for r in records if r["status"] != "ok"]
    judged = [r["verdict"] for r in records if "verdict" in r]
    lot = {"lot": {"blades": len(records), "ok": len(records) - len(failed), "failed": len(failed),
                   **({"verdicts": {"pass": judged.count("pass"), "fail": judged.count("fail")}} if judged else {}),
                   "tolerance_mm": float(args.tolerance), "align": args.align, "robust": bool(args.robust),
                   "limits": {k: list(v) for k, v in sorted(all_limits.items())},
                   "units": {"deviation": "mm (within_tolerance_pct: %)",
                             "section": "measured - nominal: mm, angles (_deg) in degrees",
                             "position": "mm, angles (_deg) in degrees"}},
           **(extra or {}),
           "order": _trend_order(records),
           "statistics": lot_statistics(records, all_limits),
           "worst_blades": _worst_blades(records),
           "blades": records}
    if records and len(failed) == len(records):
        return lot                      # no blade measured: no lot summary (finish says why)
    _write_lot(out, lot, args)
    return lot


def _trend_order(records: list[dict]) -> list[str]:
    """Blade names in date, then serial order (the lot order where neither is given)."""
    ranked = sorted(range(len(records)), key=lambda i: (records[i]["date"], records[i]["serial"], i))
    return [records[i]["blade"] for i in ranked]


def _worst_blades(records: list[dict], n: int = 5) -> list[dict]:
    ok = [r for r in records if r["status"] == "ok"]
    ranked = sorted(ok, key=lambda r: -r["stats"]["max_abs"])[:n]
    return [{"blade": r["blade"], "max_abs": r["stats"]["max_abs"], "rms": r["stats"]["rms"]} for r in ranked]


def _write_lot(out: str, lot: dict, args) -> None:
    from bladerecon.report.lot import write_lot_report

    with Outputs() as outs:
        tmp = outs.folder(os.path.join(out, "lot"), "lot", force=True)
        with open(os.path.join(tmp, "lot.json"), "w", encoding="utf-8") as fh:
            json.dump(lot, fh, indent=1, sort_keys=False)
            fh.write("\n")
        write_lot_report(tmp, lot)
        outs.commit()


def _execute(jobs: list[dict], args) -> list[dict]:
    """Records in job order; progress (blades done / total, time to go) on stderr."""
    results: dict[int, dict] = {}
    t0 = time.perf_counter()

    def done(i: int, rec: dict) -> None:
        results[i] = rec
        n = len(results)
        left = (time.perf_counter() - t0) / n * (len(jobs) - n)
        state = "resumed" if rec.get("_resumed") else rec["status"]
        _say(args, f"batch: {n}/{len(jobs)} blades done ({rec['blade']}: {state}), about {left:.0f} s to go")

    try:
        if args.scheduler:
            _on_dask(jobs, args, done)
        else:
            _on_pool(jobs, args, done)
    except BaseException as err:
        if results and not isinstance(err, Exception):      # Ctrl-C, SIGTERM
            _say(args, f"batch: stopped; the {len(results)} blade(s) done are kept in {args.output} "
                       "(--resume runs the others)")
        raise
    return [results[i] for i in range(len(jobs))]


def _on_pool(jobs: list[dict], args, done) -> None:
    import concurrent.futures as cf
    import multiprocessing

    saved = {v: os.environ.get(v) for v in _THREAD_VARS}
    os.environ.update({v: "1" for v in _THREAD_VARS})        # the children's BLAS: one thread, as on Dask
    try:
        ctx = multiprocessing.get_context("spawn")           # no fork of a process that may hold FreeCAD
        pool = cf.ProcessPoolExecutor(max_workers=min(args.workers, len(jobs)), mp_context=ctx,
                                      initializer=_worker_signals)
        try:
            futures = {pool.submit(run_blade, job): i for i, job in enumerate(jobs)}
            for fut in cf.as_completed(futures):
                done(futures[fut], fut.result())
        except BaseException:
            _stop_pool(pool)
            raise
        pool.shutdown()
    finally:
        for v, value in saved.items():
            if value is None:
                os.environ.pop(v, None)
            else:
                os.environ[v] = value


class _Stopped(BaseException):
    """SIGTERM reached a worker while it ran a blade."""


_RUNNING = threading.Event()     # a worker is inside run_blade


def _worker_signals() -> None:
    """In each pool worker: SIGTERM stops the blade it runs (its temporaries removed, old results
    put back by the ``with``/``except`` on the way out), or the idle worker at once; Ctrl-C is
    left to the command, which stops the pool."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def stop(signum, frame):
        if _RUNNING.is_set():
            raise _Stopped()
        os._exit(143)

    signal.signal(signal.SIGTERM, stop)


def _stop_pool(pool, grace: float = 30.0) -> None:
    """Ctrl-C or SIGTERM in the command: no blade not started is started, the running ones are
    stopped (SIGTERM: each cleans up its temporaries) and waited for; the blades done stay."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        if proc.is_alive():
            proc.terminate()
    end = time.monotonic() + grace
    for proc in processes:
        proc.join(max(0.0, end - time.monotonic()))
        if proc.is_alive():
            proc.kill()
            proc.join(5.0)


def _on_dask(jobs: list[dict], args, done) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise BladeReconError("--scheduler needs Dask distributed: sudo apt-get install python3-distributed") from None
    try:
        client = Client(args.scheduler, timeout="10s")
    except (OSError, TimeoutError, ValueError) as err:
        raise BladeReconError(f"--scheduler {args.scheduler}: cannot connect: {' '.join(str(err).split())}") from None
    try:
        futures = client.map(run_blade, jobs, pure=False)
        index = {f.key: i for i, f in enumerate(futures)}
        for fut in as_completed(futures):
            done(index[fut.key], fut.result())
    finally:
        client.close()


def _deviation_defaults() -> dict:
    """The default of every ``deviation`` option, from its own parser."""
    from bladerecon.cli import deviation

    parser = argparse.ArgumentParser()
    deviation.add_parser(parser.add_subparsers())
    return vars(parser.parse_args(["deviation", "MEASURED", "--nominal", "NOMINAL"]))


def run_batch(args: argparse.Namespace) -> dict:
    """Run the subcommand; returns the lot summary (``--json``). Exit status 2 if any blade failed."""
    from bladerecon.core.lot.manifest import read_manifest

    if args.nominal:
        check_input(args.nominal, "--nominal")
    blades = read_manifest(args.manifest)
    limits = read_plan_limits(args.plan) if args.plan else None
    if args.plan:
        _inspection_plan(args.plan)     # a bad plan stops here, in one line, before any blade runs
    with output_folder(args) as out:
        jobs = make_jobs(blades, args, out)
        where = args.scheduler or f"{args.workers} local worker(s)"
        _say(args, f"batch: {len(jobs)} blades on {where}")
        lot = run_lot(jobs, args, out, limits=limits)
        return finish(lot, args)


def finish(lot: dict, args) -> dict:
    """The summary; a lot with failed blades prints it (--json) and then fails (status 2)."""
    summary = {"blades": lot["lot"]["blades"], "ok": lot["lot"]["ok"], "failed": lot["lot"]["failed"],
               "lot_json": os.path.join(args.output, "lot", "lot.json"),
               "errors": {r["blade"]: r["error"] for r in lot["blades"] if r["status"] != "ok"}}
    nothing = lot["lot"]["blades"] and not lot["lot"]["ok"]
    if nothing:
        summary["lot_json"] = None
    else:
        _say(args, f"lot summary in {os.path.join(args.output, 'lot')}")
    if lot["lot"]["failed"]:
        if args.json:
            print(json.dumps(summary, indent=2), flush=True)
        first = next(iter(summary["errors"].items()))
        if nothing:
            raise BladeReconError(f"all {lot['lot']['blades']} blades failed, nothing was written; "
                                  f"{first[0]}: {first[1]}")
        raise BladeReconError(f"{lot['lot']['failed']} of {lot['lot']['blades']} blades failed (see "
                              f"{summary['lot_json']}); {first[0]}: {first[1]}")
    return summary
