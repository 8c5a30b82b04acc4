"""`dobwind fit AIRFRAME LOG... -o NEW.toml`: the force-air model fitted from logs with a known wind,
self-checked, and written only when the self-check passes (or with --force)."""
from __future__ import annotations

import argparse
import re
import sys

from dobwind.cli.common import AIRFRAME_HELP, JSON_HELP, Command, print_json
from dobwind.core import options as opt
from dobwind.core.errors import CheckFailed, InputError
from dobwind.io.outputs import AIRFRAME, PNG, OutputFiles, Target, check_targets


def add(command: Command) -> None:
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
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    try:
        return _run(args)
    except CheckFailed as exc:
        raise CheckFailed(naming_logs(list(args.logs), str(exc))) from None


def naming_logs(logs: list[str], message: str) -> str:
    """A refusal (exit 1) as one line that names the logs it is about (../shared/spec/INTERFACES.md: the line
    names the file): the fit's own reasons ("no airborne row of the logs is accepted", "only 0 usable
    samples") are about the logs as a whole and did not name them. A message that names a log (the one at
    fault: "b.csv: contributed no usable sample") is kept; a log's path counts as named only as a whole name,
    not inside a longer one ("a.csv" is not named by "data.csv")."""
    if any(_names(message, log) for log in logs):
        return message
    names = ", ".join(logs) if len(logs) <= 3 else f"{', '.join(logs[:2])} and {len(logs) - 2} more logs"
    return f"{names}: {message}"


def _names(message: str, log: str) -> bool:
    """Whether the message holds the path `log` not joined to more of a path or a name on either side."""
    edge = r"[\w./\\-]"
    return re.search(rf"(?<!{edge}){re.escape(log)}(?!\w|[/\\-]|\.\w)", message) is not None


def _run(args: argparse.Namespace) -> int:
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
    refuse_repeated_logs(list(args.logs))
    targets = [Target("-o", args.output, refused=AIRFRAME), Target("--plot", plot, suffixes=PNG)]
    options = field_options(args)
    check_targets(targets, [args.airframe, *args.logs, *options.files()])
    af = load_airframe(args.airframe)
    from dobwind.io.accelcheck import calibration_warnings

    for warning in calibration_warnings(af, list(args.logs)):  # said first: a refusal below may follow from it
        sys.stderr.write(f"dobwind fit: warning: {warning}\n")
    field = field_truth(options, af, list(args.logs))  # --wind unknown: the winds solved here (or exit 1)
    if field is not None:  # every fit of the logs below reads them with that truth
        fit_airframe = functools.partial(fit_airframe, log_reader=field.reader, direction_shape=field.direction_shape)
    limits = Thresholds(cv_share=args.max_error_share, replay_share=args.max_error_share,
                        floor_mps=args.error_floor, direction_deg=args.max_direction_error)
    hover = HoverNoise(target_mps=args.hover_noise)
    def fit(logs: list[str]):
        return fit_airframe(af, logs, args.terms, args.dynamic, args.model, args.still_air, limits, hover=hover)

    new, report, points = fit(list(args.logs))
    if args.exclude_outliers:
        from dobwind.calibrate.fitfamily import refit_without_outliers

        new, report, points = refit_without_outliers((new, report, points), list(args.logs), fit)
    passed = bool(report.self_check.passed)
    written = passed or args.force  # a model that failed its self-check is written only when forced
    if written:
        text = (field.header(list(args.logs)) if field else "") + dump_airframe(new)
        refuse_out_of_range(text, args.output)
        with OutputFiles(targets) as out:
            write_atomically(out.stage(args.output), lambda handle: handle.write(text))
            fit_plot(new, points, str(out.stage(plot)))
    if args.json:
        print_json({**report.as_dict(), "written": written, "airframe": str(args.output) if written else None,
                     "plot": plot if written else None, **({"wind_truth": field.record(list(args.logs))} if field else {})})
    else:
        from dobwind.calibrate.fieldfit import truth_lines

        print(text_report(report))
        print("\n".join(truth_lines(field, list(args.logs), args.still_air)))
        for line in field.summary if field else []:
            print(line)
        print(text_table(report.self_check))
        print(f"wrote {args.output} and {plot}" if written else "nothing written")
    for warning in report.warnings + (field.warnings() if field else []):
        sys.stderr.write(f"dobwind fit: warning: {warning}\n")
    return _fit_verdict(args, report)


def refuse_repeated_logs(logs: list[str]) -> None:
    """One log given twice: its wind truth is keyed by the log (`wind_truth.per_log`, the self-check's
    per-log lines), so a second `--wind` for it was silently dropped, and its rows would count twice."""
    import os

    seen: dict[object, str] = {}
    for log in logs:
        try:
            st = os.stat(log)
            key: object = (st.st_dev, st.st_ino)  # the same file under two names (./a.ulg, a link)
        except OSError:
            key = os.path.abspath(log)  # missing: the reader names it later
        if key in seen:
            said = "" if seen[key] == log else f" (as {seen[key]})"
            raise InputError(log, None, f"is given twice{said}: give each calibration log once")
        seen[key] = log


def refuse_out_of_range(text: str, output: str) -> None:
    """The fitted airframe goes through the loader before it is written: a file that `check` would
    refuse is never written (absurd logs can fit a thrust scale or a coefficient out of range)."""
    from dobwind.model.airframe import parse_airframe

    try:
        parse_airframe(text, output)
    except InputError as exc:
        raise InputError(output, exc.where, f"the fitted airframe would be refused: {exc.message}; "
                         "nothing written (check the logs' units)") from None


def _fit_verdict(args: argparse.Namespace, report) -> int:
    """Exit 0 on a passing self-check; else say why (and which log disagrees) and refuse unless --force."""
    if report.self_check.passed:
        return 0
    reasons = "; ".join(report.self_check.reasons)
    from dobwind.calibrate.runmeans import outlier_advice

    advice = None if args.exclude_outliers else outlier_advice(report.runs)
    reasons += f" (what would make the data fit: {advice})" if advice else ""
    if args.force:
        sys.stderr.write(f"dobwind fit: warning: the self-check failed ({reasons}); written anyway (--force)\n")
        return 0
    raise CheckFailed(f"the fitted model cannot be trusted: {reasons}; nothing written (--force writes it anyway)")
