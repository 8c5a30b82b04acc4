"""Replay an autopilot log through a (fitted) airframe and summarise the airborne wind, against the
simulator's wind for an ArduPilot SITL log (`--truth sitl`): the figures of docs/field-calibration.md.

    .venv/bin/python -m benchmarks.fieldcal AIRFRAME LOG [--sitl] [--rate HZ]
"""
from __future__ import annotations

import argparse
import json
import numpy as np

from dobwind.calibrate.fieldtruth import LogTime
from dobwind.model.airframe import load_airframe
from dobwind.model.forceair import wind_from_deg
from dobwind.model.status import accepted
from dobwind.replay.replay import replay_ulog


def _direction_from(n: float, e: float) -> float:
    return float(wind_from_deg(n, e))


def summary(airframe: str, log: str, sitl: bool, rate_hz: float | None) -> dict:
    af = load_airframe(airframe)
    model, flight, traj = replay_ulog(af, log, rate_hz=rate_hz)
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    airborne = ~flight.landed
    used = accepted(traj.status) & airborne
    trusted = (traj.status == 0) & airborne
    mean = wind[used].mean(axis=0)
    out = {"log": log, "airframe": airframe, "airborne_rows": int(airborne.sum()), "accepted_airborne": int(used.sum()),
           "trusted_airborne": int(trusted.sum()),
           "mean_speed_mps": float(np.mean(np.hypot(wind[used, 0], wind[used, 1]))),
           "mean_vector_from_deg": _direction_from(mean[0], mean[1]),
           "mean_abs_vertical_mps": float(np.mean(np.abs(wind[used, 2]))),
           "mean_vertical_up_mps": float(-mean[2])}
    if sitl:
        from dobwind.calibrate.sitlwind import read_sitl_log, sitl_wind_ned

        truth = sitl_wind_ned(read_sitl_log(log), LogTime(flight.log, flight.t0_s).clock_s)
        tmean = truth[used].mean(axis=0)
        out.update(truth_mean_speed_mps=float(np.mean(np.hypot(truth[used, 0], truth[used, 1]))),
                   truth_from_deg=_direction_from(tmean[0], tmean[1]),
                   speed_error_mps=out["mean_speed_mps"] - float(np.mean(np.hypot(truth[used, 0], truth[used, 1]))),
                   rms_vector_error_mps=float(np.sqrt(np.mean(np.sum((wind[used, :2] - truth[used, :2]) ** 2, axis=1)))))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("airframe")
    parser.add_argument("log")
    parser.add_argument("--sitl", action="store_true")
    parser.add_argument("--rate", type=float)
    args = parser.parse_args()
    print(json.dumps(summary(args.airframe, args.log, args.sitl, args.rate), indent=1))


if __name__ == "__main__":
    main()
