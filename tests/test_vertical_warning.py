"""The fit's warning that its vertical law is not identified (fitfamily.vertical_warning): the law's
held-out error is compared with predicting zero vertical airflow, whose error is the RMS of the truth."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.calibrate.fitfamily import vertical_warning, zero_rmse

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
