"""Random vehicles for `make accuracy` (`--random N --random-seed S`): the benchmark's six vehicles
are a fixed sample; a model change is also judged on vehicles nobody chose.

Each draw is a true vehicle file and the nominal airframe its user would start from, written in the
benchmark's folder layout. The ranges are physical, not tuned to pass:
- mass log-uniform 0.03-25 kg; frontal area 0.045 m^2 x mass^(2/3), Cd 0.6-1.3 (quadratic drag);
- rotor (momentum) drag 0.02-0.2 1/s x mass (PX4's EKF2_MCOEF range), plus 0-30 % of it as linear
  body drag; body-y / body-x drag 0.8-1.5; drag exponent 2 (half the draws), 1.8 or 2.2; in 30 % of
  the draws a Reynolds-dependent coefficient; in 40 % the quadratic drag of each body axis grows with
  that axis's own airflow component (`[drag] speed = "axis"`: per-face drag, whose force leans off the
  airflow), drawn from a second generator so that every other quantity of a draw stays as it was;
- shape harmonics up to 6 % (cos1) and 8 % (cos2), force deflection up to 2.5 deg;
- thrust curve scale 0.92-1.08, shape error +-8 % per unit T/W, inflow loss up to 5 % per m/s;
- rate 50-500 Hz; collective thrust or rpm (4, 6 or 8 rotors, hover at 45-65 % of max rpm);
  acceleration from velocity, NED acceleration or the accelerometer; nominal mass 2 % off;
- observer gains for 0.5 Hz bandwidth (6.2 kg/s per kg: `dobwind analyze --bandwidth 0.5` gives
  6.1-6.3 over these rates), the benchmark's filter and zero force-air model.
"""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from dobwind.io.atomic import write_text_atomically
from dobwind.model.airframe_toml import dumps

GRAVITY_MPS2 = 9.80665
GAIN_PER_KG = 6.2          # kg/s per kg of nominal mass: 0.5 Hz observer bandwidth
RATES_HZ = (50.0, 100.0, 200.0, 250.0, 500.0)
PER_AXIS_SHARE = 0.4       # of the draws with per-axis drag speed


def _drag(rng: np.random.Generator, mass: float) -> dict[str, Any]:
    area_m2 = 0.045 * mass ** (2 / 3)
    quadratic = 0.5 * 1.225 * rng.uniform(0.6, 1.3) * area_m2
    side = rng.uniform(0.8, 1.5)
    exponent = float(rng.choice([2.0, 2.0, 1.8, 2.2]))
    rotor = rng.uniform(0.02, 0.2) * mass
    linear = rng.uniform(0.0, 0.3) * rotor
    drag: dict[str, Any] = {
        "x": {"linear": linear, "quadratic": quadratic, "exponent": exponent},
        "y": {"linear": linear * side, "quadratic": quadratic * side, "exponent": exponent},
        "z": {"linear": rng.uniform(0.05, 0.15) * mass, "quadratic": quadratic * rng.uniform(1.0, 3.0),
              "exponent": exponent}}
    if rng.uniform() < 0.3:
        drag.update(reynolds_gain=rng.uniform(0.2, 0.6), reynolds_speed=rng.uniform(2.0, 4.0))
    return {"drag": drag, "rotor_drag": {"coefficient": rotor}}


def _vehicle(rng: np.random.Generator, mass: float, rate: float) -> dict[str, Any]:
    return {"mass": mass, "rate": rate, **_drag(rng, mass),
            "shape": {"cos1": rng.uniform(-0.06, 0.06), "cos2": rng.uniform(0.0, 0.08),
                      "deflection_deg": rng.uniform(0.0, 2.5)},
            "thrust": {"scale": rng.uniform(0.92, 1.08), "shape": rng.uniform(-0.08, 0.08),
                       "inflow_loss": rng.uniform(0.0, 0.05), "imbalance": rng.uniform(0.0, 0.03)},
            "sensors": {"acc_noise": rng.uniform(0.03, 0.25), "attitude_noise_deg": rng.uniform(0.05, 0.3),
                        "vel_noise": rng.uniform(0.02, 0.06), "rpm_noise": rng.uniform(5.0, 80.0),
                        "thrust_noise": rng.uniform(0.005, 0.03)}}


def _airframe(rng: np.random.Generator, name: str, mass: float, rate: float) -> dict[str, Any]:
    nominal = mass * rng.uniform(0.98, 1.02)
    thrust: dict[str, Any] = {"source": "collective"}
    if rng.uniform() < 0.5:
        rotors = int(rng.choice([4, 6, 8]))
        hover = rng.uniform(0.45, 0.65)   # share of max rpm
        c2 = nominal * GRAVITY_MPS2 / rotors / (hover ** 2 + 0.05 * hover)   # curve c1 x + c2 x^2, c1 = 0.05 c2
        thrust = {"source": "rpm", "rotors": rotors, "max_rpm": float(round(rng.uniform(6000, 30000))),
                  "coefficients": [0.0, 0.05 * c2, c2]}
    acceleration = str(rng.choice(["velocity", "ned", "specific_force"]))
    observer: dict[str, Any] = {"sample_time": 1.0 / rate, "gains": [GAIN_PER_KG * nominal] * 3,
                                "discretization": "paper", "acceleration": acceleration}
    if acceleration == "ned" and rng.uniform() < 0.5:
        observer["acceleration_bias_time"] = 20.0
    return {"name": name, "mass": nominal, "thrust": thrust, "observer": observer,
            "force_air": {"horizontal": {"terms": ["1", "m", "n", "m^2", "n^2"], "coefficients": [0.0] * 5},
                          "vertical": {"terms": ["fz"], "coefficients": [0.5]}},
            "filter": {"speeds": [0.0, 3.0, 10.0], "cutoffs": [0.2, 0.35, 0.5]}}


def write_random_vehicles(folder: Path, seed: int, count: int) -> tuple[str, ...]:
    """``count`` vehicles drawn with ``seed`` into ``folder`` (NAME.vehicle.toml, NAME.airframe.toml);
    their names, rand<seed>_<i>."""
    rng = np.random.default_rng(seed)
    kinds = np.random.default_rng((seed, 1))   # added later: the first generator's draws are unchanged
    folder.mkdir(parents=True, exist_ok=True)
    names = []
    for i in range(count):
        name = f"rand{seed}_{i}"
        mass = float(np.exp(rng.uniform(np.log(0.03), np.log(25.0))))
        rate = float(rng.choice(RATES_HZ))
        vehicle, airframe = _vehicle(rng, mass, rate), _airframe(rng, name, mass, rate)
        if kinds.uniform() < PER_AXIS_SHARE:
            vehicle["drag"]["speed"] = "axis"
        write_text_atomically(folder / f"{name}.vehicle.toml", lambda h, v=vehicle: h.write(dumps(v)))
        write_text_atomically(folder / f"{name}.airframe.toml", lambda h, a=airframe: h.write(dumps(a)))
        names.append(name)
    return tuple(names)
