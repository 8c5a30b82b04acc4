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

from dobwind.core import options as opt
from dobwind.cli.helpfmt import DefaultsFormatter
from dobwind.core.resources import shipped_airframe_names
from dobwind.core.version import package_version
from dobwind.core.errors import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, CheckFailed, InputError
from dobwind.core.interrupts import Interrupted, signals_raise
from dobwind.io.outputs import OutputFiles, Target, check_replaceable, check_targets

EXIT_BROKEN_PIPE = 141  # 128 + SIGPIPE, what a shell reports for a C tool killed by the closed pipe


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, not argparse's usage block
        sys.stderr.write(f"{self.prog}: error: {message} (see --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)


def _print_json(obj: dict[str, Any]) -> None:
    from dobwind.io.jsonout import print_json

    print_json(obj)


def cmd_generate(args: argparse.Namespace) -> int:
    from dobwind.model.stability import require_stable
    from dobwind.codegen.generate import is_generated_name
    from dobwind.generate.emit import generate_to_dir
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
    files = generate_to_dir(af, out_dir, args.precision, source=args.airframe, integration=args.target,
                            gate=gate)
    for path in files:
        print(path)
    return 0


def _selftest_gate(name: str, folder: Path, command: str = "generate") -> None:
    from dobwind.harness.build import system_compiler
    from dobwind.generate.selftest_gate import run_selftest

    result = run_selftest(folder, name, system_compiler())
    if not result.ran:
        sys.stderr.write(f"dobwind {command}: warning: {result.summary}\n")


def cmd_verify(args: argparse.Namespace) -> int:
    from dobwind.codegen.generate import refuse_ill_conditioned_terms
    from dobwind.harness.verify import verify_airframe
    from dobwind.model.airframe import load_airframe

    af = load_airframe(args.airframe)
    if args.c_dir is None and args.precision in ("single", "both"):
        refuse_ill_conditioned_terms(af, args.airframe)  # generate refuses them: nothing to verify
    try:
        report = verify_airframe(af, args.precision, steps=args.steps, seed=args.seed,
                                 c_dir=None if args.c_dir is None else Path(args.c_dir), flags=args.flags)
    except InputError as exc:
        if exc.source != af.name:
            raise
        raise InputError(args.airframe, exc.where, exc.message) from None  # name the file, not the airframe
    if args.json:
        _print_json(report.as_dict())
    else:
        print(report.text())
    return 0 if report.passed else EXIT_CHECK_FAILED


def cmd_analyze(args: argparse.Namespace) -> int:
    from dobwind.cli.analyze import analyze_command

    return analyze_command(args)


def cmd_check(args: argparse.Namespace) -> int:
    from dobwind.model.stability import require_stable
    from dobwind.model.airframe import load_airframe
    from dobwind.model.step import build_step

    af = load_airframe(args.airframe)
    require_stable(af, "generate would refuse it", args.airframe)
    model = build_step(af)
    _refuse_what_generate_refuses(af, model, args.airframe, selftest=not args.no_selftest)
    summary = {
        "name": af.name,
        "mass_kg": af.mass_kg,
        "thrust": af.thrust.source,
        "discretization": af.observer.discretization,
        "acceleration": af.observer.acceleration,
        "calibration": af.calibration,  # "prior": every accepted sample carries UNCALIBRATED
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


def _refuse_what_generate_refuses(af: Any, model: Any, source: str, selftest: bool = True) -> None:
    """Renders the C in both precisions and discards it: every static refusal of `generate` (a constant
    that rounds to 0 in a float, an ill-conditioned term) then stops `check` too, with the same line.
    With ``selftest`` the rendered C also goes through generate's last gate (compiled and run against its
    golden vectors), so `check` never accepts an airframe that `generate` would then refuse."""
    import tempfile

    from dobwind.codegen.generate import generate_code, write_files

    for precision in ("single", "double"):
        code = generate_code(af, precision, model, source=source)
        if not selftest:
            continue
        with tempfile.TemporaryDirectory(prefix="dobwind-check-") as work:
            write_files(code.files, work)
            _selftest_gate(af.name, Path(work), "check")


def _default_airframe() -> str:
    from dobwind.core.resources import shipped_airframe

    return str(shipped_airframe())


def cmd_simulate(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.simulate.simulate import write_log
    from dobwind.simulate.vehicle import load_vehicle

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
    from dobwind.calibrate.fitreport import fit_plot, text_report
    from dobwind.calibrate.fitfamily import fit_airframe
    from dobwind.io.logs import write_atomically
    from dobwind.model.airframe import load_airframe
    from dobwind.model.airframe_toml import dump_airframe
    from dobwind.calibrate.hovernoise import HoverNoise
    from dobwind.calibrate.selfcheck import Thresholds, text_table

    import functools

    from dobwind.calibrate.fieldfit import field_options, field_truth

    plot = args.plot if args.plot is not None else str(args.output).removesuffix(".toml") + "_fit.png"
    targets = [Target("-o", args.output), Target("--plot", plot)]
    options = field_options(args)
    check_targets(targets, [args.airframe, *args.logs, *options.files()])
    af = load_airframe(args.airframe)
    field = field_truth(options, af, list(args.logs))  # --wind unknown: the winds solved here (or exit 1)
    if field is not None:  # every fit of the logs below reads them with that truth
        fit_airframe = functools.partial(fit_airframe, log_reader=field.reader)
    limits = Thresholds(cv_share=args.max_error_share, replay_share=args.max_error_share,
                        floor_mps=args.error_floor, direction_deg=args.max_direction_error)
    hover = HoverNoise(target_mps=args.hover_noise)
    def fit(logs: list[str]):
        return fit_airframe(af, logs, args.terms, args.dynamic, args.model, args.still_air, limits, hover=hover)

    new, report, points = fit(list(args.logs))
    if args.exclude_outliers:
        from dobwind.calibrate.fitfamily import refit_without_outliers

        new, report, points = refit_without_outliers((new, report, points), list(args.logs), fit)
    passed = bool(report.self_check["passed"])
    written = passed or args.force  # a model that failed its self-check is written only when forced
    if written:
        text = (field.header(list(args.logs)) if field else "") + dump_airframe(new)
        _refuse_out_of_range(text, args.output)
        with OutputFiles(targets) as out:
            write_atomically(out.stage(args.output), lambda handle: handle.write(text))
            fit_plot(new, points, str(out.stage(plot)))
    if args.json:
        _print_json({**report.__dict__, "written": written, "airframe": str(args.output) if written else None,
                     "plot": plot if written else None, **({"wind_truth": field.record()} if field else {})})
    else:
        print(text_report(report))
        for line in field.summary if field else []:
            print(line)
        print(text_table(report.self_check))
        print(f"wrote {args.output} and {plot}" if written else "nothing written")
    for warning in report.warnings + (field.warnings() if field else []):
        sys.stderr.write(f"dobwind fit: warning: {warning}\n")
    return _fit_verdict(args, report)


def _fit_verdict(args: argparse.Namespace, report) -> int:
    """Exit 0 on a passing self-check; else say why (and which log disagrees) and refuse unless --force."""
    if report.self_check["passed"]:
        return 0
    reasons = "; ".join(report.self_check["reasons"])
    from dobwind.calibrate.runmeans import outlier_advice

    advice = None if args.exclude_outliers else outlier_advice(report.runs)
    reasons += f" (what would make the data fit: {advice})" if advice else ""
    if args.force:
        sys.stderr.write(f"dobwind fit: warning: the self-check failed ({reasons}); written anyway (--force)\n")
        return 0
    raise CheckFailed(f"the fitted model cannot be trusted: {reasons}; nothing written (--force writes it anyway)")


def cmd_replay(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.replay.replay import text_report
    from dobwind.cli.campaign import is_many

    if is_many(args.log):  # several logs or a folder of them: dobwind/cli/replaymany.py
        from dobwind.cli.replaymany import replay_many

        return replay_many(args, main)
    args.log = args.log[0]
    check_targets(_replay_targets(args), [args.airframe, args.log])
    if _netcdf(args.output):
        from dobwind.atmos.ncreplay import require_netcdf

        require_netcdf(args.output)
    af = load_airframe(args.airframe)
    _warn_uncalibrated(af, args.airframe)
    if args.backend == "c" and args.precision == "single":
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
        _print_json({"airframe": af.name, "log": str(args.log), "backend": args.backend, **metrics,
                     "plausibility": [f.as_dict() for f in result.findings]})
    elif result.scored:
        print(text_report(metrics))
    else:
        print(f"rows {metrics['rows']}, rejected {metrics['rejected_rows']} (no true wind in the log to score against)")
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
            from dobwind.io.plots import replay_plot

            series = result.series
            replay_plot(series.t, series.wind, series.truth,
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
    from dobwind.replay.replay import autopilot_summary, replay_ulog, write_output

    model, flight, traj = replay_ulog(af, args.log, args.backend, args.precision, args.rate, _topic_overrides(args))
    for warning in flight.warnings:
        sys.stderr.write(f"dobwind replay: warning: {warning}\n")
    log = flight.log
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    valid = accepted(traj.status)  # quality-flagged samples are estimates too; status_counts shows the flags
    summary = autopilot_summary(af.name, str(args.log), args.backend, model, flight, traj)
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
            from dobwind.replay.replay import autopilot_plot

            autopilot_plot(str(out.stage(args.plot)), f"{af.name}: wind estimated over {os.path.basename(args.log)}",
                           flight, wind, traj.status)
    if args.json:
        _print_json(summary)
        return 0
    print(f"{log.rows} instants over {summary['duration_s']:.2f} s, {summary['valid_rows']} valid; status: "
          + ", ".join(f"{k} {v}" for k, v in summary["status_counts"].items()))
    for note in flight.notes:
        print(f"  note: {note}")
    if summary["mean_wind_speed_h_mps"] is not None:
        print(f"mean horizontal wind {summary['mean_wind_speed_h_mps']:.2f} m/s")
    from dobwind.replay.replay import autopilot_wind_lines

    for line in autopilot_wind_lines(summary.get("px4")):
        print(line)
    return 0


class _VersionAction(argparse.Action):
    """--version, looked up only when asked: the package metadata costs 45 ms of every other command."""

    def __init__(self, option_strings: list[str], dest: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings, dest, nargs=0, default=argparse.SUPPRESS, help=help)

    def __call__(self, parser, namespace, values, option_string=None) -> None:  # type: ignore[no-untyped-def]
        print(f"dobwind {package_version()}")  # stdout, as argparse's own version action prints
        parser.exit()


AIRFRAME_HELP = ("airframe TOML file (see docs/formats.md for its keys and units), or the name of a shipped one "
                 f"({', '.join(shipped_airframe_names())}) when no such file exists")
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
    _add_profile(command)
    _add_report(command)
    _add_demo(command)
    _add_inspect(command)
    _add_init(command)
    return parser


def _add_check(command: _Command) -> None:
    p = command("check", "validate an airframe file and summarise its estimator")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.add_argument("--no-selftest", action="store_true",
                   help="skip generate's last gate: by default the C is rendered in both precisions, compiled with "
                   "the host compiler ($CC, default cc) with its self-test and run, and an airframe whose C fails its "
                   "golden vectors is refused (exit 1), as generate would refuse it")
    p.set_defaults(func=cmd_check)


def _add_generate(command: _Command) -> None:
    p = command("generate", "emit C for an airframe")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("-o", "--output", help="output folder (default: generated_c/<name>/ in the working directory)")
    p.add_argument("--precision", choices=("single", "double"), default="single",
                   help="floating-point type of the generated C: float (single) or double")
    p.add_argument("--target", choices=("px4", "ardupilot"), help="also write that autopilot's integration "
                   "beside the C: px4/ (a PX4 work-queue module, its .msg and parameter) or AP_DOBWind/ (an "
                   "ArduPilot library with its DataFlash message); single precision (default: the C only)")
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
    p.add_argument("--flags", choices=("px4", "ardupilot"), help="also build with that autopilot's own compile "
                   "flags (gcc, clang, arm-none-eabi-gcc; C and C++, -Werror), and build the self-test and the "
                   "library compared with the reference with them; ardupilot: single precision only "
                   "(default: none)")
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
    p.add_argument("--bandwidth", type=opt.DESIGN_TARGET, help="design the observer gains (kg/s, equal on x y z) that give "
                   f"this -3 dB bandwidth, Hz ({opt.DESIGN_TARGET.text()}; Hz below the Nyquist frequency), or "
                   "this wind noise along the airflow or ramp lag at an airspeed, then analyse the airframe with "
                   "those gains (default: none, analyse the gains in the file)")
    p.add_argument("--airspeed", type=opt.AIRSPEED, nargs="+", default=[],
                   help=f"airspeeds to report the wind-unit figures at besides the schedule's breakpoints, m/s "
                        f"({opt.AIRSPEED.text()}; at most {opt.MAX_AIRSPEEDS})")
    p.add_argument("--force-noise", type=opt.FORCE_NOISE, metavar="N",
                   help="1-sigma scatter of the observer's horizontal force estimate before the low-pass, per "
                        f"axis, at the file's gains, N ({opt.FORCE_NOISE.text()}); default: from the wind noise "
                        "the fit recorded in the airframe ([uncertainty] noise_h), else the wind noise is not given")
    p.set_defaults(func=cmd_analyze)


def _add_fit(command: _Command) -> None:
    p = command("fit", "fit the force-air model from logs with true wind")
    p.add_argument("airframe", help=AIRFRAME_HELP + "; its mass, thrust model and observer are kept")
    p.add_argument("logs", nargs="+", help="calibration flight logs: CSVs with true wind columns (docs/formats.md), "
                   "or autopilot logs (.ulg, .bin, ROS 2 bags) with --wind or --truth")
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
    from dobwind.calibrate.fieldfit import add_options

    add_options(p)
    p.add_argument("--plot", help="PNG of the fitted surface and residuals (default: OUTPUT without .toml + _fit.png)")
    p.add_argument("--dynamic", action="store_true",
                   help="calibrate on manoeuvring flight too (constant wind), not only on steady holds")
    p.add_argument("--force", action="store_true",
                   help="write the airframe even when the self-check fails (exit 0, with a warning)")
    from dobwind.calibrate.thresholds import Thresholds  # not dobwind.calibrate.selfcheck: that imports scipy for every command

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
    from dobwind.calibrate.hovernoise import HoverNoise

    hover = HoverNoise()
    p.add_argument("--hover-noise", type=opt.HOVER_NOISE, default=hover.target_mps, metavar="MPS",
                   help="the wind estimate's noise per horizontal axis at low airflow that the fit aims for: when "
                   "the self-check measures more, the low-pass's cutoff at zero airflow is lowered (never below "
                   f"{hover.floor_hz:g} Hz, never raised), and when it stays above, an acceleration input is blended "
                   "with the velocity's derivative at low frequency (acceleration_bias_time 0.5 s) if that fit is "
                   f"clearly quieter and passes its self-check; 0 keeps the airframe's schedule and observer ({opt.HOVER_NOISE.text()}; "
                   f"default {hover.target_mps:g})")
    p.add_argument("--exclude-outliers", action="store_true",
                   help="when the fit flags calibration logs as outliers (a log whose mean airflow disagrees with "
                   "the others', docs/tunnel-runs.md), fit again without them; the report names the logs left out")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=cmd_fit)


def _add_replay(command: _Command) -> None:
    p = command("replay", "run the estimator over a flight log")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("log", nargs="+", help="flight log: CSV (docs/formats.md), PX4 ULog (.ulg), ArduPilot DataFlash "
                   "(.bin) or ROS 2 bag; several logs or a folder of logs are replayed in parallel (docs/atmospheric.md)")
    p.add_argument("-o", "--output", help="estimate CSV, one row per log row (docs/formats.md), or CF-NetCDF when the "
                   "name ends in .nc; with several logs a folder, one file per log named after it (default: none, "
                   "not written)")
    p.add_argument("--backend", choices=("python", "c"), default="python",
                   help="run the CasADi reference (python) or the generated C, compiled on the fly (c)")
    p.add_argument("--precision", choices=("single", "double"), default="single", help="C backend precision")
    p.add_argument("--rate", type=opt.ULOG_RATE,
                   help=f"autopilot logs only: resample at this rate, Hz ({opt.ULOG_RATE.text()}) (default: none, "
                   "the airframe's observer rate, 1/observer.sample_time)")
    p.add_argument("--px4-wind", help="autopilot logs: also write the estimate as PX4's wind message holds it "
                   "(timestamp, north/east wind and their variances) to this CSV (default: none)")
    p.add_argument("--topic", action="append", metavar="ROLE=NAME",
                   help="ROS 2 bags: a topic name other than the default (roles: see docs; repeatable) "
                   "(default: none)")
    p.add_argument("--plot", help="PNG of the estimated wind against the truth or the autopilot's wind "
                   "(default: none, not drawn)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    _add_many_options(p, "replay")
    p.add_argument("--format", choices=("csv", "nc"), default="csv",
                   help="several logs: the format of each estimate file in the -o folder (default: csv)")
    p.set_defaults(func=cmd_replay)


def _add_many_options(p: argparse.ArgumentParser, what: str) -> None:
    from dobwind.cli.campaign import JOBS, default_jobs

    p.add_argument("--jobs", type=JOBS, default=default_jobs(), metavar="N",
                   help=f"several logs: {what} N logs at once in worker processes ({JOBS.text()}; default: one "
                   "per core)")


def _add_profile(command: _Command) -> None:
    from dobwind.atmos.profile import BIN

    p = command("profile", "wind speed, direction and vertical wind binned by height above take-off, over "
                "one or many flights")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("logs", nargs="+", help="flight logs (autopilot logs with global position; CSV logs with "
                   "lat, lon, alt columns, else height from vel_d) or folders of them")
    p.add_argument("-o", "--output", required=True, help="the profile to write: .csv or CF-NetCDF .nc (required)")
    p.add_argument("--bin", type=BIN, default=5.0, metavar="M", help=f"height bin, m ({BIN.text()}; default 5)")
    p.add_argument("--plot", help="PNG of speed, direction and vertical wind against height with wind barbs "
                   "(default: none, not drawn)")
    p.add_argument("--allow", action="append", metavar="FLAG",
                   help="also use rows carrying this quality flag (e.g. extrapolated; repeatable; default: none, "
                   "status 0 rows only)")
    p.add_argument("--backend", choices=("python", "c"), default="python",
                   help="run the CasADi reference (python) or the generated C, compiled on the fly (c)")
    p.add_argument("--precision", choices=("single", "double"), default="single", help="C backend precision")
    p.add_argument("--rate", type=opt.ULOG_RATE,
                   help=f"autopilot logs only: resample at this rate, Hz ({opt.ULOG_RATE.text()}) (default: none, "
                   "the airframe's observer rate, 1/observer.sample_time)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    _add_many_options(p, "profile")
    p.set_defaults(func=cmd_profile)


def cmd_profile(args: argparse.Namespace) -> int:
    from dobwind.cli.profile import profile_command

    return profile_command(args)


def _add_simulate(command: _Command) -> None:
    p = command("simulate", "synthesize a flight log with known wind")
    p.add_argument("scenario", help="sweep (the paper's calibration) | vertical (climbs and descents) | tunnel "
                   "(60 deg, 3-10 m/s) | still-air (manoeuvres) | outdoor (turbulent) | box (legs along 4 tracks, out and "
                   "back, in a steady wind: for fit --wind unknown) | one-heading (the same legs along one track, the "
                   "nose never turning)")
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


def _add_inspect(command: _Command) -> None:
    p = command("inspect", "what an autopilot or CSV log holds for the estimator: streams and rates, airborne "
                "time, the autopilot's wind, parameters, vehicle, and the inputs replay would use")
    p.add_argument("log", help="flight log: PX4 ULog (.ulg), ArduPilot DataFlash (.bin), ROS 2 bag (.mcap, "
                   ".db3 or its folder) or CSV (docs/formats.md)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=cmd_inspect)


def cmd_inspect(args: argparse.Namespace) -> int:
    from dobwind.inspect.anylog import inspect_log
    from dobwind.inspect.loginspect import text_report

    summary = inspect_log(args.log)
    if args.json:
        _print_json(summary.as_dict())
    else:
        print(text_report(summary))
    return 0


def _add_init(command: _Command) -> None:
    p = command("init", "a starter airframe (an uncalibrated prior) for the vehicle that flew a log")
    p.add_argument("log", help="flight log: PX4 ULog (.ulg), ArduPilot DataFlash (.bin), ROS 2 bag or CSV")
    p.add_argument("--mass", type=float, required=True, help="the vehicle's take-off mass, kg (required)")
    p.add_argument("-o", "--output", required=True, help="the airframe TOML to write (required; never the log)")
    p.add_argument("--name", default=None, help="airframe name, [a-z][a-z0-9_]* (default: from the output file name)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.set_defaults(func=cmd_init)


def cmd_init(args: argparse.Namespace) -> int:
    from dobwind.inspect.initframe import run_init

    return run_init(args.log, args.mass, args.output, args.name, args.json)


def cmd_report(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.report.report import flight_report

    target = Target("-o", args.output)
    check_targets([target], [args.airframe, args.log])
    af = load_airframe(args.airframe)
    page, summary = flight_report(af, args.airframe, args.log, args.backend, args.precision)
    with OutputFiles([target]) as out:
        from dobwind.io.atomic import write_text_atomically

        write_text_atomically(out.stage(args.output), lambda handle: handle.write(page))
    print(f"wrote {args.output} ({len(page) // 1024} KiB): {summary}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    from dobwind.cli.demo import is_demo_name, run_demo

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
    from dobwind.io.specialfiles import refuse_special_inputs

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
