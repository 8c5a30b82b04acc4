"""Gain design: the observer gain lambda that gives a chosen -3 dB bandwidth at the airframe's sample
time and discretization, found on the linearized step (so it is exact for the code that will run)."""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import scipy.optimize

from dobwind.analysis.figures import bandwidth_hz, group_delay_s, noise_gain
from dobwind.analysis.linear import axis_system, linearize
from dobwind.analysis.windunits import wind_scatter
from dobwind.core.errors import InputError
from dobwind.model.airframe import Airframe
from dobwind.model.step import build_step

# Largest gain searched, as a multiple of m/dt: where the discrete pole reaches zero (paper 2, euler 1,
# tustin 2) or, for zoh, where it is e^-20.
_MAX_GAIN_PER_M_OVER_DT = {"paper": 2.0, "euler": 1.0, "tustin": 2.0, "zoh": 20.0}


def with_gains(af: Airframe, gains: tuple[float, float, float]) -> Airframe:
    return dataclasses.replace(af, observer=dataclasses.replace(af.observer, gains=gains))


def observer_bandwidth_hz(af: Airframe, gain: float) -> float:
    return bandwidth_hz(axis_system(build_step(with_gains(af, (gain, gain, gain))), 0, with_filter=False))


def design_gain(af: Airframe, target_hz: float) -> float:
    """Observer gain (kg/s, the same on every axis) whose -3 dB bandwidth is target_hz."""
    dt, m = af.observer.sample_time_s, af.mass_kg
    if not 0 < target_hz < 0.5 / dt:
        raise InputError(af.name, "--bandwidth", f"must be between 0 and the Nyquist frequency {0.5 / dt:g} Hz")
    hi = 0.999 * _MAX_GAIN_PER_M_OVER_DT[af.observer.discretization] * m / dt
    lo = 1e-9 * m / dt
    top = observer_bandwidth_hz(af, hi)
    if not math.isinf(top) and top < target_hz:
        raise InputError(af.name, "--bandwidth", f"{target_hz:g} Hz is beyond what the {af.observer.discretization} "
                                                 f"observer reaches at dt = {dt:g} s (at most {top:.4g} Hz)")
    capped = lambda g: min(observer_bandwidth_hz(af, g), 0.5 / dt) - target_hz
    return float(scipy.optimize.brentq(capped, lo, hi, xtol=1e-10, rtol=1e-12))


# --- design in wind units -----------------------------------------------------------------------------

@dataclass(frozen=True)
class WindTarget:
    """A design target in wind units: ``kind`` "noise" (m/s, the wind component along the airflow) or
    "lag" (s, the ramp lag) at ``airspeed_mps``."""
    kind: str
    value: float
    airspeed_mps: float


def _wind_figure(af: Airframe, gain: float, target: WindTarget, input_sigma: float | None) -> float:
    model = build_step(with_gains(af, (gain, gain, gain)))
    if target.kind == "lag":
        return group_delay_s(linearize(model, target.airspeed_mps).axis(0))
    gains = noise_gain(linearize(model, target.airspeed_mps, kind="noise").axis(0))
    return wind_scatter(af, target.airspeed_mps, (input_sigma * gains, input_sigma * gains))[0]


def design_gain_for_wind(af: Airframe, target: WindTarget, input_sigma: float | None) -> float:
    """Observer gain (kg/s, equal on every axis) whose wind noise or ramp lag at the target airspeed,
    with the airframe's schedule, is the target. Noise grows with the gain and lag falls with it."""
    if target.kind == "noise" and input_sigma is None:
        raise InputError(af.name, "--bandwidth", "a wind-noise target needs the force noise: give --force-noise N "
                                                 "(or fit the airframe, which records it)")
    dt, m = af.observer.sample_time_s, af.mass_kg
    # The gain must keep the observer stable up to max_dt too (the step runs at the measured dt).
    lo = 1e-4 * m / dt
    hi = 0.999 * _MAX_GAIN_PER_M_OVER_DT[af.observer.discretization] * m / max(dt, af.limits.max_dt_s)
    error = lambda g: _wind_figure(af, g, target, input_sigma) - target.value  # noqa: E731
    low, high = error(lo), error(hi)
    if low * high > 0:
        reach = sorted((low + target.value, high + target.value))
        unit = "s" if target.kind == "lag" else "m/s"
        raise InputError(af.name, "--bandwidth", f"a wind {target.kind} of {target.value:g} {unit} at "
                         f"{target.airspeed_mps:g} m/s is out of reach: the gains give {reach[0]:.4g} to "
                         f"{reach[1]:.4g} {unit} with this low-pass schedule")
    return float(scipy.optimize.brentq(error, lo, hi, xtol=1e-8, rtol=1e-8))
