"""The four discretizations of the first-order observer d f_hat/dt = w (f_e - f_hat), w = lambda/m.

Every form is y(k+1) = pole * y(k) + b0 * x(k) + b1 * x(k-1); only Tustin uses the previous input.
Coefficients are expressions in the measured step dt, so the C code adapts to jittery sample times.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np


@dataclass(frozen=True)
class FirstOrder:
    pole: Any
    b0: Any
    b1: Any


def first_order(method: str, rate_per_s: Any, dt: Any) -> FirstOrder:
    """Coefficients for rate w (1/s) and step dt; works on CasADi SX and on NumPy/float values."""
    lib = ca if isinstance(dt, (ca.SX, ca.MX)) or isinstance(rate_per_s, (ca.SX, ca.MX)) else np
    if method == "paper":
        # As printed in the paper: dt*lambda/(2m). It halves the continuous gain (docs/model.md, the factor 2).
        a = dt * (rate_per_s / 2)
        return FirstOrder(1 - a, a, 0 * a)
    if method == "euler":
        a = dt * rate_per_s
        return FirstOrder(1 - a, a, 0 * a)
    if method == "zoh":
        a = -lib.expm1(-dt * rate_per_s)  # expm1 keeps precision for small dt*w in float
        return FirstOrder(1 - a, a, 0 * a)
    if method == "tustin":
        k = dt * (rate_per_s / 2)
        return FirstOrder((1 - k) / (1 + k), k / (1 + k), k / (1 + k))
    raise ValueError(f"unknown discretization {method!r}")

