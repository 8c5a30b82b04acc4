"""How close generated C must come to the double-precision Python reference.

Double: the same operations in the same order, so only libm's last bits may differ.
Single: measured over a million-step flight with `dobwind verify --precision single --steps 1000000`
(see the README); the bound leaves a margin over the worst error seen there.
Errors are judged as |c - ref| <= atol + rtol * |ref| on every output and state element; directions
as an angle, only where the horizontal wind is at least MIN_SPEED_FOR_DIRECTION.
"""
from __future__ import annotations

from dataclasses import dataclass
from dobwind.model.kinds import Precision


@dataclass(frozen=True)
class Tolerance:
    rtol: float
    atol: float
    angle_deg: float


TOLERANCE = {
    Precision.DOUBLE: Tolerance(rtol=1e-12, atol=1e-12, angle_deg=1e-9),
    # Measured on m300, 1,000,000 steps: worst 1.0e-4 m/s (wind), 2.0e-5 N (force), 9.5e-4 deg (with the
    # polynomial expm1/atan2/sincos kernels; 3.7e-4 deg with libm's).
    Precision.SINGLE: Tolerance(rtol=2e-5, atol=1e-3, angle_deg=0.01),
}
# Self-test vectors are printed with 7 decimals, so the port check allows for that rounding.
SELFTEST_TOLERANCE = {
    Precision.DOUBLE: Tolerance(rtol=1e-9, atol=2e-7, angle_deg=1e-5),
    Precision.SINGLE: TOLERANCE[Precision.SINGLE],
}
MIN_SPEED_FOR_DIRECTION = 0.5  # m/s
