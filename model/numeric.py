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
    omega = bisect_increasing(lambda x: np.polynomial.polynomial.polyval(x, coefficients),
                              np.asarray(thrust_n, dtype=float), 0.0, 2.0, iterations=60)
    return omega * max_rpm
