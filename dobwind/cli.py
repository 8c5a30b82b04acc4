"""The ``dobwind`` command line (docs/formats.md, and each subcommand's --help).

Every user mistake ends as one stderr line and exit status 2; a failed check as exit status 1.
"""
from __future__ import annotations

import argparse
import contextlib
import errno
import os
import sys
from pathlib import Path
from functools import partial

import numpy as np
from typing import Any, Callable, NoReturn, Sequence

from dobwind import options as opt
from dobwind.helpfmt import DefaultsFormatter
from dobwind.errors import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, CheckFailed, InputError
from dobwind.interrupts import Interrupted, signals_raise
from dobwind.outputs import OutputFiles, Target, check_replaceable, check_targets

EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what a shell reports for a C tool killed by the closed pipe


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, not argparse's usage block
        sys.stderr.write(f"{self.prog}: error: {message} (see --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)


def _print_json(obj: dict[str, Any]) -> None:
    from dobwind.jsonout import print_json

    print_json(obj)


def cmd_generate(args: argparse.Namespace) -> int:
    from dobwind.model.stability import require_stable
    from dobwind.codegen.generate import is_generated_name
    from dobwind.emit import generate_to_dir
    from dobwind.model.airframe import load_airframe

    if args.output is not None:
        check_targets([Target("-o", args.output, "dir")], [args.airframe])
    af = load_airframe(args.airframe)
    require_stable(af, "refusing to generate code", args.airframe)  # the same gate as `check`
    out_dir = args.output if args.output is not None else f"generated_c/{af.name}"
    target = Target("-o", out_dir, "dir")
    check_targets([target], [args.airframe])
    check_replaceable(target, is_generated_name)
    gate = None if args.no_selftest else partial(_selftest_gate, af.name)
    files = generate_to_dir(af, out_dir, args.precision, source=args.airframe, gate=gate)
    for path in files:
        print(path)
    return 0


def _selftest_gate(name: str, folder: Path) -> None:
    from dobwind.harness.build import system_compiler
    from dobwind.selftest_gate import run_selftest

    result = run_selftest(folder, name, system_compiler())
    if not result.ran:
        sys.stderr.write(f"dobwind generate: warning: {result.summary}\n")


def cmd_verify(args: argparse.Namespace) -> int:
    from dobwind.codegen.generate import refuse_ill_conditioned_terms
    from dobwind.harness.verify import verify_airframe
    from dobwind.model.airframe import load_airframe

    af = load_airframe(args.airframe)
    if args.c_dir is None and args.precision in ("single", "both"):
        refuse_ill_conditioned_terms(af, args.airframe)  # generate refuses them: nothing to verify
    report = verify_airframe(af, args.precision, steps=args.steps, seed=args.seed,
                             c_dir=None if args.c_dir is None else Path(args.c_dir))
    if args.json:
        _print_json(report.as_dict())
    else:
        print(report.text())
    return 0 if report.passed else EXIT_CHECK_FAILED


def cmd_analyze(args: argparse.Namespace) -> int:
    from dobwind.analyze_command import analyze_command

    return analyze_command(args)


def cmd_check(args: argparse.Namespace) -> int:
    from dobwind.model.stability import require_stable
    from dobwind.model.airframe import load_airframe
    from dobwind.model.step import build_step

    af = load_airframe(args.airframe)
    require_stable(af, "generate would refuse it", args.airframe)
    model = build_step(af)
    _refuse_what_generate_refuses(af, model, args.airframe)
    summary = {
        "name": af.name,
        "mass_kg": af.mass_kg,
        "thrust": af.thrust.source,
        "discretization": af.observer.discretization,
        "acceleration": af.observer.acceleration,
        "inputs": list(model.inputs.element_names()),
        "state_size": model.state.size,
        "step_instructions": model.step.n_instructions(),
    }
    if args.json:
        _print_json(summary)
    else:
        for key, value in summary.items():
            print(f"{key:18s} {value}")
    return 0


def _refuse_what_generate_refuses(af: Any, model: Any, source: str) -> None:
    """Renders the C in both precisions and discards it: every static refusal of `generate` (a constant
    that rounds to 0 in a float, an ill-conditioned term) then stops `check` too, with the same line."""
    from dobwind.codegen.generate import generate_code

    for precision in ("single", "double"):
        generate_code(af, precision, model, source=source)


def _default_airframe() -> str:
    from dobwind.resources import shipped_airframe

    return str(shipped_airframe())


def cmd_simulate(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.simulate import write_log
    from dobwind.vehicle import load_vehicle

    target = Target("-o", args.output)
    check_targets([target], [args.airframe] if args.airframe else [])
    af = load_airframe(args.airframe or _default_airframe())
    vehicle = load_vehicle(args.vehicle) if args.vehicle else None
    # The log's rate: --rate, else the vehicle file's sensors, else the rate the airframe's observer expects.
    rate = args.rate or (vehicle.rate_hz if vehicle else 1.0 / af.observer.sample_time_s)
    with OutputFiles([target]) as out:
        rows = write_log(out.stage(args.output), af, args.scenario, args.seed, args.hold, rate, vehicle,
                         args.vehicle)
    print(f"{args.output}: {rows} rows, {rows / rate:.1f} s of '{args.scenario}' at {rate:g} Hz")
    return 0


def _refuse_out_of_range(text: str, output: str) -> None:
    """The fitted airframe goes through the loader before it is written: a file that `check` would
    refuse is never written (absurd logs can fit a thrust scale or a coefficient out of range)."""
    from dobwind.model.airframe import parse_airframe

    try:
        parse_airframe(text, output)
    except InputError as exc:
        raise InputError(output, exc.where, f"the fitted airframe would be refused: {exc.message}; "
                         "nothing written (check the logs' units)") from None


def cmd_fit(args: argparse.Namespace) -> int:
    from dobwind.fitreport import fit_plot, text_report
    from dobwind.fitfamily import fit_airframe
    from dobwind.logs import write_atomically
    from dobwind.model.airframe import load_airframe
    from dobwind.model.airframe_toml import dump_airframe
    from dobwind.hovernoise import HoverNoise
    from dobwind.selfcheck import Thresholds, text_table

    plot = args.plot if args.plot is not None else str(args.output).removesuffix(".toml") + "_fit.png"
    targets = [Target("-o", args.output), Target("--plot", plot)]
    check_targets(targets, [args.airframe, *args.logs])
    af = load_airframe(args.airframe)
    limits = Thresholds(cv_share=args.max_error_share, replay_share=args.max_error_share,
                        floor_mps=args.error_floor, direction_deg=args.max_direction_error)
    hover = HoverNoise(target_mps=args.hover_noise)
    new, report, points = fit_airframe(af, list(args.logs), args.terms, args.dynamic, args.model, args.still_air,
                                       limits, hover=hover)
    passed = bool(report.self_check["passed"])
    written = passed or args.force  # a model that failed its self-check is written only when forced
    if written:
        text = dump_airframe(new)
        _refuse_out_of_range(text, args.output)
        with OutputFiles(targets) as out:
            write_atomically(out.stage(args.output), lambda handle: handle.write(text))
            fit_plot(new, points, str(out.stage(plot)))
    if args.json:
        _print_json({**report.__dict__, "written": written, "airframe": str(args.output) if written else None,
                     "plot": plot if written else None})
    else:
        print(text_report(report))
        print(text_table(report.self_check))
        print(f"wrote {args.output} and {plot}" if written else "nothing written")
    for warning in report.warnings:
        sys.stderr.write(f"dobwind fit: warning: {warning}\n")
    if passed:
        return 0
    reasons = "; ".join(report.self_check["reasons"])
    if args.force:
        sys.stderr.write(f"dobwind fit: warning: the self-check failed ({reasons}); written anyway (--force)\n")
        return 0
    raise CheckFailed(f"the fitted model cannot be trusted: {reasons}; nothing written (--force writes it anyway)")


def cmd_replay(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.replay import text_report

    check_targets(_replay_targets(args), [args.airframe, args.log])
    af = load_airframe(args.airframe)
    if args.backend == "c" and args.precision == "single":
        from dobwind.codegen.single_terms import refuse_ill_conditioned_terms

        refuse_ill_conditioned_terms(af, args.airframe)  # named by its file, before any log is read
    from dobwind.autopilot import is_autopilot_log

    if is_autopilot_log(args.log):
        return _replay_ulog(args, af)
    for option, value in (("--rate", args.rate), ("--topic", args.topic)):
        if value:
            raise InputError(args.log, option, "only applies to autopilot logs (CSV logs keep their own clock)")
    if args.px4_wind is not None:
        raise InputError(args.log, "--px4-wind", "only applies to autopilot logs (.ulg, .bin, ROS 2 bags)")
    result = _replay_csv(args, af)
    metrics = result.metrics
    _warn_mostly_rejected(args.log, metrics, af)
    if args.json:
        _print_json({"airframe": af.name, "log": str(args.log), "backend": args.backend, **metrics})
    elif result.scored:
        print(text_report(metrics))
    else:
        print(f"rows {metrics['rows']}, rejected {metrics['rejected_rows']} (no true wind in the log to score against)")
    return 0


def _replay_csv(args: argparse.Namespace, af):
    """Streams the log: the estimates are written while it is read, all outputs renamed in at the end."""
    from dobwind.progress import byte_bar, wanted
    from dobwind.replay import replay_stream

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
            from dobwind.plots import replay_plot

            series = result.series
            replay_plot(series.t, series.wind, series.truth,
                        f"{af.name}: wind estimated over {os.path.basename(args.log)}", str(out.stage(args.plot)))
    return result


# Above this share of rejected rows a replay "succeeds" with next to no estimate: say so on stderr.
MOSTLY_REJECTED = 0.9


def _warn_mostly_rejected(log: str, metrics: dict, af: Any) -> None:
    rows, rejected = int(metrics.get("rows", 0)), int(metrics.get("rejected_rows", 0))
    if rows and rejected > MOSTLY_REJECTED * rows:
        sys.stderr.write(f"dobwind replay: warning: {log}: {rejected} of {rows} rows rejected (see the status column; "
                         f"a log slower than 1/limits.max_dt = {1 / af.limits.max_dt_s:g} Hz is rejected as BAD_DT)\n")


@contextlib.contextmanager
def _no_file():
    yield None


def _replay_targets(args: argparse.Namespace) -> list[Target]:
    return [Target(option, path) for option, path in (("-o", args.output), ("--plot", args.plot),
                                                      ("--px4-wind", args.px4_wind)) if path is not None]


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
    from dobwind.replay import autopilot_summary, replay_ulog, write_output

    model, flight, traj = replay_ulog(af, args.log, args.backend, args.precision, args.rate, _topic_overrides(args))
    for warning in flight.warnings:
        sys.stderr.write(f"dobwind replay: warning: {warning}\n")
    log = flight.log
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    valid = accepted(traj.status)  # quality-flagged samples are estimates too; status_counts shows the flags
    summary = autopilot_summary(af.name, str(args.log), args.backend, model, flight, traj)
    with OutputFiles(_replay_targets(args)) as out:
        if args.output is not None:
            write_output(out.stage(args.output), log, traj)
        if args.px4_wind is not None:
            from dobwind.autopilot import px4_wind_rows, write_px4_wind

            sigma = traj.outputs[:, model.outputs.slice("wind_sigma_h")][:, 0]
            write_px4_wind(out.stage(args.px4_wind), px4_wind_rows(flight, wind, sigma, traj.status, valid))
        if args.plot is not None:
            from dobwind.plots import replay_plot

            others = [] if flight.px4_wind is None else [(f"PX4 ({flight.px4_wind[0]})", flight.px4_wind[1], flight.px4_wind[2])]
            replay_plot(log.time_s, np.where(valid[:, None], wind, np.nan), None,
                        f"{af.name}: wind estimated over {os.path.basename(args.log)}",
                        str(out.stage(args.plot)), others)
    if args.json:
        _print_json(summary)
        return 0
    print(f"{log.rows} instants over {summary['duration_s']:.2f} s, {summary['valid_rows']} valid; status: "
          + ", ".join(f"{k} {v}" for k, v in summary["status_counts"].items()))
    for note in flight.notes:
        print(f"  note: {note}")
    if summary["mean_wind_speed_h_mps"] is not None:
        print(f"mean horizontal wind {summary['mean_wind_speed_h_mps']:.2f} m/s")
    px4 = summary.get("px4")
    label = px4["topic"] if px4 and " " in px4["topic"] else f"PX4 {px4['topic']}" if px4 else ""  # ArduPilot/ROS name themselves
    if px4 and px4.get("overlap_rows"):
        print(f"{label}: mean vector difference {px4['mean_vector_difference_mps']:.2f} m/s, mean speed "
              f"difference (ours - PX4) {px4['mean_speed_difference_mps']:+.2f} m/s over {px4['overlap_rows']} instants")
    elif px4:
        print(f"{label}: no overlap with valid estimates")
    return 0


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("dobwind")
    except PackageNotFoundError:  # run from a checkout that was never installed
        from dobwind import __version__

        return __version__


class _VersionAction(argparse.Action):
    """--version, looked up only when asked: the package metadata costs 45 ms of every other command."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(self, parser, namespace, values, option_string=None) -> None:  # type: ignore[no-untyped-def]
        print(f"dobwind {_version()}")  # stdout, as argparse's own version action prints
        parser.exit()


AIRFRAME_HELP = "airframe TOML file (see docs/formats.md for its keys and units)"
JSON_HELP = "print the results as JSON (indent 2, units in the key names) instead of text"
# adds one subcommand: (name, one-line description) -> its parser
_Command = Callable[[str, str], argparse.ArgumentParser]


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="dobwind", description="Airframe description -> verified C wind estimator.",
                     formatter_class=DefaultsFormatter)
    parser.add_argument("--version", action=_VersionAction, help="show program's version number and exit")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND")

    def command(name: str, text: str) -> argparse.ArgumentParser:
        return sub.add_parser(name, help=text, description=text, formatter_class=DefaultsFormatter)

    _add_check(command)
    _add_generate(command)
    _add_verify(command)
    _add_analyze(command)
    _add_fit(command)
    _add_replay(command)
    _add_simulate(command)
    _add_report(command)
    _add_demo(command)
    return parser


def _add_check(command: _Command) -> None:
    p = command("check", "validate an airframe file and summarise its estimator")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=cmd_check)


def _add_generate(command: _Command) -> None:
    p = command("generate", "emit C for an airframe")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("-o", "--output", help="output folder (default: generated_c/<name>/ in the working directory)")
    p.add_argument("--precision", choices=("single", "double"), default="single",
                   help="floating-point type of the generated C: float (single) or double")
    p.add_argument("--no-selftest", action="store_true",
                   help="skip the final gate: by default the generated C and its self-test are compiled with the "
                   "host compiler ($CC, default cc) and run, and C that fails its golden vectors is refused "
                   "(exit 1, nothing written); without a host compiler generate warns on stderr and still writes")
    p.set_defaults(func=cmd_generate)


def _add_verify(command: _Command) -> None:
    p = command("verify", "generate, compile strictly, compare with the Python reference")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("--precision", choices=("single", "double", "both"), default="both",
                   help="which generated C to build and compare")
    p.add_argument("--steps", type=opt.VERIFY_STEPS, default=20000,
                   help=f"length of the simulated flight compared step by step ({opt.VERIFY_STEPS.text()})")
    p.add_argument("--seed", type=opt.SEED, default=1, help=f"random seed of the flight and of the random cases "
                   f"({opt.SEED.text()})")
    p.add_argument("--c-dir", help="verify the generated C in this folder as it is (e.g. generated_c/m300) "
                   "instead of freshly generated C; its precision is read from its header (default: none)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=cmd_verify)


def _add_analyze(command: _Command) -> None:
    p = command("analyze", "observer and filter poles, bandwidth, Bode plots; --bandwidth designs gains")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("-o", "--output", help="folder for the PNG plots (none are drawn without it); with --bandwidth: "
                   "the new airframe TOML with the designed gains (default: none, nothing written)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.add_argument("--freq", type=opt.FREQUENCY, nargs="+", default=[0.1, 0.5, 1.0],
                   help=f"frequencies to report gain and phase at, Hz ({opt.FREQUENCY.text()}, below the Nyquist "
                        f"frequency 1/(2 sample_time); at most {opt.MAX_FREQUENCIES})")
    p.add_argument("--bandwidth", type=opt.BANDWIDTH, help="design the observer gains (kg/s, equal on x y z) that give "
                   f"this -3 dB bandwidth, Hz ({opt.BANDWIDTH.text()}, below the Nyquist frequency), then analyse "
                   "the airframe with those gains (default: none, analyse the gains in the file)")
    p.set_defaults(func=cmd_analyze)


def _add_fit(command: _Command) -> None:
    p = command("fit", "fit the force-air model from logs with true wind")
    p.add_argument("airframe", help=AIRFRAME_HELP + "; its mass, thrust model and observer are kept")
    p.add_argument("logs", nargs="+", help="calibration flight-log CSVs with true wind columns (docs/formats.md)")
    p.add_argument("-o", "--output", required=True, help="the new airframe file (TOML, required)")
    p.add_argument("--model", choices=("auto", "drag", "drag-heading", "drag-body", "polynomial"), default="auto",
                   help="force-air family: 'drag' (a drag law fitted forward and inverted in the step, in the "
                   "level heading frame and in the body frame at the measured attitude; the better frame is "
                   "kept), 'drag-heading' or 'drag-body' (one frame), 'polynomial' (the paper's), or 'auto': "
                   "all of them, scored by grouped cross-validation and extrapolation in airflow space "
                   "(default: auto)")
    p.add_argument("--terms", choices=("airframe", "auto"), default="auto",
                   help="polynomial family: fit the airframe's terms, or choose them from a library by "
                   "cross-validation (default: auto)")
    p.add_argument("--still-air", action="store_true",
                   help="the logs were flown in still air: wind columns may be absent and are taken as zero")
    p.add_argument("--plot", help="PNG of the fitted surface and residuals (default: OUTPUT without .toml + _fit.png)")
    p.add_argument("--dynamic", action="store_true",
                   help="calibrate on manoeuvring flight too (constant wind), not only on steady holds")
    p.add_argument("--force", action="store_true",
                   help="write the airframe even when the self-check fails (exit 0, with a warning)")
    from dobwind.thresholds import Thresholds  # not dobwind.selfcheck: that imports scipy for every command

    limits = Thresholds()
    p.add_argument("--max-error-share", type=opt.ERROR_SHARE, default=limits.replay_share, metavar="SHARE",
                   help="self-check: the largest hold-level CV and training-replay speed error (RMS over a log's "
                   f"segments) as a share of the calibrated airflow speed range ({opt.ERROR_SHARE.text()}; "
                   f"default {limits.replay_share:g})")
    p.add_argument("--error-floor", type=opt.ERROR_FLOOR, default=limits.floor_mps, metavar="MPS",
                   help=f"self-check: the speed limits are never below this ({opt.ERROR_FLOOR.text()}; "
                   f"default {limits.floor_mps:g})")
    p.add_argument("--max-direction-error", type=opt.DIRECTION_LIMIT, default=limits.direction_deg, metavar="DEG",
                   help="self-check: the largest mean per-segment direction error of a training replay "
                   f"({opt.DIRECTION_LIMIT.text()}; default {limits.direction_deg:g})")
    from dobwind.hovernoise import HoverNoise

    hover = HoverNoise()
    p.add_argument("--hover-noise", type=opt.HOVER_NOISE, default=hover.target_mps, metavar="MPS",
                   help="the wind estimate's noise per horizontal axis at low airflow that the fit aims for: when "
                   "the self-check measures more, the low-pass's cutoff at zero airflow is lowered (never below "
                   f"{hover.floor_hz:g} Hz, never raised), and when it stays above, an acceleration input is blended "
                   "with the velocity's derivative at low frequency (acceleration_bias_time 0.5 s) if that fit is "
                   f"clearly quieter and passes its self-check; 0 keeps the airframe's schedule and observer ({opt.HOVER_NOISE.text()}; "
                   f"default {hover.target_mps:g})")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=cmd_fit)


def _add_replay(command: _Command) -> None:
    p = command("replay", "run the estimator over a flight log")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("log", help="flight log: CSV (docs/formats.md) or PX4 ULog (.ulg)")
    p.add_argument("-o", "--output", help="estimate CSV, one row per log row (docs/formats.md) (default: none, not written)")
    p.add_argument("--backend", choices=("python", "c"), default="python",
                   help="run the CasADi reference (python) or the generated C, compiled on the fly (c)")
    p.add_argument("--precision", choices=("single", "double"), default="single", help="C backend precision")
    p.add_argument("--rate", type=opt.ULOG_RATE,
                   help=f"autopilot logs only: resample at this rate, Hz ({opt.ULOG_RATE.text()}) (default: none, "
                   "the attitude's clock)")
    p.add_argument("--px4-wind", help="autopilot logs: also write the estimate as PX4's wind message holds it "
                   "(timestamp, north/east wind and their variances) to this CSV (default: none)")
    p.add_argument("--topic", action="append", metavar="ROLE=NAME",
                   help="ROS 2 bags: a topic name other than the default (roles: see docs; repeatable) "
                   "(default: none)")
    p.add_argument("--plot", help="PNG of the estimated wind against the truth or the autopilot's wind "
                   "(default: none, not drawn)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=cmd_replay)


def _add_simulate(command: _Command) -> None:
    p = command("simulate", "synthesize a flight log with known wind")
    p.add_argument("scenario", help="sweep (the paper's calibration) | vertical (climbs and descents) | tunnel "
                   "(60 deg, 3-10 m/s) | still-air (manoeuvres) | outdoor (turbulent)")
    p.add_argument("--airframe", help="airframe TOML (default: the shipped reference airframe m300)")
    p.add_argument("-o", "--output", required=True, help="the flight-log CSV to write (required)")
    p.add_argument("--seed", type=opt.SEED, default=0, help=f"turbulence and timing noise ({opt.SEED.text()})")
    p.add_argument("--hold", type=opt.SIMULATE_HOLD,
                   help=f"seconds per hold ({opt.SIMULATE_HOLD.text()}; default: the scenario's own)")
    p.add_argument("--rate", type=opt.SIMULATE_RATE, help=f"sample rate, Hz ({opt.SIMULATE_RATE.text()}; default: "
                   f"the vehicle file's rate, else 1 / the airframe's observer.sample_time); at most "
                   f"{opt.SIMULATE_MAX_ROWS:,} rows in all")
    p.add_argument("--vehicle", help="the true vehicle's physics and sensors (TOML; default: a vehicle of the "
                   "airframe's size with built-in drag)")
    p.set_defaults(func=cmd_simulate)


def _add_report(command: _Command) -> None:
    p = command("report", "one self-contained HTML page: airframe, estimate vs truth or the autopilot, errors, "
                "status counts, analysis figures")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("log", help="flight log: CSV (docs/formats.md) or PX4 ULog (.ulg)")
    p.add_argument("-o", "--output", required=True, help="the HTML file to write (required; figures are inlined)")
    p.add_argument("--backend", choices=("python", "c"), default="python",
                   help="run the CasADi reference (python) or the generated C, compiled on the fly (c)")
    p.add_argument("--precision", choices=("single", "double"), default="single", help="C backend precision")
    p.set_defaults(func=cmd_report)


def _add_demo(command: _Command) -> None:
    p = command("demo", "the whole pipeline on the reference airframe")
    p.add_argument("-o", "--output", default="out/demo", help="folder for logs, fitted airframe, plots and C")
    p.set_defaults(func=cmd_demo)


def cmd_report(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.report import flight_report

    target = Target("-o", args.output)
    check_targets([target], [args.airframe, args.log])
    af = load_airframe(args.airframe)
    page, summary = flight_report(af, args.airframe, args.log, args.backend, args.precision)
    with OutputFiles([target]) as out:
        from dobwind.atomic import write_text_atomically

        write_text_atomically(out.stage(args.output), lambda handle: handle.write(page))
    print(f"wrote {args.output} ({len(page) // 1024} KiB): {summary}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from dobwind.demo import is_demo_name, run_demo

    target = Target("-o", args.output, "dir")
    check_targets([target])
    check_replaceable(target, is_demo_name)
    return run_demo(args.output)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    with signals_raise() as caught:
        command = "?"
        try:
            args = parser.parse_args(argv)
            command = args.command
            _refuse_closed_stdout_and_special_files(args)
            status = int(args.func(args))
            if caught.signo is not None:  # its exception was swallowed (CasADi): still a stop
                raise Interrupted(caught.signo)
            sys.stdout.flush()  # inside the try: a reader that went away is reported here, not at exit
            return status
        except InputError as exc:
            sys.stderr.write(f"dobwind {command}: {exc}\n")
            return EXIT_BAD_INPUT
        except CheckFailed as exc:
            sys.stderr.write(f"dobwind {command}: {exc}\n")
            return EXIT_CHECK_FAILED
        except BrokenPipeError:
            return _reader_went_away()
        except OSError as exc:  # a write that failed outside the atomic writers: stdout on a full disk
            if caught.signo is not None:
                raise
            where = exc.filename or ("stdout" if exc.errno in _WRITE_ERRNOS else "error")
            sys.stderr.write(f"dobwind {command}: {where}: {exc.strerror or exc}\n")
            _reader_went_away()  # the buffered rest would fail again at exit
            return EXIT_BAD_INPUT
        except BaseException:
            if caught.signo is None:
                raise
            # The `with` blocks on the way out have removed every temporary; earlier outputs are untouched.
            sys.stderr.write(f"dobwind {command}: stopped by {caught.name}; no partial output left\n")
            return 128 + caught.signo


# Errors of a write to an ordinary stream (the OSError then names no file): full disk, quota, I/O, closed.
_WRITE_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EBADF)


def _refuse_closed_stdout_and_special_files(args: argparse.Namespace) -> None:
    from dobwind.specialfiles import refuse_special_inputs

    if sys.stdout is None:  # started with fd 1 closed: Python then has no stdout at all
        raise InputError("stdout", None, "is closed; run with an open standard output (e.g. >/dev/null)")
    refuse_special_inputs(args)


def _reader_went_away() -> int:
    """`dobwind ... | head`: the reader closed the pipe, which is not an error worth a traceback.

    Python flushes stdout again at exit and would report the same broken pipe there, so stdout is
    pointed at /dev/null first (the usual recipe; see the signal module's documentation on SIGPIPE)."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # stdout is not a real file (in-process callers): nothing to flush
        pass
    return EXIT_BROKEN_PIPE


if __name__ == "__main__":
    raise SystemExit(main())
