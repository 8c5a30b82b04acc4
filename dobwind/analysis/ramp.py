"""The ramp experiment: a hovering vehicle in wind ramping to 10 m/s, the scheduled low-pass against
a fixed one at the lowest cutoff. The force is made from the airframe's own force-air model (so only
the observer and filter dynamics are on trial), the vehicle tilts to hold position, and the Python
reference runs the step over the whole ramp.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import casadi as ca
import numpy as np

from dobwind.model import forceair, reference
from dobwind.model.airframe import Airframe, FilterSchedule
from dobwind.model.attitude import attitude_with_body_down, quaternion_wxyz
from dobwind.model.numeric import bisect_increasing, rpm_for_rotor_thrust
from dobwind.model.step import StepModel, build_step
from dobwind.model.terms import polynomial_expr

RAMP_START_S, RAMP_RATE_MPS2, RAMP_TOP_MPS, HOLD_S = 5.0, 0.5, 10.0, 15.0
LAG_LEVELS_MPS = np.arange(2.0, 9.01, 0.5)


def _model_functions(af: Airframe) -> tuple[ca.Function, ca.Function]:
    m, n, fz = ca.SX.sym("m"), ca.SX.sym("n"), ca.SX.sym("fz")
    env = forceair.term_variables(m, n, fz)
    horizontal = ca.Function("h", [m, n, fz], [polynomial_expr(af.horizontal.terms, af.horizontal.coefficients, env)])
    vertical = ca.Function("v", [m, n, fz], [polynomial_expr(af.vertical.terms, af.vertical.coefficients, env)])
    return horizontal, vertical


def _monotone_inverse(values: np.ndarray, grid: np.ndarray, zero: int, target: np.ndarray) -> np.ndarray:
    """Invert a sampled function on the monotone branch through grid[zero] (targets off it clamp)."""
    step = np.sign(np.diff(values))
    direction = step[zero] if step[zero] != 0 else 1.0
    lo = zero
    while lo > 0 and step[lo - 1] == direction:
        lo -= 1
    hi = zero
    while hi < len(step) and step[hi] == direction:
        hi += 1
    branch_v, branch_g = values[lo:hi + 1], grid[lo:hi + 1]
    if direction < 0:
        branch_v, branch_g = branch_v[::-1], branch_g[::-1]
    return np.interp(target, branch_v, branch_g)


def force_for_airflow(af: Airframe, air_rel_ned: np.ndarray, yaw: np.ndarray, max_force_n: float | None = None) -> np.ndarray:
    """External force (NED, rows) that the airframe's force-air model maps to the given relative
    airflow: horizontal force along the airflow (searched up to the weight), vertical force on the
    vertical model's monotone branch through zero force."""
    max_force_n = max_force_n or af.mass_kg * af.gravity_mps2
    horizontal, vertical = _model_functions(af)
    h_map = horizontal.map(len(yaw))
    c, s = np.cos(yaw), np.sin(yaw)
    rel_c = np.stack(forceair.heading_force(air_rel_ned.T, c, s, (0.0, 0.0, 0.0))[:2], 1)
    speed = np.hypot(rel_c[:, 0], rel_c[:, 1])
    direction = np.where(speed[:, None] > 0, rel_c / np.maximum(speed, 1e-12)[:, None], [1.0, 0.0])
    h_of = lambda fh: np.asarray(h_map(fh * direction[:, 0], fh * direction[:, 1], np.zeros_like(fh))).ravel()
    fh = bisect_increasing(h_of, speed, 0.0, max_force_n)
    grid = np.linspace(-max_force_n, max_force_n, 4001)
    v_grid = np.asarray(vertical.map(len(grid))(np.zeros_like(grid), np.zeros_like(grid), grid)).ravel()
    if np.ptp(v_grid) == 0.0:  # a vertical model that ignores fz cannot be inverted: no vertical force
        fz = np.zeros(len(yaw))
    else:
        fz = _monotone_inverse(v_grid, grid, len(grid) // 2, air_rel_ned[:, 2])
    off = np.asarray(af.observer.force_offset_n)
    m_c, n_c = fh * direction[:, 0] + off[0], fh * direction[:, 1] + off[1]
    return np.stack([*forceair.heading_to_ned(m_c, n_c, c, s), fz + off[2]], 1)


def hover_inputs(model: StepModel, force_ned: np.ndarray, yaw: np.ndarray, dt: float) -> np.ndarray:
    """Inputs of a vehicle holding position against an external force: tilted so that
    -u_f z_b + m g e3 + f = 0, no acceleration, no velocity."""
    af = model.airframe
    n = len(yaw)
    need = af.mass_kg * af.gravity_mps2 * np.array([0, 0, 1.0]) + force_ned
    true_thrust = np.linalg.norm(need, axis=1)
    thrust = true_thrust / af.thrust.scale  # what the sensors report, through the calibrated scale
    rot = attitude_with_body_down(need / true_thrust[:, None], yaw)
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
