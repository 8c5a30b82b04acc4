"""A drag fit anchored on run means: each calibration log's MEAN force is one observation, weighted alike.

The per-sample fit (dragfit.robust_fit) weights every decimated sample alike, so a log's variation within
itself (a figure-8's +-1.4 m/s, thousands of samples) can outvote what each log says as a whole: its mean
force at its mean airflow. When the logs are flown at a few fixed wind settings with only a nominal
speed known (a tunnel), the means are the only absolute speed information there is, and the shape the
within-log variation implies may disagree with them (a real tunnel's figure-8 crosses a sheared jet; the
Neural-Fly runs' within-run slopes put a 4.2 m/s run at 5.35 m/s or more, README).

Here the law is fitted to two kinds of observation per log, each counting once:
- its mean equation, mean(y) = mean(A) theta (3 axes), with a robust (Tukey bisquare) weight from the
  speed error the law leaves on that log's mean airflow: a log off by several of the others' errors
  moves the law by a small share only (none beyond TUKEY_C robust scales), and is flagged as an outlier;
- its within-log variation, (y - mean y) = (A - mean A) theta over the log's samples, normalized by the
  log's sample count: the shape information of a log's whole sweep weighs as much as one mean, however
  many samples it holds. It carries no offset (it is centred), so the absolute scale and the force
  offsets come from the means alone.
Both are scaled per axis by the per-sample residual's size (horizontal and vertical noise differ), so the
two kinds share one unit and the result does not depend on it.

The anchored fit is used only when the per-sample fit leaves some log's mean airflow off by more than
GATE_MPS with three logs or more (``needs_anchor``): simulated calibrations whose logs agree keep the
per-sample fit they had, unchanged.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

# A log's mean horizontal airflow speed error above this (m/s), left by the per-sample fit, makes the
# fit anchor on the run means. Far above the per-log mean errors of consistent calibrations (the
# observer noise averages over a log), far below the 1-3 m/s a tunnel's inconsistent runs leave.
GATE_MPS = 0.25
MIN_LOGS = 3            # fewer logs than this cannot tell a disagreeing log from the law
CAUCHY_C = 2.385        # Cauchy constant (95 % efficiency at the normal) of the loss that ranks fits
TUKEY_C = 4.685         # Tukey bisquare tuning constant (95 % efficiency at the normal), in robust scales
# The robust scale of the logs' mean speed errors never goes below this (m/s): a law through every
# other log exactly would otherwise call any small disagreement an outlier.
SCALE_FLOOR_MPS = 0.1
# A log whose bisquare weight falls below this (its error beyond 0.54 TUKEY_C robust scales) is an outlier.
OUTLIER_WEIGHT = 0.5
ROUNDS = 12


@dataclass(frozen=True)
class RunStats:
    """Per log: mean observed force (L, 3), mean regressor columns (L, 3, P), the within-log Gram
    matrix and right-hand side normalized by the log's count (L, P, P) and (L, P), all axis-scaled."""
    logs: np.ndarray
    mean_observed: np.ndarray
    mean_columns: np.ndarray
    within_gram: np.ndarray
    within_rhs: np.ndarray


def run_stats(observed: np.ndarray, columns: np.ndarray, log_index: np.ndarray, axis_scale: np.ndarray) -> RunStats:
    """The per-log summaries of axis-scaled samples (``axis_scale``: 1/sigma per axis)."""
    y = observed * axis_scale
    a = columns * axis_scale[None, :, None]
    logs = np.unique(log_index)
    means_y, means_a, grams, rhs = [], [], [], []
    for log in logs:
        pick = log_index == log
        ya, aa = y[pick], a[pick]
        my, ma = ya.mean(axis=0), aa.mean(axis=0)
        dy, da = ya - my, aa - ma
        count = len(ya)
        means_y.append(my)
        means_a.append(ma)
        grams.append(np.einsum("nap,naq->pq", da, da) / count)
        rhs.append(np.einsum("nap,na->p", da, dy) / count)
    return RunStats(logs, np.array(means_y), np.array(means_a), np.array(grams), np.array(rhs))


