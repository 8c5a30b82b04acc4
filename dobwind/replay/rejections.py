"""Why a CSV replay rejected its rows: the rows per rejection bit, and, when one reason rejects most of them,
one stderr line naming it with its likely cause.

A CSV whose columns carry the wrong names (q_w holding the wind, wind_n a quaternion component: a
spreadsheet's column moved) replays with exit 0 and every row rejected as BAD_QUATERNION; the log is not
refused (a valid log of a bad flight may be rejected too, and its estimate CSV says where), but a
flight-software engineer must not have to decode the status column to learn that the columns are wrong.
"""
from __future__ import annotations

import numpy as np

from dobwind.model.status import STATUS_BITS

# Above this share of the rows one rejection reason is "most of the log": said with its likely cause.
MOST_ROWS = 0.5
# Above this share of rejected rows, whatever the reasons, a replay "succeeds" with next to no estimate.
MOSTLY_REJECTED = 0.9

# The likely cause of a log-wide rejection, per status bit (model/status.py says what each bit means).
LIKELY_CAUSE = {
    "BAD_QUATERNION": "the q_w, q_x, q_y, q_z columns do not hold a unit quaternion: a swapped or mislabelled "
                      "column (another quantity under a q_ name, or q under another name)",
    "IMPLAUSIBLE": "inputs beyond any multirotor's: a swapped or mislabelled column, or a unit error (rpm in "
                   "another unit, thrust in grams, velocity in cm/s)",
    "NONFINITE": "an input column is empty, not a number or beyond +-1e6: a mislabelled column or another unit",
    "BAD_DT": "time steps out of range: a log slower than 1/limits.max_dt, or t in ms or us instead of s",
    "TILT": "quaternion components in another order (x, y, z, w) or a mislabelled q_ column",
    "BAD_THRUST": "a negative rpm or thrust: a swapped column, or the thrust's sign (positive up)",
    "NUMERIC": "the result overflowed: inputs far beyond a flight's (a mislabelled column or another unit)",
}
_REJECTING = tuple(bit for bit in STATUS_BITS if bit.rejects)


def count_rejections(status: np.ndarray, into: dict[str, int] | None = None) -> dict[str, int]:
    """Rows carrying each rejection bit (a row may carry several: a NaN dt is NONFINITE and BAD_DT), added
    to ``into``; bits no row carries are left out."""
    out = dict(into or {})
    codes = np.asarray(status).astype(np.int64)
    for bit in _REJECTING:
        n = int(np.count_nonzero(codes & bit.value))
        if n:
            out[bit.name] = out.get(bit.name, 0) + n
    return out


def rejection_warning(log: str, rows: int, rejected: int, rejections: dict[str, int], max_dt_s: float) -> str | None:
    """One line when one reason rejected most rows (the reason, its share, the likely cause), or when most
    rows were rejected for mixed reasons; None otherwise."""
    if not rows:
        return None
    name, n = max(rejections.items(), key=lambda kv: kv[1], default=("", 0))
    if n > MOST_ROWS * rows:
        doc = next(bit.doc for bit in _REJECTING if bit.name == name)
        cause = LIKELY_CAUSE.get(name, "")
        if name == "BAD_DT":
            cause += f" (1/limits.max_dt = {1 / max_dt_s:g} Hz)"
        return (f"{log}: {n} of {rows} rows ({100 * n / rows:.0f} %) rejected as {name} ({doc}); likely cause: "
                f"{cause}; the estimate covers the other rows only (see the status column)")
    if rejected > MOSTLY_REJECTED * rows:
        return (f"{log}: {rejected} of {rows} rows rejected (see the status column; a log slower than "
                f"1/limits.max_dt = {1 / max_dt_s:g} Hz is rejected as BAD_DT)")
    return None


def breakdown(rejections: dict[str, int]) -> str:
    """" (BAD_QUATERNION 1600, NONFINITE 3)" for a report line, most rows first; "" when none."""
    if not rejections:
        return ""
    return " (" + ", ".join(f"{k} {v}" for k, v in sorted(rejections.items(), key=lambda kv: -kv[1])) + ")"
