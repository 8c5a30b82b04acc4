"""A refused fit on a flight shorter than the cross-validation's folds says so (issue #36: a refusal names what
the flight lacks). The PX4 drag-fusion field log (37 s airborne) gave two 20 s blocks: each fold fitted the law
on one block and predicted the other, and the CV diverged without saying the flight was the reason."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from dobwind.calibrate import dragfit
from dobwind.calibrate.fitfamily import _short_flight
from dobwind.calibrate.reportparts import SelfCheck


def _samples(blocks: int) -> SimpleNamespace:
    # few_blocks reads the block labels only; labels repeat as the samples of a block do
    return SimpleNamespace(group=np.repeat(np.arange(blocks), 7))


def _check(passed: bool, cv_mps: float | None, reasons: list[str]) -> SelfCheck:
    return SelfCheck(passed=passed, reasons=reasons, cv_mps=cv_mps, speed_range_mps=7.0, cv_limit_mps=0.42,
                     replay_limit_mps=0.42, direction_limit_deg=10.0, logs=[])


@pytest.mark.parametrize("blocks", [1, 2, dragfit.FOLDS - 1])
def test_fewer_blocks_than_folds_name_the_count_and_the_flight_time_that_would_do(blocks):
    text = dragfit.few_blocks(_samples(blocks))
    assert text is not None
    assert f"gives {blocks} cross-validation block" in text
    assert f"at least {dragfit.FOLDS * dragfit.BLOCK_S:g} s of airborne flight" in text


@pytest.mark.parametrize("blocks", [dragfit.FOLDS, dragfit.FOLDS + 3])
def test_as_many_blocks_as_folds_add_nothing(blocks):
    assert dragfit.few_blocks(_samples(blocks)) is None


def test_a_cv_refusal_on_a_short_flight_gains_the_clause():
    check = _short_flight(_check(False, 480.7, ["hold-level CV 480.693 m/s > 0.424 m/s"]), _samples(2))
    assert len(check.reasons) == 2 and "2 cross-validation blocks" in check.reasons[1]
    assert "100 s" in check.reasons[1]


def test_a_missing_cv_figure_on_a_short_flight_gains_the_clause():
    for cv in (None, math.nan):
        check = _short_flight(_check(False, cv, ["no cross-validation figure"]), _samples(1))
        assert "1 cross-validation block of" in check.reasons[-1]


@pytest.mark.parametrize("passed, cv, blocks", [(True, 0.1, 2),      # a pass stays a pass, word for word
                                                (False, 0.3, 2),     # the CV passed: the flight was long enough for it
                                                (False, 480.7, 5)])  # enough blocks: the law, not the flight
def test_other_verdicts_are_left_as_they_are(passed, cv, blocks):
    before = _check(passed, cv, [] if passed else ["training replay speed error RMS 0.554 m/s > 0.424 m/s"])
    assert _short_flight(before, _samples(blocks)) == before
