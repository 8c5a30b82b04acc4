"""The drag fit's horizontal force offset, measured where the true airflow is near zero.

Every term of the drag law (model/forceair.py) vanishes at zero airflow, so there the heading-frame force
the observer sees IS the offset (a sensor bias times the mass). Fitted freely beside the law instead, the
offset also takes up the part of a law's misfit at speed that is the same whatever the airflow direction:
a body whose front/back asymmetry the law's single q1c term cannot follow (benchmarks/anisovehicles/
nv_longthin: per-axis drag shaped by cos1 = -0.2) left it 0.06 N off, which its slope at zero airflow
(0.23 N per m/s) reads as 0.27 m/s of wind in still air. Measured there, the misfit stays at speed,
where it belongs. docs/calibration.md, "The force offset".
"""
from __future__ import annotations

import numpy as np

from dobwind.model.forceair import heading_force

ZERO_AIRFLOW_MPS = 0.3   # as the polynomial family's offset (calibrate/fit.py): hover in still air
# At least this much zero-airflow flight, in seconds of samples: the observed force passes H (a low-pass
# of a few tenths of a hertz at zero airflow), so nearby samples are not independent, and a short stretch
# would measure the offset no better than the regression does.
MIN_ZERO_AIRFLOW_S = 10.0
DEFAULT_INTERVAL_S = 0.1  # a sample's length when the samples do not say (dragfit.DECIMATED_RATE_HZ)


def zero_airflow_offset(observed: np.ndarray, cos_yaw: np.ndarray, sin_yaw: np.ndarray, airflow: np.ndarray,
                        interval_s: np.ndarray | None) -> tuple[float, float] | None:
    """The mean heading-frame horizontal force (N) over the samples whose H-filtered true airflow is
    under ZERO_AIRFLOW_MPS on every axis; None when they span less than MIN_ZERO_AIRFLOW_S."""
    zero = (np.hypot(airflow[:, 0], airflow[:, 1]) < ZERO_AIRFLOW_MPS) & (np.abs(airflow[:, 2]) < ZERO_AIRFLOW_MPS)
    length = np.full(len(zero), DEFAULT_INTERVAL_S) if interval_s is None else interval_s
    if float(np.sum(length[zero])) < MIN_ZERO_AIRFLOW_S:
        return None
    m, n, _ = heading_force(observed[zero].T, cos_yaw[zero], sin_yaw[zero], (0.0, 0.0, 0.0))
    return float(np.mean(m)), float(np.mean(n))


def pinned_system(active: tuple[str, ...], gram: np.ndarray, rhs: np.ndarray,
                  pin: tuple[float, float]) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    """The normal equations of the ``active`` parameters but ox, oy, with those held at ``pin``: their
    known columns moved to the right-hand side. Returns the other parameters, their Gram matrix and rhs."""
    pinned = [active.index("ox"), active.index("oy")]
    free = [i for i in range(len(active)) if i not in pinned]
    rhs = rhs - gram[:, pinned] @ np.asarray(pin)
    return tuple(active[i] for i in free), gram[np.ix_(free, free)], rhs[free]
