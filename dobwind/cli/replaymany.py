"""`dobwind replay AIRFRAME LOG LOG... [-o DIR]` or `replay AIRFRAME FOLDER`: every log replayed as
the single-log command replays it, in parallel worker processes, then one summary table.

With several logs, ``-o`` is a FOLDER: each log's estimate is written there under the log's name with
``.csv`` (or ``.nc`` with ``--format nc``) instead of its own suffix, byte for byte what
``replay AIRFRAME LOG -o FOLDER/NAME`` writes. Each file is written atomically on its own; a log that
fails (unreadable, wrong topics) is reported in the table and on stderr and writes nothing, the others
are written. The exit status is the worst of the logs' (2 bad input over 1 failed check over 0).
"""
from __future__ import annotations

import argparse
import json
import sys
from typing import Callable

from dobwind.cli.campaign import Done, expand_logs, format_table, output_names, run_all, run_command
from dobwind.core.errors import InputError
from dobwind.io.outputs import Target, check_targets
from dobwind.core.progress import wanted


def _argv(args: argparse.Namespace, log: str, output: str | None) -> list[str]:
    argv = ["replay", str(args.airframe), log, "--backend", args.backend, "--precision", args.precision, "--json"]
    if output is not None:
        argv += ["-o", output]
    if args.rate:
        argv += ["--rate", repr(args.rate)]
    for topic in args.topic or []:
        argv += ["--topic", topic]
    return argv


def replay_many(args: argparse.Namespace, main: Callable[[list[str]], int]) -> int:
    """``main`` is the command line's entry point (dobwind.cli.app.main), each worker's single-log replay."""
    logs = expand_logs(args.log)
    for option, value in (("--plot", args.plot), ("--px4-wind", args.px4_wind)):
        if value is not None:
            raise InputError(option, None, "takes one log; with several logs, replay them one by one for it")
    outputs: list[str | None] = [None] * len(logs)
    if args.output is not None:
        check_targets([Target("-o", args.output, "dir")], [str(args.airframe), *logs])
        if args.format == "nc":
            from dobwind.io.netcdf import require_xarray

            require_xarray(args.output)
        outputs = list(output_names(logs, args.output, "." + args.format))
    from dobwind.model.airframe import load_airframe

    load_airframe(args.airframe)  # a bad airframe is one line, not one line per log
    import dobwind.replay.replay  # noqa: F401 - imported once here, inherited by every forked worker
    done = run_all(run_command, [(main, log, _argv(args, log, out)) for log, out in zip(logs, outputs)], logs,
                   args.jobs, "replay", wanted(args.json))
    for result in done:
        for line in result.value[1].splitlines():
            if result.code == 0 and line.strip():  # a failed log's reason is its last line, printed below
                sys.stderr.write(line + "\n")
        if result.code != 0:
            sys.stderr.write(result.error + "\n")
    summaries = [_summary(r) for r in done]
    if args.json:
        print(json.dumps({"airframe_file": str(args.airframe), "logs": [
            {"log": r.log, "exit": r.code, "output": o, "error": r.error, "summary": s}
            for r, o, s in zip(done, outputs, summaries)]}, indent=2))
    else:
        print(_table(done, outputs, summaries))
    return max(r.code for r in done)


def _summary(result: Done) -> dict | None:
    if result.code != 0:
        return None
    try:
        return json.loads(result.value[0])
    except ValueError:
        return None


def _num(value, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def _table(done: list[Done], outputs: list[str | None], summaries: list[dict | None]) -> str:
    rows = []
    for r, out, s in zip(done, outputs, summaries):
        if s is None:
            rows.append([r.log, f"failed ({r.code})", "-", "-", "-", "-"])
            continue
        valid = s.get("valid_rows", s["rows"] - s.get("rejected_rows", 0))
        wind = s.get("mean_wind_speed_h_mps")
        if wind is None and "mean_estimated_wind" in s:
            wind = s["mean_estimated_wind"].get("horizontal_mps")
        rows.append([r.log, "ok", str(s["rows"]), str(valid), _num(wind, ".2f"), out or "-"])
    ok = sum(1 for s in summaries if s is not None)
    return (format_table(["log", "result", "rows", "valid", "mean wind m/s", "output"], rows)
            + f"\n{ok} of {len(done)} logs replayed")
