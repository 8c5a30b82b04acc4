"""The ramp experiment: a hovering vehicle in wind ramping to 10 m/s, the scheduled low-pass against
a fixed one at the lowest cutoff. The force is made from the airframe's own force-air model (so only
the observer and filter dynamics are on trial), the vehicle tilts to hold position, and the Python
reference runs the step over the whole ramp.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from dobwind.model import forceair, reference
from dobwind.model.airframe import Airframe, FilterSchedule
from dobwind.model.attitude import attitude_with_body_down, quaternion_wxyz
from dobwind.model.numeric import rpm_for_rotor_thrust
from dobwind.model.step import StepModel, build_step

RAMP_START_S, RAMP_RATE_MPS2, RAMP_TOP_MPS, HOLD_S = 5.0, 0.5, 10.0, 15.0
LAG_LEVELS_MPS = np.arange(2.0, 9.01, 0.5)


# Fixed-point passes of the hover balance (the body-frame law's force depends on the tilt it causes):
# the tilt's effect on the force is a few percent, so each pass gains about two digits.
HOVER_BALANCE_PASSES = 8


def hover_attitude(af: Airframe, force_ned: np.ndarray, yaw: np.ndarray) -> tuple[Rotation, np.ndarray]:
    """The attitude that holds position against ``force_ned`` (thrust -u_f z_b = -(m g e3 + f)) and the
    true thrust u_f it takes."""
    need = af.mass_kg * af.gravity_mps2 * np.array([0, 0, 1.0]) + force_ned
    true_thrust = np.linalg.norm(need, axis=1)
    return attitude_with_body_down(need / true_thrust[:, None], yaw), true_thrust


def force_for_airflow(af: Airframe, air_rel_ned: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """External force (NED, rows) that the airframe's force-air law (model/forceair.py, any family) maps
    to the given relative airflow for a vehicle hovering against it: for the body-frame law the tilt
    and thrust that force needs are found with it (a fixed point), as the step will see them."""
    force = forceair.airframe_force(af, air_rel_ned, yaw)
    if not forceair.needs_attitude(af):
        return force
    for _ in range(HOVER_BALANCE_PASSES):
        rot, thrust = hover_attitude(af, force, yaw)
        rotor = np.sqrt(thrust / (af.mass_kg * af.gravity_mps2))
        force = forceair.airframe_force(af, air_rel_ned, yaw, rot.as_matrix(), rotor)
    return force


def hover_inputs(model: StepModel, force_ned: np.ndarray, yaw: np.ndarray, dt: float) -> np.ndarray:
    """Inputs of a vehicle holding position against an external force: tilted so that
    -u_f z_b + m g e3 + f = 0, no acceleration, no velocity."""
    af = model.airframe
    n = len(yaw)
    rot, true_thrust = hover_attitude(af, force_ned, yaw)
    thrust = true_thrust / af.thrust.scale  # what the sensors report, through the calibrated scale
    values = {"dt": np.full(n, dt), "vel_ned": np.zeros((n, 3)), "acc_ned": np.zeros((n, 3)),
              "q": quaternion_wxyz(rot), "yaw_ref": yaw, "thrust": thrust,
              "specific_force": rot.inv().apply(np.tile([0, 0, -af.gravity_mps2], (n, 1)))}
    if "rotor_rpm" in model.inputs:
        values["rotor_rpm"] = rpm_for_rotor_thrust(af.thrust.coefficients, af.thrust.max_rpm,
                                                   np.repeat((thrust / af.thrust.rotors)[:, None], af.thrust.rotors, 1))
    return model.inputs.pack({f.name: values[f.name] for f in model.inputs.fields}, rows=n)


@dataclass(frozen=True)
class RampResult:
    time_s: np.ndarray
    truth_mps: np.ndarray
    scheduled_mps: np.ndarray
    fixed_mps: np.ndarray
    scheduled_lag_s: float
    fixed_lag_s: float
    fixed_cutoff_hz: float

    @property
    def lag_reduction_s(self) -> float:
        return self.fixed_lag_s - self.scheduled_lag_s


def _lag(time_s: np.ndarray, truth: np.ndarray, estimate: np.ndarray) -> float:
    """Mean over speed levels of (time the estimate first reaches the level - time the truth does)."""
    lags = []
    for level in LAG_LEVELS_MPS:
        t_true = time_s[np.argmax(truth >= level)]
        reached = estimate >= level
        if not reached.any():
            return float("inf")
        lags.append(time_s[np.argmax(reached)] - t_true)
    return float(np.mean(lags))


def ramp_experiment(af: Airframe) -> RampResult:
    dt = af.observer.sample_time_s
    duration = RAMP_START_S + RAMP_TOP_MPS / RAMP_RATE_MPS2 + HOLD_S
    t = np.arange(0.0, duration, dt)
    speed = np.clip((t - RAMP_START_S) * RAMP_RATE_MPS2, 0.0, RAMP_TOP_MPS)
    wind = np.stack([-speed, np.zeros_like(t), np.zeros_like(t)], 1)  # from the north
    yaw = np.zeros_like(t)
    fixed_af = dataclasses.replace(af, filter=FilterSchedule((0.0,), (min(af.filter.cutoffs_hz),)))
    results = []
    for variant in (af, fixed_af):
        model = build_step(variant)
        inputs = hover_inputs(model, force_for_airflow(variant, wind, yaw), yaw, dt)
        traj = reference.run(model, inputs)
        results.append(traj.outputs[:, model.outputs.slice("wind_speed_h")].ravel())
    return RampResult(t, speed, results[0], results[1], _lag(t, speed, results[0]), _lag(t, speed, results[1]),
                      min(af.filter.cutoffs_hz))
