"""The true wind for `fit` from an autopilot log (issue #36): a steady wind (`--wind SPEED@FROM[,UP]`),
a time series in the log's own time (`--truth FILE.csv`) or, for an ArduPilot SITL log, the wind its
simulator was told to blow (`--truth sitl`, dobwind/calibrate/sitlwind.py).

Each calibration log becomes the same ``FlightLog`` a CSV log with wind columns is (docs/formats.md), so
the one fit pipeline (fitfamily.fit_airframe) reads it: the autopilot log through the reader replay uses
(dobwind/io/autopilot.py), its rows without data or on the ground already NaN (the step rejects them), and
the rows where the truth is unknown (outside a truth file's span) made NaN too, so nothing is calibrated
on a guess.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from dobwind.core.errors import InputError
from dobwind.io.logs import TRUE_WIND_MAX_MPS, TRUTH_COLUMNS, FlightLog, read_log, required_columns
from dobwind.model.airframe import Airframe
from dobwind.model.forceair import wind_from_ne
from dobwind.io.resample import blank
from dobwind.io.timewindow import TimeWindow


@dataclass(frozen=True)
class LogTime:
    """A calibration log as the fit reads it, and its own clock at row 0 (PX4: s since boot; ArduPilot:
    TimeUS in s; a CSV log: 0, its `t` is the log time)."""
    log: FlightLog
    t0_s: float

    @property
    def clock_s(self) -> np.ndarray:
        return self.log.time_s + self.t0_s


class Truth(Protocol):
    """A source of the true wind for one log: (N, 3) NED wind on the log's rows and which rows it knows."""

    def wind(self, path: str, flight: LogTime) -> tuple[np.ndarray, np.ndarray]: ...

    def describe(self) -> str: ...

    def describe_log(self, path: str) -> str:
        """What this truth gave one log, for fit's per-log lines (what the airflow was computed against)."""
        ...


@dataclass(frozen=True)
class SteadyWind:
    """One steady wind for every log: SPEED m/s from FROM deg, UP m/s updraft (positive up)."""
    speed_mps: float
    from_deg: float
    up_mps: float = 0.0

    def vector(self) -> np.ndarray:
        n, e = wind_from_ne(self.speed_mps, self.from_deg)[0]
        return np.array([n, e, -self.up_mps])

    def wind(self, path: str, flight: LogTime) -> tuple[np.ndarray, np.ndarray]:
        rows = flight.log.rows
        return np.tile(self.vector(), (rows, 1)), np.ones(rows, dtype=bool)

    def describe(self) -> str:
        return f"steady wind {self.speed_mps:g} m/s from {self.from_deg:g} deg, updraft {self.up_mps:g} m/s (--wind)"

    def describe_log(self, path: str) -> str:
        return (f"a known steady wind on every airborne row (--wind): {self.speed_mps:g} m/s from {self.from_deg:g} deg, "
                f"updraft {self.up_mps:g} m/s")


@dataclass(frozen=True)
class PerLogWind:
    """A steady wind per log (`--wind` repeated once per log, in the logs' order)."""
    winds: tuple[tuple[str, SteadyWind], ...]

    def wind(self, path: str, flight: LogTime) -> tuple[np.ndarray, np.ndarray]:
        return dict(self.winds)[path].wind(path, flight)

    def describe(self) -> str:
        return "; ".join(f"{path}: {wind.describe()}" for path, wind in self.winds)

    def describe_log(self, path: str) -> str:
        return dict(self.winds)[path].describe_log(path)


WIND_SYNTAX = "SPEED@FROM[,UP] (m/s, degrees the wind blows from clockwise from north, optional updraft m/s)"
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
_WIND = re.compile(rf"^\s*({_NUMBER})\s*@\s*({_NUMBER})\s*(?:,\s*({_NUMBER})\s*)?$")


def parse_wind(text: str, unknown_allowed: bool = True) -> SteadyWind:
    """`--wind SPEED@FROM[,UP]`; a bad value is an InputError naming the option and the value. The
    direction is a compass bearing as a vane or mast gives it, [0, 360] (360 is north, stored as 0):
    anything else is more likely a typo or a swapped field than a bearing, so it is refused, not wrapped.
    ``unknown_allowed``: the option also takes 'unknown' (fit's; its caller handles that word), so the
    refusal names it as the other choice; `simulate --wind` blows a wind and takes none but a value."""
    match = _WIND.match(text)
    if match is None:
        raise InputError("--wind", None, f"{text!r} is not {WIND_SYNTAX}" + (", nor 'unknown'" if unknown_allowed else ""))
    speed, from_deg = float(match.group(1)), float(match.group(2))
    up = float(match.group(3)) if match.group(3) is not None else 0.0
    # NaN cannot pass the regex, but an overflowing literal (1e400) reads as inf: the comparisons refuse it.
    if not 0 <= speed <= TRUE_WIND_MAX_MPS:
        raise InputError("--wind", None, f"{text!r}: the speed {speed:g} m/s must be in [0, {TRUE_WIND_MAX_MPS:g}] m/s")
    if not 0 <= from_deg <= 360:
        raise InputError("--wind", None, f"{text!r}: the direction {from_deg:g} deg must be in [0, 360] deg "
                         "(the bearing the wind blows from, clockwise from north)")
    if not abs(up) <= TRUE_WIND_MAX_MPS:
        raise InputError("--wind", None, f"{text!r}: the updraft {up:g} m/s must be in "
                         f"[-{TRUE_WIND_MAX_MPS:g}, {TRUE_WIND_MAX_MPS:g}] m/s")
    return SteadyWind(speed, from_deg % 360.0, up)


