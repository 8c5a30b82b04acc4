"""An optional check on real flights: the Neural-Fly wind-tunnel runs in ../shared/data/neural-fly/.

Their licence allows personal and educational use only, so nothing here copies or commits them: the
runs are converted in memory into a temporary folder, calibrated leave-one-out (fit on four runs,
score the fifth), and only the figures are printed. There is no anemometer series, so each run is
scored by its mean estimated horizontal speed against the nominal tunnel speed. Every controller's
runs in the folder are scored (tunnelruns.py finds them): the other controllers' through the split fit.

    python -m benchmarks.realdata [DATA_DIR] [--json] [--consistency]
"""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import math
import os
import sys
import tempfile
from pathlib import Path
from typing import Iterator

import numpy as np

from benchmarks import loobound, runconsistency
from dobwind.calibrate.fit import read_calibration_logs
from dobwind.calibrate.fitfamily import drag_samples, fit_airframe
from dobwind.io.jsonout import dumps
from dobwind.model.airframe import Airframe, load_airframe
from dobwind.model.forceair import heading_force, wind_from_deg
from dobwind.model.status import accepted
from benchmarks.tunnelruns import BASELINE, FLIP, NOMINAL_MPS, convert, convert_all, discover, training_controller
from dobwind.replay.replay import WARMUP_S, replay
from dobwind.core.resources import shipped_airframe

__all__ = ["AIRFRAME", "DEFAULT_DATA", "FLIP", "NOMINAL_MPS", "check", "consistency", "convert", "discover", "main",
           "runs"]

# The licensed data lives beside the checkout, never inside it: found from the working directory (make and
# pytest run at the checkout's root), or wherever DOBWIND_NEURAL_FLY points.
DEFAULT_DATA = Path(os.environ.get("DOBWIND_NEURAL_FLY", "../shared/data/neural-fly"))
AIRFRAME = shipped_airframe("nf_quad")


def runs(data_dir: Path) -> dict[str, Path]:
    """The baseline controller's runs by wind setting (``discover`` has every controller's)."""
    return discover(data_dir, warn=lambda _: None).get(BASELINE, {})


SPLIT_TRAIN = ("nowind", "35wind", "100wind")  # spans the range, zero wind included
# Issue #31's goal: `dobwind fit` on the four constant-wind runs with no options writes a model.
CONSTANT_WIND = ("nowind", "35wind", "70wind", "100wind")


def _score(fitted, log_path: Path, nominal: float, report) -> dict:
    model, log, traj = replay(fitted, str(log_path))
    use = accepted(traj.status) & (log.time_s >= WARMUP_S)
    wind = traj.outputs[use][:, model.outputs.slice("wind_ned")]
    mean = wind.mean(axis=0)
    return {
        "nominal_mps": nominal,
        "mean_speed_mps": float(np.mean(np.hypot(wind[:, 0], wind[:, 1]))),
        "speed_of_mean_mps": float(np.hypot(mean[0], mean[1])),
        "mean_from_deg": float(wind_from_deg(mean[0], mean[1])),
        "mean_up_mps": float(-mean[2]),
        "fit_terms": report.horizontal_terms, "fit_cv_rmse_mps": report.horizontal_cv_rmse_mps,
        "thrust_scale": report.thrust_scale, "warnings": report.warnings,
        "fit_outliers": [Path(str(run.log)).stem for run in report.runs if run.outlier],
        # the fit's own per-log table (its mean airflow error per training log, not a replay)
        "training_errors_mps": {Path(str(run.log)).stem: run.error_mps for run in report.runs},
    }


def _constant_wind_fit(af: Airframe, own: dict[str, Path]) -> dict:
    """The fit the user runs on the constant-wind runs, no options (not --dynamic): passed or refused,
    and the per-run table of its report (runmeans.py)."""
    names = [n for n in CONSTANT_WIND if n in own]
    _, report, _ = fit_airframe(af, [str(own[n]) for n in names], "auto")
    return {"runs": names, "passed": bool(report.self_check.passed), "reasons": report.self_check.reasons,
            "model": report.model, "anchored": report.anchored,
            "per_run": [{**dataclasses.asdict(run), "log": Path(str(run.log)).stem} for run in report.runs]}


