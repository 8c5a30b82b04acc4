"""Shared test helpers: airframe variants built from a plain dict, so each test states its vehicle."""
from __future__ import annotations

import copy
import itertools
from pathlib import Path
from typing import Any

from dobwind.model.airframe import Airframe, parse_airframe
from dobwind.model.airframe_toml import dumps

ROOT = Path(__file__).resolve().parents[1]
M300 = ROOT / "airframes" / "m300.toml"

BASE: dict[str, Any] = {
    "name": "testcraft",
    "mass": 2.5,
    "thrust": {"source": "rpm", "scale": 0.98, "rotors": 4, "max_rpm": 10000.0, "coefficients": [0.0, 1.5, 22.0]},
    "observer": {"sample_time": 0.02, "gains": [20.0, 25.0, 30.0], "discretization": "paper", "acceleration": "ned",
                 "force_offset": [0.1, -0.2, 0.3]},
    "force_air": {
        "horizontal": {"terms": ["1", "m", "n", "m^2", "n^2", "fh^0.5"], "coefficients": [0.2, 0.05, -0.03, 0.08, 0.06, 0.9]},
        "vertical": {"terms": ["fz", "fz*abs(fz)"], "coefficients": [0.6, 0.05]},
    },
    "filter": {"speeds": [0.0, 4.0, 12.0], "cutoffs": [0.3, 0.6, 1.0]},
    "limits": {"max_dt": 0.1, "max_tilt_deg": 50.0},
}


def airframe_dict(**changes: Any) -> dict[str, Any]:
    """BASE with dotted-key changes, e.g. airframe_dict(**{"observer.gains": [1, 2, 3]})."""
    doc = copy.deepcopy(BASE)
    for dotted, value in changes.items():
        *path, leaf = dotted.split(".")
        table = doc
        for key in path:
            table = table[key]
        if value is None:
            table.pop(leaf, None)
        else:
            table[leaf] = value
    return doc


def make_airframe(**changes: Any) -> Airframe:
    return parse_airframe(dumps(airframe_dict(**changes)), "<test>")


def collective(doc: dict[str, Any]) -> dict[str, Any]:
    doc = copy.deepcopy(doc)
    doc["thrust"] = {"source": "collective", "scale": 1.03}
    return doc


