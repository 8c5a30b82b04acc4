"""Gain design: the observer gain lambda that gives a chosen -3 dB bandwidth at the airframe's sample
time and discretization, found on the linearized step (so it is exact for the code that will run)."""
from __future__ import annotations

import dataclasses
import math

import scipy.optimize

from dobwind.analysis.figures import bandwidth_hz
from dobwind.analysis.linear import axis_system
from dobwind.errors import InputError
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