def _training_set(logs: dict[str, dict[str, Path]], data_dir: Path) -> str:
    trainer = training_controller(logs, SPLIT_TRAIN)
    if trainer is None:
        count = sum(len(w) for w in logs.values())
        raise FileNotFoundError(f"no controller's readable Neural-Fly runs cover {', '.join(SPLIT_TRAIN)} in {data_dir} "
                                f"({count} readable runs found)")
    return trainer


@contextlib.contextmanager
def _converted(data_dir: Path) -> Iterator[tuple[Airframe, dict[str, dict[str, Path]], list]]:
    """The airframe, every controller's runs converted into a temporary folder (gone on exit), and the
    runs skipped."""
    af = load_airframe(AIRFRAME)
    with tempfile.TemporaryDirectory(prefix="dobwind-nf-") as tmp:
        logs, skipped = convert_all(discover(data_dir), af.mass_kg, af.gravity_mps2, Path(tmp))
        yield af, logs, skipped


def check(data_dir: Path = DEFAULT_DATA, leave_one_out: bool = True) -> dict:
    """Leave-one-out and the split on the training controller's runs (the baseline's when present); every
    other controller's runs are scored through the split fit, all held out (same vehicle, same tunnel).
    ``leave_one_out=False`` skips its fits (five of the seven; ``leave_one_out`` is then empty)."""
    with _converted(data_dir) as (af, logs, skipped):
        return _check_converted(af, logs, skipped, data_dir, leave_one_out)


def _check_converted(af: Airframe, logs: dict[str, dict[str, Path]], skipped: list, data_dir: Path,
                     leave_one_out: bool = True) -> dict:
    trainer = _training_set(logs, data_dir)
    own = logs[trainer]
    loo = {}
    for name, log_path in (own.items() if leave_one_out else ()):
        training = [str(p) for other, p in own.items() if other != name]
        fitted, report, _ = fit_airframe(af, training, "auto", dynamic=True)
        loo[name] = _score(fitted, log_path, NOMINAL_MPS[name], report)
    fitted, report, _ = fit_airframe(af, [str(own[n]) for n in SPLIT_TRAIN], "auto", dynamic=True)
    split = {name: {**_score(fitted, log_path, NOMINAL_MPS[name], report), "trained_on": name in SPLIT_TRAIN}
             for name, log_path in own.items()}
    others = {controller: {name: {**_score(fitted, log_path, NOMINAL_MPS[name], report), "trained_on": False}
                           for name, log_path in winds.items()}
              for controller, winds in logs.items() if controller != trainer}
    return {"leave_one_out": loo, "split": split, "training_controller": trainer, "other_controllers": others,
            "skipped": skipped, "constant_wind_fit": _constant_wind_fit(af, own)}


def loo_goal(results: dict) -> dict[str, dict]:
    """Issue #31's leave-one-out goal per interior run (below the fastest, above zero): held out within
    loobound.GOAL_MPS of its nominal speed unless the four-run fit (constant_wind_fit) flags it, and each
    training run the LOO fit does not flag within it by that fit's per-log table."""
    loo = results.get("leave_one_out", {})
    top = max((r["nominal_mps"] for r in loo.values()), default=0.0)
    flagged = {run["log"].rsplit("_", 1)[-1] for run in results.get("constant_wind_fit", {}).get("per_run", [])
               if run["outlier"]}
    goal = {}
    for name, r in loo.items():
        if not 0 < r["nominal_mps"] < top:
            continue
        error = r["mean_speed_mps"] - r["nominal_mps"]
        training = max((e for log, e in r.get("training_errors_mps", {}).items() if log not in r["fit_outliers"]),
                       default=math.nan)
        exempt = name in flagged
        met = (exempt or abs(error) <= loobound.GOAL_MPS) and not training > loobound.GOAL_MPS
        goal[name] = {"error_mps": error, "exempt": exempt, "training_max_error_mps": training, "met": met}
    return goal


