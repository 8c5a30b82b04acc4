"""Whether a fitted vertical law is identified: its held-out error set against predicting zero vertical
airflow, with the uncertainty of that comparison over the cross-validation blocks (issue #31; the
measurement behind the rule is in docs/tunnel-runs.md, "An unidentified vertical law").

The grouped CV scores the law on FOLDS folds of BLOCK_S-second blocks (dragfit.py). Per block b the law
leaves L_b, the sum of its held-out squared vertical errors, and zero leaves Z_b, the sum of the true
vertical airflow squared. Their ratio of sums, share = sum L / sum Z = (cv_v / zero)^2, is the part of
the vertical airflow's mean square the law leaves unexplained: below 1 the law beats zero. It is a
ratio estimator over the blocks, and its standard error is the usual one of such estimators (the
delta method: the scatter of the residuals L_b - share Z_b). A law is identified when its share is
below 1 by more than SE_MULTIPLE standard errors; a CV that beats zero on one block of climbs and
loses on the others is not."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from dobwind.calibrate.dragfit import DragSamples, FitPredict, Split, fold_splits, prediction_error

# How many standard errors the share must stay below 1 by: 2, the usual two-sided 95 % (one-sided
# 97.7 %) normal bound, not tuned on the measured fits (docs/tunnel-runs.md lists their margins).
SE_MULTIPLE = 2.0


@dataclass(frozen=True)
class VerticalSkill:
    """The law's unexplained share of the held-out vertical mean square, its standard error over the
    blocks, and how many blocks it was judged on."""
    share: float
    share_se: float
    blocks: int

    @property
    def upper(self) -> float:
        """The share's upper bound: SE_MULTIPLE standard errors above it."""
        return self.share + SE_MULTIPLE * self.share_se

    @property
    def identified(self) -> bool:
        return self.upper < 1.0


def block_errors(samples: DragSamples, fit_predict: FitPredict,
                 folds: tuple[Split, ...] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Per CV block (in the folds' order): the law's held-out squared vertical error summed, and zero's
    (the true vertical airflow squared, summed). The same errors as dragfit.grouped_cv's, clipped alike."""
    folds = fold_splits(samples) if folds is None else folds
    law, zero = [], []
    for train, test in folds:
        error = prediction_error(fit_predict(train, test), test.airflow)[:, 2]
        _, block = np.unique(test.group, return_inverse=True)
        law.append(np.bincount(block, error ** 2))
        zero.append(np.bincount(block, test.airflow[:, 2] ** 2))
    return (np.concatenate(law), np.concatenate(zero)) if law else (np.zeros(0), np.zeros(0))


def vertical_skill(law: np.ndarray, zero: np.ndarray) -> VerticalSkill | None:
    """The share and its standard error from the per-block sums; None with fewer than two blocks (no
    scatter to judge by). A flight with no vertical airflow at all has an infinite share: nothing to identify."""
    n = len(law)
    if n < 2:
        return None
    total = float(np.sum(zero))
    if total <= 0:
        return VerticalSkill(math.inf, math.inf, n)
    share = float(np.sum(law)) / total
    residual = law - share * zero
    # n / (n - 1): the residuals' scatter from n blocks, one degree of freedom spent on the share itself.
    return VerticalSkill(share, math.sqrt(n / (n - 1) * float(np.sum(residual ** 2))) / total, n)
