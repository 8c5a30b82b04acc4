"""Monotone functions inverted on arrays: a vectorized bisection, and the rotor thrust curve solved for
the rpm that gives a wanted thrust (the simulator, the analysis and the limit cases need it)."""
from __future__ import annotations

import numpy as np


def bisect_increasing(fun, target: np.ndarray, lo: float, hi: float, iterations: int = 80) -> np.ndarray:
    """Vectorized bisection for fun(x) = target, fun increasing on [lo, hi] (elementwise)."""
    a, b = np.full_like(target, lo, dtype=float), np.full_like(target, hi, dtype=float)
    for _ in range(iterations):
        mid = 0.5 * (a + b)
        below = fun(mid) < target
        a, b = np.where(below, mid, a), np.where(below, b, mid)
    return 0.5 * (a + b)


def rpm_for_rotor_thrust(coefficients: tuple[float, ...], max_rpm: float, thrust_n: np.ndarray) -> np.ndarray:
    """Invert a per-rotor thrust polynomial (increasing on [0, 2]) by bisection, vectorized."""
    thrust = np.asarray(thrust_n, dtype=float)
    if thrust.size == 1:
        omega = np.full_like(thrust, _bisect_polynomial(tuple(float(c) for c in coefficients), float(thrust.flat[0])))
        return omega * max_rpm
    omega = bisect_increasing(lambda x: np.polynomial.polynomial.polyval(x, coefficients), thrust, 0.0, 2.0,
                              iterations=60)
    return omega * max_rpm


def _bisect_polynomial(coefficients: tuple[float, ...], target: float) -> float:
    """bisect_increasing(polyval, target, 0, 2, 60) for one target, in Python floats: the same operations in
    the same order (numpy's polyval is c0 = c[-1] + x*0, then c0 = c[-i] + c0*x; IEEE doubles either way),
    so the same bits, at a tenth of the time of 60 rounds of numpy calls on one element. The limit cases of
    an rpm airframe ask for one rotor's rpm about 50 times per render (model/boundaries.py's climb)."""
    a, b = 0.0, 2.0
    for _ in range(60):
        mid = 0.5 * (a + b)
        value = coefficients[-1] + mid * 0
        for c in coefficients[-2::-1]:
            value = c + value * mid
        if value < target:
            a = mid
        else:
            b = mid
    return 0.5 * (a + b)