def loo_goal_lines(results: dict) -> list[str]:
    goal = loo_goal(results)
    if not goal:
        return []
    lines = [f"Leave-one-out goal (issue #31): each interior run held out within {loobound.GOAL_MPS} m/s unless the "
             f"four-run fit flags it; each training run within {loobound.GOAL_MPS} m/s (the LOO fit's per-log table)"]
    for name, g in goal.items():
        verdict = "exempt (flagged)" if g["exempt"] else ("met" if g["met"] else "NOT met")
        lines.append(f"  {name:10s} held out {g['error_mps']:+.2f} m/s, training runs within "
                     f"{g['training_max_error_mps']:.2f} m/s: {verdict}")
    lines.append(f"  goal {'met' if all(g['met'] for g in goal.values()) else 'NOT met'}")
    return lines


def held_out_error_mps(results: dict) -> tuple[float, int]:
    """Mean |mean |wind| - nominal| over every held-out run of every controller, and how many runs."""
    held = [r for r in results["split"].values() if not r["trained_on"]]
    held += [r for winds in results.get("other_controllers", {}).values() for r in winds.values()]
    errors = [abs(r["mean_speed_mps"] - r["nominal_mps"]) for r in held]
    return (float(np.mean(errors)) if errors else math.nan), len(errors)


HEAD = "  run         nominal  mean |wind|  |mean wind|  from deg  up m/s   fitted terms (CV RMSE)"


def _row(name: str, r: dict) -> str:
    mark = "*" if r.get("trained_on") else " "
    flagged = f"; fit flags {', '.join(r['fit_outliers'])}" if r.get("fit_outliers") else ""
    return (f"  {name:9s}{mark}  {r['nominal_mps']:7.1f}  {r['mean_speed_mps']:11.2f}  {r['speed_of_mean_mps']:11.2f}  "
            f"{r['mean_from_deg']:8.1f}  {r['mean_up_mps']:6.2f}   {', '.join(r['fit_terms'])} ({r['fit_cv_rmse_mps'] or math.nan:.2f})"
            f"{flagged}")


def constant_wind_lines(result: dict | None) -> list[str]:
    """The four-run fit's verdict and its per-run table."""
    if not result:
        return []
    verdict = "writes a model (self-check PASS)" if result["passed"] else "refuses: " + "; ".join(result["reasons"])
    lines = [f"`dobwind fit` on {', '.join(result['runs'])} (no options): the {result['model']} family "
             f"{'fitted on the run means' if result['anchored'] else 'fitted per sample'}; {verdict}"]
    lines += [f"  {run['log']:24s} mean airflow {run['mean_speed_mps']:5.2f} m/s, error {run['error_mps']:.2f} m/s, "
              f"weight {run['weight']:.2f}{'  OUTLIER' if run['outlier'] else ''}" for run in result["per_run"]]
    return lines


def tables(results: dict) -> list[str]:
    trainer = results.get("training_controller", BASELINE)
    lines = []
    for title, key in ((f"leave-one-out (fit on the other runs of {trainer})", "leave_one_out"),
                       (f"split: fit on {trainer}'s {', '.join(SPLIT_TRAIN)}; * marks a training run", "split")):
        lines += [f"Neural-Fly runs, {title}; --dynamic --terms auto; the wind blows from 0 deg", HEAD]
        lines += [_row(name, r) for name, r in results[key].items()]
    others = results.get("other_controllers", {})
    if others:
        lines += ["Other controllers' runs through the same split fit (all held out); the wind blows from 0 deg", HEAD]
        for controller, winds in others.items():
            lines.append(f"  {controller}:")
            lines += [_row(name, r) for name, r in winds.items()]
    for entry in results.get("skipped", []):
        lines.append(f"  skipped {entry['controller']} {entry['wind']}: {entry['reason']}")
    lines += constant_wind_lines(results.get("constant_wind_fit"))
    lines += loo_goal_lines(results)
    error, count = held_out_error_mps(results)
    controllers = 1 + len(others)
    lines.append(f"  held-out runs, {controllers} controller{'s' * (controllers != 1)}: mean |mean |wind| - nominal| "
                 f"{error:.2f} m/s over {count} runs")
    return lines


