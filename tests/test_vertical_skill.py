"""The vertical law's skill over the CV blocks (dobwind/calibrate/verticalskill.py): the share of the
held-out vertical mean square it leaves unexplained, the share's standard error over the blocks, and the
rule that calls the law identified only when the share is below 1 by more than two standard errors."""
from __future__ import annotations

import math

import numpy as np
import pytest

from dobwind.calibrate import dragfit
from dobwind.calibrate.verticalskill import SE_MULTIPLE, VerticalSkill, block_errors, vertical_skill


def test_share_and_standard_error_in_closed_form():
    """law [0, 2], zero [2, 1]: share 2/3; residuals -4/3 and +4/3, sum of squares 32/9, times n/(n-1) = 2
    gives 64/9, root 8/3, over the total 3: SE 8/9."""
    skill = vertical_skill(np.array([0.0, 2.0]), np.array([2.0, 1.0]))
    assert skill is not None and skill.blocks == 2
    assert skill.share == pytest.approx(2 / 3, rel=1e-12) and skill.share_se == pytest.approx(8 / 9, rel=1e-12)
    assert skill.upper == pytest.approx(2 / 3 + SE_MULTIPLE * 8 / 9, rel=1e-12)


def test_a_law_that_beats_zero_alike_on_every_block_is_identified():
    """Every block's error a tenth of zero's: share 0.1 with no scatter at all."""
    skill = vertical_skill(np.full(5, 0.1), np.ones(5))
    assert skill is not None and skill.share == pytest.approx(0.1) and skill.share_se == pytest.approx(0.0, abs=1e-15)
    assert skill.identified


def test_a_law_that_beats_zero_on_one_block_only_is_not():
    """Below zero on the whole (share 0.77: a CV 12 % under zero's, which the old rule called identified)
    but won on a single block of climbs: the per-block sums of the ArduPilot SITL field log's fit,
    rounded (docs/tunnel-runs.md)."""
    law, zero = np.array([91.3, 111.2, 15.4, 222.1, 66.8]), np.array([89.4, 48.4, 326.7, 152.9, 41.2])
    skill = vertical_skill(law, zero)
    assert skill is not None and skill.share == pytest.approx(law.sum() / zero.sum())
    assert skill.share < 1 and not skill.identified


def test_the_bound_is_strict_at_one():
    assert not VerticalSkill(0.5, 0.25, 5).identified and VerticalSkill(0.5, 0.2499, 5).identified


def test_one_block_or_no_vertical_airflow():
    assert vertical_skill(np.array([1.0]), np.array([2.0])) is None
    flat = vertical_skill(np.zeros(3), np.zeros(3))
    assert flat is not None and math.isinf(flat.share) and not flat.identified


def _samples(n: int = 700) -> dragfit.DragSamples:
    """Samples in 7 blocks of 100 whose only use here is their vertical airflow and blocks."""
    rng = np.random.default_rng(3)
    air = rng.normal(0.0, 1.0, (n, 3))
    columns = np.zeros((n, 3, len(dragfit.PARAMETERS)))
    return dragfit.DragSamples(np.zeros((n, 3)), columns, np.ones(n), np.zeros(n), air, np.arange(n) // 100,
                               np.zeros(n, dtype=int))


def _off_by(offset_mps: float):
    """A 'law' that predicts every held-out airflow with a vertical error of offset_mps."""
    return lambda train, test: test.airflow + np.array([0.0, 0.0, offset_mps])


def test_block_errors_are_the_grouped_cvs_errors_block_by_block():
    samples = _samples()
    law, zero = block_errors(samples, _off_by(0.5))
    assert len(law) == 7 and law == pytest.approx(np.full(7, 100 * 0.25))
    assert sorted(zero) == pytest.approx(sorted(np.sum(samples.airflow[:, 2].reshape(7, 100) ** 2, axis=1)))
    _, cv_v = dragfit.grouped_cv(samples, _off_by(0.5))
    assert law.sum() / zero.sum() == pytest.approx(cv_v ** 2 / np.mean(samples.airflow[:, 2] ** 2))