def anchored_system(stats: RunStats, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The normal equations: each log's mean (weighted) and its normalized within-log variation."""
    gram = np.einsum("l,lap,laq->pq", weights, stats.mean_columns, stats.mean_columns) + stats.within_gram.sum(axis=0)
    rhs = np.einsum("l,lap,la->p", weights, stats.mean_columns, stats.mean_observed) + stats.within_rhs.sum(axis=0)
    return gram, rhs


def robust_scale(errors: np.ndarray) -> float:
    """1.4826 MAD of the logs' mean speed errors about zero, floored (SCALE_FLOOR_MPS)."""
    return max(SCALE_FLOOR_MPS, 1.4826 * float(np.median(np.abs(errors))))


def tukey_weights(errors: np.ndarray, scale: float) -> np.ndarray:
    """Bisquare weights: zero beyond TUKEY_C robust scales. The fit's weights are these, not Cauchy's:
    with a few logs and nearly as many parameters a log's mean pulls the law hard however small its
    weight, and a weight that never reaches zero drifts back to least squares (on the Neural-Fly runs a
    Cauchy weight of 0.24 on the disagreeing run moved the others' errors from 0.2 to 1.2 m/s)."""
    u = errors / (TUKEY_C * scale)
    return np.where(np.abs(u) < 1, (1 - u * u) ** 2, 0.0)


# theta -> each log's mean horizontal airflow speed error (m/s), in stats.logs order
RunErrors = Callable[[np.ndarray], np.ndarray]
# (gram, rhs) -> theta (the caller's solver: its active set and non-negativity)
Solver = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _reweighted(stats: RunStats, solve: Solver, run_errors: RunErrors,
                weights: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """IRLS from ``weights``: theta and the logs' final bisquare weights. The scale is fixed from the
    start's errors (an MM-estimate): re-estimated every round, it grows with the error an outlier
    spreads over the others once it is weighted in again, and the fit drifts back to least squares."""
    theta = solve(*anchored_system(stats, weights))
    scale = robust_scale(run_errors(theta)[weights > 0])
    for _ in range(ROUNDS):
        new = tukey_weights(run_errors(theta), scale)
        if np.allclose(new, weights, atol=1e-3):
            break
        weights = new
        theta = solve(*anchored_system(stats, weights))
    return theta, weights


def cauchy_loss(errors: np.ndarray) -> float:
    """The Cauchy loss of the logs' mean errors at the floor scale: the same yardstick for every start."""
    return float(np.sum(np.log1p((errors / (CAUCHY_C * SCALE_FLOOR_MPS)) ** 2)))


def anchored_fit(stats: RunStats, solve: Solver, run_errors: RunErrors) -> tuple[np.ndarray, np.ndarray]:
    """The robust fit of the run means, started from every log's mean weighted alike and, with more
    than MIN_LOGS logs, also from each log's mean left out (the loss is not convex: from the
    least-squares start a disagreeing log spreads its error over the others, and the robust scale grown
    from those errors never singles it out). The start whose end leaves the least Cauchy loss wins
    (the first on a tie): theta and the logs' bisquare weights."""
    count = len(stats.logs)
    starts = [np.ones(count)]
    if count > MIN_LOGS:
        starts += [np.where(np.arange(count) == k, 0.0, 1.0) for k in range(count)]
    best: tuple[float, np.ndarray, np.ndarray] | None = None
    for start in starts:
        theta, weights = _reweighted(stats, solve, run_errors, start)
        loss = cauchy_loss(run_errors(theta))
        if best is None or loss < best[0] - 1e-9:
            best = (loss, theta, weights)
    assert best is not None
    return best[1], best[2]


@dataclass(frozen=True)
class RunVerdict:
    """One calibration log's figures under the fitted law: a row of the fit report's `runs`."""
    log: int | str               # the log's index among the fit's logs; its path once the fit names it (fitfamily)
    mean_speed_mps: float        # the log's mean true horizontal airflow speed (H-filtered)
    error_mps: float             # size of the error of the log's mean estimated horizontal airflow vector
    weight: float                # its bisquare weight in the anchored fit (1 when not anchored)
    outlier: bool


def verdicts(logs: np.ndarray, speeds: np.ndarray, errors: np.ndarray,
             weights: np.ndarray | None) -> list[RunVerdict]:
    """Each log's mean error, its weight in the anchored fit (``weights``; None: not anchored, each 1)
    and whether it looks like an outlier: a weight below OUTLIER_WEIGHT, by the fit's weights or, when
    it did not anchor, by the bisquare rule on the errors it left (never with fewer than MIN_LOGS logs)."""
    judged = weights if weights is not None else tukey_weights(errors, robust_scale(errors))
    shown = weights if weights is not None else np.ones(len(errors))
    return [RunVerdict(int(l), float(s), float(e), float(w), len(errors) >= MIN_LOGS and bool(j < OUTLIER_WEIGHT))
            for l, s, e, w, j in zip(logs, speeds, errors, shown, judged)]


def needs_anchor(errors: np.ndarray) -> bool:
    """The per-sample fit leaves some log's mean airflow off by more than GATE_MPS, with MIN_LOGS or more."""
    return len(errors) >= MIN_LOGS and bool(np.any(np.abs(errors) > GATE_MPS))


# The self-check leaves the fit's outliers unjudged only while they are fewer than this share of the
# logs: one of four tunnel runs, none of three (two agreeing logs cannot outvote a third).
EXEMPT_SHARE = 1 / 3


def exempt_outliers(runs: list[RunVerdict], anchored: bool) -> list[str]:
    """The flagged logs (outlier_logs) of a fit anchored on the run means when they are fewer than
    EXEMPT_SHARE of all; else none: a fit that disowns more of its logs than that, or one fitted per
    sample (which weighted the flagged log in fully), is judged on all of them."""
    flagged = outlier_logs(runs)
    return flagged if anchored and 0 < len(flagged) < EXEMPT_SHARE * len(runs) else []


def exempt_warning(runs: list[RunVerdict], exempt: list[str]) -> str:
    """The warning a fit prints for the outliers its self-check does not judge."""
    named = "; ".join(f"{run.log} (mean airflow {run.error_mps:.2f} m/s off, weight {run.weight:.2f})"
                      for run in runs if run.log in exempt)
    return (f"the fit flagged {named} as disagreeing with the other logs: weighted by the robust fit of the run "
            "means, left out of the hold-level CV and not held to the self-check's per-log limit; check that "
            "log's truth and thrust, or --exclude-outliers fits without it")


def outlier_logs(runs: list[RunVerdict]) -> list[str]:
    """The logs a fit report's per-log table (FitReport.runs) flags as outliers."""
    return [run.log for run in runs if run.outlier]


def outlier_advice(runs: list[RunVerdict]) -> str | None:
    """What would make the data fit, for a refusal: which logs disagree with the others and by how much,
    and the option that fits without them; None when no log is flagged."""
    flagged = [run for run in runs if run.outlier]
    if not flagged:
        return None
    named = "; ".join(f"{run.log} disagrees with the other logs: its mean airflow is {run.error_mps:.2f} m/s "
                      f"off under the law (weight {run.weight:.2f})" for run in flagged)
    return f"{named}; --exclude-outliers fits again without {'it' if len(flagged) == 1 else 'them'}"
