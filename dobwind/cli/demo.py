"""`dobwind demo`: from nothing to the paper's table, on the reference airframe.

simulate the calibration (the paper's sweep, 20 s holds, and climbs/descents) -> fit (terms chosen
by cross-validation) -> analyze -> generate -> verify -> replay the tunnel, still-air and outdoor
scenarios through the generated C (single precision) -> our numbers beside the paper's and beside the
classic tilt-angle method calibrated on the same sweep.
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import TYPE_CHECKING

from dobwind.cli.common import Command
from dobwind.core.resources import shipped_airframe
from dobwind.io.outputs import Target, check_replaceable, check_targets, staged_folder
from dobwind.model.kinds import Precision

if TYPE_CHECKING:
    from dobwind.model.airframe import Airframe

# The pipeline's modules (CasADi, SciPy, Matplotlib: seconds) are imported by the steps that use them,
# not when the command line's parser is built.

REFERENCE_AIRFRAME = shipped_airframe()  # package data: works from a wheel as from the checkout
SCENARIO_SEEDS = {"sweep": 1, "vertical": 2, "tunnel": 3, "still-air": 4, "outdoor": 5}

PAPER = {"tunnel_speed": "0.11 / 0.21", "tunnel_direction": "2.8 / 5.3",
         "still_air": "0.35 / 0.40"}  # hover baseline 0.21 / 0.22 plus 0.14 / 0.18 in manoeuvres


def _fmt(a: float | None, b: float | None, digits: int = 3) -> str:
    return "-" if a is None or b is None else f"{a:.{digits}f} / {b:.{digits}f}"


def add(command: Command) -> None:
    p = command("demo", "the whole pipeline on the reference airframe")
    p.add_argument("-o", "--output", default="out/demo", help="folder for logs, fitted airframe, plots and C")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    target = Target("-o", args.output, "dir")
    check_targets([target])
    check_replaceable(target, is_demo_name)
    return run_demo(args.output)


def is_demo_name(name: str) -> bool:
    """What the demo writes into its folder: the only entries a folder it replaces may hold."""
    return (name in ("logs", "analysis", "c", "fit.png") or name.endswith("_fitted.toml")
            or (name.startswith("replay_") and name.endswith(".png")))


def run_demo(out_dir: str) -> int:
    """Builds the whole demo folder beside ``out_dir`` and swaps it in at the end: an interrupted or
    failed demo leaves the previous one as it was."""
    with staged_folder(Target("-o", out_dir, "dir")) as work:
        return _pipeline(work, Path(out_dir))


def _pipeline(out: Path, shown: Path) -> int:
    """Writes into ``out``; names ``shown`` (where the folder will be) in what it prints."""
    from dobwind.analysis.report import analyze, write_plots
    from dobwind.model.airframe import load_airframe

    start = time.perf_counter()
    af = load_airframe(REFERENCE_AIRFRAME)
    logs = _simulate(af, out, shown)
    fitted = _fit(af, logs, out)
    report, systems = analyze(fitted, [0.1, 0.5, 1.0])
    write_plots(report, systems, out / "analysis")
    obs, ramp = report["observer"][0], report["ramp"]
    print(f"== analyze: observer bandwidth {obs['bandwidth_hz']:.3f} Hz (paper 0.5 Hz); schedule "
          f"{'stable' if report['schedule']['stable'] else 'UNSTABLE'}; ramp lag {ramp['lag_reduction_s']:.2f} s less than "
          f"a fixed {ramp['fixed_cutoff_hz']:g} Hz filter (paper 2.2 s); plots in {shown / 'analysis'}")
    passed = _generate_and_verify(fitted, out, shown)
    _print_results(_replay_scenarios(af, fitted, logs, out), shown)
    _time_reference(fitted, start)
    return 0 if passed and report["stable"] else 1


def _simulate(af: Airframe, out: Path, shown: Path) -> dict[str, str]:
    """The demo's scenario logs: name -> CSV path."""
    from dobwind.simulate.simulate import write_log

    logs = {}
    for name, seed in SCENARIO_SEEDS.items():
        path = out / "logs" / f"{name}.csv"
        write_log(path, af, name, seed)
        logs[name] = str(path)
    print(f"== simulate: {', '.join(f'{n} ({Path(p).stat().st_size // 1_000_000} MB)' for n, p in logs.items())} "
          f"in {shown / 'logs'}")
    return logs


def _fit(af: Airframe, logs: dict[str, str], out: Path) -> Airframe:
    """Calibrate on the sweep and vertical logs; writes the fitted airframe and its plot."""
    from dobwind.calibrate.fitfamily import fit_airframe
    from dobwind.calibrate.fitreport import fit_plot, text_report
    from dobwind.io.logs import write_atomically
    from dobwind.model.airframe_toml import dump_airframe, rehashed

    fitted, fit_report, points = fit_airframe(af, [logs["sweep"], logs["vertical"]], "auto")
    fitted_path = out / f"{af.name}_fitted.toml"
    fitted = rehashed(fitted)  # the C generated from it names this file, not the one fitted from
    text = dump_airframe(fitted)
    write_atomically(fitted_path, lambda handle: handle.write(text))
    fit_plot(fitted, points, str(out / "fit.png"))
    print("== fit (sweep + vertical, --terms auto): " + text_report(fit_report).replace("\n", "\n   "))
    for warning in fit_report.warnings:
        print(f"   warning: {warning}")
    return fitted


