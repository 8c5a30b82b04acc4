"""Is a log's acceleration the vehicle's? Its agreement with the velocity's derivative in the observer's band.

Why init asks: autopilots log their acceleration as instants of a fast, vibrating signal. PX4 writes
vehicle_local_position (ax, ay, az) and sensor_combined at about 10 Hz by default, each message one
sample of an estimate updated at 100-250 Hz from an IMU that feels the rotors' vibration. Sampled that
sparsely, the vibration aliases down into the fraction of a hertz the observer passes. On two of the real
PX4 flights in ../shared/data/field/ (a 1.5 kg quad and a coaxial octo) the logged horizontal acceleration
disagrees with the derivative of the logged velocity by 0.6-1.7 m/s² RMS below 0.5 Hz, where the two
measure the same thing; on the third (an X500) by 0.12 m/s², on a PX4 SITL log by 0.01 m/s². A 1.7 m/s²
error is 17 % of the weight as a horizontal force: the starter read 8 m/s of "wind" where PX4's own
drag-fusion estimate said 1.8 m/s, and the vertical check saw a 6 m/s downdraft. Through the velocity's
derivative the same starter reads 1.3 m/s. The velocity is the EKF's fused estimate (GNSS and IMU) and
carries no such aliasing: its derivative is the better input when the two disagree this much.

The limit is 2 % of g (0.196 m/s²): the residual force a `--wind unknown` solve expects from gusts and
the thrust model (dobwind/calibrate/windsolve.py takes 2 % of the weight as its residuals' scale). An
acceleration wrong by more than that in the observer's band is the largest error in the force.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dobwind.io.logs import FlightLog
from dobwind.model.airframe import Airframe
from dobwind.model.attitude import rotation_matrices
from dobwind.model.signals import log_signals

LIMIT_MPS2 = 0.02 * 9.80665
# Runs of valid rows shorter than this many periods of the band are left out, and each run's first and
# last period is not scored: the zero-phase filter's start and end transients (of out-of-band vibration
# too, which it otherwise removes) would dominate them.
MIN_RUN_PERIODS = 3.0
EDGE_PERIODS = 1.0
MIN_SAMPLES = 50
# A silence longer than this many typical intervals ends a run (dobwind/io/resample.py GapPolicy's
# figure): interpolating over a few lost messages is harmless, over seconds of flight it is not.
MAX_GAP_INTERVALS = 4.0


@dataclass(frozen=True)
class AccelCheck:
    """The logged acceleration (``source``: "ned" or "specific_force") against the velocity's derivative:
    RMS of their horizontal difference after a zero-phase low-pass at ``band_hz``, over ``seconds`` of
    airborne rows with data."""
    source: str
    disagreement_mps2: float
    band_hz: float
    seconds: float

    @property
    def broken(self) -> bool:
        return self.disagreement_mps2 > LIMIT_MPS2

    def text(self) -> str:
        """The measurement, as a clause: '<the logged input> and the velocity's derivative differ by ...'."""
        verdict = "above" if self.broken else "within"
        what = "NED acceleration" if self.source == "ned" else "specific force (turned to NED)"
        return (f"the log's {what} and the velocity's derivative differ by {self.disagreement_mps2:.2f} m/s² RMS "
                f"below {self.band_hz:.2g} Hz over {self.seconds:.0f} s airborne ({verdict} the {LIMIT_MPS2:.2f} m/s² "
                "limit, 2 % of g)")


