"""`dobwind replay AIRFRAME LOG`: the estimator run over one flight log (CSV streamed, autopilot logs
read whole); several logs or a folder go to dobwind/cli/replaymany.py."""
from __future__ import annotations

import argparse
import contextlib
import os
import sys
from functools import partial
from typing import Any, Callable

from dobwind.cli.common import add_backend_options, AIRFRAME_HELP, JSON_HELP, Command, add_many_options, print_json
from dobwind.core.errors import InputError
from dobwind.io.outputs import CSV_TABLE, PNG, OutputFiles, Target, check_targets
from dobwind.io.provenance import calibration_record
from dobwind.model.kinds import Precision


def add(command: Command, entry: Callable[[list[str]], int]) -> None:
    """``entry`` is the command line's ``main``: with several logs, each worker runs it on one log. It is
    handed down by the parser's assembly (dobwind/cli/app.py), which imports this module, not imported back."""
    p = command("replay", "run the estimator over a flight log")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("log", nargs="+", help="flight log: CSV (docs/formats.md), PX4 ULog (.ulg), ArduPilot DataFlash "
                   "(.bin) or ROS 2 bag; several logs or a folder of logs are replayed in parallel (docs/atmospheric.md)")
    p.add_argument("-o", "--output", help="estimate CSV, one row per log row (docs/formats.md), or CF-NetCDF when the "
                   "name ends in .nc; with several logs a folder, one file per log named after it (default: none, "
                   "not written)")
    add_backend_options(p)
    p.add_argument("--px4-wind", help="autopilot logs: also write the estimate as PX4's wind message holds it "
                   "(timestamp, north/east wind and their variances) to this CSV (default: none)")
    p.add_argument("--topic", action="append", metavar="ROLE=NAME",
                   help="ROS 2 bags: a topic name other than the default (roles: see docs; repeatable) "
                   "(default: none)")
    p.add_argument("--plot", help="PNG of the estimated wind against the truth or the autopilot's wind "
                   "(default: none, not drawn)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    add_many_options(p, "replay")
    p.add_argument("--format", choices=("csv", "nc"), default="csv",
                   help="several logs: the format of each estimate file in the -o folder (default: csv)")
    p.set_defaults(func=partial(run, entry=entry))


def run(args: argparse.Namespace, entry: Callable[[list[str]], int]) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.replay.replay import text_report
    from dobwind.cli.campaign import is_many

    if is_many(args.log):  # several logs or a folder of them: dobwind/cli/replaymany.py
        from dobwind.cli.replaymany import replay_many

        return replay_many(args, entry)
    args.log = args.log[0]
    check_targets(_replay_targets(args), [args.airframe, args.log])
    if _netcdf(args.output):
        from dobwind.atmos.ncreplay import require_netcdf

        require_netcdf(args.output)
    af = load_airframe(args.airframe)
    _warn_uncalibrated(af, args.airframe)
    if args.backend == "c" and args.precision == Precision.SINGLE:
        from dobwind.codegen.single_terms import refuse_ill_conditioned_terms

        refuse_ill_conditioned_terms(af, args.airframe)  # named by its file, before any log is read
    from dobwind.io.autopilot import is_autopilot_log

    if is_autopilot_log(args.log):
        return _replay_ulog(args, af)
    for option, value in (("--rate", args.rate), ("--topic", args.topic)):
        if value:
            raise InputError(args.log, option, "only applies to autopilot logs (CSV logs keep their own clock)")
    if args.px4_wind is not None:
        raise InputError(args.log, "--px4-wind", "only applies to autopilot logs (.ulg, .bin, ROS 2 bags)")
    result = _replay_csv_netcdf(args, af) if _netcdf(args.output) else _replay_csv(args, af)
    metrics = result.metrics
    for finding in result.findings:
        sys.stderr.write(f"dobwind replay: warning: {args.log}: {finding.message}\n")
    _warn_mostly_rejected(args.log, metrics, af)
    if args.json:
        print_json({"airframe": af.name, "log": str(args.log), "backend": args.backend, **metrics,
                     "plausibility": [f.as_dict() for f in result.findings],
                     "calibration": calibration_record(af, args.airframe)})
    elif result.scored:
        print(text_report(metrics))
    else:
        from dobwind.replay.rejections import breakdown

        print(f"rows {metrics['rows']}, rejected {metrics['rejected_rows']}{breakdown(metrics.get('rejections', {}))} "
              "(no true wind in the log to score against)")
    for finding in [] if args.json else result.findings:
        print(f"  note: plausibility ({finding.check}): {finding.message} (a streamed CSV log: not marked SUSPECT)")
    return 0


def _warn_uncalibrated(af, path: str) -> None:
    if af.uncalibrated:  # dobwind init's prior: the numbers are a guess, and every row says so
        sys.stderr.write(f"dobwind replay: warning: {path} is an uncalibrated prior ([calibration] status = "
                         f"\"{af.calibration}\"): every estimate carries UNCALIBRATED until `dobwind fit` calibrates it\n")


def _replay_csv(args: argparse.Namespace, af):
    """Streams the log: the estimates are written while it is read, all outputs renamed in at the end."""
    from dobwind.core.progress import byte_bar, wanted
    from dobwind.replay.replay import replay_stream

    try:
        size = os.path.getsize(args.log)
    except OSError:
        size = 0  # the reader names the problem
    with OutputFiles(_replay_targets(args)) as out, byte_bar(size, "replay", wanted(args.json)) as progress:
        staged = out.stage(args.output) if args.output is not None else None
        with open(staged, "w") if staged is not None else _no_file() as handle:
            result = replay_stream(af, args.log, args.backend, args.precision, handle,
                                   keep_series=args.plot is not None, progress=progress)
        if args.plot is not None:
            from dobwind.io.plots import published, replay_plot

            series = result.series
            replay_plot(series.t, published(series.wind, af.vertical_law), series.truth,
                        f"{af.name}: wind estimated over {os.path.basename(args.log)}", str(out.stage(args.plot)))
    return result


def _netcdf(output: str | None) -> bool:
    from dobwind.io.netcdf import is_netcdf

    return is_netcdf(output)


def _replay_csv_netcdf(args: argparse.Namespace, af):
    """-o OUT.nc: the estimate as a CF-NetCDF trajectory (dobwind/atmos/ncreplay.py)."""
    from dobwind.atmos.ncreplay import replay_csv_netcdf

    with OutputFiles(_replay_targets(args)) as out:
        return replay_csv_netcdf(args, af, out)


def _warn_mostly_rejected(log: str, metrics: dict, af: Any) -> None:
    """One stderr line when one reason rejected most rows (with its likely cause: a swapped column) or when
    most rows were rejected (dobwind/replay/rejections.py); the replay still succeeds."""
    from dobwind.replay.rejections import rejection_warning

    said = rejection_warning(log, int(metrics.get("rows", 0)), int(metrics.get("rejected_rows", 0)),
                             metrics.get("rejections", {}), af.limits.max_dt_s)
    if said:
        sys.stderr.write(f"dobwind replay: warning: {said}\n")


@contextlib.contextmanager
def _no_file():
    yield None


def _replay_targets(args: argparse.Namespace) -> list[Target]:
    return [Target(option, path, suffixes=suffixes, refused=refused) for option, path, suffixes, refused in
            (("-o", args.output, (), CSV_TABLE), ("--plot", args.plot, PNG, ()), ("--px4-wind", args.px4_wind, (), CSV_TABLE))
            if path is not None]


def _topic_overrides(args: argparse.Namespace) -> dict[str, str]:
    """--topic ROLE=NAME, repeated: the ROS 2 topic names that differ from the defaults."""
    out = {}
    for item in args.topic or []:
        role, sep, name = item.partition("=")
        if not sep or not role or not name:
            raise InputError(args.log, "--topic", f"expects ROLE=/topic/name, got {item!r}")
        out[role.strip()] = name.strip()
    return out


def _replay_ulog(args: argparse.Namespace, af) -> int:
    from dobwind.model.status import accepted
    from dobwind.replay.replay import autopilot_summary, replay_ulog, write_output

    model, flight, traj = replay_ulog(af, args.log, args.backend, args.precision, args.rate, _topic_overrides(args))
    for warning in flight.warnings:
        sys.stderr.write(f"dobwind replay: warning: {warning}\n")
    log = flight.log
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    valid = accepted(traj.status)  # quality-flagged samples are estimates too; status_counts shows the flags
    summary = autopilot_summary(af.name, str(args.log), args.backend, model, flight, traj)
    summary["calibration"] = calibration_record(af, args.airframe)
    with OutputFiles(_replay_targets(args)) as out:
        if args.output is not None and _netcdf(args.output):
            from dobwind.atmos.ncreplay import write_replay_netcdf

            write_replay_netcdf(out.stage(args.output), af, args, flight.t0_s + log.time_s, traj, flight.landed)
        elif args.output is not None:
            write_output(out.stage(args.output), log, traj, flight.t0_s)
        if args.px4_wind is not None:
            from dobwind.io.autopilot import px4_wind_rows, write_px4_wind

            sigma = traj.outputs[:, model.outputs.slice("wind_sigma_h")][:, 0]
            write_px4_wind(out.stage(args.px4_wind), px4_wind_rows(flight, wind, sigma, traj.status, valid))
        if args.plot is not None:
            from dobwind.io.plots import published
            from dobwind.replay.replay import autopilot_plot

            autopilot_plot(str(out.stage(args.plot)), f"{af.name}: wind estimated over {os.path.basename(args.log)}",
                           flight, published(wind, af.vertical_law), traj.status)
    if args.json:
        print_json(summary)
        return 0
    print(f"{log.rows} instants over {summary['duration_s']:.2f} s, {summary['valid_rows']} valid; status: "
          + ", ".join(f"{k} {v}" for k, v in summary["status_counts"].items()))
    for note in flight.notes:
        print(f"  note: {note}")
    if summary["mean_wind_speed_h_mps"] is not None:
        print(f"mean horizontal wind {summary['mean_wind_speed_h_mps']:.2f} m/s {_over_rows(summary)}")
    from dobwind.replay.replay import autopilot_wind_lines
    from dobwind.replay.sitlcompare import sitl_line

    for line in sitl_line(summary.get("sitl_wind")) + autopilot_wind_lines(summary.get("px4")):
        print(line)
    return 0


def _over_rows(summary: dict) -> str:
    """Which rows the mean is over: every accepted row, flagged or not, so say how many of them are
    trusted (status OK); an uncalibrated or settling estimate must not read as a confident number."""
    accepted, trusted = summary["valid_rows"], summary["status_counts"].get("OK", 0)
    if trusted == accepted:
        return f"(over the {accepted} accepted rows, all trusted)"
    return (f"(over the {accepted} accepted rows, {trusted} of them trusted; the others carry the quality flags "
            "in the status counts above)")
