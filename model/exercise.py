"""Input sequences that exercise every branch of a step: a jittery, manoeuvring flight with rejected
rows mixed in, and random (state, input) pairs with edge cases. They feed the C-versus-reference
comparisons and the self-test vectors; they are not a flight simulator (that is ``dobwind simulate``).
"""
from __future__ import annotations

import math

import numpy as np

from dobwind.model.attitude import euler_to_quaternion, rotation_matrices
from dobwind.model.numeric import rpm_for_rotor_thrust
from dobwind.model.step import StepModel

# The largest heading the random cases use: within it the generated single-precision trig helper stays
# within a few 1e-7 of the exact value (codegen/templates/source.c.j2).
TRIG_CHECK_RAD = 1e4


def _bad_row(model: StepModel, row: np.ndarray, kind: int, rng: np.random.Generator) -> np.ndarray:
    lin = model.inputs
    row = row.copy()
    af = model.airframe
    if kind == 0:
        row[rng.integers(lin.size)] = np.nan
    elif kind == 1:
        row[rng.integers(lin.size)] = rng.choice([np.inf, -np.inf, 1e30])
    elif kind == 2:
        row[lin.slice("dt")] = rng.choice([0.0, -0.01, af.limits.max_dt_s * 1.5])
    elif kind == 3:
        row[lin.slice("q")] *= 0.5
    elif kind == 4:
        row[lin.slice("q")] = euler_to_quaternion(np.array(math.radians(af.limits.max_tilt_deg + 10)), np.array(0.1),
                                                  np.array(0.3))
    else:
        col = "rotor_rpm" if "rotor_rpm" in lin else "thrust"
        row[lin.offset(col)] = -1.0
    return row


def flight_inputs(model: StepModel, n: int, seed: int = 0, bad_every: int = 97) -> np.ndarray:
    """A manoeuvring flight of n samples (rows of the step's input layout)."""
    af = model.airframe
    rng = np.random.default_rng(seed)
    dt_nom = af.observer.sample_time_s
    dt = dt_nom * (1 + 0.1 * rng.uniform(-1, 1, n))
    t = np.cumsum(dt)
    phase = rng.uniform(0, 2 * np.pi, 8)
    vel = np.stack([3 * np.sin(0.21 * t + phase[0]) + 2 * np.sin(0.05 * t + phase[1]),
                    3 * np.sin(0.17 * t + phase[2]),
                    0.8 * np.sin(0.11 * t + phase[3])], -1)
    acc = np.stack([3 * 0.21 * np.cos(0.21 * t + phase[0]) + 2 * 0.05 * np.cos(0.05 * t + phase[1]),
                    3 * 0.17 * np.cos(0.17 * t + phase[2]),
                    0.8 * 0.11 * np.cos(0.11 * t + phase[3])], -1)
    acc += rng.normal(0, 0.2, acc.shape)
    yaw = np.angle(np.exp(1j * (0.15 * t + 0.8 * np.sin(0.03 * t + phase[4]))))
    roll = 0.25 * np.sin(0.37 * t + phase[5]) + rng.normal(0, 0.005, n)
    pitch = 0.25 * np.sin(0.29 * t + phase[6]) + rng.normal(0, 0.005, n)
    q = euler_to_quaternion(roll, pitch, yaw)
    rot = rotation_matrices(q)
    g = af.gravity_mps2
    # Thrust that would hold the attitude's vertical balance, with a force-like disturbance on top.
    thrust = af.mass_kg * (g - acc[:, 2]) / np.clip(rot[:, 2, 2], 0.3, None) * (1 + 0.05 * np.sin(0.7 * t + phase[7]))
    values = {"dt": dt, "vel_ned": vel + rng.normal(0, 0.02, vel.shape), "acc_ned": acc, "q": q,
              "yaw_ref": np.angle(np.exp(1j * (yaw + rng.normal(0, 0.02, n)))), "thrust": thrust}
    if "specific_force" in model.inputs:
        values["specific_force"] = np.einsum("nji,nj->ni", rot, acc - np.array([0, 0, g])) + rng.normal(0, 0.05, acc.shape)
    if "rotor_rpm" in model.inputs:
        rotors = af.thrust.rotors
        share = thrust[:, None] / rotors * (1 + 0.04 * rng.standard_normal((n, rotors)))
        values["rotor_rpm"] = rpm_for_rotor_thrust(af.thrust.coefficients, af.thrust.max_rpm, share)
    rows = model.inputs.pack(values, rows=n)
    if bad_every:
        for k in range(bad_every // 2, n, bad_every):
            rows[k] = _bad_row(model, rows[k], int(rng.integers(6)), rng)
    return rows


def random_cases(model: StepModel, n: int, seed: int = 0, boundaries: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Random (state, input) pairs; with ``boundaries`` some sit exactly on a rejection threshold."""
    rng = np.random.default_rng(seed)
    flight = flight_inputs(model, n, seed + 1, bad_every=7)
    lin, lst = model.inputs, model.state
    states = rng.normal(0, 4, (n, lst.size))
    states[:, lst.slice("initialized")] = (rng.random((n, 1)) < 0.9).astype(float)
    states[:, lst.slice("last.wind_speed_h")] = rng.uniform(0, 15, (n, 1))
    inputs = flight.copy()
    kinds = rng.integers(0, 8, n)
    for k in range(n):
        if kinds[k] == 0:  # no horizontal force at all: the direction guard
            states[k, lst.slice("f_obs")] = 0.0
            states[k, lst.slice("f_filt")] = 0.0
        elif kinds[k] == 1:
            inputs[k, lin.slice("yaw_ref")] = rng.choice([np.pi, -np.pi, 0.0])
        elif kinds[k] == 2:
            inputs[k, lin.slice("vel_ned")] = 0.0
        elif kinds[k] == 3:
            inputs[k, lin.slice("vel_ned")] *= 1e3  # large but finite
        elif kinds[k] == 4 and boundaries:
            inputs[k, lin.slice("dt")] = model.airframe.limits.max_dt_s
        elif kinds[k] == 5:
            states[k, lst.slice("last.wind_speed_h")] = rng.choice(model.airframe.filter.speeds_mps)
        elif kinds[k] == 6:
            # Headings far outside [-pi, pi] (accepted up to 1e6): the single-precision sine and cosine
            # must reduce them as well as libm does, and a slip in the reduction grows with |yaw|.
            inputs[k, lin.slice("yaw_ref")] = rng.uniform(-TRIG_CHECK_RAD, TRIG_CHECK_RAD)
    return states, inputs
