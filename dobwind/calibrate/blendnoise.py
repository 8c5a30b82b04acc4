"""Whether blending the acceleration input with the velocity's derivative can lower the still-air noise,
predicted from the two sensors' noise before any fit is run on it.

The blend (accelroute.py) is the velocity-aided bias estimate with a short time constant T:
p'' = HP_T(a) + LP_T(v'), fh = 1 / (2 pi T). It goes through the observer (first order per axis, at
fo = gain / (2 pi m)) and the low-pass at fc (the schedule's first cutoff):

- white acceleration noise of variance sa^2 per sample (two-sided density sa^2 dt) leaves
  sa^2 dt * pi fc^2 fo^2 / ((fh + fc)(fc + fo)(fo + fh)) through the high-pass, against
  sa^2 dt * pi fc fo / (fc + fo) without a bias estimate;
- white velocity noise of variance sv^2 per sample, differentiated (density sv^2 dt (2 pi f)^2), leaves
  sv^2 dt * 4 pi^3 fh^2 fc^2 fo^2 / ((fh + fc)(fc + fo)(fo + fh)) through the blend's low-pass.

(Over all f, f^2 / ((a^2 + f^2)(b^2 + f^2)(c^2 + f^2)) integrates to pi / ((a + b)(b + c)(c + a)).) So
the acceleration route's noise variance, relative to the unbiased input alone, is

    ratio(T) = fc / (fh + fc) * fo / (fo + fh) * (1 + sv^2 / (sa^2 T^2)),

independent of the sample time. The observer's factor matters: the low-pass passes a 1/f^2 tail above
fh that a 1 Hz observer (the m300's, the 25 kg hexacopter's) cuts, so without it the form favours too
long a T. A noiseless accelerometer (sa = 0) makes the ratio infinite: the input is kept as it is. It covers the acceleration's share of the force noise only (the thrust's is untouched),
so it says whether the blend is worth a fit, and the self-check's replay says whether it was.

The two noise levels are read off the logs' first rows: a first difference of white noise has twice its
variance and a second difference six times, while the flight's own motion adds only jerk * dt (and
jerk * dt^2) at the sample rate. Robust (median absolute deviation) spreads keep manoeuvre edges and
glitches out.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dobwind.core.errors import InputError
from dobwind.io.logs import FlightLog, iter_log

# Rows of each log the noise levels are read from: enough for a spread within a few per cent, and a
# first block of the file only (a second or two of reading on a large calibration).
NOISE_ROWS = 20_000
NOISE_BLOCK_BYTES = 1 << 22
MIN_ROWS = 200
ACCELERATION_COLUMNS = {"ned": ("acc_n", "acc_e"), "specific_force": ("sf_x", "sf_y")}
VELOCITY_COLUMNS = ("vel_n", "vel_e")
MAD_TO_SIGMA = 1.4826


@dataclass(frozen=True)
class SensorNoise:
    """Per-sample white noise, 1 sigma per horizontal axis: the acceleration input (m/s^2) and the
    ground velocity (m/s)."""
    acceleration_mps2: float
    velocity_mps: float


def acceleration_noise_ratio(noise: SensorNoise, cutoff_hz: float, bias_time_s: float,
                             observer_hz: float = math.inf) -> float:
    """The acceleration route's noise variance behind the observer (``observer_hz``; inf: far above the
    corners) and the low-pass at ``cutoff_hz`` with a velocity-aided bias estimate of time constant
    ``bias_time_s`` (0: none), over that of the input alone."""
    if bias_time_s <= 0:
        return 1.0
    if noise.acceleration_mps2 <= 0:
        return math.inf  # everything the blend adds is the velocity's noise
    corner_hz = 1.0 / (2.0 * math.pi * bias_time_s)
    observer_share = 1.0 if math.isinf(observer_hz) else observer_hz / (observer_hz + corner_hz)
    velocity_share = (noise.velocity_mps / (noise.acceleration_mps2 * bias_time_s)) ** 2
    return cutoff_hz / (corner_hz + cutoff_hz) * observer_share * (1.0 + velocity_share)


def blend_rms_ratio(noise: SensorNoise, cutoff_hz: float, bias_time_s: float, blend_time_s: float,
                    observer_hz: float = math.inf) -> float:
    """The blend's acceleration noise (RMS) over the airframe's own route (bias time ``bias_time_s``)."""
    return math.sqrt(acceleration_noise_ratio(noise, cutoff_hz, blend_time_s, observer_hz)
                     / acceleration_noise_ratio(noise, cutoff_hz, bias_time_s, observer_hz))


def quietest_blend_time(noise: SensorNoise, cutoff_hz: float, observer_hz: float = math.inf) -> float:
    """The bias time T that minimizes acceleration_noise_ratio. With k = (2 pi sv / sa)^2 the ratio is
    proportional to (1 + k fh^2) / ((fh + fc)(fh + fo)), whose derivative vanishes where
    k s fh^2 + 2 (k fc fo - 1) fh - s = 0 (s = fc + fo); without the observer's factor (fo infinite),
    fh = sqrt(fc^2 + 1 / k) - fc. Infinite T for a noiseless accelerometer, none for a noiseless velocity."""
    if noise.acceleration_mps2 <= 0:
        return math.inf
    if noise.velocity_mps <= 0:
        return 0.0
    k = (2.0 * math.pi * noise.velocity_mps / noise.acceleration_mps2) ** 2
    if math.isinf(observer_hz):
        corner_hz = math.sqrt(cutoff_hz * cutoff_hz + 1.0 / k) - cutoff_hz
    else:
        s, b = cutoff_hz + observer_hz, 1.0 - k * cutoff_hz * observer_hz
        corner_hz = (b + math.sqrt(b * b + k * s * s)) / (k * s)
    return 1.0 / (2.0 * math.pi * corner_hz)


def _robust_sigma(values: np.ndarray) -> float:
    finite = values[np.isfinite(values)]
    if len(finite) < MIN_ROWS:
        return math.nan
    return MAD_TO_SIGMA * float(np.median(np.abs(finite - np.median(finite))))


def log_sensor_noise(log: FlightLog, acceleration: str) -> SensorNoise | None:
    """The noise levels of one log's acceleration input (``acceleration``: "ned" or "specific_force")
    and ground velocity, from its first NOISE_ROWS rows; None when the log lacks them."""
    columns = ACCELERATION_COLUMNS.get(acceleration)
    if columns is None or not log.has(*columns, *VELOCITY_COLUMNS) or log.rows < MIN_ROWS:
        return None
    acc = log.stack(*columns)[:NOISE_ROWS]
    vel = log.stack(*VELOCITY_COLUMNS)[:NOISE_ROWS]
    sa = float(np.median([_robust_sigma(np.diff(acc[:, k])) for k in range(2)])) / math.sqrt(2.0)
    sv = float(np.median([_robust_sigma(np.diff(vel[:, k], n=2)) for k in range(2)])) / math.sqrt(6.0)
    if not (math.isfinite(sa) and math.isfinite(sv)):
        return None
    return SensorNoise(sa, sv)


def pooled_sensor_noise(levels: list[SensorNoise | None]) -> SensorNoise | None:
    """The median of the logs' levels (None when no log gave one)."""
    known = [n for n in levels if n is not None]
    if not known:
        return None
    return SensorNoise(float(np.median([n.acceleration_mps2 for n in known])),
                       float(np.median([n.velocity_mps for n in known])))


def logs_sensor_noise(paths: list[str], acceleration: str) -> SensorNoise | None:
    """The pooled noise levels of the CSV logs at ``paths`` (their first block each); None when no log
    gives one (autopilot logs, logs without the columns: the blend is then judged by the replay alone)."""
    from dobwind.io.autopilot import is_autopilot_log

    columns = ACCELERATION_COLUMNS.get(acceleration)
    if columns is None:
        return None
    needed = [(c, "noise level") for c in ("t", *columns, *VELOCITY_COLUMNS)]
    levels = []
    for path in paths:
        try:
            if is_autopilot_log(path):
                continue
            first = next(iter(iter_log(path, needed, NOISE_BLOCK_BYTES)), None)
        except (InputError, OSError):
            continue
        levels.append(None if first is None else log_sensor_noise(first.log, acceleration))
    return pooled_sensor_noise(levels)
