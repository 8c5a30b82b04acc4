"""The fit's shortcuts change no number: dragfit's normal equations from the contiguous parameter rows, the
results remembered per sample set (DragSamples.memo: CV splits, robust fits, held-out predictions, the
polynomial family's term matrices) and `--wind unknown`'s horizontal unit forces.

Each shortcut is held to the computation it replaced, written out here, bit for bit (np.array_equal, not
a tolerance): the brief of the change was that `fit` writes the same airframe and report to the last digit.
The samples are synthetic: a heading-frame drag law on a figure-8 airflow, blocks of 20 s at 10 Hz."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from dobwind.calibrate import dragfit, holdcv, windrows
from dobwind.model.terms import parse_term

TRUE = {"l0": 0.3, "q0": 0.08, "q2c": 0.01, "ox": 0.4, "oy": -0.2, "lz": 0.4, "qz": 0.1, "kappa": 0.02}
ACTIVE = dragfit.HORIZONTAL_SETS[3] + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS


@pytest.fixture(scope="module")
def samples() -> dragfit.DragSamples:
    """1,200 samples (6 blocks) of a figure-8 whose speed grows, with noise and a few outliers."""
    rng = np.random.default_rng(3)
    n = 1200
    phase = np.linspace(0.0, 24 * math.pi, n)
    speed = np.linspace(1.0, 9.0, n)
    air = np.column_stack([speed * np.cos(phase / 3), speed * np.sin(phase / 3), 0.8 * np.sin(phase)])
    columns = dragfit.basis(air)
    columns[:, :, dragfit.PARAMETERS.index("kappa")] = np.column_stack([0.1 * np.sin(phase), np.zeros(n),
                                                                        -(30.0 + np.cos(phase))])
    force = np.einsum("nap,p->na", columns, np.array([TRUE.get(p, 0.0) for p in dragfit.PARAMETERS]))
    force += 0.05 * rng.standard_normal(force.shape)
    force[::97] += 3.0   # outliers: the Huber weights must differ from one
    yaw = 0.3 * np.sin(phase / 7)
    return dragfit.DragSamples(force, columns, np.cos(yaw), np.sin(yaw), air,
                               (np.arange(n) // 200).astype(int), np.zeros(n, dtype=int))


def _fresh(samples: dragfit.DragSamples) -> dragfit.DragSamples:
    """The same numbers in a new object: nothing remembered."""
    return dataclasses.replace(samples)


def _strided_normal_equations(samples: dragfit.DragSamples, weights: np.ndarray | None,
                              columns: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """The construction before the change: each column read strided from the (3N, P) array."""
    flat = samples.columns.reshape(-1, samples.columns.shape[2])
    w = np.ones(samples.observed.size) if weights is None else weights.reshape(-1)
    augmented = np.empty((len(columns) + 1, samples.observed.size))
    for row, column in enumerate(columns):
        np.multiply(flat[:, column], w, out=augmented[row])
    np.multiply(samples.observed.reshape(-1), w, out=augmented[-1])
    product = augmented @ augmented.T
    return product[:-1, :-1], product[:-1, -1]


@pytest.mark.parametrize("weighted", [False, True])
def test_normal_equations_are_the_strided_constructions_to_the_bit(samples, weighted):
    columns = [samples.parameters.index(p) for p in ACTIVE]
    weights = np.random.default_rng(0).uniform(0.2, 3.0, samples.observed.shape) if weighted else None
    gram, rhs = dragfit._normal_equations(samples, weights, columns)
    want_gram, want_rhs = _strided_normal_equations(samples, weights, columns)
    assert np.array_equal(gram, want_gram) and np.array_equal(rhs, want_rhs)
    # and they are the normal equations (a wrong row or weight would not be a last-bit matter)
    a = samples.columns[:, :, columns].reshape(-1, len(columns)) * (1.0 if weights is None else weights.reshape(-1, 1))
    assert np.allclose(gram, a.T @ a, rtol=1e-12)


def test_parameter_rows_are_the_columns_transposed(samples):
    rows = samples.parameter_rows
    assert rows.flags.c_contiguous and rows.shape == (len(samples.parameters), 3 * len(samples))
    assert np.array_equal(rows[samples.parameters.index("q0")], samples.columns[:, :, samples.parameters.index("q0")].ravel())


def test_a_remembered_robust_fit_is_the_fit_and_cannot_be_changed_through_its_result(samples):
    fresh = _fresh(samples)
    first = dragfit.robust_fit(fresh, ACTIVE)
    assert ("robust_fit", ACTIVE, 4) in fresh.memo
    first[:] = 0.0   # the caller's copy: what the next caller gets is untouched
    again = dragfit.robust_fit(fresh, ACTIVE)
    assert np.array_equal(again, dragfit._robust_fit(_fresh(samples), ACTIVE, 4)) and np.any(again != 0.0)
    # the rounds are part of the key: two rounds are another fit
    assert not np.array_equal(dragfit.robust_fit(fresh, ACTIVE, rounds=2), again)


def _old_folds(group: np.ndarray) -> np.ndarray:
    """holdcv's own fold assignment before it took dragfit.fold_splits (same blocks, same seed)."""
    unique = np.unique(group)
    fold_of = dict(zip(np.random.default_rng(0).permutation(unique), np.arange(len(unique)) % dragfit.FOLDS))
    return np.array([fold_of[g] for g in group])


def test_the_remembered_splits_are_the_hold_cvs_folds(samples):
    fresh = _fresh(samples)
    splits = dragfit.fold_splits(fresh)
    fold = _old_folds(fresh.group)
    assert len(splits) == fold.max() + 1
    for k, (train, test) in enumerate(splits):
        assert np.array_equal(train.observed, fresh.observed[fold != k])
        assert np.array_equal(test.observed, fresh.observed[fold == k])