def consistency(data_dir: Path = DEFAULT_DATA) -> dict:
    """The training controller's runs checked against a drag law's convexity (runconsistency.py): no fit."""
    with _converted(data_dir) as (af, logs, _):
        return _consistency_converted(af, logs, data_dir)


def _consistency_converted(af: Airframe, logs: dict[str, dict[str, Path]], data_dir: Path) -> dict:
    trainer = _training_set(logs, data_dir)
    names = list(logs[trainer])
    samples = drag_samples(af, read_calibration_logs(af, [str(logs[trainer][n]) for n in names]))[0]["heading"]
    force = np.column_stack(heading_force(samples.observed.T, samples.cos_yaw, samples.sin_yaw, (0.0, 0.0, 0.0))[:2])
    per_run = [samples.log_index == i for i in range(len(names))]
    runs, offset = runconsistency.check_runs(names, [force[k] for k in per_run], [samples.airflow[k] for k in per_run])
    slopes = [loobound.zero_airflow_slope(force[k], samples.airflow[k]) for k in per_run]
    zero_slope = next((g for g in slopes if g is not None), None)
    return {"training_controller": trainer, "runs": runs, "offset_n": offset, "zero_slope_n_per_mps": zero_slope,
            "held_out_bounds": _held_out_bounds(runs, zero_slope)}


def _held_out_bounds(runs: list[runconsistency.RunForce], zero_slope: float | None) -> list[loobound.HeldOutBound]:
    """The leave-one-out bounds (loobound.py) of each interior run (below the fastest; the zero-airflow run
    is slower than every run here), trained on all the others, then without each other run in turn (as a
    fit that flags it would be)."""
    top = max((r.speed_mps for r in runs), default=0.0)
    interior = {r.name for r in runs if r.speed_mps < top}
    found = []
    for left_out in [()] + [(r.name,) for r in runs]:
        found += [b for b in loobound.held_out_bounds(runs, zero_slope, left_out) if b.name in interior]
    return found


def _both(data_dir: Path, fits: bool) -> tuple[dict, dict]:
    """The fit tables' results ({} without ``fits``) and the consistency check, the runs converted once."""
    with _converted(data_dir) as (af, logs, skipped):
        found = _consistency_converted(af, logs, data_dir)
        return (_check_converted(af, logs, skipped, data_dir) if fits else {}), found


def consistency_lines(result: dict) -> list[str]:
    return ([f"Neural-Fly runs of {result['training_controller']} against any convex drag law through zero "
             "(no fit; benchmarks/runconsistency.py): a logged speed below its bound F/F' cannot be reproduced"]
            + runconsistency.lines(result["runs"], result["offset_n"])
            + [f"Leave-one-out bounds: the readings any drag law with a convex force per m/s (l s + q s^p, p >= 2) "
               "can give a held-out run (no fit; benchmarks/loobound.py)"]
            + loobound.lines(result.get("held_out_bounds", []), result.get("zero_slope_n_per_mps")))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.realdata")
    parser.add_argument("data", nargs="?", default=str(DEFAULT_DATA))
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--consistency", action="store_true",
                        help="only check the runs' logged speeds against their forces (no fit)")
    args = parser.parse_args(argv)
    try:
        results, found = _both(Path(args.data), not args.consistency)
    except FileNotFoundError as exc:
        sys.stderr.write(f"realdata: {exc}\n")
        return 2
    if args.json:
        # strict JSON, the common style: a NaN figure becomes null, listed
        runs_ = [{**dataclasses.asdict(r), "below_bound": r.below_bound} for r in found["runs"]]
        bounds = [{**dataclasses.asdict(b), "beyond_goal": b.beyond_goal, "training_consistent": b.training_consistent}
                  for b in found.get("held_out_bounds", [])]
        print(dumps({**results, "loo_goal": loo_goal(results) if results else {},
                     "consistency": {**found, "runs": runs_, "held_out_bounds": bounds}}))
        return 0
    print("\n".join(([] if args.consistency else tables(results)) + consistency_lines(found)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
