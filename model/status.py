"""Status bits of the step (INTERFACES.md section 5). 0 means the estimate is valid.

Any nonzero status means the sample was rejected: state unchanged, output repeats the last valid one.
Several bits may be set at once (a NaN dt is both non-finite and out of range).
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class StatusBit:
    name: str
    value: int
    doc: str


STATUS_BITS: tuple[StatusBit, ...] = (
    StatusBit("NONFINITE", 1 << 0, "an input is NaN, infinite or beyond +-1e6"),
    StatusBit("BAD_DT", 1 << 1, "dt < 1e-5 s (including dt <= 0) or dt > limits.max_dt"),
    StatusBit("BAD_QUATERNION", 1 << 2, "quaternion norm outside [0.9, 1.1]"),
    StatusBit("TILT", 1 << 3, "tilt beyond limits.max_tilt_deg"),
    StatusBit("BAD_THRUST", 1 << 4, "a rotor rpm or the collective thrust is negative"),
    StatusBit("NUMERIC", 1 << 5, "the inputs were accepted but the result is not finite (sum of magnitudes beyond 1e30)"),
)

# Bits set by replay (not by the step) for rows it did not feed to the estimator: a topic had no data
# there, or the vehicle was on the ground (the ground's reaction is not wind).
STATUS_NO_DATA = 1 << 8
STATUS_LANDED = 1 << 9

# A magnitude no physical input reaches; anything beyond is treated like infinity.
INPUT_MAGNITUDE_LIMIT = 1e6
QUATERNION_NORM_TOLERANCE = 0.1
# Shorter steps than this are duplicated timestamps, not measurements (a velocity difference over a
# denormal dt would overflow).
MIN_DT_S = 1e-5
# Every value of an accepted result must stay below this; float's range ends near 3.4e38.
RESULT_MAGNITUDE_LIMIT = 1e30


def describe(status: int) -> str:
    names = [b.name for b in STATUS_BITS if status & b.value]
    if status & STATUS_NO_DATA:
        names.append("NO_DATA")
    if status & STATUS_LANDED:
        names.append("LANDED")
    return "|".join(names) if names else "OK"
