"""The ``dobwind`` command line (INTERFACES.md section 4).

Every user mistake ends as one stderr line and exit status 2; a failed check as exit status 1.
"""
from __future__ import annotations

import argparse
import json
import sys

import numpy as np
from typing import Any, NoReturn, Sequence

from dobwind.errors import EXIT_BAD_INPUT, EXIT_CHECK_FAILED, CheckFailed, InputError


class _Parser(argparse.ArgumentParser):
    def error(self, message: str) -> NoReturn:  # one line, not argparse's usage block
        sys.stderr.write(f"{self.prog}: error: {message} (see --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)


def _print_json(obj: dict[str, Any]) -> None:
    sys.stdout.write(json.dumps(obj, indent=2, sort_keys=False, allow_nan=False) + "\n")


def cmd_generate(args: argparse.Namespace) -> int:
    from dobwind.codegen.generate import generate_to_dir
    from dobwind.model.airframe import load_airframe

    af = load_airframe(args.airframe)
    out_dir = args.output or f"generated_c/{af.name}"
    files = generate_to_dir(af, out_dir, args.precision)
    for path in files:
        print(path)
    return 0


def cmd_verify(args: argparse.Namespace) -> int:
    from dobwind.harness.verify import verify_airframe
    from dobwind.model.airframe import load_airframe

    af = load_airframe(args.airframe)
    report = verify_airframe(af, args.precision, steps=args.steps, seed=args.seed)
    if args.json:
        _print_json(report.as_dict())
    else:
        print(report.text())
    return 0 if report.passed else EXIT_CHECK_FAILED


def cmd_analyze(args: argparse.Namespace) -> int:
    from dobwind.analysis.report import analyze_command

    return analyze_command(args)


def cmd_check(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.model.step import build_step

    af = load_airframe(args.airframe)
    model = build_step(af)
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


def _default_airframe() -> str:
    from dobwind.demo import REFERENCE_AIRFRAME

    return str(REFERENCE_AIRFRAME)


def cmd_simulate(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.simulate import write_log
    from dobwind.vehicle import load_vehicle

    af = load_airframe(args.airframe or _default_airframe())
    vehicle = load_vehicle(args.vehicle) if args.vehicle else None
    if args.hold is not None and args.hold <= 0:
        raise InputError("simulate", "--hold", "must be > 0 seconds")
    if args.rate is not None and not args.rate > 0:
        raise InputError("simulate", "--rate", "must be > 0 Hz")
    rows = write_log(args.output, af, args.scenario, args.seed, args.hold, args.rate, vehicle, args.vehicle)
    rate = args.rate or (vehicle.rate_hz if vehicle else 50.0)
    print(f"{args.output}: {rows} rows, {rows / rate:.1f} s of '{args.scenario}' at {rate:g} Hz")
    return 0


def cmd_fit(args: argparse.Namespace) -> int:
    from dobwind.fit import fit_airframe, fit_plot, text_report
    from dobwind.logs import write_atomically
    from dobwind.model.airframe import load_airframe
    from dobwind.model.airframe_toml import dump_airframe

    af = load_airframe(args.airframe)
    new, report, points = fit_airframe(af, list(args.logs), args.terms, args.dynamic)
    text = dump_airframe(new)
    write_atomically(args.output, lambda handle: handle.write(text))
    plot = args.plot or str(args.output).removesuffix(".toml") + "_fit.png"
    fit_plot(new, points, plot)
    if args.json:
        _print_json({**report.__dict__, "airframe": str(args.output), "plot": plot})
    else:
        print(text_report(report))
        print(f"wrote {args.output} and {plot}")
    for warning in report.warnings:
        sys.stderr.write(f"dobwind fit: warning: {warning}\n")
    return 0


def cmd_replay(args: argparse.Namespace) -> int:
    from dobwind.model.airframe import load_airframe
    from dobwind.replay import replay, score, text_report, write_output

    af = load_airframe(args.airframe)
    if str(args.log).lower().endswith(".ulg"):
        return _replay_ulog(args, af)
    if args.rate is not None:
        raise InputError(args.log, "--rate", "only applies to ULog files (CSV logs keep their own clock)")
    model, log, traj = replay(af, args.log, args.backend, args.precision)
    if args.output:
        write_output(args.output, log, traj)
    metrics = score(log, traj, model) if log.true_wind is not None else {
        "rows": log.rows, "rejected_rows": int((traj.status != 0).sum())}
    if args.plot:
        from dobwind.plots import replay_plot

        replay_plot(log.time_s, traj.outputs[:, model.outputs.slice("wind_ned")], log.true_wind,
                    f"{af.name}: {args.log}", args.plot)
    if args.json:
        _print_json({"airframe": af.name, "log": str(args.log), "backend": args.backend, **metrics})
    elif log.true_wind is not None:
        print(text_report(metrics))
    else:
        print(f"rows {metrics['rows']}, rejected {metrics['rejected_rows']} (no true wind in the log to score against)")
    return 0


def _replay_ulog(args: argparse.Namespace, af) -> int:
    from dobwind.model.status import describe
    from dobwind.replay import replay_ulog, write_output
    from dobwind.ulog import compare_with_px4

    if args.rate is not None and not args.rate > 0:
        raise InputError("replay", "--rate", "must be > 0 Hz")
    model, flight, traj = replay_ulog(af, args.log, args.backend, args.precision, args.rate)
    log = flight.log
    if args.output:
        write_output(args.output, log, traj)
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    valid = traj.status == 0
    summary = {"airframe": af.name, "log": str(args.log), "backend": args.backend, "rows": log.rows,
               "valid_rows": int(valid.sum()), "duration_s": float(log.time_s[-1]), "notes": list(flight.notes),
               "status_counts": {describe(int(s)): int((traj.status == s).sum()) for s in np.unique(traj.status)},
               "mean_wind_speed_h_mps": float(np.mean(np.hypot(wind[valid, 0], wind[valid, 1]))) if valid.any() else None,
               "outputs_finite": bool(np.all(np.isfinite(traj.outputs)))}
    if flight.px4_wind is not None:
        summary["px4"] = compare_with_px4(log.time_s, wind, valid, flight.px4_wind)
    if args.plot:
        from dobwind.plots import replay_plot

        others = [] if flight.px4_wind is None else [(f"PX4 ({flight.px4_wind[0]})", flight.px4_wind[1], flight.px4_wind[2])]
        replay_plot(log.time_s, np.where(valid[:, None], wind, np.nan), None, f"{af.name}: {args.log}", args.plot, others)
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
    if px4 and px4.get("overlap_rows"):
        print(f"PX4 {px4['topic']}: mean vector difference {px4['mean_vector_difference_mps']:.2f} m/s, mean speed "
              f"difference (ours - PX4) {px4['mean_speed_difference_mps']:+.2f} m/s over {px4['overlap_rows']} instants")
    elif px4:
        print(f"PX4 {px4['topic']}: no overlap with valid estimates")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="dobwind", description="Airframe description -> verified C wind estimator.")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser, metavar="COMMAND")

    p = sub.add_parser("check", help="validate an airframe file and summarise its estimator")
    p.add_argument("airframe")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_check)

    p = sub.add_parser("generate", help="emit C for an airframe")
    p.add_argument("airframe")
    p.add_argument("-o", "--output", help="output folder (default generated_c/<name>/)")
    p.add_argument("--precision", choices=("single", "double"), default="single")
    p.set_defaults(func=cmd_generate)

    p = sub.add_parser("verify", help="generate, compile strictly, compare with the Python reference")
    p.add_argument("airframe")
    p.add_argument("--precision", choices=("single", "double", "both"), default="both")
    p.add_argument("--steps", type=int, default=20000, help="length of the simulated flight compared step by step")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_verify)

    p = sub.add_parser("analyze", help="observer and filter poles, bandwidth, Bode plots")
    p.add_argument("airframe")
    p.add_argument("-o", "--output", help="folder for the PNG plots")
    p.add_argument("--json", action="store_true")
    p.add_argument("--freq", type=float, nargs="+", default=[0.1, 0.5, 1.0], help="frequencies (Hz) to report")
    p.add_argument("--bandwidth", type=float, help="print the gains that give this observer bandwidth (Hz)")
    p.set_defaults(func=cmd_analyze)

    p = sub.add_parser("fit", help="fit the force-air model from logs with true wind")
    p.add_argument("airframe")
    p.add_argument("logs", nargs="+")
    p.add_argument("-o", "--output", required=True, help="the new airframe file")
    p.add_argument("--terms", choices=("airframe", "auto"), default="airframe",
                   help="fit the airframe's terms, or choose them from a library by cross-validation")
    p.add_argument("--plot", help="PNG of the fitted surface and residuals (default: beside the output)")
    p.add_argument("--dynamic", action="store_true",
                   help="calibrate on manoeuvring flight too (constant wind), not only on steady holds")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_fit)

    p = sub.add_parser("replay", help="run the estimator over a flight log")
    p.add_argument("airframe")
    p.add_argument("log")
    p.add_argument("-o", "--output")
    p.add_argument("--backend", choices=("python", "c"), default="python")
    p.add_argument("--precision", choices=("single", "double"), default="single", help="C backend precision")
    p.add_argument("--rate", type=float, help="ULog only: resample at this rate (Hz) instead of the attitude's clock")
    p.add_argument("--plot")
    p.add_argument("--json", action="store_true")
    p.set_defaults(func=cmd_replay)

    p = sub.add_parser("simulate", help="synthesize a flight log with known wind")
    p.add_argument("scenario", help="sweep | vertical | tunnel | still-air | outdoor")
    p.add_argument("--airframe", help="default: airframes/m300.toml")
    p.add_argument("-o", "--output", required=True)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--hold", type=float, help="seconds per hold (default: the scenario's own)")
    p.add_argument("--rate", type=float, help="sample rate in Hz (default 50, or the vehicle file's rate)")
    p.add_argument("--vehicle", help="the true vehicle's physics and sensors (TOML; default: a vehicle of the "
                   "airframe's size with built-in drag)")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("demo", help="the whole pipeline on the reference airframe")
    p.add_argument("-o", "--output", default="out/demo")
    p.set_defaults(func=cmd_demo)
    return parser


def cmd_demo(args: argparse.Namespace) -> int:
    from dobwind.demo import run_demo

    return run_demo(args.output)


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args))
    except InputError as exc:
        sys.stderr.write(f"dobwind {args.command}: {exc}\n")
        return EXIT_BAD_INPUT
    except CheckFailed as exc:
        sys.stderr.write(f"dobwind {args.command}: {exc}\n")
        return EXIT_CHECK_FAILED


if __name__ == "__main__":
    raise SystemExit(main())
