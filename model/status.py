"""Status bits of the step (docs/c-api.md, the status). 0 means the estimate is valid and trusted.

Two kinds of bit. A REJECTION bit means the sample was rejected: the estimate (filters, bias, output)
is unchanged and the output repeats the last accepted one; only the gap bookkeeping advances. A
QUALITY bit (SETTLING, EXTRAPOLATED, UNCALIBRATED) marks an accepted sample (state and output updated) whose
estimate should not be trusted yet or is outside the calibration. "Accepted" is therefore
``status & REJECTED_MASK == 0`` and "trusted" is ``status == 0``. Several bits may be set at once
(a NaN dt is both non-finite and out of range); a rejected sample carries rejection bits only.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class StatusBit:
    name: str
    value: int
    doc: str
    rejects: bool = True  # False: a quality flag on an accepted sample


STATUS_BITS: tuple[StatusBit, ...] = (
    StatusBit("NONFINITE", 1 << 0, "an input is NaN, infinite or beyond +-1e6"),
    StatusBit("BAD_DT", 1 << 1, "dt < 1e-5 s (including dt <= 0) or dt > limits.max_dt * (1 + 1e-4)"),
    StatusBit("BAD_QUATERNION", 1 << 2, "quaternion norm outside [0.9, 1.1]"),
    StatusBit("TILT", 1 << 3, "tilt beyond limits.max_tilt_deg"),
    StatusBit("BAD_THRUST", 1 << 4, "a rotor rpm or the collective thrust is negative"),
    StatusBit("NUMERIC", 1 << 5, "the inputs were accepted but the result is not finite (sum of magnitudes beyond 1e30)"),
    StatusBit("SETTLING", 1 << 6, "accepted, but within one settling time of the first sample or of a gap "
              "(a rejected sample): the filters have not caught up yet", rejects=False),
    StatusBit("EXTRAPOLATED", 1 << 7, "accepted, but the heading-frame force or the model's airflow speed is "
              "outside the envelope calibrated by fit, or the wind exceeds 50 m/s", rejects=False),
    # 1 << 8 and 1 << 9 are replay's (STATUS_NO_DATA, STATUS_LANDED below): not the step's.
    StatusBit("UNCALIBRATED", 1 << 10, "accepted, but the airframe's force-air law is an uncalibrated prior "
              "([calibration] status = \"prior\", as `dobwind init` writes it): the wind is a rough guess until "
              "`dobwind fit` calibrates it", rejects=False),
    StatusBit("IMPLAUSIBLE", 1 << 11, "physically implausible for a multirotor (model/plausibility.py): ground "
              "speed > 150 m/s, acceleration > 10 g, a rotor > 1.5 max_rpm or thrust > 20 weights; or (airframes with a "
              "velocity-aided bias estimate) an acceleration input that disagrees with the velocity's derivative far "
              "beyond the log's own spread (model/biasgate.py)"),
)
# The bits that mean "rejected"; an autopilot that accepts quality-flagged samples tests these only.
REJECTED_MASK = sum(bit.value for bit in STATUS_BITS if bit.rejects)

# Bits set by replay (not by the step) for rows it did not feed to the estimator: a topic had no data
# there, or the vehicle was on the ground (the ground's reaction is not wind).
STATUS_NO_DATA = 1 << 8
STATUS_LANDED = 1 << 9
# Set by replay on rows (or, for a whole-flight finding, every row) where a plausibility check says the
# airframe does not fit this flight (dobwind/replay/plausibility.py): a quality flag, the estimate is still
# written, but it is not trusted. Not in NOT_ACCEPTED_MASK.
STATUS_SUSPECT = 1 << 13
# Bits under which a row's estimate was not updated: the step's rejections and replay's own reasons.
NOT_ACCEPTED_MASK = REJECTED_MASK | STATUS_NO_DATA | STATUS_LANDED

# A magnitude no physical input reaches; anything beyond is treated like infinity.
INPUT_MAGNITUDE_LIMIT = 1e6
QUATERNION_NORM_TOLERANCE = 0.1
# Shorter steps than this are duplicated timestamps, not measurements (a velocity difference over a
# denormal dt would overflow).
MIN_DT_S = 1e-5
# dt may exceed limits.max_dt by this fraction: timestamps t = k * T differenced in binary floating
# point come out a few ulp above T (0.02 -> 0.020000000000000004), and single and double precision
# must agree on such a log. Every backend compares dt <= max_dt * (1 + DT_TOLERANCE).
DT_TOLERANCE = 1e-4
# Every value of an accepted result must stay below this; float's range ends near 3.4e38.
RESULT_MAGNITUDE_LIMIT = 1e30


def accepted(status: np.ndarray) -> np.ndarray:
    """Rows whose sample updated the estimate (quality bits allowed)."""
    return (np.asarray(status).astype(np.int64) & NOT_ACCEPTED_MASK) == 0


def trusted(status: np.ndarray) -> np.ndarray:
    """Rows an autopilot should act on: accepted and with no quality flag."""
    return np.asarray(status) == 0


# 1 << 12 stays unused by the step. An airframe whose vertical law is a fallback (force_air.vertical_law =
# "zero-wind") says so once, in the generated header (NAME_WIND_VERTICAL_ESTIMATED 0), and on every sample
# by wind_sigma_up = -1 (unknown) beside a vertical wind of exactly 0: a status bit set on every sample
# would carry no information about the sample and would withdraw trust from the horizontal wind too.


def describe(status: int) -> str:
    names = [b.name for b in STATUS_BITS if status & b.value]
    if status & STATUS_NO_DATA:
        names.append("NO_DATA")
    if status & STATUS_LANDED:
        names.append("LANDED")
    if status & STATUS_SUSPECT:
        names.append("SUSPECT")
    return "|".join(names) if names else "OK"
