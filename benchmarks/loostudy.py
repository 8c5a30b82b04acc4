"""A study, not a check: leave-one-out on the interior Neural-Fly runs under the anchored fit's weighting
of the within-run variation (dobwind/calibrate/runmeans.py) scaled from none to 64 times its weight.

The anchored fit counts each log's mean once and its within-log variation (normalized by its sample
count) once. Issue #31 asks whether another balance, or another frame or linear term, would read a
held-out interior run within 0.5 m/s. This fits each of those variants on the other four runs, as
dragfit.anchored_theta does but with the within-run normal equations scaled, and prints each held-out
run's mean airflow error under the fitted law (dragfit.run_errors: the fit's own per-log error, no
replay), the largest error it leaves on a training run it does not flag, and the runs it flags. The
runs are converted into a temporary folder and nothing is kept (their licence).

    python -m benchmarks.loostudy [DATA_DIR]
"""
from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

from benchmarks import realdata
from dobwind.calibrate import dragfit, runmeans
from dobwind.calibrate.fit import read_calibration_logs
from dobwind.calibrate.fitfamily import drag_samples
from dobwind.model.kinds import DragFrame

RUNS = ("nowind", "35wind", "70wind", "70p20sint", "100wind")
HELD_OUT = ("35wind", "70wind", "70p20sint")
WITHIN_SCALES = (0.0, 1.0, 4.0, 16.0, 64.0)
# The anchored fit's candidate sets (dragfit.anchored_sets) of the plainest shape, in each frame.
VARIANTS = ((DragFrame.HEADING, ("l0", "q0")), (DragFrame.BODY, ("lr", "q0")), (DragFrame.BODY, ("l0", "q0")))


def scaled_fit(samples: dragfit.DragSamples, active: tuple[str, ...], within: float) -> tuple[np.ndarray, np.ndarray]:
    """dragfit.anchored_theta with the within-log normal equations times ``within`` (1: the fit's own)."""
    parameters = samples.parameters
    index = [parameters.index(p) for p in active]
    start = dragfit._solve(samples, active)
    stats = runmeans.run_stats(samples.observed, samples.columns[:, :, index], samples.log_index,
                               dragfit._axis_scale(samples, start))
    stats = dataclasses.replace(stats, within_gram=within * stats.within_gram, within_rhs=within * stats.within_rhs)

    def solve(gram: np.ndarray, rhs: np.ndarray) -> np.ndarray:
        return dragfit.solve_normal(parameters, active, gram, rhs)

    return runmeans.anchored_fit(stats, solve, lambda theta: dragfit.run_errors(samples, theta)[2])


def held_out(samples: dragfit.DragSamples, active: tuple[str, ...], within: float, name: str) -> dict:
    """The fit without run ``name``: its signed mean speed error there, its worst unflagged training run,
    the runs it flags and its horizontal coefficients."""
    k = RUNS.index(name)
    training = samples.select(samples.log_index != k)
    theta, weights = scaled_fit(training, active, within)
    logs, _, errors = dragfit.run_errors(samples, theta)
    pick = samples.log_index == k
    predicted = dragfit.predicted_airflow(samples, theta)[pick, :2].mean(axis=0)
    signed = float(np.hypot(*predicted) - np.hypot(*samples.airflow[pick, :2].mean(axis=0)))
    weight = dict(zip(np.unique(training.log_index), weights))
    kept = [e for log, e in zip(logs, errors) if log != k and weight[log] >= runmeans.OUTLIER_WEIGHT]
    values = dict(zip(samples.parameters, theta))
    return {"error_mps": signed, "training_max_mps": max(kept), "coefficients": {p: values[p] for p in active[:2]},
            "flags": [RUNS[log] for log, w in weight.items() if w < runmeans.OUTLIER_WEIGHT]}


def study(data_dir: Path) -> list[dict]:
    with realdata._converted(data_dir) as (af, logs, _):
        own = logs[realdata.BASELINE]
        frames = (DragFrame.HEADING, DragFrame.BODY)
        by_frame, _ = drag_samples(af, read_calibration_logs(af, [str(own[n]) for n in RUNS]), frames)
    rows = []
    for frame, horizontal in VARIANTS:
        active = horizontal + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS
        for within in WITHIN_SCALES:
            rows.append({"frame": frame.value, "set": "+".join(horizontal), "within": within,
                         "held_out": {n: held_out(by_frame[frame], active, within, n) for n in HELD_OUT}})
    return rows


def lines(rows: list[dict]) -> list[str]:
    out = ["frame    set     within  " + "  ".join(f"{n:>36s}" for n in HELD_OUT),
           "                         " + "  ".join(f"{'held out, training max, flags':>36s}" for _ in HELD_OUT)]
    for row in rows:
        cells = [f"{h['error_mps']:+6.2f} {h['training_max_mps']:5.2f} {','.join(h['flags']) or '-':>9s} "
                 + " ".join(f"{p}={v:.3f}" for p, v in h["coefficients"].items())
                 for h in row["held_out"].values()]
        out.append(f"{row['frame']:8s} {row['set']:6s}  x{row['within']:<4g}  " + "  ".join(f"{c:>36s}" for c in cells))
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.loostudy")
    parser.add_argument("data", nargs="?", default=str(realdata.DEFAULT_DATA))
    args = parser.parse_args(argv)
    if len(realdata.runs(Path(args.data))) < len(RUNS):
        sys.stderr.write(f"loostudy: {args.data}: the five baseline Neural-Fly runs are not there\n")
        return 2
    print("\n".join(lines(study(Path(args.data)))))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
