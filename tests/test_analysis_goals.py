"""Issue #33's goals: `analyze`'s figures against a replay through the step.

- The ramp lag `analyze --json` reports, on each family's airframe, is positive and within 10 % of the
  lag measured by replaying (`dobwind replay`, from a CSV log) a hover in a ramping wind made with the
  same airframe's law, another wind direction and heading than the analysis flies.
- The wind-unit noise at each breakpoint is within 15 % of the sample scatter of the wind a replay of a
  long noisy hover at that airspeed shows, for a heavy slow noisy vehicle (tests/helpers.py
  NOISY_AIRFRAME, a law whose slope is infinite at zero airflow) and a body-frame drag airframe; the
  force noise the analysis is given is the scatter of the observer's force estimate the replay measured
  (what the fit can measure), not the injected sensor noise.
"""
from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dobwind.analysis.windunits import wind_units
from dobwind.cli.app import main
from dobwind.model import forceair, reference
from dobwind.model.airframe import parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.model.step import build_step
from tests.families import FAMILIES, family_doc
from tests.helpers import NOISY_AIRFRAME, collective

LEVELS = np.arange(2.0, 9.01, 0.5)


def _hover(af, wind: np.ndarray, yaw: np.ndarray):
    """Force, attitude (scipy Rotation) and true thrust of a vehicle holding position in ``wind``: the
    tilt balances m g e3 + f, the force is the law's for the airflow at that tilt (a fixed point)."""
    weight = af.mass_kg * af.gravity_mps2
    force = forceair.airframe_force(af, wind, yaw)
    for _ in range(10):
        need = force + weight * np.array([0.0, 0.0, 1.0])
        thrust = np.linalg.norm(need, axis=1)
        z = need / thrust[:, None]
        heading = np.column_stack([np.cos(yaw), np.sin(yaw), np.zeros_like(yaw)])
        y = np.cross(z, heading)
        y /= np.linalg.norm(y, axis=1)[:, None]
        rot = Rotation.from_matrix(np.stack([np.cross(y, z), y, z], axis=2))
        force = forceair.airframe_force(af, wind, yaw, rot.as_matrix(), np.sqrt(thrust / weight))
    return force, rot, thrust


