"""Autopilot logs (PX4 ULog, ArduPilot DataFlash, ROS 2 bags) onto one clock for the estimator.

Every reader returns an ``AutopilotFlight``: the same ``FlightLog`` columns a CSV log has (docs/formats.md,
flight log), plus the rows replay must not feed (no data, on the ground), the autopilot's own wind for
comparison and notes for the user. The helpers here resample one message stream onto the clock.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from dobwind.core.errors import InputError
from dobwind.io.logs import FlightLog

if TYPE_CHECKING:
    from dobwind.io.sitlwind import SitlLog

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
    findings: tuple = ()                    # replay's plausibility findings (dobwind.replay.plausibility.Finding)
    autopilot_wind_variance: np.ndarray | None = None  # (north, east) variances, m²/s², per autopilot_wind row
    # NO_DATA rows inside a short silence whose inputs were interpolated and fed (dobwind/io/bridge.py);
    # None when the reader was not asked to bridge (then every NO_DATA row is blanked).
    bridged: np.ndarray | None = None
    silences: tuple[tuple[str, float, float], ...] = ()  # (stream, its gap tolerance, its longest silence), s
    sitl: SitlLog | None = None  # an ArduPilot SITL log's simulated wind (dobwind/io/sitlwind.py)

    @property
    def px4_wind(self) -> tuple[str, np.ndarray, np.ndarray] | None:  # the name the ULog path had first
        return self.autopilot_wind


@dataclass(frozen=True)
class GapPolicy:
    """When a topic's silence is a gap (rows NO_DATA) rather than its normal interval.

    PX4 logs vehicle_local_position at 8-10 Hz and ArduPilot its EKF at 10 Hz next to a 50-250 Hz
    attitude: a fixed tolerance of max_dt (0.1 s) turns every other row of such a log into a gap. So each
    topic is judged by its own typical (median) interval: a gap is a silence longer than ``intervals``
    of them, never shorter than the airframe's max_dt (a fast topic keeps today's tolerance) and never
    longer than ``ceiling_s`` (velocity interpolated across longer silences hides a manoeuvre)."""
    intervals: float = 4.0  # up to three lost messages in a row: real logs drop a few (SD-card writes)
    ceiling_s: float = 0.5

    def tolerance(self, t_src: np.ndarray, max_dt_s: float) -> float:
        typical = float(np.median(np.diff(t_src))) if len(t_src) > 1 else max_dt_s
        return float(min(max(max_dt_s, self.intervals * typical), max(self.ceiling_s, max_dt_s)))


DEFAULT_GAP_POLICY = GapPolicy()


def topic_tolerances(streams: dict[str, np.ndarray], max_dt_s: float, fixed: dict[str, float] | None = None,
                     policy: GapPolicy = DEFAULT_GAP_POLICY) -> tuple[dict[str, tuple[np.ndarray, float]], list[str]]:
    """({name: (its times, its gap tolerance)} for ``source_gaps``, notes naming the slow topics).
    ``fixed`` tolerances win (esc_status: ROTOR_MAX_GAP_S)."""
    out: dict[str, tuple[np.ndarray, float]] = {}
    slow = []
    for name, t_src in streams.items():
        if fixed and name in fixed:
            out[name] = (t_src, fixed[name])
            continue
        tol = policy.tolerance(t_src, max_dt_s)
        out[name] = (t_src, tol)
        if tol > max_dt_s:
            rate = 1.0 / float(np.median(np.diff(t_src)))
            slow.append(f"{name} {rate:.1f} Hz")
    notes = [f"slow topics interpolated, a gap only beyond {policy.intervals:g} of their median intervals "
             f"(at most {policy.ceiling_s:g} s): " + ", ".join(slow)] if slow else []
    return out, notes


def uniform_clock(path: str, spans: list[np.ndarray], rate_hz: float) -> np.ndarray:
    """Instants at ``rate_hz`` over the span every stream covers, on whole microseconds (the clock of
    ULog and DataFlash timestamps, so an instant that is a sample's time compares equal to it). A
    uniform clock keeps dt constant: the attitude's own clock jitters by a few percent, and each
    jitter beyond max_dt was a rejected sample that restarted the settling time."""
    start = max(float(t[0]) for t in spans)
    stop = min(float(t[-1]) for t in spans)
    if not stop > start:
        raise InputError(path, None, "the needed topics do not overlap in time")
    n = int(np.floor((stop - start) * rate_hz + 1e-3)) + 1  # a last instant within a microsecond of stop counts
    clock = np.round((start + np.arange(n) / rate_hz) * 1e6) * 1e-6
    clock = clock[(clock >= start) & (clock <= stop)]  # a ROS 2 stamp (ns) is not whole us: rounding may step out
    if len(clock) < 2:
        raise InputError(path, None, "fewer than two instants to resample onto")
    return clock


def wind_active(wind: np.ndarray) -> np.ndarray:
    """Samples where the autopilot actually estimates wind. PX4 publishes its wind topics with exactly
    zero north and east while the EKF does not fuse drag or airspeed (the states stay at their initial
    0), so an all-zero sample is "inactive", not a calm: no estimate ever lands on exactly 0.0 in both."""
    return (wind[:, 0] != 0.0) | (wind[:, 1] != 0.0)


def active_reference(label: str, wind: tuple[str, np.ndarray, np.ndarray] | None):
    """(label, t, wind NED) of the autopilot's wind for a plot, NaN where it is inactive (drawn only
    where the autopilot estimates); None when it never is."""
    if wind is None or not wind_active(wind[2]).any():
        return None
    shown = np.where(wind_active(wind[2])[:, None], wind[2], np.nan)
    if np.all(wind[2][:, 2] == 0.0):  # PX4 and ArduPilot estimate no vertical wind: no line at a fake 0
        shown[:, 2] = np.nan
    return label, wind[1], shown


def speed_band(wind: tuple[str, np.ndarray, np.ndarray] | None, variance: np.ndarray | None,
               t0_s: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """(t, speed - sigma, speed + sigma) of the autopilot's horizontal wind speed where it is active, the
    sigma of the speed from its north/east variances (the variance along the wind's direction); None
    without variances."""
    if wind is None or variance is None or not wind_active(wind[2]).any():
        return None
    on = wind_active(wind[2])
    n, e = wind[2][on, 0], wind[2][on, 1]
    speed = np.hypot(n, e)
    sigma = np.sqrt((variance[on, 0] * n * n + variance[on, 1] * e * e) / np.maximum(speed * speed, 1e-12))
    return wind[1][on] + t0_s, np.maximum(speed - sigma, 0.0), speed + sigma


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


def in_time_order(cols: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The columns (one row per sample, times in "t") with the rows sorted by time, stably, and a
    repeated stamp's later rows dropped. interp, hold and bracketing take times that increase: a log
    written out of order (a logger flushing a buffer late, two files spliced, a damaged timestamp)
    otherwise interpolates between the wrong samples without a word. The DataFlash reader's pick_stream
    orders its rows so too."""
    t = cols["t"]
    if len(t) < 2 or bool(np.all(np.diff(t) > 0)):
        return cols
    order = np.argsort(t, kind="stable")
    keep = order[np.r_[True, np.diff(t[order]) > 0]]
    return {name: values[keep] for name, values in cols.items()}


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


def truncated_note(size: int) -> str:
    """What a reader says of a log whose last message is cut off at ``size`` bytes (ULog, DataFlash)."""
    return f"truncated: the file ends inside a message at byte {size:,}; replaying the readable part only"
