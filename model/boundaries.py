"""(state, input) cases on both sides of every limit the step tests, in the precision the C holds.

Each limit is crossed along one parameter (an input element, a quaternion component, a state value)
from a neutral sample: level, hovering, no horizontal force, so that the heading (yaw_ref up to 1e6 rad)
cannot move the outputs and only the status decides. The crossing is found by bisection on the
precision's own number grid, evaluated with the step itself, so the rows sit at the representable values
on each side of the flip:

- a limit compared directly with an input (|x| <= 1e6, dt bounds, rpm >= 0) gets the two values at the
  flip and one ulp beyond each: the C compares the same float against a constant printed on the safe
  side (see ``codegen.printer.directed_float``), so it must decide exactly as the reference;
- a limit on a computed value (quaternion norm, tilt, result magnitude, settling time) gets the same in
  double, where C and reference run the same operations; in single precision the sums round
  differently from the double reference, so those rows stand COMPUTED_MARGIN_ULPS off the flip.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from dobwind.model.numeric import rpm_for_rotor_thrust
from dobwind.model.plausibility import MAX_ACCELERATION_MPS2, MAX_GROUND_SPEED_MPS, MAX_RPM_FRACTION, \
    MAX_THRUST_TO_WEIGHT
from dobwind.model.status import INPUT_MAGNITUDE_LIMIT, MIN_DT_S, DT_TOLERANCE, QUATERNION_NORM_TOLERANCE, \
    REJECTED_MASK, RESULT_MAGNITUDE_LIMIT
from dobwind.model.step import StepModel
from dobwind.model.kinds import Precision

# Float32 ulps between a single-precision row and the flip of a computed limit: well above the few ulps
# by which a float sum of squares differs from its double value.
COMPUTED_MARGIN_ULPS = 16
# The rounding error of a float cos(tilt) test (w^2 - x^2 - y^2 + z^2 against cos(max_tilt) * |q|^2):
# a few ulps of 1. Near a small max_tilt the crossing moves fast with that error (d r33 / dx = 2x(1 + cos)
# is small), so the rows must stand this far in r33, not 16 ulps of x, off the flip.
TILT_R33_ERROR = 64 * 2.0 ** -24
_BISECTION_STEPS = 70
# Double ulps between a row and a flip that reassociation can move (see boundary_cases).
REASSOCIATION_MARGIN_ULPS = 8

Row = tuple[np.ndarray, np.ndarray]  # (state, input)
Family = Callable[[float], Row]


@dataclass(frozen=True)
class BoundaryCases:
    labels: tuple[str, ...]
    states: np.ndarray  # (n, state size): each case starts from its own state
    inputs: np.ndarray  # (n, input size)


def _dtype(precision: Precision) -> type:
    return np.float32 if precision == Precision.SINGLE else np.float64


def _as_bits(value: float, precision: Precision) -> int:
    """Positive floats in increasing order map to increasing integers (IEEE 754 layout)."""
    return int(np.array(value, dtype=_dtype(precision)).view(np.int32 if precision == Precision.SINGLE else np.int64))


def _from_bits(bits: int, precision: Precision) -> float:
    return float(np.array(bits, dtype=np.int32 if precision == Precision.SINGLE else np.int64).view(_dtype(precision)))


def neutral_row(model: StepModel) -> Row:
    """A running estimator (initialized, settled) and a level, hovering, unaccelerated sample."""

    af, lin, lst = model.airframe, model.inputs, model.state
    state = np.zeros(lst.size)
    state[lst.slice("initialized")] = 1.0
    state[lst.slice("run_s")] = model.settling_time_s
    row = np.zeros(lin.size)
    row[lin.slice("dt")] = af.observer.sample_time_s
    row[lin.offset("q")] = 1.0
    hover = af.mass_kg * af.gravity_mps2
    if "rotor_rpm" in lin:
        rpm = rpm_for_rotor_thrust(af.thrust.coefficients, af.thrust.max_rpm, np.array([hover / af.thrust.rotors]))
        row[lin.slice("rotor_rpm")] = float(rpm[0])
    elif "thrust" in lin:
        row[lin.slice("thrust")] = hover
    if "specific_force" in lin:
        row[lin.offset("specific_force") + 2] = -af.gravity_mps2
    return state, row


def _rounded(rows: list[Row], precision: Precision) -> tuple[np.ndarray, np.ndarray]:
    """The rows' states and inputs as the C holds them (rounded to its precision), in double."""
    dtype = _dtype(precision)
    states = np.array([s for s, _ in rows], dtype=dtype).astype(float)
    inputs = np.array([u for _, u in rows], dtype=dtype).astype(float)
    return states, inputs