def test_a_splits_results_are_remembered_with_its_parent_and_found_from_the_split_made_again(samples):
    fresh = _fresh(samples)
    train, _ = dragfit.fold_splits(fresh)[1]
    theta = dragfit.robust_fit(train, ACTIVE, rounds=2)
    assert ("fold", 1, "fitted", "robust_fit", ACTIVE, 2) in fresh.memo and not train.memo
    again, _ = dragfit.fold_splits(fresh)[1]
    assert again is not train and np.array_equal(dragfit.robust_fit(again, ACTIVE, rounds=2), theta)
    # a copy of a split is samples of its own: changed numbers are never read through the parent's memo
    shifted = dragfit.with_exponent(again, 1.8)
    assert shifted.split_of is None and dataclasses.replace(again).split_of is None and again.select(
        np.ones(len(again), bool)).split_of is None
    assert not np.array_equal(dragfit.robust_fit(shifted, ACTIVE, rounds=2), theta)


def test_hold_cv_after_the_grouped_cv_is_the_hold_cv_of_fresh_samples(samples):
    """The hold-level CV reuses the grouped CV's fits and predictions: the same figures as computing all
    of it anew on samples that remember nothing."""
    scored = _fresh(samples)
    fit_predict = dragfit.drag_fit_predict(ACTIVE)
    dragfit.grouped_cv(scored, fit_predict, dragfit.fold_splits(scored))
    dragfit.top_error(fit_predict, dragfit.top_split(scored))
    reused = holdcv.hold_cv(scored, fit_predict)
    anew = holdcv.hold_cv(_fresh(samples), dragfit.drag_fit_predict(ACTIVE))
    assert reused is not None and anew is not None
    assert reused.rms_mps == anew.rms_mps and reused.extrapolation_mps == anew.extrapolation_mps
    assert np.array_equal(reused.window_errors_mps, anew.window_errors_mps)
    assert np.array_equal(reused.top_errors_mps, anew.top_errors_mps)


def test_a_remembered_prediction_is_read_only_and_keyed_by_the_coefficients(samples):
    train, test = dragfit.fold_splits(_fresh(samples))[0]
    predicted = dragfit.drag_fit_predict(ACTIVE)(train, test)
    assert not predicted.flags.writeable
    assert np.array_equal(predicted, dragfit.predicted_airflow(test, dragfit.robust_fit(train, ACTIVE, rounds=2)))
    smaller = dragfit.drag_fit_predict(("l0",) + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS)(train, test)
    assert not np.array_equal(smaller, predicted)   # another law's prediction, not the remembered one


def test_the_polynomial_familys_remembered_terms_give_the_same_cv(samples):
    horizontal = [parse_term(t) for t in ("fh^0.5", "1", "m*fh^-0.5")]
    vertical = [parse_term(t) for t in ("fz", "1")]
    offset = (0.4, -0.2, 0.0)
    scored = _fresh(samples)
    first = dragfit.grouped_cv(scored, dragfit.polynomial_fit_predict(horizontal, vertical, offset))
    again = dragfit.grouped_cv(scored, dragfit.polynomial_fit_predict(horizontal, vertical, offset))
    anew = dragfit.grouped_cv(_fresh(samples), dragfit.polynomial_fit_predict(horizontal, vertical, offset))
    assert first == again == anew
    other = dragfit.grouped_cv(scored, dragfit.polynomial_fit_predict(horizontal[:2], vertical, offset))
    assert other != first   # the terms are part of the key


def test_the_unit_forces_are_dragfits_basis_to_the_bit():
    rng = np.random.default_rng(5)
    air = np.column_stack([rng.normal(0, 6, 500), rng.normal(0, 6, 500), np.zeros(500)])
    air[:3, :2] = 0.0   # zero airflow: the 1e-9 floor on the speed
    full = dragfit.basis(air)
    unit = windrows._unit_forces(air)
    for key in dragfit.HORIZONTAL_SETS[4] + ("ox", "oy"):
        assert np.array_equal(np.column_stack(unit[key]), full[:, :2, dragfit.PARAMETERS.index(key)]), key


def test_hold_cvs_windows_are_those_of_the_old_fold_masks(samples):
    """Each fold's windows in the hold-level CV are the windows of that fold's samples, the fold made
    as holdcv made it before it took dragfit.fold_splits; and the top windows those of top_split's rule."""
    fresh = _fresh(samples)
    fit_predict = dragfit.drag_fit_predict(ACTIVE)
    hold = holdcv.hold_cv(fresh, fit_predict)
    assert hold is not None and hold.window_folds is not None
    fold = _old_folds(fresh.group)
    for k in range(fold.max() + 1):
        split = (_fresh(samples).select(fold != k), _fresh(samples).select(fold == k))
        expected = holdcv._held_out(split, fit_predict, holdcv.HOLD_WINDOW_S).error_mps
        assert np.array_equal(hold.window_errors_mps[hold.window_folds == k], expected)
    speed = np.hypot(fresh.airflow[:, 0], fresh.airflow[:, 1])
    _, inverse = np.unique(fresh.group, return_inverse=True)
    level = np.bincount(inverse, speed) / np.bincount(inverse)
    top = level[inverse] >= dragfit.TOP_SHARE * level.max()
    assert 0 < top.sum() < len(top)   # the case this checks: a top split exists
    expected_top = holdcv._held_out((fresh.select(~top), fresh.select(top)), fit_predict, holdcv.HOLD_WINDOW_S)
    assert np.array_equal(hold.top_errors_mps, expected_top.error_mps)
