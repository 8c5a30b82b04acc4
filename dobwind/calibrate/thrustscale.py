"""`fit --wind unknown`'s thrust scale: from the vertical force balance, used only when the data need it.

A starter airframe's collective thrust is the setpoint over the hover throttle (`dobwind init`), and
that hover throttle is often 10-25 % off on a real vehicle. The observer then reads kappa u_f z_b as an
external force (kappa = 1 - true/nominal thrust, dobwind/calibrate/dragfit.py's convention): mostly
vertical (-kappa m g at hover), and horizontal in manoeuvres, where the thrust's horizontal part is the
vehicle's acceleration and not the drag, which the wind solver would read as wind.

The vertical balance pins kappa without the wind: with the mean vertical wind zero (the solver's
assumption anyway) the vertical airflow is -v_d, so the down force's filtered value is linear in
(kappa, lz, qz):

    H[f_d] = kappa H[t_d] + lz H[a_d] + qz H[|a_d| a_d],   a_d = -v_d,

t_d the nominal thrust's down component and H the step's observer and low-pass (windrows), then the
same zero-phase smoothing. Ordinary least squares over the fitted rows gives kappa and its 1-sigma
(residual scale, inflated for the residuals' correlation as windsolve does).

Tried only when the vertical estimate is more than SIGNIFICANCE 1-sigmas and MIN_KAPPA from zero, and
used only when the data support it, a nested-model test on the horizontal problem, the one the wind
comes from: the wind solve is run with kappa = 0 and with kappa fixed at the vertical estimate, and the
estimate is kept only when it lowers the horizontal residuals' sum of squares by more than the
chi-square(1) quantile CHI2_1 times the residual variance (inflated for the residuals' correlation,
as the 1-sigma is). The vertical balance alone cannot decide: a thrust that changes a few percent with
the airflow through the rotors, or a setpoint bias, shifts the vertical mean without being a scale error
that the horizontal force shows (on the simulated default vehicle, kappa = +0.02 from the vertical
balance made the wind 0.2 m/s worse; on a vehicle whose starter is 20 % off, it removes a 2 m/s error).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dobwind.calibrate import windrows
from dobwind.model.airframe import Airframe

SIGNIFICANCE = 3.0   # the vertical estimate is tried only this many of its 1-sigmas away from zero
# ... and only when at least this large: thrust changes with the airflow through the rotors by a few
# percent at a few m/s (translational lift, inflow), so a smaller vertical mean is not evidence of a
# scale error, while a wrong hover throttle is 10-25 % off. (Without it, the simulated default vehicle's
# +0.02 passed the nested test on a 300 s two-wind flight and cost 0.5 m/s: tests/test_fieldcal.py's
# per-segment test.)
MIN_KAPPA = 0.05
CHI2_1 = 10.83       # chi-square(1) at 0.999: the horizontal residual must drop by this many variances


@dataclass(frozen=True)
class VerticalRows:
    """One log's accepted rows for the vertical balance: filtered down force and the regressors."""
    force_d: np.ndarray    # (n,) the step's filtered down force, smoothed
    columns: np.ndarray    # (n, 3) H-filtered, smoothed: nominal thrust down, a_d, |a_d| a_d
    fitted: np.ndarray     # (n,) bool


@dataclass(frozen=True)
class ThrustScale:
    kappa: float           # the estimate (1 - true/nominal thrust), whether used or not
    sigma: float           # its 1-sigma
    used: bool             # the nested-model test passed: the solve uses kappa
    evidence: float = 0.0  # the horizontal sum-of-squares drop in residual variances (test: > CHI2_1)

    @property
    def applied(self) -> float:
        return self.kappa if self.used else 0.0

    def text(self) -> str:
        if not worth_trying(self):
            verdict = f"not used (within {SIGNIFICANCE:g} sigma or {MIN_KAPPA:g} of the starter's)"
        else:
            verdict = ("used" if self.used else "not used") + (f" (horizontal residual drop {self.evidence:.3g} "
                                                               f"variances, needs > {CHI2_1:g})")
        return (f"thrust scale from the vertical balance: true/nominal {1 - self.kappa:.3f} "
                f"(kappa {self.kappa:+.3f}, 1-sigma {self.sigma:.3f}), {verdict}")


def vertical_rows(cal: Airframe, times: np.ndarray, force_d: np.ndarray, thrust_d: np.ndarray, vel_d: np.ndarray,
                  fitted: np.ndarray, dt: float) -> VerticalRows:
    """The accepted rows' vertical force and regressors, filtered as the step filters the down axis."""
    path = windrows.observer_path(cal, np.diff(times, prepend=times[0]), axes=(2, 2))
    sos = windrows.smoothing(dt)
    air = -vel_d
    raw = np.column_stack([thrust_d, air, np.abs(air) * air])
    h = np.column_stack([windrows.through_observer(path, raw[:, :2]), windrows.through_observer(path, raw[:, 2:3].repeat(2, 1))[:, :1]])
    return VerticalRows(windrows.smooth(sos, force_d[:, None])[:, 0], windrows.smooth(sos, h), fitted)


def _inflation(residual: np.ndarray) -> float:
    r = residual
    den = float(np.sum(r * r))
    rho = min(max(float(np.sum(r[1:] * r[:-1])) / den, 0.0), 0.95) if den > 0 else 0.0
    return math.sqrt((1 + rho) / (1 - rho))


def estimate(logs: list[VerticalRows]) -> ThrustScale:
    """kappa by least squares over every log's fitted rows, its 1-sigma, and the nested-model verdict."""
    y = np.concatenate([rows.force_d[rows.fitted] for rows in logs])
    x = np.vstack([rows.columns[rows.fitted] for rows in logs])
    if len(y) < 2 * x.shape[1]:
        return ThrustScale(0.0, math.inf, False)
    norms = np.maximum(np.linalg.norm(x, axis=0), 1e-12)
    coef, *_ = np.linalg.lstsq(x / norms, y, rcond=None)
    coef = coef / norms
    residual = y - x @ coef
    sigma2 = float(np.sum(residual ** 2)) / (len(y) - x.shape[1])
    cov = np.linalg.pinv(x.T @ x) * sigma2
    sigma = math.sqrt(max(float(cov[0, 0]), 0.0)) * _inflation(residual)
    return ThrustScale(float(coef[0]), sigma, False)


def worth_trying(scale: ThrustScale) -> bool:
    """The vertical estimate is clearly non-zero and large enough to be a scale error: a second wind
    solve with it is worth its time."""
    return (math.isfinite(scale.sigma) and abs(scale.kappa) > SIGNIFICANCE * scale.sigma
            and abs(scale.kappa) > MIN_KAPPA)


def nested_test(scale: ThrustScale, without: np.ndarray, with_kappa: np.ndarray, inflation: float) -> ThrustScale:
    """``without``, ``with_kappa``: the horizontal data residuals at each solve's solution. The drop in
    their sum of squares, in units of the (MAD) residual variance times the correlation's inflation
    squared, against CHI2_1."""
    sigma = 1.4826 * float(np.median(np.abs(with_kappa - np.median(with_kappa))))
    if not sigma > 0:
        return scale
    drop = (float(np.sum(without ** 2)) - float(np.sum(with_kappa ** 2))) / (sigma * sigma * inflation * inflation)
    return ThrustScale(scale.kappa, scale.sigma, drop > CHI2_1, drop)
