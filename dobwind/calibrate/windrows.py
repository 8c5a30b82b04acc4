"""`fit --wind unknown`'s samples: every settled accepted airborne row, compared through the observer.

The step's force (the calibration airframe's `force_ned`) is the raw external force f_e passed through two
linear first-order filters: the disturbance observer (pole and gains from model/discretization.py's
`first_order`) and the fixed-cutoff low-pass. Neither changes on a rejected row (a rejection only resets
the gap bookkeeping), so over the sequence of accepted rows force_ned = H f_e, H one linear filter.
Comparing force_ned with the law's force at the CURRENT airflow (what the steady-row sampling had to do)
reads H's lag in manoeuvres as wind; comparing it with H applied to the law's force row by row,

    force_ned(k) = H[ R(yaw)^T f_law(R(yaw) (w - v)) ](k) + H[noise](k),

is exact for any law and any manoeuvre (H is linear), so every accepted row counts, not only the steady
ones. The price is residuals correlated over H's time constant: they are decimated to SAMPLE_RATE_HZ and
the 1-sigma is inflated for the remaining correlation (windsolve._inflation). Offline, so H may run over
the whole log."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, lfilter, sosfiltfilt

from dobwind.model.airframe import Airframe
from dobwind.model.discretization import first_order
from dobwind.model.forceair import heading_force, heading_to_ned, horizontal_drag_basis

SAMPLE_RATE_HZ = 5.0
SMOOTH_HZ = 0.15   # the zero-phase low-pass on measured and predicted force alike (see smooth)


@dataclass(frozen=True)
class LogRows:
    """One log's accepted rows in order (the observer's own sequence) and which of them are fitted."""
    force: np.ndarray      # (n, 2) the step's filtered force, north/east
    vel: np.ndarray        # (n, 2) raw ground velocity, north/east
    cos_yaw: np.ndarray    # heading of each row
    sin_yaw: np.ndarray
    thrust: np.ndarray     # (n, 2) the nominal thrust's horizontal part u_f z_b, north/east
    group: np.ndarray      # (n,) wind group of each row
    fitted: np.ndarray     # (n,) bool: settled after any rejection, decimated
    path: ObserverPath     # the step's filters at each row's dt
    sos: np.ndarray        # the zero-phase low-pass (second-order sections) at this log's step


@dataclass(frozen=True)
class ObserverPath:
    """The calibration airframe's observer and fixed-cutoff low-pass as per-row coefficients, at each
    accepted row's own dt (the step's): y_k = pole_k y_(k-1) + b0_k x_k + b1_k x_(k-1) on each axis,
    then z_k = keep_k z_(k-1) + (1 - keep_k) y_k. Shapes (n, 2)."""
    pole: np.ndarray
    b0: np.ndarray
    b1: np.ndarray
    keep: np.ndarray


def observer_path(af: Airframe, dt: np.ndarray, axes: tuple[int, int] = (0, 1)) -> ObserverPath:
    """``dt`` (n,): the time since the previous accepted row (the first row's is unused). ``axes``: the
    observer gains of the two columns filtered (north, east; (2, 2) filters two down-axis signals)."""
    rates = np.asarray(af.observer.gains, dtype=float)[list(axes)] / af.mass_kg
    c = first_order(af.observer.discretization, rates[None, :], dt[:, None])
    keep = np.exp(-2 * math.pi * max(af.filter.cutoffs_hz) * dt)
    ones = np.ones((len(dt), 2))
    return ObserverPath(c.pole * ones, c.b0 * ones, c.b1 * ones, np.repeat(keep[:, None], 2, axis=1))


# Rows per block of the recursion below. Poles >= 0.05 (smaller ones take a plain loop) keep the running
# product above 0.05**128 = 3e-167, far from underflow; the rounding error stays eps times the sum of |u|
# whatever the block length (each u_j enters as u_j P_k / P_j <= u_j), so a long block costs no accuracy and
# saves Python iterations: a jittered log's --wind unknown solve 54 s -> 20 s (16 -> 128).
BLOCK = 128


def _recursion(pole: np.ndarray, u: np.ndarray, y0: np.ndarray) -> np.ndarray:
    """y_k = pole_k y_(k-1) + u_k for k >= 1, y_0 given; (n, 2). One pole for all rows (a resampled log's
    constant dt): scipy's lfilter. Otherwise vectorised within blocks of BLOCK rows (y_k = P_k (y_start
    + sum_j u_j / P_j), P the running product of the poles since the block's start)."""
    if len(u) > 1 and np.all(pole[1:] == pole[1]):
        y = np.empty_like(u)
        y[0] = y0
        for axis in range(u.shape[1]):
            p = float(pole[1, axis])
            y[1:, axis], _ = lfilter([1.0], [1.0, -p], u[1:, axis], zi=[p * y0[axis]])
        return y
    y = np.empty_like(u)
    y[0] = y0
    last = y0
    for start in range(1, len(u), BLOCK):
        p = pole[start:start + BLOCK]
        if np.any(np.abs(p) < 0.05):   # a pole near zero: the products would divide by ~0; plain loop
            for k in range(start, min(start + BLOCK, len(u))):
                last = pole[k] * last + u[k]
                y[k] = last
            continue
        prod = np.cumprod(p, axis=0)
        y[start:start + BLOCK] = prod * (last + np.cumsum(u[start:start + BLOCK] / prod, axis=0))
        last = y[min(start + BLOCK, len(u)) - 1]
    return y


