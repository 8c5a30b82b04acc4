"""Autopilot logs (PX4 ULog, ArduPilot DataFlash, ROS 2 bags) onto one clock for the estimator.

Every reader returns an ``AutopilotFlight``: the same ``FlightLog`` columns a CSV log has (docs/formats.md,
flight log), plus the rows replay must not feed (no data, on the ground), the autopilot's own wind for
comparison and notes for the user. The helpers here resample one message stream onto the clock.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dobwind.logs import FlightLog

# Rotor speeds come from ESC telemetry, which autopilots often publish far slower than the attitude
# (PX4's esc_status at 4 Hz in SITL, DShot telemetry round-robin on hardware). Rotor speed follows the
# thrust command within tens of milliseconds but the command itself changes slowly in flight, so
# rpm is interpolated linearly between reports, and a row has no rotor data only when the reports
# around it are more than this far apart (two missed 4 Hz reports), independent of limits.max_dt.
ROTOR_MAX_GAP_S = 0.75


@dataclass(frozen=True)
class AutopilotFlight:
    log: FlightLog
    no_data: np.ndarray                     # rows without data from some message stream
    landed: np.ndarray                      # rows on the ground (landed, maybe landed or ground contact)
    autopilot_wind: tuple[str, np.ndarray, np.ndarray] | None  # (source, t, wind NED rows)
    notes: tuple[str, ...]
    t0_s: float = 0.0                       # the log's own clock at row 0 (log.time_s starts at 0)
    warnings: tuple[str, ...] = ()          # said on stderr too: the user must not miss them

    @property
    def px4_wind(self) -> tuple[str, np.ndarray, np.ndarray] | None:  # the name the ULog path had first
        return self.autopilot_wind


def gaps(t_src: np.ndarray, t_dst: np.ndarray, max_gap: float) -> np.ndarray:
    """True where t_dst is outside the stream's span or between samples farther apart than max_gap."""
    idx = np.searchsorted(t_src, t_dst, side="right")
    outside = (idx == 0) | (t_dst > t_src[-1])
    prev = t_src[np.clip(idx - 1, 0, len(t_src) - 1)]
    nxt = t_src[np.clip(idx, 0, len(t_src) - 1)]
    exact = t_dst == prev
    return outside | (~exact & ((nxt - prev) > max_gap))


def source_gaps(streams: dict[str, tuple[np.ndarray, float]], t_dst: np.ndarray) -> tuple[np.ndarray, str]:
    """Rows of t_dst inside a gap of any stream ({name: (its times, its maximum gap)}), and which streams
    caused them ("vehicle_local_position 155, esc_status 3"): a user must know which topic to log faster."""
    mask = np.zeros(len(t_dst), dtype=bool)
    counts = []
    for name, (t_src, max_gap) in streams.items():
        own = gaps(t_src, t_dst, max_gap)
        mask |= own
        if own.any():
            counts.append(f"{name} {int(own.sum())}")
    return mask, ", ".join(counts)


def bracketing(t_src: np.ndarray, flag: np.ndarray, t_dst: np.ndarray) -> np.ndarray:
    """True where either source sample around t_dst (the one at or before, the one after) is flagged:
    an interpolated value is only as good as both ends."""
    idx = np.searchsorted(t_src, t_dst, side="right")
    before = flag[np.clip(idx - 1, 0, len(t_src) - 1)]
    after = flag[np.clip(idx, 0, len(t_src) - 1)]
    exact = t_dst == t_src[np.clip(idx - 1, 0, len(t_src) - 1)]
    return before | (after & ~exact)


def interp(src: dict, fields: list[str], t: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(t, src["t"], src[f]) for f in fields])


def hold(src: dict, fields: list[str], t: np.ndarray) -> np.ndarray:
    idx = np.clip(np.searchsorted(src["t"], t, side="right") - 1, 0, len(src["t"]) - 1)
    return np.column_stack([src[f][idx] for f in fields])


def quaternions(t_src: np.ndarray, q: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(w, x, y, z) rows interpolated at t: sign-aligned first (q and -q are one attitude), then
    normalised."""
    flips = np.cumsum(np.r_[0, np.einsum("ij,ij->i", q[1:], q[:-1]) < 0]) % 2
    aligned = np.where((flips == 1)[:, None], -q, q)
    out = np.column_stack([np.interp(t, t_src, aligned[:, i]) for i in range(4)])
    with np.errstate(invalid="ignore", divide="ignore"):  # a zero quaternion (a corrupt log) becomes NaN,
        return out / np.linalg.norm(out, axis=1)[:, None]  # which the step rejects: no RuntimeWarning


def blank(cols: dict[str, np.ndarray], skip: np.ndarray) -> dict[str, np.ndarray]:
    """Rows the estimator must not see get NaN inputs: the step rejects them and keeps its state, so the
    observer starts at the first airborne sample instead of at the ground's reaction force."""
    return {k: (v if k == "t" else np.where(skip, np.nan, v)) for k, v in cols.items()}


def count_note(mask: np.ndarray, what: str, status: str) -> str:
    return f"{int(mask.sum())} of {len(mask)} instants {what}: status {status}"
