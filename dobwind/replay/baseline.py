"""The classic tilt-angle wind estimate, as the baseline users know.

A hovering multirotor leans into the wind until thrust balances drag: the horizontal airflow speed is
a function of tan(tilt), and the air moves the way the body's down axis leans. Calibrated on the same
logs as `dobwind fit` (least squares of speed on sqrt(tan) and tan), smoothed with a causal
first-order low-pass, ground velocity added. It ignores acceleration: manoeuvres read as wind.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from dobwind.io.logs import FlightLog
from dobwind.model.attitude import rotation_matrices

SMOOTH_S = 1.0
SKIP_S = 10.0


@dataclass(frozen=True)
class TiltModel:
    sqrt_coef: float
    linear_coef: float

    def speed(self, tan_tilt: np.ndarray) -> np.ndarray:
        t = np.maximum(tan_tilt, 0.0)
        return np.maximum(self.sqrt_coef * np.sqrt(t) + self.linear_coef * t, 0.0)


def _smooth(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    dt = float(np.median(np.diff(t)))
    a = math.exp(-dt / SMOOTH_S)
    return lfilter([1 - a], [1, -a], x, axis=0, zi=np.outer([a], x[0]) if x.ndim == 2 else [a * x[0]])[0]


def _lean(log: FlightLog) -> tuple[np.ndarray, np.ndarray]:
    """(tan of tilt, horizontal lean direction unit vector) after smoothing the body down axis."""
    q = log.stack("q_w", "q_x", "q_y", "q_z")
    q = q / np.linalg.norm(q, axis=1)[:, None]
    z_b = _smooth(rotation_matrices(q)[:, :, 2], log.time_s)
    horizontal = np.hypot(z_b[:, 0], z_b[:, 1])
    direction = z_b[:, :2] / np.maximum(horizontal, 1e-9)[:, None]
    return horizontal / np.maximum(z_b[:, 2], 1e-6), direction


def calibrate(logs: list[FlightLog]) -> TiltModel:
    tans, speeds = [], []
    for log in logs:
        tan, _ = _lean(log)
        rel = _smooth(log.true_wind - log.stack("vel_n", "vel_e", "vel_d"), log.time_s)
        use = log.time_s >= log.time_s[0] + SKIP_S
        tans.append(tan[use][::10])
        speeds.append(np.hypot(rel[use, 0], rel[use, 1])[::10])
    t, v = np.concatenate(tans), np.concatenate(speeds)
    coef, *_ = np.linalg.lstsq(np.column_stack([np.sqrt(t), t]), v, rcond=None)
    return TiltModel(float(coef[0]), float(coef[1]))


def estimate(model: TiltModel, log: FlightLog) -> np.ndarray:
    """Wind (NED rows); the vertical component is not observable from tilt and is reported as 0."""
    tan, direction = _lean(log)
    speed = model.speed(tan)
    ground = _smooth(log.stack("vel_n", "vel_e", "vel_d"), log.time_s)
    return np.column_stack([speed * direction[:, 0] + ground[:, 0], speed * direction[:, 1] + ground[:, 1],
                            np.zeros(log.rows)])
