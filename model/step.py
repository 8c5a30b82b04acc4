"""The estimator's one source of truth: a CasADi ``step(state, input) -> (state_next, output, status)``
built from an airframe.

The step is assembled from named stages (attitude, thrust, acceleration, external force, observer,
low-pass, force-air, wind). Each stage is its own small SX Function with named signals, so the C
generator can print it as a labelled section with readable variable names; the composed ``step`` is
what the Python reference runs and what the generated C is verified against.

Signals are named "in.<field>" (inputs), "state.<field>" (previous state) or by the stage that makes
them. A rejected sample (a rejection bit in the status) leaves the estimate unchanged; the output then
repeats the last accepted one, which the state carries in its ``last.*`` fields. Only the gap
bookkeeping ``run_s`` advances on rejection (it drops to 0), so that the next accepted sample knows it
follows a gap: it must not difference the velocity across the gap, and it starts a SETTLING period.
Quality bits (SETTLING, EXTRAPOLATED, UNCALIBRATED) flag accepted samples; see status.py. The frames, signs and
equations of every stage, and the paper's slips the stages correct, are in docs/model.md.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import Callable

import casadi as ca
import numpy as np

from dobwind.model.airframe import Airframe
from dobwind.model import biasgate, forceair
from dobwind.model.discretization import first_order
from dobwind.model.dynamics import quaternion_to_rotation_any_norm, solve_external_force
from dobwind.model.layout import Field, Layout
from dobwind.model.plausibility import implausible_inputs, input_bounds, wind_beyond_bound, within_bounds
from dobwind.model.settling import settling_time_s
from dobwind.model.status import (DT_TOLERANCE, INPUT_MAGNITUDE_LIMIT, MIN_DT_S, QUATERNION_NORM_TOLERANCE,
                                  RESULT_MAGNITUDE_LIMIT, STATUS_BITS)
from dobwind.model.kinds import DragFrame
from dobwind.model.signals import log_signals

# The sigma outputs when the airframe records no [uncertainty] table: "unknown", never NaN.
UNKNOWN_SIGMA = -1.0

Signals = dict[str, ca.SX]


@dataclass(frozen=True)
class Stage:
    name: str
    doc: str
    function: ca.Function
    inputs: tuple[str, ...]   # signal names, in the Function's input order
    outputs: tuple[str, ...]  # signal names, in the Function's output order


@dataclass(frozen=True)
class StepModel:
    airframe: Airframe
    inputs: Layout
    state: Layout
    outputs: Layout
    validate: Stage
    stages: tuple[Stage, ...]
    check_result: Stage  # rejects results that overflowed (status bit NUMERIC)
    next_state: tuple[tuple[str, str], ...]  # (state field, signal that becomes it)
    step: ca.Function
    settling_time_s: float  # baked into the SETTLING bit
    # (state field, value) written on a rejected sample: the gap bookkeeping, nothing of the estimate
    reset_on_reject: tuple[tuple[str, float], ...] = (("run_s", 0.0),)
    # (state field, signal) written when a validated sample is rejected after the front end (the
    # acceleration check, model/biasgate.py): the check's own bookkeeping, nothing of the estimate
    advance_on_check: tuple[tuple[str, str], ...] = ()

    def initial_state(self) -> np.ndarray:
        """Zeros but the last output's 1-sigma fields, -1 (unknown): a sample rejected before the first
        accepted one repeats this output, and a 0 there would read as a perfectly known wind."""
        state = np.zeros(self.state.size)
        for name in UNKNOWN_BEFORE_FIRST:
            state[self.state.slice(name)] = -1.0
        return state


def input_layout(af: Airframe) -> Layout:
    fields = [
        Field("dt", 1, "s", "time since the previous step"),
        Field("vel_ned", 3, "m/s", "ground velocity, NED"),
    ]
    if log_signals(af).ned_acceleration:
        fields.append(Field("acc_ned", 3, "m/s^2", "kinematic acceleration d2p/dt2, NED"))
    elif log_signals(af).specific_force:
        fields.append(Field("specific_force", 3, "m/s^2", "accelerometer specific force, body FRD"))
    fields.append(Field("q", 4, "-", "attitude quaternion w, x, y, z: body FRD -> NED"))
    if log_signals(af).rotor_speeds:
        fields.append(Field("rotor_rpm", af.thrust.rotors, "rev/min", "rotor speeds"))
    else:
        fields.append(Field("thrust", 1, "N", "collective thrust along -z body"))
    fields.append(Field("yaw_ref", 1, "rad", "desired yaw psi_d: the heading frame"))
    return Layout(tuple(fields))


OUTPUT_FIELDS = (
    Field("force_ned", 3, "N", "filtered external force, NED"),
    Field("wind_ned", 3, "m/s", "wind: velocity of the air over ground, NED"),
    Field("wind_speed_h", 1, "m/s", "horizontal wind speed"),
    Field("wind_speed_up", 1, "m/s", "vertical wind, positive up"),
    Field("wind_from_deg", 1, "deg", "direction the wind blows FROM, clockwise from north, [0, 360)"),
    Field("wind_sigma_h", 1, "m/s", "1-sigma error of the horizontal wind speed: the calibration "
          "residuals at this speed and the observer noise (-1: the airframe records no uncertainty)"),
    Field("wind_sigma_up", 1, "m/s", "1-sigma error of the vertical wind (-1: unknown)"),
)


# The state's fields that start at -1, not 0 (StepModel.initial_state; the C init writes the same).
UNKNOWN_BEFORE_FIRST = ("last.wind_sigma_h", "last.wind_sigma_up")


def output_layout() -> Layout:
    return Layout(OUTPUT_FIELDS)


def uses_previous_velocity(af: Airframe) -> bool:
    return (not log_signals(af).measured_acceleration or af.observer.discretization == "tustin"
            or af.observer.estimates_acceleration_bias)


def state_layout(af: Airframe) -> Layout:
    fields = [
        Field("f_obs", 3, "N", "observer estimate of the external force, NED"),
        Field("v_obs", 3, "m/s", "ground velocity through the observer's response (delay matching)"),
        Field("f_filt", 3, "N", "observer estimate after the scheduled low-pass, NED"),
        Field("v_filt", 3, "m/s", "ground velocity after the same two responses"),
    ]
    if af.observer.discretization == "tustin":
        fields.append(Field("fe_prev", 3, "N", "previous raw external force (Tustin)"))
    if uses_previous_velocity(af):
        fields.append(Field("vel_prev", 3, "m/s", "previous ground velocity"))
    if af.observer.estimates_acceleration_bias:
        fields.append(Field("acc_bias", 3, "m/s^2", "acceleration input minus the velocity's derivative, "
                            "slowly averaged (the input's bias), NED"))
        fields += [Field("acc_check", 3, "m/s^2", "acceleration check: the disagreement minus the bias, averaged "
                         f"over {biasgate.CHECK_TIME_S:g} s (model/biasgate.py)"),
                   Field("acc_noise", 1, "m^2/s^4", "acceleration check: mean square of acc_check (its bound)"),
                   Field("check_follows", 1, "-", "acceleration check: 1 when vel_prev is the previous sample's")]
    if _body_drag(af):
        fields.append(Field("air_prev", 3, "m/s", "relative airflow of the last accepted sample, body FRD: "
                            "the drag law's inversion starts from it"))
    fields += [Field(f"last.{f.name}", f.size, f.unit, "last valid output: " + f.doc) for f in OUTPUT_FIELDS]
    fields.append(Field("initialized", 1, "-", "0 until the first accepted sample, then 1"))
    fields.append(Field("run_s", 1, "s", "accepted time since the start or the last gap, capped at the "
                        "settling time; set to 0 by a rejected sample (the only field a rejection changes)"))
    return Layout(tuple(fields))


def _ident(signal: str) -> str:
    return signal.replace(".", "_")


class _Builder:
    """Adds stages one by one, composing their symbolic outputs into the growing signal table."""

    def __init__(self, signals: Signals) -> None:
        self.signals = signals
        self.stages: list[Stage] = []

    def add(self, name: str, doc: str, inputs: list[str], body: Callable[[Signals], Signals]) -> Stage:
        symbols = {s: ca.SX.sym(_ident(s), self.signals[s].numel()) for s in inputs}
        # Dense outputs: structural zeros would otherwise leave C array elements unassigned.
        result = {k: ca.densify(v) for k, v in body(symbols).items()}
        function = ca.Function(
            name, [symbols[s] for s in inputs], list(result.values()),
            [_ident(s) for s in inputs], [_ident(s) for s in result], {"cse": True},
        )
        outputs = function.call([self.signals[s] for s in inputs])
        for signal, value in zip(result, outputs):
            if signal in self.signals:
                raise ValueError(f"signal {signal} defined twice")
            self.signals[signal] = value
        stage = Stage(name, doc, function, tuple(inputs), tuple(result))
        self.stages.append(stage)
        return stage


def _all(conditions: list[ca.SX]) -> ca.SX:
    result = conditions[0]
    for condition in conditions[1:]:
        result = ca.logic_and(result, condition)
    return result


def _schedule_cutoff(speeds: tuple[float, ...], cutoffs: tuple[float, ...], speed: ca.SX) -> ca.SX:
    """Piecewise-linear cutoff (Hz) over speed, clamped outside the breakpoints."""
    cutoff: ca.SX = ca.SX(cutoffs[0])
    for (s0, c0), (s1, c1) in zip(zip(speeds, cutoffs), zip(speeds[1:], cutoffs[1:])):
        if c1 != c0:
            cutoff = cutoff + (c1 - c0) / (s1 - s0) * (ca.fmin(ca.fmax(speed, s0), s1) - s0)
    return cutoff


def build_step(af: Airframe) -> StepModel:
    """The step of ``af``, assembled from the stage functions below in the order the C prints them."""
    lin, lstate, lout = input_layout(af), state_layout(af), output_layout()
    x = ca.SX.sym("state", lstate.size)
    u = ca.SX.sym("input", lin.size)
    signals: Signals = {f"in.{f.name}": u[lin.slice(f.name)] for f in lin.fields}
    signals.update({f"state.{f.name}": x[lstate.slice(f.name)] for f in lstate.fields})
    b = _Builder(signals)
    validate_stage = b.add("validate", VALIDATE_DOC, [f"in.{f.name}" for f in lin.fields], partial(_validate, af, lin))
    _add_front_end(b, af)
    _add_observer_and_low_pass(b, af)
    _add_back_end(b, af)
    # Held as the nearest float: the single-precision C then compares run_s against the very value the
    # reference uses (with a settling time above ~100 s a float run_s cannot tell settle from settle - 1e-5).
    settle = float(np.float32(settling_time_s(af)))
    _add_quality_stages(b, af, settle)
    next_state = _next_state(lstate, signals)
    _add_result_check(b, af)
    reset, advance = _rejection_writes(af)
    step = _compose(af, signals, next_state, x, u, lstate, lout, reset, advance)
    return StepModel(af, lin, lstate, lout, validate_stage, tuple(b.stages[1:-1]), b.stages[-1], next_state, step,
                     settle, reset, advance)


def _rejection_writes(af: Airframe) -> tuple[tuple[tuple[str, float], ...], tuple[tuple[str, str], ...]]:
    """What a rejection writes: the gap bookkeeping always; the acceleration check's state when the sample
    was validated (its velocity is then the next sample's vel_prev), so that the check follows the inputs
    through the samples it rejects and lets them in again once they agree."""
    if not af.observer.estimates_acceleration_bias:
        return StepModel.reset_on_reject, ()
    return (StepModel.reset_on_reject + (("check_follows", 0.0),),
            (("acc_check", "acc_check_new"), ("acc_noise", "acc_noise_new"), ("check_follows", "const.one"),
             ("vel_prev", "in.vel_ned")))


# --- validation ---------------------------------------------------------------------------------------

def finite_inputs(every: ca.SX) -> ca.SX:
    """NONFINITE's test: every input element within +-INPUT_MAGNITUDE_LIMIT. NaN fails every comparison,
    so it is false for NaN and for +-inf alike."""
    return _all([ca.fabs(every[i]) <= INPUT_MAGNITUDE_LIMIT for i in range(every.numel())])


VALIDATE_DOC = "reject NaN/inf, bad dt, non-unit quaternion, excessive tilt, negative thrust"
FINITE_SIGNAL = "finite"  # validation's finiteness test as an input of its own (validate_given_finite)


def validate_given_finite(af: Airframe, lin: Layout) -> Stage:
    """The validate stage with the finiteness test as an input (0/1) instead of its expression: the C
    computes that test as one loop over the input struct (the same test on every element), and the rest
    of validation as printed from this Function. Same outputs as build_step's validate stage."""
    symbols = {f"in.{f.name}": ca.SX.sym(_ident(f"in.{f.name}"), f.size) for f in lin.fields}
    finite = ca.SX.sym(FINITE_SIGNAL)
    result = _validate(af, lin, {**symbols, FINITE_SIGNAL: finite})
    inputs = [*symbols, FINITE_SIGNAL]
    function = ca.Function("validate", [*symbols.values(), finite], list(result.values()),
                           [_ident(name) for name in inputs], list(result), {"cse": True})
    return Stage("validate", VALIDATE_DOC, function, tuple(inputs), tuple(result))


def _validate(af: Airframe, lin: Layout, s: Signals) -> Signals:
    bits = {bit.name: bit.value for bit in STATUS_BITS}
    every = ca.vertcat(*[s[f"in.{f.name}"] for f in lin.fields])
    finite = s[FINITE_SIGNAL] if FINITE_SIGNAL in s else finite_inputs(every)
    dt = s["in.dt"]
    dt_ok = ca.logic_and(dt >= MIN_DT_S, dt <= af.limits.max_dt_s * (1 + DT_TOLERANCE))
    q = s["in.q"]
    norm2 = ca.sumsqr(q)
    q_ok = ca.logic_and(norm2 >= (1 - QUATERNION_NORM_TOLERANCE) ** 2, norm2 <= (1 + QUATERNION_NORM_TOLERANCE) ** 2)
    # R33 = cos(tilt) = (w^2 - x^2 - y^2 + z^2) / |q|^2, compared without dividing.
    r33_scaled = q[0] * q[0] - q[1] * q[1] - q[2] * q[2] + q[3] * q[3]
    tilt_ok = r33_scaled >= math.cos(math.radians(af.limits.max_tilt_deg)) * norm2
    if log_signals(af).rotor_speeds:
        rpm = s["in.rotor_rpm"]
        thrust_ok = _all([rpm[i] >= 0 for i in range(rpm.numel())])
    else:
        thrust_ok = s["in.thrust"] >= 0
    plausible = ca.logic_not(implausible_inputs(s, af.mass_kg, af.gravity_mps2, af.thrust.max_rpm))
    status = (
        ca.if_else(plausible, 0, bits["IMPLAUSIBLE"])
        + ca.if_else(finite, 0, bits["NONFINITE"])
        + ca.if_else(dt_ok, 0, bits["BAD_DT"])
        + ca.if_else(q_ok, 0, bits["BAD_QUATERNION"])
        + ca.if_else(tilt_ok, 0, bits["TILT"])
        + ca.if_else(thrust_ok, 0, bits["BAD_THRUST"])
    )
    return {"status": status, "quick_accept": _quick_accept(af, lin, s, [dt_ok, q_ok, tilt_ok])}


def _quick_accept(af: Airframe, lin: Layout, s: Signals, exact: list[ca.SX]) -> ca.SX:
    """A test that implies acceptance (status 0) and costs less: the C runs it first and computes the
    status bits only for a sample it does not accept (the rare one).

    It is validation's tests in the form that a NaN fails: dt's, the quaternion's and the tilt's as
    they are (``exact``), the plausibility bounds as "within" (model/plausibility.py), and each rotor
    speed or the thrust as 0 <= x <= its bound, which implies thrust_ok too. Every element those bounds
    hold below INPUT_MAGNITUDE_LIMIT is then finite without NONFINITE's test (dt <= max_dt, |q_i| <=
    |q| <= 1.1, |v_i| <= |v|, ...): that test, a pass over every input, is kept only for the elements no
    bound holds (yaw_ref, and any input added later). Sufficient, not necessary: a sample it refuses
    may still be accepted (a rotor at -0 rpm), by the exact status."""
    bounds = input_bounds(set(s), af.mass_kg, af.gravity_mps2, af.thrust.max_rpm)
    tests = list(exact) + within_bounds(s, bounds)
    held = {b.field for b in bounds if b.limit <= INPUT_MAGNITUDE_LIMIT}
    held |= {"in.q"} | ({"in.dt"} if af.limits.max_dt_s * (1 + DT_TOLERANCE) <= INPUT_MAGNITUDE_LIMIT else set())
    for field in lin.fields:
        if f"in.{field.name}" not in held:
            tests.append(finite_inputs(s[f"in.{field.name}"]))
    return _all(tests)


# --- front end: external force --------------------------------------------------------------------

def _add_front_end(b: _Builder, af: Airframe) -> None:
    """attitude, thrust, acceleration and external force: the raw f_e of every accepted sample."""
    obs = af.observer
    b.add("attitude", "unit quaternion -> body down axis z_b (and rotation) in NED", ["in.q"],
          partial(_attitude, af))
    thrust_input = "in.rotor_rpm" if log_signals(af).rotor_speeds else "in.thrust"
    b.add("thrust", "collective thrust u_f (N) along -z_b", [thrust_input], partial(_thrust, af))
    accel_inputs = {
        "ned": ["in.acc_ned"],
        "specific_force": ["in.specific_force", "rot_body_to_ned"],
        "velocity": ["in.vel_ned", "state.vel_prev", "in.dt", "state.run_s"],
    }[obs.acceleration]
    if obs.estimates_acceleration_bias:
        accel_inputs = accel_inputs + ["state.acc_bias", "in.vel_ned", "state.vel_prev", "in.dt", "state.run_s",
                                       *[f"state.{f}" for f in biasgate.STATE_FIELDS]]
    b.add("acceleration", "kinematic acceleration p'' (m/s^2, NED)"
          + (f", minus its velocity-aided bias (time constant {obs.acceleration_bias_time_s:g} s)"
             if obs.estimates_acceleration_bias else ""),
          accel_inputs, partial(_acceleration, af))
    m, g0 = af.mass_kg, af.gravity_mps2
    b.add("external_force", "f_e solved from m p'' = -u_f z_b + m g e3 + f_e (N, NED)",
          ["p_ddot", "u_f", "z_b"],
          lambda s: {"f_e": solve_external_force(m, g0, s["p_ddot"], s["u_f"], s["z_b"])})


def _body_drag(af: Airframe) -> bool:
    """The body-frame drag law: its force-air stage needs the attitude and the thrust."""
    return af.drag is not None and af.drag.frame == DragFrame.BODY


def _attitude(af: Airframe, s: Signals) -> Signals:
    rot = quaternion_to_rotation_any_norm(s["in.q"])  # the validated q is near unit, not exactly
    out = {"z_b": rot[:, 2]}
    if log_signals(af).specific_force or _body_drag(af):
        out["rot_body_to_ned"] = ca.reshape(rot, 9, 1)
    return out


def _thrust(af: Airframe, s: Signals) -> Signals:
    scale = af.thrust.scale  # calibrated true/nominal thrust; folded into the coefficients
    if af.thrust.source == "collective":
        return {"u_f": s["in.thrust"] * scale if scale != 1.0 else s["in.thrust"]}
    # sum_i P(rpm_i / max) = sum_k c_k (sum_i rpm_i^k) / max^k: one power sum per degree, fewer
    # operations than a polynomial per rotor.
    rpm = s["in.rotor_rpm"]
    total: ca.SX = ca.SX(af.thrust.rotors * af.thrust.coefficients[0] * scale)
    powers = [ca.SX(1.0)] * af.thrust.rotors
    for k, c in enumerate(af.thrust.coefficients[1:], start=1):
        powers = [powers[i] * rpm[i] for i in range(af.thrust.rotors)]
        if c != 0.0:
            power_sum = powers[0]
            for p in powers[1:]:
                power_sum = power_sum + p
            total = total + (c * scale / af.thrust.max_rpm ** k) * power_sum
    return {"u_f": total}


def _acceleration(af: Airframe, s: Signals) -> Signals:
    obs = af.observer
    # vel_prev is the velocity of the previous sample only if that sample was accepted (run_s > 0);
    # after the start or a gap, differencing would divide the whole gap's velocity change by one dt.
    if not log_signals(af).measured_acceleration:
        follows = ca.if_else(s["state.run_s"] > 0, 1, 0)
        # Backward difference; a sample with no accepted predecessor counts as unaccelerated.
        diff = (s["in.vel_ned"] - s["state.vel_prev"]) / s["in.dt"]
        return {"p_ddot": follows * diff}  # follows is exactly 0 or 1
    if log_signals(af).ned_acceleration:
        measured = s["in.acc_ned"]
    else:
        rot = ca.reshape(s["rot_body_to_ned"], 3, 3)
        measured = rot @ s["in.specific_force"] + ca.vertcat(0, 0, af.gravity_mps2)
    if not obs.estimates_acceleration_bias:
        return {"p_ddot": measured}
    follows = ca.if_else(s["state.run_s"] > 0, 1, 0)
    # Velocity-aided bias: a real force moves the measured acceleration and the velocity's
    # derivative alike, a sensor or attitude bias only the former. Averaged over bias_time, their
    # difference is the bias; the differentiated velocity's noise is averaged away with it.
    difference = measured - (s["in.vel_ned"] - s["state.vel_prev"]) / s["in.dt"]
    weight = follows * -ca.expm1(-s["in.dt"] / obs.acceleration_bias_time_s)  # no bias update across a gap
    bias = s["state.acc_bias"]
    gate = biasgate.check(difference - bias, s["in.dt"], s["state.acc_check"], s["state.acc_noise"],
                          s["state.check_follows"])
    return {"p_ddot": measured - bias, "acc_bias_new": bias + weight * (difference - bias), **gate}


# --- observer and low-pass, applied alike to the force and to the ground velocity -------------------

def _add_observer_and_low_pass(b: _Builder, af: Airframe) -> None:
    obs = af.observer
    observer_inputs = ["state.f_obs", "state.v_obs", "f_e", "in.vel_ned", "in.dt", "state.initialized"]
    if obs.discretization == "tustin":
        observer_inputs += ["state.fe_prev", "state.vel_prev", "state.run_s"]
    b.add("observer", f"disturbance observer ({obs.discretization}), gains {list(obs.gains)} kg/s",
          observer_inputs, partial(_observer, af))
    b.add("low_pass", "first-order low-pass, cutoff scheduled on the last horizontal wind speed",
          ["state.f_filt", "state.v_filt", "f_obs_new", "v_obs_new", "state.last.wind_speed_h", "in.dt",
           "state.initialized"], partial(_low_pass, af))


def _observer(af: Airframe, s: Signals) -> Signals:
    obs = af.observer
    rates = ca.DM(obs.gains) / af.mass_kg  # lambda_i / m, 1/s
    started = s["state.initialized"]  # exactly 0 or 1, so the products below are exact
    if obs.discretization == "tustin":
        # After a gap the previous inputs are stale: the trapezoid then uses the current input twice.
        follows = ca.if_else(s["state.run_s"] > 0, 1, 0)
        fe_prev = follows * s["state.fe_prev"] + (1 - follows) * s["f_e"]
        vel_prev = follows * s["state.vel_prev"] + (1 - follows) * s["in.vel_ned"]
    f_new, v_new = [], []
    for i in range(3):
        c = first_order(obs.discretization, float(rates[i]), s["in.dt"])
        # Before the first accepted sample the coefficients become (0, 1, 0): the estimate starts at
        # the measurement instead of at zero, with no per-element branch.
        pole, b0 = started * c.pole, started * c.b0 + (1 - started)
        f_next = pole * s["state.f_obs"][i] + b0 * s["f_e"][i]
        # The ground velocity takes the same path so that the wind triangle adds equal delays.
        v_next = pole * s["state.v_obs"][i] + b0 * s["in.vel_ned"][i]
        if obs.discretization == "tustin":
            b1 = started * c.b1
            f_next += b1 * fe_prev[i]
            v_next += b1 * vel_prev[i]
        f_new.append(f_next)
        v_new.append(v_next)
    return {"f_obs_new": ca.vertcat(*f_new), "v_obs_new": ca.vertcat(*v_new)}


def _low_pass(af: Airframe, s: Signals) -> Signals:
    cutoff = _schedule_cutoff(af.filter.speeds_mps, af.filter.cutoffs_hz, s["state.last.wind_speed_h"])
    # ZOH-exact first order; alpha = 1 before the first accepted sample (start at the input).
    started = s["state.initialized"]
    alpha = started * -ca.expm1((-2 * math.pi) * cutoff * s["in.dt"]) + (1 - started)
    keep = 1 - alpha
    return {
        "cutoff_hz": cutoff,
        "f_filt_new": keep * s["state.f_filt"] + alpha * s["f_obs_new"],
        "v_filt_new": keep * s["state.v_filt"] + alpha * s["v_obs_new"],
    }


# --- back end: force-air model and wind triangle -------------------------------------------------

def _add_back_end(b: _Builder, af: Airframe) -> None:
    body = _body_drag(af)
    b.add("force_air", "heading-frame force -> relative airflow (air minus vehicle velocity), NED"
          + (" (body-frame drag law at the measured attitude)" if body else ""),
          ["f_filt_new", "in.yaw_ref"] + (["rot_body_to_ned", "u_f", "state.air_prev", "state.initialized"] if body else []),
          partial(_force_air, af))
    if af.vertical_law == "fitted":
        b.add("wind", "wind triangle and the reported quantities", ["air_rel_ned", "v_filt_new"], _wind)
    else:
        b.add("wind", "wind triangle and the reported quantities; the vertical law is not identified "
              "(force_air.vertical_law): zero vertical wind", ["air_rel_ned", "v_filt_new"], _wind_level)


def _force_air(af: Airframe, s: Signals) -> Signals:
    offset = af.observer.force_offset_n
    c, sn = ca.cos(s["in.yaw_ref"]), ca.sin(s["in.yaw_ref"])
    mm, nn, fz = forceair.heading_force(s["f_filt_new"], c, sn, offset)
    if _body_drag(af):
        force, rotor = body_drag_target(af, s)
        air, air_body = forceair.body_drag_airflow_tracking(
            af.drag, force, ca.reshape(s["rot_body_to_ned"], 3, 3), rotor, s["state.air_prev"],
            s["state.initialized"])
        north, east, rel_z = air[0], air[1], air[2]
        speed_h = ca.sqrt(north * north + east * east)
        return {"force_heading": ca.vertcat(mm, nn, fz), "airflow_speed_h": speed_h,
                "air_rel_ned": ca.vertcat(north, east, rel_z), "air_body": air_body}
    elif af.drag is not None:
        rel_x, rel_y, rel_z = forceair.drag_airflow(af.drag, mm, nn, fz)
        speed_h = ca.sqrt(rel_x * rel_x + rel_y * rel_y)
        north, east = forceair.heading_to_ned(rel_x, rel_y, c, sn)
    else:
        rel_x, rel_y, rel_z, speed_h, along = forceair.polynomial_airflow(
            (af.horizontal.terms, af.horizontal.coefficients), (af.vertical.terms, af.vertical.coefficients),
            mm, nn, fz)
        if offset[0] == 0.0 and offset[1] == 0.0:
            # (x, y) = k (m, n) and (m, n) is the NED force turned by -yaw: turned back, k times the NED
            # force itself (four products and two sums fewer than the rotation).
            north, east = along * s["f_filt_new"][0], along * s["f_filt_new"][1]
        else:
            north, east = forceair.heading_to_ned(rel_x, rel_y, c, sn)
    return {"force_heading": ca.vertcat(mm, nn, fz), "airflow_speed_h": speed_h,
            "air_rel_ned": ca.vertcat(north, east, rel_z)}


def body_drag_target(af: Airframe, s: Signals) -> tuple[ca.SX, ca.SX]:
    """What the body-frame drag law is inverted for: the NED force with the offset removed, and the
    rotor term sqrt(u_f / (m g)). Also the harness's (harness/compare.py judges the tracked airflow
    ``air_prev`` through the force the law gives at it)."""
    offset = af.observer.force_offset_n
    c, sn = ca.cos(s["in.yaw_ref"]), ca.sin(s["in.yaw_ref"])
    mm, nn, fz = forceair.heading_force(s["f_filt_new"], c, sn, offset)
    # The offset is calibrated in the heading frame; the law acts on the body-frame airflow. Without
    # a horizontal offset, turning into the heading frame and back is the identity: the NED force
    # itself (no sine and cosine of yaw_ref at all).
    if offset[0] == 0.0 and offset[1] == 0.0:
        fn, fe = s["f_filt_new"][0], s["f_filt_new"][1]
    else:
        fn, fe = forceair.heading_to_ned(mm, nn, c, sn)
    rotor = ca.sqrt(ca.fmax(s["u_f"], 0) * (1 / (af.mass_kg * af.gravity_mps2)))
    return ca.vertcat(fn, fe, fz), rotor


def _wind(s: Signals) -> Signals:
    w = s["air_rel_ned"] + s["v_filt_new"]  # v_wind = v_rel + v_ground
    speed_h = ca.sqrt(w[0] * w[0] + w[1] * w[1])
    return {"wind_ned": w, "wind_speed_h": speed_h, "wind_speed_up": -w[2],
            "wind_from_deg": forceair.wind_from_deg_sx(w[0], w[1])}


def _wind_level(s: Signals) -> Signals:
    """_wind with zero vertical wind: the airframe's vertical law is a fallback (issue #31). Zero WIND
    rather than zero AIRFLOW: zero airflow would publish the vehicle's own climb rate as vertical wind."""
    found = _wind(s)  # one wind triangle for both (the mutation suite anchors on it)
    w = found["wind_ned"]
    return {**found, "wind_ned": ca.vertcat(w[0], w[1], ca.SX(0)), "wind_speed_up": ca.SX(0)}


# --- the next state and the result check -----------------------------------------------------------

# state field -> the signal that becomes it on an accepted sample
_NEXT_STATE_SIGNAL = {
    "f_obs": "f_obs_new", "v_obs": "v_obs_new", "f_filt": "f_filt_new", "v_filt": "v_filt_new",
    "fe_prev": "f_e", "vel_prev": "in.vel_ned", "initialized": "const.one",
    "last.force_ned": "f_filt_new", "last.wind_ned": "wind_ned", "last.wind_speed_h": "wind_speed_h",
    "last.wind_speed_up": "wind_speed_up", "last.wind_from_deg": "wind_from_deg",
    "acc_bias": "acc_bias_new", "run_s": "run_s_new", "air_prev": "air_body",
    "acc_check": "acc_check_new", "acc_noise": "acc_noise_new", "check_follows": "const.one",
    "last.wind_sigma_h": "wind_sigma_h", "last.wind_sigma_up": "wind_sigma_up",
}


def _next_state(lstate: Layout, signals: Signals) -> tuple[tuple[str, str], ...]:
    """(state field, signal) for every field; adds the constant that ``initialized`` becomes."""
    signals["const.one"] = ca.SX(1)
    return tuple((f.name, _NEXT_STATE_SIGNAL[f.name]) for f in lstate.fields)


def _committed(af: Airframe) -> list[str]:
    # Every other committed value reaches the outputs (f_e and the observer through the low-pass, the
    # velocity paths through the wind triangle), so a non-finite state cannot hide from this check.
    committed = ["f_filt_new", "wind_ned", "wind_speed_h"]
    if af.observer.estimates_acceleration_bias:
        committed.append("acc_bias_new")  # reaches the outputs only from the next sample on
    return committed


def _add_result_check(b: _Builder, af: Airframe) -> None:
    committed = _committed(af)
    gated = af.observer.estimates_acceleration_bias
    b.add("check_result", "an accepted sample must give a finite result, else it is rejected too"
          + (" (NUMERIC); and its acceleration must agree with its velocity (IMPLAUSIBLE, model/biasgate.py)"
             if gated else ""),
          committed + (["acc_status"] if gated else []), partial(_check_result, committed))


def _check_result(committed: list[str], s: Signals) -> Signals:
    # One sum: NaN and infinity propagate into it, and so does any overflow. Every term a magnitude (the
    # wind speed, a square root, too), so that the C knows the sum is never negative: its test is then one
    # comparison of the bits (codegen/sections.py, nonnegative).
    values = [ca.fabs(s[name]) for name in committed]
    ok = ca.sum1(ca.vertcat(*values)) <= RESULT_MAGNITUDE_LIMIT
    bits = {bit.name: bit.value for bit in STATUS_BITS}
    # No bound on the sample's raw external force: it is a difference of noisy measurements divided by dt
    # (velocity differentiated at 500 Hz reads several weights of noise), so bounding it rejected a quarter
    # of a high-rate log. The input bounds (implausible_inputs) catch the glitches it was meant for.
    status = ca.if_else(ok, 0, bits["NUMERIC"])
    if "acc_status" in s:
        # Like every rejection, the acceleration check's restarts SETTLING: the first glitched samples (the
        # average needs a few to see it) were accepted, and their transient must pass before trust returns.
        # acc_status is 0 or IMPLAUSIBLE, a float between stages; the test makes it a bit of the int status
        # the C assembles (codegen/sections.py, integer_status), as validation's are.
        status = ca.if_else(ok, ca.if_else(s["acc_status"] > 0, bits["IMPLAUSIBLE"], 0), status)
    return {"result_status": status}


def _compose(af: Airframe, signals: Signals, next_state: tuple[tuple[str, str], ...], x: ca.SX, u: ca.SX,
             lstate: Layout, lout: Layout, reset_on_reject: tuple[tuple[str, float], ...],
             advance_on_check: tuple[tuple[str, str], ...]) -> ca.Function:
    """The whole step: commit the proposed state on acceptance, else hold it (but for the gap bookkeeping
    and, for a validated sample, the acceleration check's own state)."""
    proposed = ca.vertcat(*[signals[sig] for _, sig in next_state])
    validated = signals["status"] == 0
    rejected = ca.if_else(validated, signals["result_status"], signals["status"])
    reset, advance = dict(reset_on_reject), dict(advance_on_check)
    held = [ca.SX(reset[f.name]) if f.name in reset else x[lstate.slice(f.name)] for f in lstate.fields]
    if advance:
        checked = [signals[advance[f.name]] if f.name in advance else h for f, h in zip(lstate.fields, held)]
        held = [ca.if_else(validated, c, h) for c, h in zip(checked, held)]
    x_next = ca.densify(ca.if_else(rejected == 0, proposed, ca.vertcat(*held)))
    status = ca.if_else(rejected == 0, signals["quality_status"], rejected)
    y = ca.vertcat(*[x_next[lstate.slice(f"last.{f.name}")] for f in lout.fields])
    return ca.Function(f"{af.name}_step", [x, u], [x_next, y, status], ["state", "input"],
                       ["state_next", "output", "status"], {"cse": True})


def _interp(speeds: tuple[float, ...], values: tuple[float, ...], speed: ca.SX) -> ca.SX:
    """Piecewise linear over speed, clamped outside (the same form as the cutoff schedule)."""
    return _schedule_cutoff(speeds, values, speed)


def _quadrature(model_sigma: ca.SX, noise: float) -> ca.SX:
    """The model's error and the observer noise are independent: their variances add. Without a noise
    term the model's sigma passes unchanged (no sqrt(x*x) in the generated code)."""
    return ca.sqrt(model_sigma * model_sigma + noise * noise) if noise > 0 else model_sigma


def _add_quality_stages(b: _Builder, af: Airframe, settle_s: float) -> None:
    """SETTLING and EXTRAPOLATED (quality bits of an accepted sample) and the sigma outputs."""
    bits = {bit.name: bit.value for bit in STATUS_BITS}
    env = af.envelope

    def quality(s: Signals) -> Signals:
        # Capped so that the sum stays exact and small; reaching the cap ends SETTLING for good.
        run_s = ca.fmin(s["state.run_s"] + s["in.dt"], settle_s)
        status = ca.if_else(run_s < settle_s, bits["SETTLING"], 0)
        outside = wind_beyond_bound(s["wind_ned"])  # no calibration reaches it (plausibility.py)
        if env is not None:
            f = s["force_heading"]
            fh = forceair.horizontal_force(f[0], f[1])
            inside = _all([fh <= env.force_h_max_n, f[2] >= env.force_z_n[0], f[2] <= env.force_z_n[1],
                           s["airflow_speed_h"] <= env.airflow_h_max_mps])
            outside = ca.logic_or(outside, ca.logic_not(inside))
        status = status + ca.if_else(outside, bits["EXTRAPOLATED"], 0)
        if af.uncalibrated:  # a constant of the airframe, folded in: calibrated airframes' code is unchanged
            status = status + bits["UNCALIBRATED"]
        return {"run_s_new": run_s, "quality_status": status}

    inputs = ["state.run_s", "in.dt", "wind_ned"] + (["force_heading", "airflow_speed_h"] if env is not None else [])
    b.add("quality", f"quality bits of an accepted sample: SETTLING for {settle_s:g} s after the start or a gap"
          + (", EXTRAPOLATED outside the calibrated envelope" if env is not None else "")
          + (", UNCALIBRATED always (the force-air law is a prior)" if af.uncalibrated else ""),
          inputs, quality)
    unc = af.uncertainty

    def uncertainty(s: Signals) -> Signals:
        if unc is None:
            return {"wind_sigma_h": ca.SX(UNKNOWN_SIGMA), "wind_sigma_up": ca.SX(UNKNOWN_SIGMA)}
        speed = s["airflow_speed_h"]
        sigma_up = (_quadrature(_interp(unc.speeds_mps, unc.sigma_up_mps, speed), unc.noise_up_mps)
                    if af.vertical_law == "fitted" else ca.SX(UNKNOWN_SIGMA))  # the fallback: not an estimate
        return {"wind_sigma_h": _quadrature(_interp(unc.speeds_mps, unc.sigma_h_mps, speed), unc.noise_h_mps),
                "wind_sigma_up": sigma_up}

    b.add("uncertainty", "1-sigma wind errors from the calibration residuals at the model's airflow speed"
          f" and the observer noise ({unc.noise_h_mps:g} m/s horizontal, {unc.noise_up_mps:g} m/s vertical)"
          if unc is not None else "no [uncertainty] table: sigma outputs are -1 (unknown)",
          ["airflow_speed_h"] if unc is not None else [], uncertainty)