def through_observer(path: ObserverPath, force_ne: np.ndarray) -> np.ndarray:
    """``force_ne`` (n, 2) as the step would have filtered it, both stages starting at its first value
    (the step starts its filters at the first accepted sample's input)."""
    x = force_ne
    previous = np.vstack([x[:1], x[:-1]])
    observed = _recursion(path.pole, path.b0 * x + path.b1 * previous, x[0])
    return _recursion(path.keep, (1 - path.keep) * observed, x[0])


def _unit_forces(air_h: np.ndarray) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Heading-frame (x, y) force per unit of each horizontal coefficient and force offset: the horizontal
    part of dragfit.basis, the same numbers without its vertical terms and its (n, 3, P) stack, which
    took most of law_force_ne's time (it runs once per residual of the solve)."""
    vx, vy = air_h[:, 0], air_h[:, 1]
    one, zero = np.ones_like(vx), np.zeros_like(vx)
    return horizontal_drag_basis(vx, vy, np.maximum(np.hypot(vx, vy), 1e-9)) | {"ox": (one, zero), "oy": (zero, one)}


def law_force_ne(rows: LogRows, winds: np.ndarray, law: dict[str, float]) -> np.ndarray:
    """(n, 2) the horizontal drag law's force at each row's airflow R(yaw) (w - v), north/east."""
    air = winds[rows.group] - rows.vel
    c, s = rows.cos_yaw, rows.sin_yaw
    air_h = np.column_stack(heading_force(np.column_stack([air, np.zeros(len(c))]).T, c, s, (0.0, 0.0, 0.0)))
    unit = _unit_forces(air_h)
    f_h = sum(np.column_stack(unit[p]) * value for p, value in law.items() if p != "kappa")
    # kappa: a thrust-scale error shows as a force along the thrust's horizontal part, which in
    # manoeuvres is not along the airflow (in steady flight it only rescales the drag law)
    return np.column_stack(heading_to_ned(f_h[:, 0], f_h[:, 1], c, s)) + law.get("kappa", 0.0) * rows.thrust


def smoothing(dt: float) -> np.ndarray:
    """A second-order Butterworth at SMOOTH_HZ (below Nyquist whatever the log's rate)."""
    return butter(2, min(SMOOTH_HZ, 0.4 / dt), fs=1.0 / dt, output="sos")


def smooth(sos: np.ndarray, force_ne: np.ndarray) -> np.ndarray:
    """Zero-phase: it adds no lag, and applied alike to the measured and the predicted force it keeps
    the comparison exact (linear) while removing what the law cannot follow anyway (the thrust's and
    the attitude's timing in fast manoeuvres, rotor noise). Offline, so it may look ahead."""
    return sosfiltfilt(sos, force_ne, axis=0) if len(force_ne) > 12 else force_ne


def residual(rows: LogRows, winds: np.ndarray, law: dict[str, float]) -> np.ndarray:
    """(m, 2) measured minus predicted force, both filtered alike, at the fitted rows (``rows.force``
    is smoothed already)."""
    predicted = smooth(rows.sos, through_observer(rows.path, law_force_ne(rows, winds, law)))
    return rows.force[rows.fitted] - predicted[rows.fitted]


def decimation(t: np.ndarray) -> int:
    """Rows per fitted sample for about SAMPLE_RATE_HZ (the filtered force changes slowly anyway)."""
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    return max(1, int(round(1.0 / (SAMPLE_RATE_HZ * dt))))