def _statuses(model: StepModel, rows: list[Row], precision: Precision) -> np.ndarray:
    """The step's status for each row, in one call: CasADi maps a function called with n columns over
    them, each column evaluated by the same instructions as a call of its own (the same bits), at a sixth
    of the time of a Python call per row."""
    if not rows:
        return np.zeros(0, dtype=np.int64)
    states, inputs = _rounded(rows, precision)
    return np.asarray(model.step(states.T, inputs.T)[2], dtype=float).ravel().astype(np.int64)


def _flips(model: StepModel, searches: list[tuple[Family, float, float]],
           precision: Precision) -> list[tuple[int, int] | None]:
    """For each (family, lo, hi), 0 < lo < hi: adjacent grid values (as bit patterns) across which the
    status changes; None when the status is the same at both ends (a limit this airframe cannot reach from
    the neutral sample, e.g. a result check that a huge model constant trips at any force). The bisections
    run side by side, each through the midpoints its own search would take, so that each round's statuses
    are one call of the step (_statuses) instead of one per search."""
    ends = _statuses(model, [row for family, lo, hi in searches for row in (family(lo), family(hi))], precision)
    found: list[tuple[int, int] | None] = [None] * len(searches)
    open_: dict[int, tuple[int, int, int]] = {}  # search -> (low bits, high bits, status at lo)
    for k, (_, lo, hi) in enumerate(searches):
        if ends[2 * k] != ends[2 * k + 1]:
            open_[k] = (_as_bits(lo, precision), _as_bits(hi, precision), int(ends[2 * k]))
    for _ in range(_BISECTION_STEPS):
        for k in [k for k, (a, b, _) in open_.items() if b - a <= 1]:
            found[k] = open_.pop(k)[:2]
        if not open_:
            break
        mids = {k: (a + b) // 2 for k, (a, b, _) in open_.items()}
        statuses = _statuses(model, [searches[k][0](_from_bits(mid, precision)) for k, mid in mids.items()], precision)
        for (k, mid), status in zip(mids.items(), statuses):
            a, b, low_status = open_[k]
            open_[k] = (mid, b, low_status) if status == low_status else (a, mid, low_status)
    for k, (a, b, _) in open_.items():  # still open after _BISECTION_STEPS rounds: where they stand
        found[k] = (a, b)
    return found


def _crossing(family: Family, found: tuple[int, int] | None, precision: Precision, computed: bool,
              relative_margin: float = 0.0, double_margin_ulps: int = 0) -> list[Row]:
    """The rows on both sides of the flip ``found`` (by _flips) of ``family``: none without a flip."""
    if found is None:
        return []
    a, b = found
    if computed and precision == Precision.DOUBLE and double_margin_ulps:
        offsets = (a - double_margin_ulps, b + double_margin_ulps)
    elif computed and precision == Precision.SINGLE:
        below = _as_bits(_from_bits(a, precision) * (1 - relative_margin), precision)
        above = _as_bits(_from_bits(b, precision) * (1 + relative_margin), precision)
        offsets = (min(a - COMPUTED_MARGIN_ULPS, below), max(b + COMPUTED_MARGIN_ULPS, above))
    else:
        offsets = (a - 1, a, b, b + 1)
    return [family(_from_bits(bits, precision)) for bits in offsets]


def _with_input(base: Row, model: StepModel, index: int, scale: float = 1.0) -> Family:
    def family(p: float) -> Row:
        state, row = base[0], base[1].copy()
        row[index] = scale * p
        return state, row
    return family


def _with_quaternion(base: Row, model: StepModel, fixed: dict[int, float], varied: int) -> Family:
    q0 = model.inputs.offset("q")

    def family(p: float) -> Row:
        state, row = base[0], base[1].copy()
        row[q0:q0 + 4] = 0.0
        for i, v in fixed.items():
            row[q0 + i] = v
        row[q0 + varied] = p
        return state, row
    return family


def _with_state(base: Row, model: StepModel, fields: tuple[str, ...], element: int) -> Family:
    def family(p: float) -> Row:
        state, row = base[0].copy(), base[1]
        for name in fields:
            state[model.state.offset(name) + element] = p
        return state, row
    return family


def _limit_families(model: StepModel, base: Row) -> list[tuple[str, Family, float, float, bool]]:
    """(label, family, lo, hi, computed) for every limit of the validation and the result checks."""
    af, lin = model.airframe, model.inputs
    out: list[tuple[str, Family, float, float, bool]] = []
    big = INPUT_MAGNITUDE_LIMIT
    for index, name in enumerate(lin.element_names()):
        out.append((f"|{name}| <= {big:g}", _with_input(base, model, index), big / 2, big * 2, False))
        out.append((f"|-{name}| <= {big:g}", _with_input(base, model, index, -1.0), big / 2, big * 2, False))
    dt = lin.offset("dt")
    out.append(("dt >= MIN_DT_S", _with_input(base, model, dt), MIN_DT_S / 2, MIN_DT_S * 2, False))
    top = af.limits.max_dt_s * (1 + DT_TOLERANCE)
    out.append(("dt <= max_dt (1 + tol)", _with_input(base, model, dt), top / 2, top * 2, False))
    tol = QUATERNION_NORM_TOLERANCE
    out.append(("|q| >= 1 - tol", _with_quaternion(base, model, {}, 0), (1 - tol) * 0.95, (1 - tol) * 1.05, True))
    out.append(("|q| <= 1 + tol", _with_quaternion(base, model, {}, 0), (1 + tol) * 0.95, (1 + tol) * 1.05, True))
    half = math.radians(af.limits.max_tilt_deg) / 2
    w = float(np.float32(math.cos(half)))
    for axis in (1, 2):
        out.append((f"tilt about q[{axis}] <= max_tilt", _with_quaternion(base, model, {0: w}, axis),
                    0.85 * math.sin(half), 1.15 * math.sin(half), True))
    out += _plausibility_families(model, base)
    out.append(("result sum <= RESULT_MAGNITUDE_LIMIT", _with_state(base, model, ("f_obs", "f_filt"), 2),
                RESULT_MAGNITUDE_LIMIT / 10, RESULT_MAGNITUDE_LIMIT * 10, True))
    settle, step = model.settling_time_s, af.observer.sample_time_s
    out.append(("run_s + dt < settling time", _with_state(base, model, ("run_s",), 0), settle - 3 * step,
                settle, True))
    return out


def _plausibility_families(model: StepModel, base: Row) -> list[tuple[str, Family, float, float, bool]]:
    """IMPLAUSIBLE's input bounds (model/plausibility.py), each crossed from the neutral sample. The flip
    found may be another bound met first on the way (a fast ground speed or a strong acceleration is also
    a large external force): still a status flip C and reference must agree on. Computed (squared norms)."""
    lin, af = model.inputs, model.airframe

    def hover(index: int) -> float:  # the neutral sample's own value: plausible, the crossing lies above
        return float(base[1][index])

    out: list[tuple[str, Family, float, float, bool]] = [
        ("|vel_ned| <= MAX_GROUND_SPEED", _with_input(base, model, lin.offset("vel_ned")), 1e-6, 2 * MAX_GROUND_SPEED_MPS, True)]
    for name in ("acc_ned", "specific_force"):
        if name in lin:
            out.append((f"|{name}| <= MAX_ACCELERATION", _with_input(base, model, lin.offset(name)), 1e-6,
                        2 * MAX_ACCELERATION_MPS2, True))
    if "rotor_rpm" in lin:
        top = MAX_RPM_FRACTION * af.thrust.max_rpm
        out.append(("rpm <= MAX_RPM_FRACTION max_rpm", _with_input(base, model, lin.offset("rotor_rpm")), hover(lin.offset("rotor_rpm")),
                    top * 2, True))
    if "thrust" in lin:
        top = MAX_THRUST_TO_WEIGHT * af.mass_kg * af.gravity_mps2
        out.append(("thrust <= MAX_THRUST_TO_WEIGHT weight", _with_input(base, model, lin.offset("thrust")), hover(lin.offset("thrust")),
                    top * 2, True))
    return out + _steady_families(model, base) + _envelope_families(model, base)


def _envelope_families(model: StepModel, base: Row) -> list[tuple[str, Family, float, float, bool]]:
    """EXTRAPOLATED's envelope (force_h_max, force_z low and high, airflow_h_max), crossed by the filtered
    force of the state: issue #37 found its bounds checked by nothing. The flip may be another quality
    bound met first (the airflow, the 50 m/s wind); each is a status both must agree on."""
    env, lst = model.airframe.envelope, model.state
    if env is None:
        return []

    def force(axis: int, sign: float) -> Family:
        def setter(state: np.ndarray, row: np.ndarray, p: float) -> None:
            for name in ("f_obs", "f_filt"):
                state[lst.offset(name) + axis] = sign * p
        return _matched(base, setter)

    top = max(env.force_h_max_n, abs(env.force_z_n[0]), abs(env.force_z_n[1]))
    return [("|force_h| <= envelope.force_h_max", force(0, 1.0), 1e-6, 4 * top, True),
            ("force_z >= envelope.force_z low", force(2, -1.0), 1e-6, 4 * top, True),
            ("force_z <= envelope.force_z high", force(2, 1.0), 1e-6, 4 * top, True)]


def _steady_families(model: StepModel, base: Row) -> list[tuple[str, Family, float, float, bool]]:
    """The same bounds crossed with the other inputs matched, so that the external force stays zero and
    the crossing is the bound itself (not the 4-weight force bound met first): a steady fast flight, a
    climb at acceleration p with the thrust that drives it, a thrust p with the acceleration it drives."""
    lin, lst, af = model.inputs, model.state, model.airframe
    m, g = af.mass_kg, af.gravity_mps2

    def speed(state: np.ndarray, row: np.ndarray, p: float) -> None:
        row[lin.offset("vel_ned")] = p
        if "vel_prev" in lst:
            state[lst.offset("vel_prev")] = p

    def climb(state: np.ndarray, row: np.ndarray, p: float) -> None:  # p: upward acceleration
        _set_thrust(model, row, m * (g + p))
        _set_acceleration(model, state, row, p)

    def thrust(state: np.ndarray, row: np.ndarray, p: float) -> None:  # p: collective thrust
        row[lin.offset("thrust")] = p
        _set_acceleration(model, state, row, p * af.thrust.scale / m - g)

    out = [("|vel_ned| <= MAX_GROUND_SPEED (steady)", _matched(base, speed), 1e-6, 2 * MAX_GROUND_SPEED_MPS, True)]
    if "acc_ned" in lin or "specific_force" in lin:
        out.append(("|acceleration| <= MAX_ACCELERATION (climb)", _matched(base, climb), 1e-6,
                    2 * MAX_ACCELERATION_MPS2, True))
    if "thrust" in lin:
        top = MAX_THRUST_TO_WEIGHT * m * g
        out.append(("thrust <= MAX_THRUST_TO_WEIGHT weight (climb)", _matched(base, thrust), m * g, 2 * top, True))
    return out


def _matched(base: Row, setter: Callable[[np.ndarray, np.ndarray, float], None]) -> Family:
    def family(p: float) -> Row:
        state, row = base[0].copy(), base[1].copy()
        setter(state, row, p)
        return state, row
    return family


def _set_thrust(model: StepModel, row: np.ndarray, total_n: float) -> None:
    af, lin = model.airframe, model.inputs
    if "rotor_rpm" in lin:
        per_rotor = np.array([total_n / (af.thrust.rotors * af.thrust.scale)])
        row[lin.slice("rotor_rpm")] = float(rpm_for_rotor_thrust(af.thrust.coefficients, af.thrust.max_rpm, per_rotor)[0])
    else:
        row[lin.offset("thrust")] = total_n / af.thrust.scale


def _set_acceleration(model: StepModel, state: np.ndarray, row: np.ndarray, up: float) -> None:
    """An upward kinematic acceleration ``up`` (m/s^2) in whichever form the step takes it, level."""
    lin, lst, g = model.inputs, model.state, model.airframe.gravity_mps2
    if "acc_ned" in lin:
        row[lin.offset("acc_ned") + 2] = -up
    elif "specific_force" in lin:
        row[lin.offset("specific_force") + 2] = -(g + up)
    else:  # differenced velocity: the previous sample was up * dt slower downwards
        state[lst.offset("vel_prev") + 2] = 0.0
        row[lin.offset("vel_ned") + 2] = -up * float(row[lin.offset("dt")])


def _sign_rows(model: StepModel, base: Row, precision: Precision) -> tuple[list[str], list[Row]]:
    """rpm >= 0 (thrust >= 0) on every rotor: 0, -0 and the smallest numbers on either side."""
    lin = model.inputs
    column = "rotor_rpm" if "rotor_rpm" in lin else "thrust"
    tiny = float(np.nextafter(_dtype(precision)(0), _dtype(precision)(1)))
    labels, rows = [], []
    for index in range(lin.offset(column), lin.offset(column) + lin.field(column).size):
        for value in (-tiny, -0.0, 0.0, tiny):
            labels.append(f"{lin.element_names()[index]} >= 0 at {value!r}")
            rows.append(_with_input(base, model, index)(value))
    return labels, rows


def _tilt_relative_margin(max_tilt_deg: float) -> float:
    """Relative step of the varied quaternion component x that moves r33 by TILT_R33_ERROR at the flip."""
    x = math.sin(math.radians(max_tilt_deg) / 2)
    return TILT_R33_ERROR / (2 * x * x * (1 + math.cos(math.radians(max_tilt_deg))))


def boundary_cases(model: StepModel, precision: Precision) -> BoundaryCases:
    base = neutral_row(model)
    labels, rows = _sign_rows(model, base, precision)
    tilt_margin = _tilt_relative_margin(model.airframe.limits.max_tilt_deg)
    # IMPLAUSIBLE's and the envelope's flips are sums over several inputs and the state (the external force
    # met first on the way): a compiler allowed to reassociate (PX4's -funsafe-math-optimizations) moves
    # them by an ulp or two even in double, so their rows stand a few ulps off the flip there too.
    reassociable = {label for label, *_ in _plausibility_families(model, base)}
    families = _limit_families(model, base)
    flips = _flips(model, [(family, lo, hi) for _, family, lo, hi, _ in families], precision)
    for (label, family, _, _, computed), found in zip(families, flips):
        margin = tilt_margin if label.startswith("tilt") else 0.0
        crossing = _crossing(family, found, precision, computed, margin,
                             REASSOCIATION_MARGIN_ULPS if label in reassociable else 0)
        labels += [label] * len(crossing)
        rows += crossing
    if precision == Precision.SINGLE:
        labels, rows = _representable_in_float(model, labels, rows)
    states, inputs = _rounded(rows, precision)
    return BoundaryCases(tuple(labels), states, inputs)


FLOAT_MAX = float(np.finfo(np.float32).max)


def _representable_in_float(model: StepModel, labels: list[str], rows: list[Row]) -> tuple[list[str], list[Row]]:
    """All rows but those the reference accepts while one of the step's intermediate values (each
    instruction, evaluated in double) is beyond a float's range. Near the result limit (1e30) a step that
    squares the force, as a body-frame drag law does with its vertical airflow, overflows a float where
    the double reference does not: the C then says NUMERIC (or, through a clamp, anything) where the
    reference accepts, so no golden status can be expected of such a row; the float step rejects those
    forces earlier, by the overflow itself. A row the reference rejects keeps its rejection in C (the
    validation's bits come from the inputs, and NUMERIC from the overflow that rejects it)."""
    import casadi as ca

    every = ca.Function("every_instruction", model.step.sx_in(), [model.step.instructions_sx()])
    states, inputs = _rounded(rows, Precision.SINGLE)
    statuses = _statuses(model, rows, Precision.SINGLE)
    kept = [k for k, status in enumerate(statuses)
            if int(status) & REJECTED_MASK or _largest(every, states[k], inputs[k]) <= FLOAT_MAX]
    return [labels[k] for k in kept], [rows[k] for k in kept]


def _largest(every, state: np.ndarray, inputs: np.ndarray) -> float:  # type: ignore[no-untyped-def]
    values = np.abs(np.asarray(every(state, inputs)).ravel())
    return float(np.nanmax(values, initial=0.0))
