"""Replay's plausibility checks: what a wrong airframe betrays in a flight (the SUSPECT status bit).

An airframe that is not this vehicle (wrong mass, wrong rotor coefficients, a hover throttle scaled
wrongly) still gives an estimate: a confident number of metres per second. These checks look at the
replayed flight as a whole and say so instead, on stderr and in the notes, and set STATUS_SUSPECT
(model/status.py) on the rows concerned, or on every row when the finding is about the whole flight.

- hover force balance: at near-hover (slow, level flight: ``hover_level_share``), the external force the observer finds
  must be small against the weight. ``1 + (f_d - offset_d) / (m g)`` is the thrust the airframe
  computes as a fraction of the weight (hover in NED: 0 = m g - T + f_d); its median beyond
  ``hover_thrust_tolerance`` of 1 means the thrust model, the mass or the hover throttle is not this
  vehicle's. Whole flight.
- sustained vertical wind: the mean settled (not SETTLING) vertical wind over ``vertical_window_s``
  beyond ``vertical_wind_mps`` (for `init`'s starter, which publishes no vertical wind, the vertical
  wind its drag law would read from the vertical force: vertical_reading). Thermals and slope lift
  reach 1-3 m/s at multirotor heights; more, sustained over many seconds, is a vertical force the
  airframe misreads. The limit sits above what a merely unidentified vertical law reads in strong
  horizontal wind (m300 on the simulator's tunnel at 10 m/s: up to 3.0 m/s of "downdraft"; the
  vertical-law fallback's business, not a wrong vehicle).
  The rows of those windows.
- horizontal force beyond the calibrated envelope: the step's EXTRAPOLATED bit on more than
  ``extrapolated_share`` of the airborne estimates means the fit never saw forces like this flight's.
  The extrapolated rows.
- wind speed beyond any plausible figure: horizontal wind above ``wind_speed_max_mps`` (no multirotor
  holds position in such a wind; such a number is the airframe's, not the air's). Those rows.
- an acceleration input that is not the vehicle's (autopilot logs, acceleration_input): the logged
  acceleration against the velocity's derivative in the estimate's band (dobwind/io/accelcheck.py), for
  an airframe that takes the logged one. Every accepted row.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dobwind.io.accelcheck import LIMIT_MPS2, check_acceleration
from dobwind.io.inputs import heading_yaw
from dobwind.io.logs import FlightLog
from dobwind.model.airframe import Airframe
from dobwind.model.forceair import HORIZONTAL_DRAG_KEYS, drag_airflow_numpy, heading_force
from dobwind.model.kinds import DragFrame
from dobwind.model.signals import log_signals
from dobwind.model.status import STATUS_BITS, STATUS_LANDED, STATUS_SUSPECT, accepted
from dobwind.replay.finding import Finding
from dobwind.replay.logconventions import ConventionChecks

EXTRAPOLATED = next(bit.value for bit in STATUS_BITS if bit.name == "EXTRAPOLATED")
SETTLING = next(bit.value for bit in STATUS_BITS if bit.name == "SETTLING")
# The drag law's terms that depend on the direction the air comes from (all horizontal ones but l0, q0).
DIRECTION_KEYS = tuple(k for k in HORIZONTAL_DRAG_KEYS if k not in ("l0", "q0"))


@dataclass(frozen=True)
class PlausibilityLimits:
    hover_thrust_tolerance: float = 0.25   # |T / (m g) - 1| at near-hover beyond this: the airframe is not this vehicle
    hover_speed_mps: float = 1.0           # near-hover: horizontal ground speed below this ...
    hover_climb_mps: float = 0.5           # ... and vertical speed below this
    # ... and level: a horizontal external force below this share of the weight. A vehicle holding
    # position in a steady wind hovers tilted into it, and the air through its tilted body and rotors adds
    # a vertical force that grows with the wind: no sign of a wrong airframe. Measured on the simulated
    # family's PX4 logs (`python -m benchmarks.px4sim`, five vehicles in 5 and 10 m/s): the median
    # T / (m g) stays within 1.00-1.12 up to 0.2 of the weight in horizontal force, and reaches 1.27-1.28
    # (the micro, the m300) at 0.3-0.5 and beyond.
    hover_level_share: float = 0.2
    hover_min_s: float = 3.0               # the balance is judged only over at least this much near-hover time
    hover_min_height_m: float = 0.5        # ... at least this far above where the airborne stretch began
    vertical_wind_mps: float = 4.0         # sustained mean |vertical wind| beyond this ...
    vertical_window_s: float = 10.0        # ... over this long a window
    extrapolated_share: float = 0.5        # share of airborne estimates outside the calibrated envelope
    wind_speed_max_mps: float = 30.0       # horizontal wind beyond this is not air


DEFAULT_LIMITS = PlausibilityLimits()


@dataclass(frozen=True)
class FlightSeries:
    """What the checks read, one row per replayed instant."""
    t: np.ndarray
    vel: np.ndarray       # ground velocity NED (NaN where not fed)
    force: np.ndarray     # the step's filtered external force NED
    wind: np.ndarray      # wind NED
    status: np.ndarray    # after replay's own bits (NO_DATA, LANDED)
    yaw: np.ndarray | None = None  # the heading frame's yaw (rad), the force offset's frame; None: 0 (NED)

    @staticmethod
    def replayed(log: FlightLog, force: np.ndarray, wind: np.ndarray, status: np.ndarray) -> "FlightSeries":
        """A replayed log's series: its ground velocity and heading (the step's yaw_ref), the step's
        force and wind."""
        return FlightSeries(log.time_s, log.stack("vel_n", "vel_e", "vel_d"), force, wind, status,
                            heading_yaw(log, log.stack("q_w", "q_x", "q_y", "q_z")))


def _hover_text(ratio: float, seconds: float, lim: PlausibilityLimits) -> str:
    return (f"the airframe's thrust is {ratio:.2f}x the weight at hover (median over {seconds:.0f} s of near-hover; "
            f"tolerance +-{lim.hover_thrust_tolerance:g}): the airframe does not fit this vehicle (mass, thrust model "
            "or hover throttle)")


def _vertical_text(mean: float, rows: int, lim: PlausibilityLimits, af: Airframe) -> str:
    read = (", as the starter's vertical drag terms read the vertical force (it publishes no vertical wind)"
            if _reads_vertical_force(af) else "")
    return (f"a sustained {'updraft' if mean > 0 else 'downdraft'} of up to {abs(mean):.1f} m/s (mean over "
            f"{lim.vertical_window_s:g} s; limit {lim.vertical_wind_mps:g} m/s) on {rows} rows{read}: a vertical force "
            "the airframe misreads")


def _envelope_text(share: float, lim: PlausibilityLimits) -> str:
    return (f"{100 * share:.0f} % of the airborne estimates are outside the calibrated envelope (EXTRAPOLATED; limit "
            f"{100 * lim.extrapolated_share:.0f} %): the fit never saw forces like this flight's")


def _speed_text(worst: float, rows: int, lim: PlausibilityLimits) -> str:
    return (f"a horizontal wind of up to {worst:.0f} m/s on {rows} rows (limit {lim.wind_speed_max_mps:g} m/s): no "
            "multirotor flies in that, the airframe does not fit")


def check_flight(af: Airframe, s: FlightSeries, limits: PlausibilityLimits = DEFAULT_LIMITS) -> list[Finding]:
    ok = accepted(s.status)
    if not ok.any():
        return []
    found = [_hover_balance(af, s, ok, limits), _vertical_wind(af, s, ok, limits), _envelope(s, ok, limits),
             _wind_speed(s, ok, limits)]
    return [f for f in found if f is not None]


def _dt(t: np.ndarray) -> float:
    return float(np.median(np.diff(t))) if len(t) > 1 else 1.0


def _hover_balance(af: Airframe, s: FlightSeries, ok: np.ndarray, limits: PlausibilityLimits) -> Finding | None:
    # SETTLING rows count: a short hop has little settled hover, and the observer's start from zero force
    # only pulls the median towards a balance of 1 (fewer findings, never a false one).
    # Near the take-off height is no free-air hover: the land detector declares flight while the rotors
    # still spool up on the ground (PX4's take-off ramp) and touches down before they stop, and the weight
    # rests partly on the ground there (or in ground effect); counted, those rows read as a thrust short of
    # the weight for an airframe that fits.
    with np.errstate(invalid="ignore"):
        hover = (ok & (np.hypot(s.vel[:, 0], s.vel[:, 1]) < limits.hover_speed_mps)
                 & (np.abs(s.vel[:, 2]) < limits.hover_climb_mps) & _level(af, s, limits)
                 & (_height_above_takeoff(s) >= limits.hover_min_height_m))
    if hover.sum() * _dt(s.t) < limits.hover_min_s:
        return None
    weight = af.mass_kg * af.gravity_mps2
    ratio = 1.0 + float(np.median(s.force[hover, 2] - af.observer.force_offset_n[2])) / weight
    if abs(ratio - 1.0) <= limits.hover_thrust_tolerance:
        return None
    return Finding("hover_thrust", _hover_text(ratio, hover.sum() * _dt(s.t), limits), ratio,
                   limits.hover_thrust_tolerance, np.ones(len(s.t), dtype=bool))


def _level(af: Airframe, s: FlightSeries, limits: PlausibilityLimits) -> np.ndarray:
    """Rows whose horizontal external force (less the airframe's force offset, in the heading frame where
    it is calibrated) is below ``hover_level_share`` of the weight: the hover balance is judged in level
    hover only (see the limit)."""
    yaw = np.zeros(len(s.t)) if s.yaw is None else s.yaw
    m, n, _ = heading_force(s.force.T, np.cos(yaw), np.sin(yaw), af.observer.force_offset_n)
    with np.errstate(invalid="ignore"):
        return np.hypot(m, n) <= limits.hover_level_share * af.mass_kg * af.gravity_mps2


def _height_above_takeoff(s: FlightSeries) -> np.ndarray:
    """Height (m) above the last LANDED row before each row, integrated from the ground velocity (a row
    without velocity adds nothing); +inf before the first LANDED row (no take-off in the log: it began
    in the air, or has no ground state, as a CSV log)."""
    if not len(s.t):
        return np.zeros(0)
    landed = (s.status.astype(np.int64) & STATUS_LANDED) != 0
    dt = np.diff(s.t, prepend=s.t[0])
    height = np.cumsum(np.where(landed, 0.0, -np.nan_to_num(s.vel[:, 2]) * dt))
    last = np.maximum.accumulate(np.where(landed, np.arange(len(s.t)), -1))
    return np.where(last >= 0, height - height[np.maximum(last, 0)], np.inf)


def _window_mean(t: np.ndarray, x: np.ndarray, valid: np.ndarray, window_s: float) -> np.ndarray:
    """Mean of x over the valid rows within +-window/2 of each row (NaN where none)."""
    xs = np.where(valid, x, 0.0)
    csum, cnt = np.r_[0.0, np.cumsum(xs)], np.r_[0, np.cumsum(valid)]
    lo = np.searchsorted(t, t - window_s / 2, side="left")
    hi = np.searchsorted(t, t + window_s / 2, side="right")
    n = cnt[hi] - cnt[lo]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(n > 0, (csum[hi] - csum[lo]) / np.maximum(n, 1), np.nan)


def _reads_vertical_force(af: Airframe) -> bool:
    """`init`'s starter: uncalibrated, and a heading-frame drag law without direction terms or a horizontal
    force offset, so the vertical airflow it would read depends on the force's magnitudes alone."""
    law = af.drag
    return (af.uncalibrated and af.vertical_law != "fitted" and law is not None and law.frame == DragFrame.HEADING
            and not any(getattr(law, k) for k in DIRECTION_KEYS) and not any(af.observer.force_offset_n[:2]))


