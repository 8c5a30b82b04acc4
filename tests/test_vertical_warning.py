"""The fit's warning that its vertical law is not identified (fitfamily.vertical_warning): the law's
held-out error is compared with predicting zero vertical airflow, whose error is the RMS of the truth."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.calibrate import dragfit
from dobwind.calibrate.fitfamily import vertical_warning, zero_rmse
from dobwind.calibrate.verticalskill import block_errors, vertical_skill

AIR_Z = np.array([0.3, -0.4, 0.0, 0.5, -0.5, 0.4, -0.3, 0.0])   # RMS sqrt(1.0 / 8) = 0.35355 m/s


def test_a_law_worse_than_zero_is_warned_of_with_both_figures():
    text = vertical_warning(0.36, AIR_Z)
    assert text is not None and "grouped CV 0.360 m/s" in text and "vertical airflow 0.354 m/s" in text


def test_a_law_better_than_zero_is_not():
    assert vertical_warning(0.35, AIR_Z) is None
    assert vertical_warning(0.05, 10 * AIR_Z) is None


def test_no_cv_or_no_samples_says_nothing():
    assert vertical_warning(None, AIR_Z) is None
    assert vertical_warning(1.0, np.zeros(0)) is None


def test_the_zero_score_is_the_rms_of_the_truth():
    """What fit reports as vertical_zero_rmse_mps: sqrt(mean(z^2)), None without samples."""
    assert zero_rmse(AIR_Z) == pytest.approx(np.sqrt(1.0 / 8), rel=1e-12)
    assert zero_rmse(np.array([-2.0])) == pytest.approx(2.0) and zero_rmse(np.zeros(0)) is None


def _climb_then_level(n_block: int = 100) -> dragfit.DragSamples:
    """Five CV blocks (one per fold): a climb with 2 m/s RMS of vertical airflow, then four level blocks
    with 0.5 m/s."""
    rng = np.random.default_rng(7)
    group = np.arange(5 * n_block) // n_block
    air = rng.normal(0.0, 1.0, (len(group), 3)) * np.where(group == 0, 2.0, 0.5)[:, None]
    return dragfit.DragSamples(np.zeros((len(group), 3)), np.zeros((len(group), 3, len(dragfit.PARAMETERS))),
                               np.ones(len(group)), np.zeros(len(group)), air, group, np.zeros(len(group), dtype=int))


def _law_off_by(on_climb_mps: float, level_mps: float):
    """A 'law' whose held-out vertical prediction is off by one amount on the climb, another elsewhere."""
    def fit_predict(train, test):
        return test.airflow + np.stack([0 * test.group, 0 * test.group, np.where(test.group == 0, on_climb_mps, level_mps)], 1)
    return fit_predict


def test_a_law_that_wins_only_the_climb_is_not_identified_though_its_cv_beats_zero():
    """A marginal law (issue #31, the SITL field log's shape): 0.1 m/s off on the climb, 0.7 m/s off on the
    level blocks. Its CV is below zero's, which the rule before this one called identified; it leaves
    about 0.4 of the vertical mean square unexplained, with a standard error about as large."""
    samples = _climb_then_level()
    fit_predict = _law_off_by(0.1, 0.7)
    _, cv_v = dragfit.grouped_cv(samples, fit_predict)
    skill = vertical_skill(*block_errors(samples, fit_predict))
    assert cv_v < zero_rmse(samples.airflow[:, 2]) and skill is not None and not skill.identified
    text = vertical_warning(cv_v, samples.airflow[:, 2], skill)
    assert text is not None and "by less than the scatter over the CV blocks" in text and "over 5 blocks" in text


def test_a_law_that_wins_every_block_alike_is_identified():
    samples = _climb_then_level()
    fit_predict = _law_off_by(0.1, 0.1)
    _, cv_v = dragfit.grouped_cv(samples, fit_predict)
    skill = vertical_skill(*block_errors(samples, fit_predict))
    assert skill is not None and skill.identified and vertical_warning(cv_v, samples.airflow[:, 2], skill) is None