def _write_log(path, af, t, wind, yaw, vel=None, acc=None):
    _, rot, thrust = _hover(af, wind, yaw)
    n = len(t)
    xyzw = rot.as_quat()
    vel = np.zeros((n, 3)) if vel is None else vel
    acc = np.zeros((n, 3)) if acc is None else acc
    cols = {"t": t, "vel_n": vel[:, 0], "vel_e": vel[:, 1], "vel_d": vel[:, 2], "q_w": xyzw[:, 3], "q_x": xyzw[:, 0],
            "q_y": xyzw[:, 1], "q_z": xyzw[:, 2], "thrust": thrust / af.thrust.scale, "acc_n": acc[:, 0],
            "acc_e": acc[:, 1], "acc_d": acc[:, 2], "yaw_ref": yaw, "wind_n": wind[:, 0], "wind_e": wind[:, 1],
            "wind_d": wind[:, 2]}
    with open(path, "w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(cols)
        writer.writerows(zip(*(np.asarray(v, float).tolist() for v in cols.values())))


def _lag(t, truth, estimate) -> float:
    return float(np.mean([t[np.argmax(estimate >= level)] - t[np.argmax(truth >= level)] for level in LEVELS]))


@pytest.mark.parametrize("family", FAMILIES)
def test_analyze_ramp_lag_matches_a_replayed_ramp(family, tmp_path, capsys):
    # Equal gains: with unequal ones the lag depends on the direction (the observer runs per NED axis)
    # and the analysis's ramp is along north.
    doc = collective(family_doc(family, **{"observer.gains": [25.0, 25.0, 25.0]}))
    path = tmp_path / "af.toml"
    path.write_text(dumps(doc))
    af = parse_airframe(dumps(doc), str(path))
    assert main(["analyze", str(path), "--json"]) == 0
    analysed = json.loads(capsys.readouterr().out)["ramp"]["scheduled_lag_s"]
    # The replayed ramp: wind towards east-north-east, heading 40 deg, 0.5 m/s^2 to 10 m/s.
    t = np.arange(0.0, 40.0, af.observer.sample_time_s)
    speed = np.clip((t - 5.0) * 0.5, 0.0, 10.0)
    towards = math.radians(70.0)
    wind = np.column_stack([speed * math.cos(towards), speed * math.sin(towards), np.zeros_like(t)])
    _write_log(tmp_path / "ramp.csv", af, t, wind, np.full_like(t, math.radians(40.0)))
    assert main(["replay", str(path), str(tmp_path / "ramp.csv"), "-o", str(tmp_path / "est.csv")]) == 0
    est = np.genfromtxt(tmp_path / "est.csv", delimiter=",", names=True, comments="#")
    replayed = _lag(est["t"], speed, est["wind_speed_h"])
    assert analysed > 0 and replayed > 0
    assert analysed == pytest.approx(replayed, rel=0.10)


NOISE_ACC, NOISE_VEL, HOLD_S = 0.15, 0.02, 900.0


def _noisy_hover(af, speed: float, seed: int):
    """Inputs of a hover in a steady airflow of ``speed`` along north, with white noise on the NED
    acceleration and velocity inputs."""
    model = build_step(af)
    n = int(HOLD_S / af.observer.sample_time_s)
    yaw = np.zeros(n)
    wind = np.tile([speed, 0.0, 0.0], (n, 1))
    _, rot, thrust = _hover(af, wind[:1], yaw[:1])
    rng = np.random.default_rng(seed)
    xyzw = np.tile(rot.as_quat()[0], (n, 1))
    values = {"dt": np.full(n, af.observer.sample_time_s), "vel_ned": rng.normal(0, NOISE_VEL, (n, 3)),
              "acc_ned": rng.normal(0, NOISE_ACC, (n, 3)), "q": np.column_stack([xyzw[:, 3], xyzw[:, :3]]),
              "yaw_ref": yaw, "thrust": np.full(n, thrust[0] / af.thrust.scale)}
    return model, model.inputs.pack({f.name: values[f.name] for f in model.inputs.fields}, rows=n)


def _airframes():
    body = collective(family_doc("drag-body", **{"observer.sample_time": 0.05, "limits.max_dt": 0.1,
                                                  "observer.gains": [36.0, 36.0, 36.0], "mass": 6.0}))
    return {"noisy": NOISY_AIRFRAME, "drag-body": body}


@pytest.mark.parametrize("name", ["noisy", "drag-body"])
def test_wind_noise_matches_the_scatter_of_a_replayed_hover(name):
    af = parse_airframe(dumps(_airframes()[name]), name)
    settle = int(30.0 / af.observer.sample_time_s)
    model, inputs = _noisy_hover(af, 0.0, seed=1)
    states = reference.run(model, inputs).states[settle:]
    observer_noise = float(np.std(states[:, model.state.slice("f_obs")][:, 0]))
    predicted = wind_units(af, model, [], [], force_noise_n=observer_noise)["breakpoints"]
    for k, point in enumerate(predicted):
        model, inputs = _noisy_hover(af, point["airspeed_mps"], seed=10 + k)
        wind = reference.run(model, inputs).outputs[settle:, model.outputs.slice("wind_ned")]
        measured_along, measured_across = float(np.std(wind[:, 0])), float(np.std(wind[:, 1]))
        assert point["wind_noise_along_mps"] == pytest.approx(measured_along, rel=0.15), point["airspeed_mps"]
        assert point["wind_noise_across_mps"] == pytest.approx(measured_across, rel=0.15), point["airspeed_mps"]