def vertical_reading(af: Airframe, s: FlightSeries) -> np.ndarray:
    """The upward wind (m/s) the check reads: the estimate's own, or, for a starter that publishes none
    (vertical_law "zero-wind": its vertical law is a guess, not a calibration), the one its drag law would
    read from the vertical force. A misread vertical force (a thrust model, mass or hover throttle that is
    not this vehicle's) is what the check exists for, and it is there whether the wind is published or not."""
    if not _reads_vertical_force(af):
        return -s.wind[:, 2]
    f = s.force   # a row without a force reads NaN (the check's isfinite drops it), not the still-air -vel_d
    air = drag_airflow_numpy(af.drag, np.hypot(f[:, 0], f[:, 1]), np.zeros(len(f)),
                             f[:, 2] - af.observer.force_offset_n[2])
    return -(air[:, 2] + s.vel[:, 2])


def _vertical_wind(af: Airframe, s: FlightSeries, ok: np.ndarray, limits: PlausibilityLimits) -> Finding | None:
    if s.t[-1] - s.t[0] < limits.vertical_window_s:
        return None
    up = vertical_reading(af, s)
    # Settled estimates only: a take-off transient while the filters catch up is not a sustained wind.
    settled = ok & ((s.status.astype(np.int64) & SETTLING) == 0) & np.isfinite(up)
    mean = _window_mean(s.t, up, settled, limits.vertical_window_s)
    with np.errstate(invalid="ignore"):
        rows = settled & (np.abs(mean) > limits.vertical_wind_mps)
    if not rows.any():
        return None
    worst = float(np.nanmax(np.abs(mean[rows])))
    signed = worst if np.nanmean(mean[rows]) > 0 else -worst
    return Finding("vertical_wind", _vertical_text(signed, int(rows.sum()), limits, af), worst, limits.vertical_wind_mps,
                   rows)