@dataclass(frozen=True)
class WindSeries:
    """A wind time series in log time (a truth file): interpolated linearly onto the log's rows; rows
    outside its span are unknown."""
    path: str
    t_s: np.ndarray
    ned: np.ndarray   # (N, 3)

    def wind(self, path: str, flight: LogTime) -> tuple[np.ndarray, np.ndarray]:
        t = flight.clock_s
        known = (t >= self.t_s[0]) & (t <= self.t_s[-1])
        return np.column_stack([np.interp(t, self.t_s, self.ned[:, i]) for i in range(3)]), known

    def describe(self) -> str:
        return f"wind time series {self.path} (--truth, {len(self.t_s)} rows, t {self.t_s[0]:g}..{self.t_s[-1]:g} s)"

    def describe_log(self, path: str) -> str:
        return (f"a known wind time series (--truth {self.path}), interpolated on the log's clock; rows outside "
                f"t {self.t_s[0]:g}..{self.t_s[-1]:g} s not used")


TRUTH_FILE_FORMATS = ("t, wind_n, wind_e, wind_d", "t, speed, from_deg (and optionally up)")


def read_truth_csv(path: str) -> WindSeries:
    """A truth file (docs/formats.md, wind truth): `t` in the log's own time (s) and either NED
    components (wind_n, wind_e, wind_d) or speed (m/s), from_deg (deg, clockwise from north) and
    optionally up (m/s, positive up)."""
    log = read_log(path, [("t", "time in the log's own clock, s")])
    cols = log.columns
    if log.has(*TRUTH_COLUMNS):
        ned = log.stack(*TRUTH_COLUMNS)
    elif log.has("speed", "from_deg"):
        up = cols["up"] if log.has("up") else np.zeros(log.rows)
        ned = np.column_stack([wind_from_ne(cols["speed"], cols["from_deg"]), -up])
    else:
        raise InputError(path, "header", "a wind truth file needs the columns " + " or ".join(TRUTH_FILE_FORMATS))
    bad = ~np.isfinite(ned).all(axis=1) | (np.abs(ned) > TRUE_WIND_MAX_MPS).any(axis=1)
    if bad.any():
        raise InputError(path, f"data row {int(np.flatnonzero(bad)[0]) + 1}",
                         f"the wind must be finite and within +-{TRUE_WIND_MAX_MPS:g} m/s")
    if log.rows < 2:
        raise InputError(path, None, "a wind truth file needs at least two rows")
    return WindSeries(path, log.time_s.copy(), ned)


def flight_of(path: str, af: Airframe, rate_hz: float | None, window: TimeWindow | None = None) -> LogTime:
    """A calibration log, airborne accepted rows only: an autopilot log through replay's reader (rows
    without data or on the ground are NaN), or a CSV log with the airframe's columns. ``window``: an
    autopilot log's rows in that span of its clock only (dobwind/io/timewindow.py)."""
    from dobwind.io.autopilot import is_autopilot_log, read_autopilot

    if is_autopilot_log(path):
        flight = read_autopilot(path, af, rate_hz, window=window)
        return LogTime(flight.log, flight.t0_s)
    if window is not None:
        raise InputError(path, None, "a time window is for autopilot logs (a CSV log keeps its own clock)")
    return LogTime(read_log(path, required_columns(af)), 0.0)


def with_truth(path: str, flight: LogTime, truth: Truth) -> FlightLog:
    """The log with the truth's wind columns; rows the truth does not know are NaN (the step rejects
    them, the fit never sees them). A log the truth knows nowhere is an input error."""
    wind, known = truth.wind(path, flight)
    cols = {k: v for k, v in flight.log.columns.items() if k not in TRUTH_COLUMNS}
    if not known.any():
        raise InputError(path, None, f"no row of the log lies where the truth is known ({truth.describe()})")
    cols = blank(cols, ~known)
    cols.update({name: wind[:, i] for i, name in enumerate(TRUTH_COLUMNS)})
    return FlightLog(flight.log.path, cols)


LogReader = Callable[[str, Airframe], FlightLog]


def truth_reader(truth: Truth, rate_hz: float | None = None, window: TimeWindow | None = None) -> LogReader:
    """What fitfamily.fit_airframe calls for each calibration log (``log_reader``); ``window``: each log's
    rows in that span of its clock only (a fit on part of a flight, the rest held out)."""
    return lambda path, af: with_truth(path, flight_of(path, af, rate_hz, window), truth)