def horizontal_acceleration(log: FlightLog, source: str) -> np.ndarray:
    """(n, 2) the logged acceleration's north and east components: the NED acceleration as logged, or the
    specific force turned to NED by the attitude (gravity has no horizontal part)."""
    if source == "ned":
        return log.stack("acc_n", "acc_e")
    q = log.stack("q_w", "q_x", "q_y", "q_z")
    norm = np.linalg.norm(q, axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        rot = rotation_matrices(q / norm)
    return np.einsum("nij,nj->ni", rot[:, :2, :], log.stack("sf_x", "sf_y", "sf_z"))


def _runs(ok: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of each run of True."""
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(np.int8), 0]))
    return list(zip(edges[::2], edges[1::2]))


def _uniform(t: np.ndarray, dt: float, *columns: np.ndarray) -> list[np.ndarray]:
    """Each (n, k) column block on instants ``dt`` apart from t[0] (linear interpolation). The filter and
    the derivative below assume evenly spaced samples; a log's own timestamps are not (a 10 Hz topic's
    jitter by a tenth of an interval and more), and a derivative taken over the uneven times turns that
    jitter into a broadband error the comparison keeps: 10 % jitter reads as 10 % of the acceleration."""
    grid = t[0] + dt * np.arange(int(math.floor((t[-1] - t[0]) / dt + 1e-6)) + 1)
    return [np.column_stack([np.interp(grid, t, c[:, i]) for i in range(c.shape[1])]) for c in columns]


def check_acceleration(log: FlightLog, airborne: np.ndarray, source: str, band_hz: float) -> AccelCheck | None:
    """The check on the rows marked ``airborne`` (on a log read through an airframe whose
    observer.acceleration is ``source``); None when fewer than MIN_SAMPLES rows in long enough runs."""
    from scipy.signal import butter, sosfiltfilt

    t = log.time_s
    vel = log.stack("vel_n", "vel_e")
    acc = horizontal_acceleration(log, source)
    step = np.diff(t)
    dt = float(np.median(step[step > 0])) if np.any(step > 0) else math.inf
    if not math.isfinite(dt) or band_hz >= 0.5 / dt:
        return None
    # A repeated or backward timestamp (a topic's own samples, as inspect passes them) has no derivative,
    # and across a silence of several intervals the filter would join two stretches of flight as one:
    # either ends a run.
    ok = (airborne & np.all(np.isfinite(vel), axis=1) & np.all(np.isfinite(acc), axis=1)
          & np.r_[True, (step > 0) & (step <= MAX_GAP_INTERVALS * dt)])
    sos = butter(2, band_hz, fs=1.0 / dt, output="sos")
    shortest = max(int(math.ceil(MIN_RUN_PERIODS / (band_hz * dt))), 16)
    edge = int(math.ceil(EDGE_PERIODS / (band_hz * dt)))
    squares, count = 0.0, 0
    for start, end in _runs(ok):
        if end - start < shortest:
            continue
        v, a = _uniform(t[start:end], dt, vel[start:end], acc[start:end])
        # The velocity is smoothed before it is differentiated, not after: the derivative of its raw
        # samples turns their noise into a broadband error that nothing filters afterwards.
        derivative = np.gradient(sosfiltfilt(sos, v, axis=0), dt, axis=0)
        difference = (sosfiltfilt(sos, a, axis=0) - derivative)[edge:-edge]
        squares += float(np.sum(difference ** 2))
        count += difference.size
    if count < 2 * MIN_SAMPLES:
        return None
    return AccelCheck(source, math.sqrt(squares / count), band_hz, count / 2 * dt)


def check_log(path: str, af: Airframe, band_hz: float) -> AccelCheck | None:
    """check_acceleration on a log read as replay reads it through ``af`` (an autopilot log: its airborne
    rows with data; a CSV log has no ground flag, so all its rows). None when ``af`` takes no acceleration
    input, when the check cannot judge the flight, or when the reader refuses the log (its caller or replay
    says why)."""
    from dobwind.core.errors import InputError
    from dobwind.io.autopilot import is_autopilot_log, read_autopilot
    from dobwind.io.logs import read_log, required_columns

    if not log_signals(af).measured_acceleration:
        return None
    try:
        if is_autopilot_log(path):
            flight = read_autopilot(path, af)
            return check_acceleration(flight.log, ~flight.landed & ~flight.no_data, af.observer.acceleration, band_hz)
        log = read_log(path, required_columns(af))
    except InputError:
        return None
    return check_acceleration(log, np.ones(log.rows, dtype=bool), af.observer.acceleration, band_hz)


def calibration_warnings(af: Airframe, paths: list[str]) -> list[str]:
    """For `fit`: each autopilot log whose acceleration the airframe reads (observer.acceleration "ned" or
    "specific_force") and which fails the check at the estimate's band (the low-pass's highest cutoff),
    one warning. The fit would read that error as an external force."""
    from dobwind.io.autopilot import is_autopilot_log

    said = []
    for path in (p for p in paths if is_autopilot_log(p)):
        check = check_log(path, af, max(af.filter.cutoffs_hz))
        if check is not None and check.broken:
            said.append(f"{path}: {check.text()}: the calibration reads that error as an external force; "
                        'observer.acceleration = "velocity" avoids it (dobwind init chooses it for such a log)')
    return said