def _envelope(s: FlightSeries, ok: np.ndarray, limits: PlausibilityLimits) -> Finding | None:
    outside = ok & ((s.status.astype(np.int64) & EXTRAPOLATED) != 0)
    share = float(outside.sum() / ok.sum())
    if share <= limits.extrapolated_share:
        return None
    return Finding("envelope", _envelope_text(share, limits), share, limits.extrapolated_share, outside)


def _wind_speed(s: FlightSeries, ok: np.ndarray, limits: PlausibilityLimits) -> Finding | None:
    speed = np.hypot(s.wind[:, 0], s.wind[:, 1])
    with np.errstate(invalid="ignore"):
        rows = ok & (speed > limits.wind_speed_max_mps)
    if not rows.any():
        return None
    worst = float(np.max(speed[rows]))
    return Finding("wind_speed", _speed_text(worst, int(rows.sum()), limits), worst, limits.wind_speed_max_mps, rows)


def acceleration_input(af: Airframe, log: FlightLog, status: np.ndarray) -> Finding | None:
    """An airframe that takes the log's acceleration (observer.acceleration "ned" or "specific_force") on a
    log whose acceleration disagrees with the velocity's derivative in the estimate's band (the low-pass's
    highest cutoff) beyond dobwind/io/accelcheck.py's limit: every accepted row is SUSPECT, the force is
    wrong throughout. `dobwind init` routes such a log's starter through the velocity instead."""
    if not log_signals(af).measured_acceleration:
        return None
    ok = accepted(status)
    check = check_acceleration(log, ok & ((status.astype(np.int64) & STATUS_LANDED) == 0),
                               af.observer.acceleration, max(af.filter.cutoffs_hz))
    if check is None or not check.broken:
        return None
    message = (f"{check.text()}: the acceleration input carries errors the velocity does not (aliased vibration: a "
               'fast signal logged at a few hertz); observer.acceleration = "velocity" avoids it (dobwind init '
               "chooses it for such a log)")
    return Finding("acceleration", message, check.disagreement_mps2, LIMIT_MPS2, ok)


