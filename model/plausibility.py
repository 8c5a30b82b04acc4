"""Physical plausibility of a sample: the IMPLAUSIBLE rejection (status bit 1 << 11).

NONFINITE only refuses magnitudes beyond 1e6 in any unit; a ground velocity of 1e5 m/s or a rotor at
twenty times its maximum speed passes it, and one such sample fed to the observer poisons its state for
many settling times. These bounds are what no multirotor ever does, in any flight, so a sample beyond
one is a logging glitch, a unit error or an airframe that is not this vehicle, never wind. A rejected
sample leaves the estimate untouched (like every rejection, status.py), so the estimate recovers as soon
as the inputs are sane again (after one SETTLING period).

The checks run on the inputs (the validate stage): ground speed, the acceleration input, rotor speed
against ``max_rpm`` (rpm airframes) or collective thrust against weight (thrust airframes). The sample's
raw external force is NOT bounded: it is a difference of noisy measurements over dt (a velocity
differentiated at 500 Hz reads several weights of noise), and a bound on it rejected a quarter of a
500 Hz simulated log (`make accuracy`'s sample-rate study); the filtered estimate and the 50 m/s wind
flag below cover what it was for.

The wind bound (MAX_WIND_MPS) is a quality flag instead (EXTRAPOLATED, see ``wind_beyond_bound``): the
promise that a trusted output never exceeds it.

Each comparison is written as "value > bound" so that NaN (which fails every comparison) is left to
NONFINITE; an infinite input is then both NONFINITE and IMPLAUSIBLE.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

# Standard gravity: accelerations are bounded in g regardless of the airframe's gravity setting, since
# they are limited by structures, people and sensors, not by the planet.
STANDARD_GRAVITY = 9.80665
# The fastest multirotors (speed-record racing quadrotors) stay below about 130 m/s over ground; typical
# ones below 30. A logged speed above this is a glitch or a unit error (cm/s, mm/s).
MAX_GROUND_SPEED_MPS = 150.0
# Racing quadrotors pull 4-6 g; an autopilot's NED acceleration or accelerometer specific force beyond
# 10 g is a crash, a saturated or clipping sensor, or a unit error (the wind is then unknowable anyway).
MAX_ACCELERATION_MPS2 = 10.0 * STANDARD_GRAVITY
# A rotor is not driven far beyond its maximum speed; 1.5x leaves room for a max_rpm that was guessed
# low, and catches rpm logged in rad/s x 10, or in Hz x 60 twice.
MAX_RPM_FRACTION = 1.5
# Thrust-to-weight: camera and survey multirotors have 2-3, racing quadrotors up to about 10-15.
MAX_THRUST_TO_WEIGHT = 20.0
# No multirotor flies in a 50 m/s (180 km/h) wind; a trusted estimate never exceeds it.
MAX_WIND_MPS = 50.0


def _above(x: ca.SX, bound: float) -> ca.SX:
    """|x| > bound for a vector, without a square root (squared norm against bound^2)."""
    return ca.sumsqr(x) > bound * bound


def _any(conditions: list[ca.SX]) -> ca.SX:
    result = conditions[0]
    for condition in conditions[1:]:
        result = ca.logic_or(result, condition)
    return result


@dataclass(frozen=True)
class InputBound:
    """One plausibility bound on an input: on the vector's norm, or on each element."""
    field: str     # "in.<field>"
    limit: float   # in the input's unit
    norm: bool     # True: |x| <= limit (a vector); False: x[i] <= limit for every element


def input_bounds(fields: set[str] | frozenset[str], mass_kg: float, gravity_mps2: float,
                 max_rpm: float) -> tuple[InputBound, ...]:
    """The bounds of the inputs among ``fields`` ("in.<field>" names): ground speed, the acceleration
    input, rotor speed against ``max_rpm`` (rpm airframes) or collective thrust against weight."""
    bounds = [InputBound("in.vel_ned", MAX_GROUND_SPEED_MPS, True),
              InputBound("in.acc_ned", MAX_ACCELERATION_MPS2, True),
              InputBound("in.specific_force", MAX_ACCELERATION_MPS2, True),
              InputBound("in.rotor_rpm", MAX_RPM_FRACTION * max_rpm, False),
              InputBound("in.thrust", MAX_THRUST_TO_WEIGHT * mass_kg * gravity_mps2, False)]
    return tuple(b for b in bounds if b.field in fields)


def implausible_inputs(s: dict[str, ca.SX], mass_kg: float, gravity_mps2: float, max_rpm: float) -> ca.SX:
    """True when an input is beyond what any multirotor does (``s`` holds the ``in.*`` signals)."""
    tests = []
    for bound in input_bounds(set(s), mass_kg, gravity_mps2, max_rpm):
        x = s[bound.field]
        tests += [_above(x, bound.limit)] if bound.norm else [x[i] > bound.limit for i in range(x.numel())]
    return _any(tests)


def within_bounds(s: dict[str, ca.SX], bounds: tuple[InputBound, ...]) -> list[ca.SX]:
    """The bounds in the form a NaN fails ("within" rather than "not beyond"): a sample that passes
    every one is plausible, and each element of a bounded input is finite. The element bounds are on
    rotor speeds and thrust, which validation also requires to be >= 0: 0 <= x <= limit, one interval."""
    tests = []
    for bound in bounds:
        x = s[bound.field]
        tests += [ca.sumsqr(x) <= bound.limit * bound.limit] if bound.norm else \
            [ca.logic_and(0 <= x[i], x[i] <= bound.limit) for i in range(x.numel())]
    return tests


def wind_beyond_bound(wind_ned: ca.SX) -> ca.SX:
    """A wind beyond MAX_WIND_MPS: flagged EXTRAPOLATED (a quality bit), never rejected. The wind comes
    from the filtered state; rejecting it would freeze that state above the bound for good (each next
    proposal starts from the frozen state), while flagging lets the filters decay as usual."""
    return _above(wind_ned, MAX_WIND_MPS)


def hover_problem(rotors: int, max_rpm: float, coefficients: tuple[float, ...], scale: float,
                  weight_n: float) -> str | None:
    """Why an rpm airframe cannot hover inside the plausible rotor speeds, or None.

    Hover needs the rotors' thrust to equal the weight at some speed in [0, MAX_RPM_FRACTION max_rpm]:
    a curve that lifts more than the weight at rest, or less than it at 1.5 max_rpm, describes another
    vehicle, and every hovering sample of a real flight would be rejected as IMPLAUSIBLE."""
    fractions = np.linspace(0.0, MAX_RPM_FRACTION, 301)
    total = rotors * scale * np.polynomial.polynomial.polyval(fractions, coefficients)
    if total.min() > weight_n:
        return (f"the rotors give at least {total.min():.4g} N at every speed up to {MAX_RPM_FRACTION:g} max_rpm, "
                f"more than the weight ({weight_n:.4g} N): the vehicle could not hover")
    if total.max() < weight_n:
        return (f"the rotors give at most {total.max():.4g} N up to {MAX_RPM_FRACTION:g} max_rpm, less than the "
                f"weight ({weight_n:.4g} N): the vehicle could not hover")
    return None
