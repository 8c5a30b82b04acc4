"""An optional check on real flights: the Neural-Fly wind-tunnel runs in ../shared/data/neural-fly/.

Their licence allows personal and educational use only, so nothing here copies or commits them: the
runs are converted in memory into a temporary folder, calibrated leave-one-out (fit on four runs,
score the fifth), and only the figures are printed. There is no anemometer series, so each run is
scored by its mean estimated horizontal speed against the nominal tunnel speed.

    python -m dobwind.realdata [DATA_DIR] [--json]
"""
from __future__ import annotations

import argparse
import math
import ast
import csv
import gzip
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from dobwind.fitfamily import fit_airframe
from dobwind.jsonout import dumps
from dobwind.logs import write_csv
from dobwind.model.airframe import load_airframe
from dobwind.model.forceair import wind_from_deg
from dobwind.model.status import accepted
from dobwind.replay import WARMUP_S, replay
from dobwind.resources import shipped_airframe

# The licensed data lives beside the checkout, never inside it: found from the working directory (make and
# pytest run at the checkout's root), or wherever DOBWIND_NEURAL_FLY points.
DEFAULT_DATA = Path(os.environ.get("DOBWIND_NEURAL_FLY", "../shared/data/neural-fly"))
AIRFRAME = shipped_airframe("nf_quad")
NOMINAL_MPS = {"nowind": 0.0, "35wind": 4.2, "70wind": 8.5, "70p20sint": 8.5, "100wind": 12.1}
FLIP = np.diag([1.0, -1.0, -1.0])  # world (x, y, z up) -> NED, and body FLU -> FRD


def runs(data_dir: Path) -> dict[str, Path]:
    found = {}
    for suffix in NOMINAL_MPS:
        path = data_dir / f"custom_figure8_baseline_{suffix}.csv.gz"
        if path.exists():
            found[suffix] = path
    return found


def convert(path: Path, nominal_mps: float, mass_kg: float, gravity: float, out: Path) -> Path:
    """Their columns -> our flight-log CSV (NED, FRD), with the nominal wind (along world -x) as truth."""
    rows = []
    with gzip.open(path, "rt") as handle:
        for record in csv.DictReader(handle):
            rows.append(record)
    vec = lambda key: np.array([ast.literal_eval(r[key]) for r in rows], dtype=float)
    t = np.array([float(r["t"]) for r in rows])
    vel = vec("v") @ FLIP
    rot = FLIP @ np.array([ast.literal_eval(r["R"]) for r in rows]) @ FLIP
    xyzw = Rotation.from_matrix(rot).as_quat()
    scalar = lambda text: float(np.ravel(ast.literal_eval(text))[0])
    thrust = mass_kg * gravity * np.array([scalar(r["T_sp"]) / scalar(r["hover_throttle"]) for r in rows])
    wind = np.tile(np.array([-nominal_mps, 0.0, 0.0]), (len(t), 1))  # world -x is NED -x
    cols = {"t": t - t[0], "vel_n": vel[:, 0], "vel_e": vel[:, 1], "vel_d": vel[:, 2], "q_w": xyzw[:, 3],
            "q_x": xyzw[:, 0], "q_y": xyzw[:, 1], "q_z": xyzw[:, 2], "thrust": thrust,
            "wind_n": wind[:, 0], "wind_e": wind[:, 1], "wind_d": wind[:, 2]}
    keep = np.r_[True, np.diff(cols["t"]) > 0]
    write_csv(out, list(cols), np.column_stack([v[keep] for v in cols.values()]), ["%.6f"] + ["%.7g"] * (len(cols) - 1))
    return out


SPLIT_TRAIN = ("nowind", "35wind", "100wind")  # spans the range, zero wind included


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
    }


def check(data_dir: Path = DEFAULT_DATA) -> dict:
    found = runs(data_dir)
    if len(found) < 3:
        raise FileNotFoundError(f"Neural-Fly runs not found in {data_dir}")
    af = load_airframe(AIRFRAME)
    results = {}
    with tempfile.TemporaryDirectory(prefix="dobwind-nf-") as tmp:
        logs = {name: convert(p, NOMINAL_MPS[name], af.mass_kg, af.gravity_mps2, Path(tmp) / f"{name}.csv")
                for name, p in found.items()}
        loo = {}
        for name, log_path in logs.items():
            training = [str(p) for other, p in logs.items() if other != name]
            fitted, report, _ = fit_airframe(af, training, "auto", dynamic=True)
            loo[name] = _score(fitted, log_path, NOMINAL_MPS[name], report)
        split = {}
        train = [str(logs[n]) for n in SPLIT_TRAIN if n in logs]
        fitted, report, _ = fit_airframe(af, train, "auto", dynamic=True)
        for name, log_path in logs.items():
            split[name] = {**_score(fitted, log_path, NOMINAL_MPS[name], report), "trained_on": name in SPLIT_TRAIN}
        results = {"leave_one_out": loo, "split": split}
    return results


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m dobwind.realdata")
    parser.add_argument("data", nargs="?", default=str(DEFAULT_DATA))
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args(argv)
    try:
        results = check(Path(args.data))
    except FileNotFoundError as exc:
        sys.stderr.write(f"realdata: {exc}\n")
        return 2
    if args.json:
        print(dumps(results))  # strict JSON, the common style: a NaN figure becomes null, listed
        return 0
    head = "  run         nominal  mean |wind|  |mean wind|  from deg  up m/s   fitted terms (CV RMSE)"
    for title, key in (("leave-one-out (fit on the other four runs)", "leave_one_out"),
                       (f"split: fit on {', '.join(SPLIT_TRAIN)}; * marks a training run", "split")):
        print(f"Neural-Fly runs, {title}; --dynamic --terms auto; the wind blows from 0 deg")
        print(head)
        for name, r in results[key].items():
            mark = "*" if r.get("trained_on") else " "
            print(f"  {name:9s}{mark}  {r['nominal_mps']:7.1f}  {r['mean_speed_mps']:11.2f}  {r['speed_of_mean_mps']:11.2f}  "
                  f"{r['mean_from_deg']:8.1f}  {r['mean_up_mps']:6.2f}   {', '.join(r['fit_terms'])} ({r['fit_cv_rmse_mps'] or math.nan:.2f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