def mark(status: np.ndarray, findings: list[Finding]) -> np.ndarray:
    """status with STATUS_SUSPECT on every row a finding names."""
    rows = np.zeros(len(status), dtype=bool)
    for f in findings:
        rows |= f.rows
    return np.where(rows, status | STATUS_SUSPECT, status)


class StreamedChecks:
    """The same checks over a log read chunk by chunk (CSV replay streams in bounded memory): the hover
    ratio's median from a fine histogram, the vertical wind as means over consecutive windows of
    ``vertical_window_s`` (not sliding), counts for the rest. Rows already written cannot be marked, so
    a streamed log gets the warnings and notes only: Finding.rows is empty, Finding.count counts."""
    RATIO_BIN = 0.005
    RATIO_MAX = 5.0

    def __init__(self, af: Airframe, limits: PlausibilityLimits = DEFAULT_LIMITS) -> None:
        self._af, self._limits = af, limits
        self._ratio_hist = np.zeros(int(self.RATIO_MAX / self.RATIO_BIN) + 1, dtype=np.int64)
        self._hover_s = 0.0
        self._window: tuple[int, float, int, int] | None = None   # (index, sum up, settled count, rows)
        self._t0: float | None = None
        self._vertical_rows, self._vertical_worst = 0, 0.0   # worst: the signed window mean
        self._ok = self._extrapolated = self._gale_rows = 0
        self._gale_worst = 0.0
        self._conventions = ConventionChecks(af)

    def add(self, s: FlightSeries, log: FlightLog | None = None) -> None:
        """One chunk's series; with its CSV ``log``, the log's conventions too (dobwind/replay/logconventions.py)."""
        if log is not None:
            self._conventions.add(log, s.status)
        ok = accepted(s.status)
        dt = _dt(s.t) if len(s.t) > 1 else 0.0
        self._t0 = float(s.t[0]) if self._t0 is None else self._t0
        with np.errstate(invalid="ignore"):
            hover = (ok & (np.hypot(s.vel[:, 0], s.vel[:, 1]) < self._limits.hover_speed_mps)
                     & (np.abs(s.vel[:, 2]) < self._limits.hover_climb_mps) & _level(self._af, s, self._limits))
            speed = np.hypot(s.wind[:, 0], s.wind[:, 1])
            gale = ok & (speed > self._limits.wind_speed_max_mps)
        weight = self._af.mass_kg * self._af.gravity_mps2
        ratio = 1.0 + (s.force[hover, 2] - self._af.observer.force_offset_n[2]) / weight
        bins = np.clip(np.round(ratio / self.RATIO_BIN), 0, len(self._ratio_hist) - 1).astype(np.int64)
        np.add.at(self._ratio_hist, bins[np.isfinite(ratio)], 1)
        self._hover_s += float(hover.sum()) * dt
        self._ok += int(ok.sum())
        self._extrapolated += int((ok & ((s.status.astype(np.int64) & EXTRAPOLATED) != 0)).sum())
        self._gale_rows += int(gale.sum())
        self._gale_worst = max(self._gale_worst, float(speed[gale].max()) if gale.any() else 0.0)
        self._vertical(s, ok)

    def _vertical(self, s: FlightSeries, ok: np.ndarray) -> None:
        up = vertical_reading(self._af, s)
        settled = ok & ((s.status.astype(np.int64) & SETTLING) == 0) & np.isfinite(up)
        index = np.floor((s.t - self._t0) / self._limits.vertical_window_s).astype(np.int64)
        for k in np.unique(index):
            here = index == k
            part = (int(k), float(up[here & settled].sum()), int((here & settled).sum()), int(here.sum()))
            if self._window is not None and self._window[0] == part[0]:
                w = self._window
                self._window = (w[0], w[1] + part[1], w[2] + part[2], w[3] + part[3])
            else:
                self._close_window()
                self._window = part

    def _close_window(self) -> None:
        if self._window is None or self._window[2] == 0:
            return
        mean = self._window[1] / self._window[2]
        if abs(mean) > self._limits.vertical_wind_mps:
            self._vertical_rows += self._window[2]
            if abs(mean) > abs(self._vertical_worst):
                self._vertical_worst = mean

    def findings(self) -> list[Finding]:
        self._close_window()
        self._window = None
        lim, none = self._limits, np.zeros(0, dtype=bool)
        out = []
        if self._hover_s >= lim.hover_min_s and self._ratio_hist.any():
            cum = np.cumsum(self._ratio_hist)
            ratio = float(np.searchsorted(cum, cum[-1] / 2.0) * self.RATIO_BIN)
            if abs(ratio - 1.0) > lim.hover_thrust_tolerance:
                out.append(Finding("hover_thrust", _hover_text(ratio, self._hover_s, lim), ratio,
                                   lim.hover_thrust_tolerance, none, self._ok))
        if self._vertical_rows:
            out.append(Finding("vertical_wind", _vertical_text(self._vertical_worst, self._vertical_rows, lim, self._af),
                               abs(self._vertical_worst), lim.vertical_wind_mps, none, self._vertical_rows))
        if self._ok and self._extrapolated / self._ok > lim.extrapolated_share:
            share = self._extrapolated / self._ok
            out.append(Finding("envelope", _envelope_text(share, lim), share, lim.extrapolated_share, none,
                               self._extrapolated))
        if self._gale_rows:
            out.append(Finding("wind_speed", _speed_text(self._gale_worst, self._gale_rows, lim), self._gale_worst,
                               lim.wind_speed_max_mps, none, self._gale_rows))
        return out + self._conventions.findings()
