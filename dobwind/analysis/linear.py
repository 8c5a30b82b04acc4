"""Linear models of the observer and the scheduled low-pass, taken from the CasADi step.

The step is linearized at a hover equilibrium (level, no wind, observer settled) with the schedule
frozen at a chosen wind speed. A disturbance enters the way the vehicle would feel it, through the
airframe's own acceleration input:
  - ned:            acc_ned += f / m
  - specific_force: specific_force += f / m (body axes; level hover at yaw 0)
  - velocity:       vel_ned = vel_prev + dt f / m (the velocity integrates the force)
  - with the acceleration bias estimate, the velocity integrates the force as well
or, for noise studies, as white noise added to that input. Per axis, only the states the force
output depends on are kept, and the result is a python-control discrete state-space system.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import control as ct
import numpy as np

from dobwind.model.numeric import rpm_for_rotor_thrust
from dobwind.model.step import StepModel


@dataclass(frozen=True)
class OperatingPoint:
    state: np.ndarray
    inputs: np.ndarray
    dt_s: float


def hover_point(model: StepModel, wind_speed_mps: float = 0.0, dt_s: float | None = None) -> OperatingPoint:
    af = model.airframe
    dt = af.observer.sample_time_s if dt_s is None else dt_s
    weight = af.mass_kg * af.gravity_mps2 / af.thrust.scale  # the nominal thrust that holds the weight
    values = {"dt": dt, "vel_ned": np.zeros(3), "acc_ned": np.zeros(3), "q": np.array([1.0, 0, 0, 0]),
              "specific_force": np.array([0, 0, -af.gravity_mps2]), "thrust": weight, "yaw_ref": 0.0}
    if "rotor_rpm" in model.inputs:
        values["rotor_rpm"] = rpm_for_rotor_thrust(af.thrust.coefficients, af.thrust.max_rpm,
                                                   np.full(af.thrust.rotors, weight / af.thrust.rotors))
    inputs = model.inputs.pack({f.name: values[f.name] for f in model.inputs.fields})
    state = model.state.unpack(model.initial_state())
    state["initialized"][:] = 1.0
    state["last.wind_speed_h"][:] = wind_speed_mps
    # Settle the observer on the hover sample so the point is an equilibrium to rounding.
    x = model.state.pack({k: v for k, v in state.items()})
    for _ in range(3):
        x = np.asarray(model.step(x, inputs)[0]).ravel()
        x[model.state.slice("last.wind_speed_h")] = wind_speed_mps
    return OperatingPoint(x, inputs, dt)


def _injected_inputs(model: StepModel, u0: ca.SX, dt: ca.SX, x: ca.SX, d: ca.SX, kind: str) -> ca.SX:
    af = model.airframe
    u = ca.SX(u0)
    mode = af.observer.acceleration
    force = kind == "force"
    if mode != "velocity":
        sl = model.inputs.slice("acc_ned" if mode == "ned" else "specific_force")
        u[sl] = u[sl] + (d / af.mass_kg if force else d)
    sv = model.inputs.slice("vel_ned")
    if force and (mode == "velocity" or af.observer.estimates_acceleration_bias):
        # A real force moves the velocity too (the bias estimate would otherwise take it for a bias).
        u[sv] = x[model.state.slice("vel_prev")] + dt / af.mass_kg * d
    elif mode == "velocity":
        u[sv] = u[sv] + d  # velocity noise
    return u


def jacobian_function(model: StepModel, kind: str = "force") -> ca.Function:
    """(x, u0, dt) -> (A, B): A = d x_next / d x, B = d x_next / d disturbance (3 columns), for a
    disturbance of the given kind ("force", N; or "noise" in the acceleration input's units)."""
    x = ca.SX.sym("x", model.state.size)
    u0 = ca.SX.sym("u0", model.inputs.size)
    dt = ca.SX.sym("dt")
    d = ca.SX.sym("d", 3)
    x_next = model.step(x, _injected_inputs(model, u0, dt, x, d, kind))[0]
    a, b = ca.jacobian(x_next, x), ca.jacobian(x_next, d)
    zero = ca.Function("lin", [x, d, u0, dt], [a, b])
    return ca.Function("lin0", [x, u0, dt], zero.call([x, ca.SX.zeros(3), u0, dt]))


def _relevant_states(a: np.ndarray, output: int) -> list[int]:
    """Every state the output reads, directly or through others (backward closure over A)."""
    keep = {output}
    frontier = [output]
    while frontier:
        row = frontier.pop()
        for j in np.flatnonzero(a[row] != 0.0):
            if j not in keep:
                keep.add(int(j))
                frontier.append(int(j))
    return sorted(keep)


@dataclass(frozen=True)
class Linearization:
    """A and B of the step at one operating point, with the schedule frozen."""
    model: StepModel
    a: np.ndarray
    b: np.ndarray
    dt_s: float

    def axis(self, axis: int, with_filter: bool = True) -> ct.StateSpace:
        """Discrete SISO system from the axis's disturbance to the force estimate the step returns
        (after the low-pass when with_filter, else the observer's)."""
        out = self.model.state.offset("f_filt" if with_filter else "f_obs") + axis
        keep = _relevant_states(self.a, out)
        # The step returns the updated state: y(k) = x(k+1)[out] = A[out] x(k) + B[out] d(k).
        return ct.ss(self.a[np.ix_(keep, keep)], self.b[keep, axis:axis + 1], self.a[out:out + 1, keep],
                     self.b[out:out + 1, axis:axis + 1], self.dt_s)


def linearize(model: StepModel, wind_speed_mps: float = 0.0, dt_s: float | None = None, kind: str = "force",
              function: ca.Function | None = None) -> Linearization:
    point = hover_point(model, wind_speed_mps, dt_s)
    function = function or jacobian_function(model, kind)
    a, b = (np.asarray(m) for m in function(point.state, point.inputs, point.dt_s))
    # Frozen schedule: the last outputs (the wind speed that sets the cutoff) are parameters here, not
    # states. Their coupling is zero at an exact equilibrium anyway; dropping it also keeps out the
    # undefined derivatives of atan2 and hypot at zero wind.
    for f in model.state.fields:
        if f.name.startswith("last."):
            a[:, model.state.slice(f.name)] = 0.0
    return Linearization(model, a, b, point.dt_s)


def axis_system(model: StepModel, axis: int, with_filter: bool = True, wind_speed_mps: float = 0.0,
                dt_s: float | None = None, kind: str = "force") -> ct.StateSpace:
    return linearize(model, wind_speed_mps, dt_s, kind).axis(axis, with_filter)


def continuous_observer(rate_per_s: float) -> ct.TransferFunction:
    """The continuous observer the discretizations approximate: w / (s + w), w = lambda / m."""
    return ct.tf([rate_per_s], [1.0, rate_per_s])
