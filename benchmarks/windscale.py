"""`fit --wind unknown` on simulated box flights of a family of collective-thrust vehicles whose starter
airframe has the thrust scale wrong (init's hover throttle off by 0.8x or 1.25x) or right: the wind
found against the simulator's mean wind (or the refusal). The figures of docs/field-calibration.md.

    .venv/bin/python -m benchmarks.windscale [--masses 1.4 3 8] [--scales 0.8 1 1.25] [--seeds 5 6 7]
        [--no-thrust-scale]   (the solve as before the thrust scale: kappa 0 always)
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
from pathlib import Path

import numpy as np

from dobwind.calibrate.fieldtruth import flight_of
from dobwind.calibrate.windsolve import estimate_winds
from dobwind.core.errors import CheckFailed
from dobwind.io.logs import write_csv
from dobwind.model.airframe import Airframe, parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.simulate.simulate import simulate


# The field airframe of tests/test_fieldcal.py (its test helpers' base airframe with collective thrust,
# 10 Hz and max_dt 0.25 s): written out here so that a benchmark does not import the tests.
STARTER = {
    "name": "family", "thrust": {"source": "collective"},
    "observer": {"sample_time": 0.1, "gains": [20.0, 25.0, 30.0], "discretization": "paper", "acceleration": "velocity",
                 "force_offset": [0.1, -0.2, 0.3]},
    "force_air": {
        "horizontal": {"terms": ["1", "m", "n", "m^2", "n^2", "fh^0.5"], "coefficients": [0.2, 0.05, -0.03, 0.08, 0.06, 0.9]},
        "vertical": {"terms": ["fz", "fz*abs(fz)"], "coefficients": [0.6, 0.05]},
    },
    "filter": {"speeds": [0.0, 4.0, 12.0], "cutoffs": [0.3, 0.6, 1.0]},
    "limits": {"max_dt": 0.25, "max_tilt_deg": 50.0},
}


def starter(mass_kg: float) -> Airframe:
    """A 10 Hz collective-thrust quad of this mass (the rates an autopilot log has)."""
    return parse_airframe(dumps(STARTER | {"mass": mass_kg}), "<family>")


def mis_scaled(af: Airframe, factor: float) -> Airframe:
    """The same airframe with its thrust scale multiplied by ``factor`` (a wrong hover throttle)."""
    return dataclasses.replace(af, thrust=dataclasses.replace(af.thrust, scale=af.thrust.scale * factor))


def one(mass_kg: float, factor: float, seed: int, workdir: Path, thrust_scale: bool = True) -> dict:
    af = starter(mass_kg)
    cols = simulate(af, "box", seed=seed, hold_s=6.0, rate_hz=10.0)
    names = [k for k in cols if not k.startswith("wind_")]
    csv = workdir / f"box_{mass_kg:g}_{seed}.csv"
    if not csv.exists():
        write_csv(csv, names, np.column_stack([cols[k] for k in names]), ["%.9g"] * len(names))
    truth = np.array([cols["wind_n"].mean(), cols["wind_e"].mean()])
    row = {"mass_kg": mass_kg, "thrust_factor": factor, "seed": seed, "truth_speed_mps": float(np.hypot(*truth))}
    guess = mis_scaled(af, factor)
    try:
        solution = estimate_winds(guess, [(str(csv), flight_of(str(csv), guess, None))], thrust_scale=thrust_scale)
    except CheckFailed as exc:
        return row | {"refused": str(exc)}
    (group,) = solution.groups
    return row | {"error_mps": float(np.hypot(*(np.array(group.wind_ne) - truth))), "sigma_mps": group.sigma_mps,
                  "kappa": solution.law.get("kappa", 0.0), "notes": list(solution.notes)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--masses", type=float, nargs="+", default=[1.4, 3.0, 8.0])
    parser.add_argument("--scales", type=float, nargs="+", default=[0.8, 1.0, 1.25])
    parser.add_argument("--seeds", type=int, nargs="+", default=[5, 6, 7])
    parser.add_argument("--no-thrust-scale", action="store_true", help="never estimate the thrust scale")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for mass in args.masses:
            for seed in args.seeds:
                for factor in args.scales:
                    row = one(mass, factor, seed, Path(tmp), not args.no_thrust_scale)
                    print(json.dumps(row), flush=True)


if __name__ == "__main__":
    main()