def all_modes() -> list[dict[str, Any]]:
    """Every discretization x acceleration mode x thrust source (rotor count varied too); the
    velocity-aided acceleration bias estimate is on for half of the acceleration-input modes, so that
    each discretization meets it with both inputs and the two thrust sources share it."""
    out = []
    for i, (disc, acc, src) in enumerate(itertools.product(
            ("paper", "euler", "zoh", "tustin"), ("ned", "specific_force", "velocity"), ("rpm", "collective"))):
        doc = airframe_dict(**{"observer.discretization": disc, "observer.acceleration": acc})
        bias = acc != "velocity" and (i + i // 6) % 2 == 0
        if bias:
            doc["observer"]["acceleration_bias_time"] = 3.0
        if src == "collective":
            doc = collective(doc)
        else:
            doc["thrust"]["rotors"] = (4, 6, 8, 3)[i % 4]
        doc["name"] = f"mode_{disc}_{acc}_{src}" + ("_bias" if bias else "")
        out.append(doc)
    return out


def observed_force(af: Airframe, rate_hz: float, force, noise_n: float, rng):
    """A true force (N, 3) as the fit observes it: through H (the observer and a 0.5 Hz low-pass, per
    axis, dragfit.observer_filter) with white noise of ``noise_n`` newtons added."""
    import numpy as np

    from dobwind.calibrate import dragfit

    observed = np.empty_like(force)
    for axis in range(3):
        b, a = dragfit.observer_filter(af, 1 / rate_hz, 0.5, axis)
        observed[:, axis] = dragfit._filtered(b, a, force[:, axis])
    return observed + rng.normal(0, noise_n, force.shape)


def random_body_flight(speed, seed: int):
    """Airflow at these horizontal speeds (m/s) in random directions with -4..4 m/s vertical, attitudes
    tilted up to about 40 degrees at any heading, and rotor terms sqrt(0.7..1.6): (a, rot, rotor)."""
    import math

    import numpy as np
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    n = len(speed)
    angle = rng.uniform(-math.pi, math.pi, n)
    a = np.column_stack([speed * np.cos(angle), speed * np.sin(angle), rng.uniform(-4, 4, n)])
    rot = Rotation.from_euler("ZYX", np.column_stack([rng.uniform(-math.pi, math.pi, n), rng.uniform(-0.7, 0.7, n),
                                                      rng.uniform(-0.7, 0.7, n)])).as_matrix()
    return a, rot, np.sqrt(rng.uniform(0.7, 1.6, n))


def hold_samples(force_of, noise_n: float = 0.05, seed: int = 3, frame: str = "heading"):
    """Drag samples as the fit makes them (H applied to the force, noise added): 20 s holds at random
    headings, 0-9 m/s, level, 40 min; ``force_of(vx, vy, vz)`` the true heading-frame force (N) of the
    heading-frame airflow, ``frame`` the law frame the samples are for."""
    import math

    import numpy as np

    from dobwind.calibrate import dragfit
    from dobwind.model.airframe import load_airframe

    af = load_airframe(M300)
    rate, seconds, hold = 50.0, 2400.0, 20
    rng = np.random.default_rng(seed)
    holds = int(seconds / hold)
    per = lambda x: np.repeat(x, int(rate * hold))
    t = np.arange(int(rate * seconds)) / rate
    yaw = per(rng.uniform(-math.pi, math.pi, holds))
    air = np.column_stack([per(rng.uniform(0, 9, holds)), np.zeros_like(t), per(rng.uniform(-2, 2, holds))])
    c, s = np.cos(yaw), np.sin(yaw)
    fx, fy, fz = force_of(c * air[:, 0], -s * air[:, 0], air[:, 2])
    force = np.column_stack([c * fx - s * fy, s * fx + c * fy, fz])
    observed = observed_force(af, rate, force, noise_n, rng)
    thrust = np.column_stack([np.zeros_like(t), np.zeros_like(t), np.full_like(t, 78.0)])
    segment = per(np.arange(holds) % 2).astype(float)  # labelled holds: holdcv scores them settled
    q = np.column_stack([np.cos(yaw / 2), np.zeros_like(t), np.zeros_like(t), np.sin(yaw / 2)])  # level
    return dragfit.merge([dragfit.log_samples(af, 0.5, t, observed, air, thrust, yaw, np.ones(len(t), dtype=bool),
                                              frame, q, segment=segment)], frame)


# A heavy, slow vehicle's airframe (6 kg, 20 Hz, NED acceleration input, a law steep near zero force):
# the tests of the fit's handling of noise at low airflow simulate their vehicles against it.
NOISY_AIRFRAME = {
    "name": "noisy", "mass": 6.0, "thrust": {"source": "collective"},
    "observer": {"sample_time": 0.05, "gains": [36.0, 36.0, 36.0], "discretization": "paper", "acceleration": "ned"},
    "force_air": {"horizontal": {"terms": ["fh^0.5"], "coefficients": [4.0]},
                  "vertical": {"terms": ["fz"], "coefficients": [0.5]}},
    "filter": {"speeds": [0.0, 3.0, 10.0], "cutoffs": [0.2, 0.35, 0.5]},
}


def noisy_flights(folder: Path, vehicle: dict[str, Any]) -> dict[str, str]:
    """A sweep (6 s holds), a vertical climb (8 s holds) and a still-air flight of ``vehicle`` simulated
    with NOISY_AIRFRAME into ``folder``: their paths by name, and the airframe's ("airframe")."""
    from dobwind.cli.app import main   # the applications layer, only for the tests that fly
    (folder / "v.toml").write_text(dumps(vehicle))
    (folder / "a.toml").write_text(dumps(NOISY_AIRFRAME))
    paths = {"airframe": str(folder / "a.toml")}
    for name, seed, hold in (("sweep", 1, "6"), ("vertical", 2, "8"), ("still-air", 4, None)):
        path = folder / f"{name}.csv"
        args = ["simulate", name, "--airframe", paths["airframe"], "--vehicle", str(folder / "v.toml"),
                "--seed", str(seed), "-o", str(path)] + (["--hold", hold] if hold else [])
        assert main(args) == 0
        paths[name] = str(path)
    return paths