def _generate_and_verify(fitted: Airframe, out: Path, shown: Path) -> bool:
    from dobwind.generate.emit import generate_to_dir
    from dobwind.harness.verify import verify_airframe

    written = generate_to_dir(fitted, out / "c" / fitted.name, Precision.SINGLE)
    print(f"== generate: {', '.join(p.name for p in written)} in {shown / 'c' / fitted.name}")
    verification = verify_airframe(fitted, "both", steps=20000)
    worst = {p.precision: p.flight.worst_ratio for p in verification.precisions if p.flight}
    print(f"== verify: {'PASS' if verification.passed else 'FAIL'} (worst error / tolerance: double {worst['double']:.3g}, "
          f"single {worst['single']:.3g}; {verification.builds_text()}, self-test)")
    return verification.passed


def _replay_scenarios(af: Airframe, fitted: Airframe, logs: dict[str, str], out: Path) -> dict[str, tuple[dict, dict]]:
    """Scenario -> (our scores through the single-precision C, the tilt method's); draws each replay."""
    import numpy as np

    from dobwind.io.logs import read_log, required_columns
    from dobwind.io.plots import replay_plot
    from dobwind.replay import baseline
    from dobwind.replay.replay import replay, score, score_wind

    tilt = baseline.calibrate([read_log(logs["sweep"], required_columns(af) + [("wind_n", "truth")])])
    results = {}
    for name in ("tunnel", "still-air", "outdoor"):
        model, log, traj = replay(fitted, logs[name], backend="c", precision=Precision.SINGLE)
        ours = score(log, traj, model)
        tilt_wind = baseline.estimate(tilt, log)
        theirs = score_wind(log, tilt_wind, np.zeros(log.rows, dtype=int))
        no_vertical = np.column_stack([tilt_wind[:, :2], np.full(log.rows, np.nan)])  # tilt has no vertical estimate
        replay_plot(log.time_s, traj.outputs[:, model.outputs.slice("wind_ned")], log.true_wind,
                    f"{fitted.name}, '{name}' scenario: estimated and true wind (C, single precision)",
                    str(out / f"replay_{name}.png"), others=[("tilt method", log.time_s, no_vertical)])
        results[name] = (ours, theirs)
    return results


def _print_results(results: dict[str, tuple[dict, dict]], shown: Path) -> None:
    """The table beside the paper's figures."""
    tun, still, outdoor = results["tunnel"], results["still-air"], results["outdoor"]
    rows = [
        ("tunnel 60 deg, 3-10 m/s: speed error mean / max, m/s (per hold)", PAPER["tunnel_speed"],
         _fmt(tun[0]["per_segment"]["speed_mean"], tun[0]["per_segment"]["speed_max"]),
         _fmt(tun[1]["per_segment"]["speed_mean"], tun[1]["per_segment"]["speed_max"])),
        ("tunnel: direction error mean / max, deg (per hold)", PAPER["tunnel_direction"],
         _fmt(tun[0]["per_segment"]["direction_mean"], tun[0]["per_segment"]["direction_max"], 2),
         _fmt(tun[1]["per_segment"]["direction_mean"], tun[1]["per_segment"]["direction_max"], 2)),
        ("tunnel: speed error mean / max, m/s (every sample)", "-",
         _fmt(tun[0]["per_sample"]["speed_mean"], tun[0]["per_sample"]["speed_max"]),
         _fmt(tun[1]["per_sample"]["speed_mean"], tun[1]["per_sample"]["speed_max"])),
        ("still air, manoeuvres: mean estimated wind horizontal / |vertical|, m/s", PAPER["still_air"],
         _fmt(still[0]["mean_estimated_wind"]["horizontal_mps"], still[0]["mean_estimated_wind"]["vertical_mps"]),
         _fmt(still[1]["mean_estimated_wind"]["horizontal_mps"], None)),
        ("outdoor, turbulent: speed error mean / max, m/s (per segment)", "-",
         _fmt(outdoor[0]["per_segment"]["speed_mean"], outdoor[0]["per_segment"]["speed_max"]),
         _fmt(outdoor[1]["per_segment"]["speed_mean"], outdoor[1]["per_segment"]["speed_max"])),
        ("outdoor: direction error mean / max, deg (per segment)", "-",
         _fmt(outdoor[0]["per_segment"]["direction_mean"], outdoor[0]["per_segment"]["direction_max"], 2),
         _fmt(outdoor[1]["per_segment"]["direction_mean"], outdoor[1]["per_segment"]["direction_max"], 2)),
    ]
    width = max(len(r[0]) for r in rows)
    print(f"== results (replayed through the generated single-precision C; plots replay_*.png in {shown})")
    print(f"   {'':{width}s}  {'paper':>12s}  {'dobwind':>15s}  {'tilt method':>15s}")
    for label, paper, ours, theirs in rows:
        print(f"   {label:{width}s}  {paper:>12s}  {ours:>15s}  {theirs:>15s}")


def _time_reference(fitted: Airframe, start: float) -> None:
    from dobwind.model import reference
    from dobwind.model.exercise import flight_inputs
    from dobwind.model.step import build_step

    model = build_step(fitted)
    rows_in = flight_inputs(model, 100_000, seed=3)
    rolled = reference.rolled_step(model)
    t0 = time.perf_counter()
    reference.run(model, rows_in, rolled=rolled)
    print(f"== Python reference: 100,000 samples in {time.perf_counter() - t0:.2f} s; demo took "
          f"{time.perf_counter() - start:.0f} s")
